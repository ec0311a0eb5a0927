//! Pressure steps in a regulator's log: holds (stretches where the pressure stays in a
//! band) and the steps between two holds that follow each other quickly with levels
//! far enough apart. A log of one level (noise included) has no step; a change too small
//! to be a step, but larger than the noise explains, is reported as such.

use serde::Serialize;

/// A hold lasts at least this long, s.
pub const HOLD_MIN_S: f64 = 0.3;

/// A hold's samples stay within a band this wide, kPa, or [`HOLD_BAND_NOISE`] noise sds.
pub const HOLD_BAND_MIN_KPA: f64 = 0.5;

/// A hold's band in noise standard deviations of the log ([`super::noise_sd`]).
pub const HOLD_BAND_NOISE: f64 = 8.0;

/// A step changes the held level by at least this much, kPa, and by
/// [`STEP_BAND_FACTOR`] hold bands.
pub const STEP_MIN_KPA: f64 = 2.0;

/// A step changes the held level by at least this many hold bands.
pub const STEP_BAND_FACTOR: f64 = 2.0;

/// The pressure goes from one hold to the next within this long for a step, s.
pub const STEP_MAX_TRANSITION_S: f64 = 1.0;

/// A change between two parts of a log of one level is reported (as too small to be a
/// step) when it is this many standard errors.
pub const CHANGE_SIGNIFICANCE: f64 = 6.0;

/// The noise sd assumed at least, kPa (a regulator's resolution): a clean log's change
/// is significant only above it.
pub const NOISE_FLOOR_KPA: f64 = 0.01;

/// A stretch of the log where the pressure holds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Hold {
    /// First sample's time, s.
    pub start_s: f64,
    /// Last sample's time, s.
    pub end_s: f64,
    /// Median pressure, kPa.
    pub level_kpa: f64,
    /// Index of its first sample.
    #[serde(skip)]
    pub first: usize,
    /// Index of its last sample.
    #[serde(skip)]
    pub last: usize,
}

/// A step between two holds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PressureStep {
    /// Step number, from 1 in time order.
    pub step: usize,
    /// The hold before it.
    pub before: Hold,
    /// The hold after it.
    pub after: Hold,
    /// When it begins: the logged pressure's 10% crossing, s (linear between samples).
    pub onset_s: f64,
}

impl PressureStep {
    /// Level before, kPa.
    pub fn from_kpa(&self) -> f64 {
        self.before.level_kpa
    }
    /// Level after, kPa.
    pub fn to_kpa(&self) -> f64 {
        self.after.level_kpa
    }
}

/// A change of a log of one level that is too small for a step but larger than its noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SmallChange {
    /// Where the two parts meet, s.
    pub at_s: f64,
    /// Mean after minus mean before, kPa.
    pub change_kpa: f64,
}

/// What [`find_steps`] found in a log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StepSearch {
    /// The log's noise sd, kPa ([`super::noise_sd`]).
    pub noise_sd_kpa: f64,
    /// The holds' band, kPa.
    pub band_kpa: f64,
    /// The smallest step, kPa.
    pub threshold_kpa: f64,
    /// The holds, in time order.
    pub holds: Vec<Hold>,
    /// The steps, in time order.
    pub steps: Vec<PressureStep>,
    /// A log without steps whose pressure stays within the threshold but changes by
    /// more than its noise explains (e.g. a step smaller than the threshold).
    pub small_change: Option<SmallChange>,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The holds of the log: from each sample, the longest run whose values stay within
/// `band`; a run of [`HOLD_MIN_S`] or longer is a hold and the search goes on after it,
/// else from the next sample.
pub fn holds(times: &[f64], values: &[f64], band: f64) -> Vec<Hold> {
    let n = times.len().min(values.len());
    let mut out = Vec::new();
    let mut i = 0;
    while i < n {
        let (mut lo, mut hi, mut j) = (values[i], values[i], i);
        while j + 1 < n && hi.max(values[j + 1]) - lo.min(values[j + 1]) <= band {
            j += 1;
            lo = lo.min(values[j]);
            hi = hi.max(values[j]);
        }
        if times[j] - times[i] >= HOLD_MIN_S {
            out.push(Hold {
                start_s: times[i],
                end_s: times[j],
                level_kpa: median(&mut values[i..=j].to_vec()),
                first: i,
                last: j,
            });
            i = j + 1;
        } else {
            i += 1;
        }
    }
    out
}

