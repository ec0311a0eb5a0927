//! Conversions between bendscope's types (nalgebra, image) and OpenCV's.

use nalgebra::{Matrix3, Point2};
use opencv::core::{Mat, Point2d, Vector, CV_64F, CV_8UC1};
use opencv::prelude::*;

/// A 3x3 `CV_64F` matrix from a nalgebra matrix.
pub fn mat_from_matrix3(m: &Matrix3<f64>) -> opencv::Result<Mat> {
    let rows: Vec<[f64; 3]> = (0..3).map(|r| [m[(r, 0)], m[(r, 1)], m[(r, 2)]]).collect();
    Mat::from_slice_2d(&rows)
}

/// A nalgebra matrix from a 3x3 numeric matrix (any depth converted to f64).
pub fn matrix3_from_mat(m: &Mat) -> opencv::Result<Matrix3<f64>> {
    let mut d = Mat::default();
    m.convert_to(&mut d, CV_64F, 1.0, 0.0)?;
    if d.rows() != 3 || d.cols() != 3 {
        return Err(opencv::Error::new(
            opencv::core::StsBadSize,
            format!("expected a 3x3 matrix, got {}x{}", d.rows(), d.cols()),
        ));
    }
    let mut out = Matrix3::zeros();
    for r in 0..3 {
        for c in 0..3 {
            out[(r as usize, c as usize)] = *d.at_2d::<f64>(r, c)?;
        }
    }
    Ok(out)
}

/// A column `CV_64F` matrix from a slice.
pub fn mat_from_column(v: &[f64]) -> opencv::Result<Mat> {
    let rows: Vec<[f64; 1]> = v.iter().map(|x| [*x]).collect();
    Mat::from_slice_2d(&rows)
}

/// All elements of a numeric matrix, row-major, as f64.
pub fn values_from_mat(m: &Mat) -> opencv::Result<Vec<f64>> {
    let mut d = Mat::default();
    m.convert_to(&mut d, CV_64F, 1.0, 0.0)?;
    let d = if d.is_continuous() { d } else { d.try_clone()? };
    Ok(d.data_typed::<f64>()?.to_vec())
}

/// A vector of OpenCV double points.
pub fn vector_from_points(pts: &[Point2<f64>]) -> Vector<Point2d> {
    pts.iter().map(|p| Point2d::new(p.x, p.y)).collect()
}

/// nalgebra points from OpenCV double points.
pub fn points_from_vector(v: &Vector<Point2d>) -> Vec<Point2<f64>> {
    v.iter().map(|p| Point2::new(p.x, p.y)).collect()
}

/// An 8-bit single-channel Mat (a copy) from a grey image.
pub fn mat_from_gray(img: &image::GrayImage) -> opencv::Result<Mat> {
    let (w, h) = img.dimensions();
    let flat = Mat::from_slice(img.as_raw())?;
    let shaped = flat.reshape(1, h as i32)?;
    let mut out = Mat::default();
    shaped.copy_to(&mut out)?;
    debug_assert_eq!(out.typ(), CV_8UC1);
    debug_assert_eq!(out.cols() as u32, w);
    Ok(out)
}
