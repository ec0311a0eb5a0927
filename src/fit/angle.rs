//! Bending angles: the half-angle convention between the rest and current tip (method.md
//! §2.9), from a fitted circle's tangent when there is no rest frame, and along the
//! markers for an actuator curled past 180 degrees.

use nalgebra::Point2;

use super::circle::CircleFit;
use super::error::FitError;

/// Bending angle by the half-angle convention (method.md §2.9): with O the clamped-end
/// marker, O' the tip marker at rest and A the tip marker now,
/// cos(alpha/2) = (OO' . OA) / (|OO'| |OA|); returns alpha in degrees, in [0, 360).
/// On a circular arc starting tangent to OO', alpha is the turning angle of the tangent
/// between O and A.
pub fn bending_angle_deg(
    clamp: Point2<f64>,
    tip_rest: Point2<f64>,
    tip_now: Point2<f64>,
) -> Result<f64, FitError> {
    let u = tip_rest - clamp;
    let v = tip_now - clamp;
    let (nu, nv) = (u.norm(), v.norm());
    if !(nu > 0.0 && nv > 0.0) || !(nu.is_finite() && nv.is_finite()) {
        return Err(FitError::Degenerate {
            what: "bending angle",
            why: "the clamped-end and tip markers coincide",
        });
    }
    let cos_half = (u.dot(&v) / (nu * nv)).clamp(-1.0, 1.0);
    Ok(2.0 * cos_half.acos().to_degrees())
}

/// Bending angle without a rest frame: the rest direction OO' is taken as the fitted
/// circle's tangent at the clamped-end marker, oriented towards the tip (equivalent to
/// [`bending_angle_deg`] when the actuator leaves the clamp tangentially). Collinear
/// markers give 0.
pub fn bending_angle_from_circle_deg(
    clamp: Point2<f64>,
    tip: Point2<f64>,
    circle: &CircleFit,
) -> Result<f64, FitError> {
    if circle.curvature == 0.0 || !circle.center.x.is_finite() {
        return Ok(0.0);
    }
    let r = clamp - circle.center;
    let mut t = nalgebra::Vector2::new(-r.y, r.x);
    if t.dot(&(tip - clamp)) < 0.0 {
        t = -t;
    }
    bending_angle_deg(clamp, clamp + t, tip)
}

/// Bending angle as the turning of the fitted circle's tangent from the clamped-end
/// marker to the tip, following the markers in order: the sum of the signed central
/// angles between successive markers (each well under 180 degrees at any marker
/// spacing), so an actuator curled past 180 degrees reads its whole turn, where the
/// chord-tangent angle of [`bending_angle_from_circle_deg`] folds back (200 degrees read
/// as 160). Below 180 degrees both give the same value. A straight chain gives 0.
pub fn bending_angle_along_markers_deg(
    markers: &[Point2<f64>],
    circle: &CircleFit,
) -> Result<f64, FitError> {
    if markers.len() < 2 {
        return Err(FitError::TooFewPoints {
            what: "bending angle",
            needed: 2,
            got: markers.len(),
        });
    }
    if circle.curvature == 0.0 || !circle.center.x.is_finite() {
        return Ok(0.0);
    }
    let total: f64 = markers
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0] - circle.center, w[1] - circle.center);
            (a.x * b.y - a.y * b.x).atan2(a.dot(&b))
        })
        .sum();
    Ok(total.abs().to_degrees())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::circle::fit_circle_pratt;

    #[test]
    fn bending_angle_half_angle_convention() {
        let o = Point2::new(0.0, 0.0);
        let rest = Point2::new(100.0, 0.0);
        // Tip rotated by 30° about O: alpha = 60°.
        let a = Point2::new(
            80.0 * 30f64.to_radians().cos(),
            -80.0 * 30f64.to_radians().sin(),
        );
        assert!((bending_angle_deg(o, rest, a).unwrap() - 60.0).abs() < 1e-10);
        assert!((bending_angle_deg(o, rest, rest).unwrap()).abs() < 1e-6);
        assert!(bending_angle_deg(o, o, a).is_err());
        // On an arc leaving O tangentially, the turning angle is recovered.
        let r = 50.0;
        let theta = 1.2f64;
        let on_arc = |t: f64| Point2::new(r * t.sin(), -r * (1.0 - t.cos()));
        let c = fit_circle_pratt(
            &(0..8)
                .map(|i| on_arc(theta * i as f64 / 7.0))
                .collect::<Vec<_>>(),
        )
        .unwrap();
        let alpha = bending_angle_from_circle_deg(on_arc(0.0), on_arc(theta), &c).unwrap();
        assert!((alpha - theta.to_degrees()).abs() < 1e-9, "{alpha}");
        let markers: Vec<_> = (0..8).map(|i| on_arc(theta * i as f64 / 7.0)).collect();
        let along = bending_angle_along_markers_deg(&markers, &c).unwrap();
        assert!((along - alpha).abs() < 1e-9, "{along} vs {alpha}");
        // Curled past 180 degrees: 250 degrees of turn, the chord-tangent angle folds
        // back to 110; following the markers reads 250.
        let theta = 250f64.to_radians();
        let markers: Vec<_> = (0..8).map(|i| on_arc(theta * i as f64 / 7.0)).collect();
        let c = fit_circle_pratt(&markers).unwrap();
        let folded = bending_angle_from_circle_deg(markers[0], markers[7], &c).unwrap();
        assert!((folded - 110.0).abs() < 1e-6, "{folded}");
        let along = bending_angle_along_markers_deg(&markers, &c).unwrap();
        assert!((along - 250.0).abs() < 1e-9, "{along}");
    }
}