/// The first time after sample `from` where the log reaches `share` of the way from
/// `a` to `b`, linear between samples.
fn crossing(times: &[f64], values: &[f64], from: usize, a: f64, b: f64, share: f64) -> f64 {
    let level = a + share * (b - a);
    let sign = (b - a).signum();
    for i in from + 1..times.len().min(values.len()) {
        if sign * (values[i] - level) >= 0.0 {
            let (t0, v0) = (times[i - 1], values[i - 1]);
            return if sign * (v0 - level) >= 0.0 || values[i] == v0 {
                times[i]
            } else {
                t0 + (times[i] - t0) * (level - v0) / (values[i] - v0)
            };
        }
    }
    f64::NAN
}

/// The steps of a pressure log (`times` s increasing, `pressures` kPa): holds with a
/// band of max([`HOLD_BAND_MIN_KPA`], [`HOLD_BAND_NOISE`] noise sds); two holds that
/// follow each other within [`STEP_MAX_TRANSITION_S`] with levels at least
/// max([`STEP_MIN_KPA`], [`STEP_BAND_FACTOR`] bands) apart make a step.
pub fn find_steps(times: &[f64], pressures: &[f64]) -> StepSearch {
    let n = times.len().min(pressures.len());
    let (times, pressures) = (&times[..n], &pressures[..n]);
    let noise = super::noise_sd(times, pressures);
    let band = HOLD_BAND_MIN_KPA.max(HOLD_BAND_NOISE * noise);
    let threshold = STEP_MIN_KPA.max(STEP_BAND_FACTOR * band);
    let hs = holds(times, pressures, band);
    let mut steps = Vec::new();
    for w in hs.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b.start_s - a.end_s <= STEP_MAX_TRANSITION_S
            && (b.level_kpa - a.level_kpa).abs() >= threshold
        {
            steps.push(PressureStep {
                step: steps.len() + 1,
                before: a,
                after: b,
                onset_s: crossing(times, pressures, a.last, a.level_kpa, b.level_kpa, 0.1),
            });
        }
    }
    let (lo, hi) = pressures
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
            (l.min(*p), h.max(*p))
        });
    let small_change = if steps.is_empty() && hi - lo < threshold {
        one_change(times, pressures, noise.max(NOISE_FLOOR_KPA))
    } else {
        None
    };
    StepSearch {
        noise_sd_kpa: noise,
        band_kpa: band,
        threshold_kpa: threshold,
        holds: hs,
        steps,
        small_change,
    }
}

