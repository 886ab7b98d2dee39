//! The file's layout of a 3 × 3 matrix: an array of rows, row = sensor,
//! column = input axis (CONTRACT §5a), shared by the terms and their
//! thermal coefficients.

use nalgebra::Matrix3;

pub(crate) fn rows(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    [0, 1, 2].map(|i| [m[(i, 0)], m[(i, 1)], m[(i, 2)]])
}

pub(crate) fn matrix(r: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| r[i][j])
}
