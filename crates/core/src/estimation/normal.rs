//! Normal equations of a weighted linear least-squares problem, built one
//! observation block at a time: Σ LᵀWL and Σ LᵀW(−d) over blocks whose
//! residual is r = L u + d in a few of the unknowns, plus diagonal and
//! 3 × 3 priors, solved by Cholesky. The velocity-error-rate cross-check
//! and the discrepancy workflow's gap fit both assemble theirs here.

use nalgebra::{DMatrix, DVector, Matrix3};

/// HᵀWH and HᵀWy of a problem in `n` unknowns, being accumulated.
pub(crate) struct NormalEquations {
    normal: DMatrix<f64>,
    rhs: DVector<f64>,
}

/// The solution and its covariance (the inverse of the normal matrix).
pub(crate) struct Solution {
    pub u: DVector<f64>,
    pub cov: DMatrix<f64>,
}

impl NormalEquations {
    pub fn new(n: usize) -> Self {
        NormalEquations {
            normal: DMatrix::zeros(n, n),
            rhs: DVector::zeros(n),
        }
    }

    /// An independent prior of information `weight` (1/σ²) on each of
    /// `unknowns`, centred on zero.
    pub fn add_diagonal(&mut self, unknowns: std::ops::Range<usize>, weight: f64) {
        for i in unknowns {
            self.normal[(i, i)] += weight;
        }
    }

    /// A prior of information `info` on the three unknowns from `at`,
    /// centred on zero.
    pub fn add_block3(&mut self, at: usize, info: &Matrix3<f64>) {
        for i in 0..3 {
            for j in 0..3 {
                self.normal[(at + i, at + j)] += info[(i, j)];
            }
        }
    }

    /// A prior of information `info` on the unknowns `idx` (row j of
    /// `info` is unknown `idx[j]`), centred on zero.
    pub fn add_information(&mut self, idx: &[usize], info: &DMatrix<f64>) {
        for (a, &i) in idx.iter().enumerate() {
            for (b, &j) in idx.iter().enumerate() {
                self.normal[(i, j)] += info[(a, b)];
            }
        }
    }

    /// An observation block with residual r = L u_loc + d and weight W,
    /// where u_loc are the unknowns `idx` (column j of L is unknown
    /// `idx[j]`).
    pub fn add_observation(
        &mut self,
        idx: &[usize],
        l: &DMatrix<f64>,
        w: &DMatrix<f64>,
        d: &DVector<f64>,
    ) {
        let ltw = l.transpose() * w;
        let block = &ltw * l;
        let g = -(&ltw * d);
        for (a_i, &gi) in idx.iter().enumerate() {
            self.rhs[gi] += g[a_i];
            for (b_i, &gj) in idx.iter().enumerate() {
                self.normal[(gi, gj)] += block[(a_i, b_i)];
            }
        }
    }

    /// The minimiser and its covariance; `None` when the normal matrix is
    /// not positive definite.
    pub fn solve(self) -> Option<Solution> {
        let chol = self.normal.cholesky()?;
        let u = chol.solve(&self.rhs);
        Some(Solution {
            u,
            cov: chol.inverse(),
        })
    }
}