/// The most significant split of the log into two parts of [`HOLD_MIN_S`] or more (the
/// largest difference of their means in standard errors for noise sd `sd`), when it
/// reaches [`CHANGE_SIGNIFICANCE`].
fn one_change(times: &[f64], values: &[f64], sd: f64) -> Option<SmallChange> {
    let n = values.len();
    let (t0, t1) = (*times.first()?, *times.last()?);
    let mut prefix = vec![0.0; n + 1];
    for (i, v) in values.iter().enumerate() {
        prefix[i + 1] = prefix[i] + v;
    }
    let mut best: Option<(f64, SmallChange)> = None;
    for k in 1..n {
        // Left part: samples 0..k; right part: k..n.
        if times[k - 1] - t0 < HOLD_MIN_S || t1 - times[k] < HOLD_MIN_S {
            continue;
        }
        let (nl, nr) = (k as f64, (n - k) as f64);
        let d = (prefix[n] - prefix[k]) / nr - prefix[k] / nl;
        let z = d.abs() / (sd * (1.0 / nl + 1.0 / nr).sqrt());
        if best.as_ref().is_none_or(|(bz, _)| z > *bz) {
            let at_s = 0.5 * (times[k - 1] + times[k]);
            best = Some((
                z,
                SmallChange {
                    at_s,
                    change_kpa: d,
                },
            ));
        }
    }
    best.filter(|(z, _)| *z >= CHANGE_SIGNIFICANCE)
        .map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Samples every 10 ms on 0..`end` s of `p(t)` plus a deterministic dither of
    /// amplitude `noise` (a sequence of sd about 0.63 `noise`).
    fn log(end: f64, noise: f64, p: impl Fn(f64) -> f64) -> (Vec<f64>, Vec<f64>) {
        let n = (end / 0.01).round() as usize + 1;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let v = t
            .iter()
            .enumerate()
            .map(|(i, t)| p(*t) + noise * [1.0, -1.0, 0.5, -0.5, 0.0, 0.8, -0.3][i % 7])
            .collect();
        (t, v)
    }

    #[test]
    fn steps_up_and_down_between_holds() {
        // 20 -> 50 at 1 s (within one sample), 50 -> 30 at 2.5 s (a 50 ms ramp).
        let p = |t: f64| {
            if t < 1.0 {
                20.0
            } else if t < 2.5 {
                50.0
            } else {
                50.0 - 20.0 * ((t - 2.5) / 0.05).min(1.0)
            }
        };
        for noise in [0.0, 0.2] {
            let (t, v) = log(4.0, noise, p);
            let s = find_steps(&t, &v);
            assert_eq!(s.steps.len(), 2, "noise {noise}: {s:?}");
            let (a, b) = (s.steps[0], s.steps[1]);
            assert!((a.from_kpa() - 20.0).abs() < 0.5 && (a.to_kpa() - 50.0).abs() < 0.5);
            assert!((b.from_kpa() - 50.0).abs() < 0.5 && (b.to_kpa() - 30.0).abs() < 0.5);
            // 10% crossings: within the jump's sample interval, and 5 ms into the ramp.
            assert!((0.99..=1.0).contains(&a.onset_s), "{}", a.onset_s);
            if noise == 0.0 {
                assert!((b.onset_s - 2.505).abs() < 1e-9, "{}", b.onset_s);
            }
            assert!(s.small_change.is_none());
        }
    }

    #[test]
    fn ramps_and_one_level_logs_have_no_step() {
        // A steady ramp, fast or slow, never holds between two levels far apart.
        for rate in [0.25, 2.0, 30.0] {
            let (t, v) = log(4.0, 0.0, |t| 5.0 + rate * t);
            let s = find_steps(&t, &v);
            assert!(s.steps.is_empty(), "{rate} kPa/s: {:?}", s.steps);
        }
        // One level with noise: no step and nothing to report.
        let (t, v) = log(5.0, 0.3, |_| 40.0);
        let s = find_steps(&t, &v);
        assert!(s.steps.is_empty() && s.small_change.is_none(), "{s:?}");
        // A clean constant log.
        let (t, v) = log(2.0, 0.0, |_| 40.0);
        let s = find_steps(&t, &v);
        assert!(s.steps.is_empty() && s.small_change.is_none(), "{s:?}");
    }

    #[test]
    fn a_step_smaller_than_the_noise_band_is_reported_not_measured() {
        // Noise dither 0.5 kPa (sd ~0.32): band ~2.5 kPa, threshold ~5 kPa; a 1.5 kPa
        // step at 2 s is no step, but the split finds it.
        let (t, v) = log(4.0, 0.5, |t| if t < 2.0 { 20.0 } else { 21.5 });
        let s = find_steps(&t, &v);
        assert!(s.steps.is_empty(), "{s:?}");
        assert!(s.threshold_kpa > 1.5, "{s:?}");
        let c = s.small_change.expect("the change is found");
        assert!(
            (c.at_s - 2.0).abs() < 0.05 && (c.change_kpa - 1.5).abs() < 0.1,
            "{c:?}"
        );
    }

    #[test]
    fn a_step_without_a_hold_after_it_is_no_step() {
        // The log ends 0.2 s after the jump: no hold after it.
        let (t, v) = log(1.2, 0.0, |t| if t < 1.0 { 20.0 } else { 50.0 });
        assert!(find_steps(&t, &v).steps.is_empty());
    }
}
