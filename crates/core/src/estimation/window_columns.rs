//! A window's parameter input, accumulated record by record.
//!
//! Over a window of length T the parameters drive the navigation errors
//! through B = Σ_j exp(F (T − τ_j)) B_j, where B_j is record j's column
//! block (`sensitivity`, `effect_columns`) at its mid time τ_j. To second
//! order in F T that is
//!
//! ```text
//! B = S0 + F (T S0 − S1) + ½ F² (T² S0 − 2 T S1 + S2),   Sk = Σ_j τ_j^k B_j,
//! ```
//!
//! so a window needs only the three moments of its records' columns.
//!
//! Every column drives three rows of the six (attitude or velocity), the
//! same three for a parameter throughout, so the moments are kept as three
//! numbers a parameter, in SI per unit of parameter, and expanded (rows
//! placed, prior scale applied) once a window. A record's columns are
//! written into a buffer first and folded into the moments in one dense
//! loop: this runs for every record of every pass, and three contiguous
//! sums vectorise where 24 scattered ones did not.

use nalgebra::{DMatrix, Matrix6, Vector3};

use super::nav_errors::NAV;
use super::sensitivity::Rows;

/// One record's parameter columns, as the caller writes them.
pub struct RecordColumns<'a> {
    values: &'a mut [f64],
    rows: &'a mut [Option<Rows>],
}

impl RecordColumns<'_> {
    /// Sets parameter `param`'s column for this record: `col` (SI per unit
    /// of parameter) on `rows`. A parameter keeps its rows through a run.
    #[inline(always)]
    pub fn set(&mut self, param: usize, rows: Rows, col: &Vector3<f64>) {
        debug_assert!(
            self.rows[param].map_or(true, |r| r == rows),
            "parameter {param} changed rows"
        );
        self.rows[param] = Some(rows);
        self.values[3 * param..3 * param + 3].copy_from_slice(col.as_slice());
    }
}

/// The moments of a window's record columns, three numbers a parameter.
pub(crate) struct WindowColumns {
    /// The rows each parameter drives, once it has driven any.
    rows: Vec<Option<Rows>>,
    /// The record being added; zero between records.
    record: Vec<f64>,
    m0: Vec<f64>,
    m1: Vec<f64>,
    m2: Vec<f64>,
}

impl WindowColumns {
    pub fn new(n_p: usize) -> Self {
        WindowColumns {
            rows: vec![None; n_p],
            record: vec![0.0; 3 * n_p],
            m0: vec![0.0; 3 * n_p],
            m1: vec![0.0; 3 * n_p],
            m2: vec![0.0; 3 * n_p],
        }
    }

    /// Adds a record at mid time `tau` from the window start, whose
    /// columns `fill` sets (those it leaves are zero).
    #[inline(always)]
    pub fn add_record(&mut self, tau: f64, fill: impl FnOnce(&mut RecordColumns)) {
        fill(&mut RecordColumns {
            values: &mut self.record,
            rows: &mut self.rows,
        });
        let tau2 = tau * tau;
        let moments = self.m0.iter_mut().zip(self.m1.iter_mut().zip(&mut self.m2));
        for (x, (m0, (m1, m2))) in self.record.iter_mut().zip(moments) {
            *m0 += *x;
            *m1 += *x * tau;
            *m2 += *x * tau2;
            *x = 0.0;
        }
    }

    /// The window's input B (6 × n_p) for parameters in units of `scale`
    /// (state i is δp_i / scale_i), under error dynamics `f` over a window
    /// of length `t`; the moments start again from zero.
    pub fn take_input(&mut self, f: &Matrix6<f64>, t: f64, scale: &[f64]) -> DMatrix<f64> {
        let n_p = self.rows.len();
        let placed = |m: &[f64]| {
            let mut s = DMatrix::zeros(NAV, n_p);
            for (p, rows) in self.rows.iter().enumerate() {
                let r0 = match rows {
                    None => continue,
                    Some(Rows::Attitude) => 0,
                    Some(Rows::Velocity) => 3,
                };
                for i in 0..3 {
                    s[(r0 + i, p)] = m[3 * p + i] * scale[p];
                }
            }
            s
        };
        let (s0, s1, s2) = (placed(&self.m0), placed(&self.m1), placed(&self.m2));
        for m in [&mut self.m0, &mut self.m1, &mut self.m2] {
            m.fill(0.0);
        }
        let fm = DMatrix::from_column_slice(NAV, NAV, f.as_slice());
        let first = &s0 * t - &s1;
        let second = &s0 * (t * t) - &s1 * (2.0 * t) + &s2;
        &s0 + &fm * first + (&fm * &fm) * second * 0.5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the sum it stands for, Σ_j exp(F (T − τ_j)) B_j record by
    /// record, the exponential to second order as the moments expand it,
    /// each column on its own rows and scaled.
    #[test]
    fn moments_give_the_propagated_sum_of_the_columns() {
        let f = Matrix6::from_fn(|r, c| 0.01 * ((r * 7 + c * 3) % 5) as f64 - 0.02);
        let (n_p, t, n) = (4, 1.0, 100);
        let scale = [2.0, 0.5, 1.0, 3.0];
        let rows = [
            Rows::Attitude,
            Rows::Velocity,
            Rows::Velocity,
            Rows::Attitude,
        ];
        let col = |j: usize, p: usize| {
            let a = (j * 5 + p * 11) as f64;
            Vector3::new(a.sin(), a.cos(), (0.3 * a).sin())
        };
        let mut w = WindowColumns::new(n_p);
        let mut expected = DMatrix::<f64>::zeros(NAV, n_p);
        for j in 0..n {
            let tau = (j as f64 + 0.5) * t / n as f64;
            w.add_record(tau, |cols| {
                for (p, &rows_p) in rows.iter().enumerate() {
                    cols.set(p, rows_p, &col(j, p));
                }
            });
            let s = t - tau;
            let phi = Matrix6::identity() + f * s + f * f * (0.5 * s * s);
            for p in 0..n_p {
                let r0 = if rows[p] == Rows::Attitude { 0 } else { 3 };
                let mut b = nalgebra::Vector6::zeros();
                b.fixed_rows_mut::<3>(r0).copy_from(&(col(j, p) * scale[p]));
                let add = phi * b;
                for r in 0..NAV {
                    expected[(r, p)] += add[r];
                }
            }
        }
        let b = w.take_input(&f, t, &scale);
        assert!((&b - &expected).amax() < 1e-12 * expected.amax());
        let again = w.take_input(&f, t, &scale);
        assert_eq!(again.amax(), 0.0, "the moments start again");
    }
}
