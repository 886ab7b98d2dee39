//! Pulse outputs found in the data: whether every record's increment on an
//! axis is a whole number of one quantum q (SPEC §2a), and q.
//!
//! The test is exact, not statistical. The candidate q of an axis is the
//! greatest common divisor of the increments seen so far, found by
//! Euclid's algorithm on floating-point numbers: `%` is exact in IEEE
//! arithmetic, so the remainders of whole multiples of q stay whole
//! multiples of q up to the rounding of the multiples themselves (a few
//! ulps of the largest), and the algorithm stops when a remainder is that
//! small. A record that is not a whole multiple of the candidate (to 10⁻⁶
//! of a quantum) replaces it by the common divisor of both, which is the
//! old candidate divided by a whole number, so every earlier record stays a
//! multiple. An axis is declared unquantized, for good, when the candidate
//! would need more than 2²⁴ quanta in its largest record: unquantized
//! numbers drive Euclid's algorithm down to their rounding within a few
//! records, while a real pulse output's record holds at most some tens of
//! thousands of quanta even in a fast turn.
//!
//! Per record and axis: one division and a rounding; Euclid's algorithm
//! runs only when the candidate shrinks (a handful of times per run). The
//! candidate is refined by least squares over the counts as records pass
//! (q = Σ n u / Σ n²), so it carries no rounding from the divisions that
//! found it.

use super::allan::CHANNELS;

/// The most quanta a record may hold.
const MAX_COUNT: f64 = 16_777_216.0;

/// How far from a whole number of quanta a record may be (rounding of
/// count × quantum, in quanta).
const COUNT_TOLERANCE: f64 = 1e-6;

/// A Euclid remainder this far below the larger operand is rounding, not a
/// quantum.
const EUCLID_FLOOR: f64 = 1.0 / (1u64 << 32) as f64;

/// Records with a non-zero increment needed before a quantum is reported.
pub const MIN_NONZERO_RECORDS: u64 = 100;

/// One axis's state.
#[derive(Clone, Debug, Default)]
struct Axis {
    /// The candidate quantum; 0 before the first non-zero record.
    q: f64,
    /// Σ n·|u| and Σ n² over the records, in the candidate's counts.
    sum_nu: f64,
    sum_nn: f64,
    largest: f64,
    nonzero: u64,
    unquantized: bool,
}

impl Axis {
    fn push(&mut self, u: f64) {
        let a = u.abs();
        // Within rounding of no quantum at all is none: increments summed
        // in floating point (a logger adding a fast stream into slower
        // records) leave 1e-20 where +q and −q cancelled.
        let rounding_of_zero = a < COUNT_TOLERANCE * self.q;
        if self.unquantized || a == 0.0 || rounding_of_zero {
            return;
        }
        if !a.is_finite() {
            self.unquantized = true;
            return;
        }
        self.nonzero += 1;
        self.largest = self.largest.max(a);
        if self.q == 0.0 {
            self.q = a;
        }
        let mut n = (a / self.q).round();
        if (a / self.q - n).abs() > COUNT_TOLERANCE || n == 0.0 {
            let g = euclid(self.q, a);
            let k = (self.q / g).round().max(1.0);
            self.q /= k;
            self.sum_nu *= k;
            self.sum_nn *= k * k;
            n = (a / self.q).round();
            if (a / self.q - n).abs() > 1e3 * COUNT_TOLERANCE {
                self.unquantized = true;
                return;
            }
        }
        if self.largest / self.q > MAX_COUNT || n == 0.0 {
            self.unquantized = true;
            return;
        }
        self.sum_nu += n * a;
        self.sum_nn += n * n;
        self.q = self.sum_nu / self.sum_nn;
    }

    fn quantum(&self) -> Option<f64> {
        (!self.unquantized && self.nonzero >= MIN_NONZERO_RECORDS && self.q > 0.0).then_some(self.q)
    }
}

/// The greatest common divisor of two positive numbers that are whole
/// multiples of a quantum, to rounding.
fn euclid(a: f64, b: f64) -> f64 {
    let floor = a.max(b) * EUCLID_FLOOR;
    let (mut x, mut y) = (a.max(b), a.min(b));
    while y > floor {
        let r = x % y;
        // A remainder within rounding of y is y itself.
        let r = if y - r <= floor { 0.0 } else { r };
        x = y;
        y = r;
    }
    x
}

/// Finds each axis's quantum as records stream past: the three gyro axes
/// (angle increments), then the three accelerometer axes (velocity
/// increments), in the order the Allan sums take them.
///
/// ```
/// use sinscal_core::noise::quantum::QuantumDetector;
/// let q = 0.1 / 206_264.806; // 0.1 arcsec, rad
/// let mut d = QuantumDetector::default();
/// for k in 0..1000_i64 {
///     let counts = [(k * 7) % 5 - 2, 3, -(k % 4), 1, 0, 80];
///     d.push(&counts.map(|n| n as f64 * q));
/// }
/// let found = d.quanta();
/// assert!((found[0].unwrap() / q - 1.0).abs() < 1e-12);
/// assert!(found[4].is_none()); // never a non-zero increment
/// ```
#[derive(Clone, Debug, Default)]
pub struct QuantumDetector {
    axes: [Axis; CHANNELS],
}

impl QuantumDetector {
    /// One record's increments.
    pub fn push(&mut self, inc: &[f64; CHANNELS]) {
        for (axis, u) in self.axes.iter_mut().zip(inc) {
            axis.push(*u);
        }
    }

    /// Each axis's quantum (rad or m/s), `None` where some record is not
    /// a whole number of one quantum, or where fewer than
    /// [`MIN_NONZERO_RECORDS`] records moved at all.
    pub fn quanta(&self) -> [Option<f64>; CHANNELS] {
        std::array::from_fn(|c| self.axes[c].quantum())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Counts of pulse outputs (a unit at rest: a few counts a record, one
    /// channel far from zero), each quantum found to rounding; the same
    /// numbers with noise below a thousandth of a quantum are unquantized.
    #[test]
    fn quanta_are_found_exactly_and_only_where_every_record_is_whole() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let q = [4.8e-7, 4.8e-7, 9.7e-7, 1.2e-3, 1.2e-3, 1.0e-5];
        let mut exact = QuantumDetector::default();
        let mut rough = QuantumDetector::default();
        for _ in 0..20_000 {
            let counts: [f64; CHANNELS] = std::array::from_fn(|c| {
                let base = if c == 5 { 980.0 } else { 0.0 };
                base + rng.gen_range(-6..=6) as f64
            });
            let u: [f64; CHANNELS] = std::array::from_fn(|c| counts[c] * q[c]);
            exact.push(&u);
            rough.push(&std::array::from_fn(|c| {
                u[c] + q[c] * 1e-3 * (rng.gen::<f64>() - 0.5)
            }));
        }
        for (c, found) in exact.quanta().iter().enumerate() {
            let found = found.unwrap_or_else(|| panic!("axis {c}: none"));
            assert!((found / q[c] - 1.0).abs() < 1e-12, "axis {c}: {found}");
        }
        assert_eq!(rough.quanta(), [None; CHANNELS]);
    }

    /// Counts that are all even give twice the quantum (every record is a
    /// whole number of it); a channel that never moves has none.
    #[test]
    fn a_common_factor_of_the_counts_is_the_quantum_the_data_shows() {
        let mut d = QuantumDetector::default();
        for k in 0..500 {
            let n = 2.0 * ((k % 7) as f64 - 3.0);
            d.push(&[n * 0.3, 0.0, 0.0, 0.0, 0.0, 0.0]);
        }
        let found = d.quanta();
        assert!((found[0].unwrap() - 0.6).abs() < 1e-12, "{found:?}");
        assert_eq!(found[1], None);
    }

    /// Pulses summed into slower records in floating point: where they
    /// cancel, the sum is a rounding residue, not a record off the lattice.
    #[test]
    fn a_sum_of_pulses_that_cancels_to_rounding_stays_quantized() {
        let q = 1e-4;
        let mut d = QuantumDetector::default();
        for k in 0..500 {
            let cancelled = (0.3 * q + 0.7 * q) - q - (0.1 * q + 0.2 * q) + 0.3 * q;
            let u = if k % 50 == 7 {
                cancelled
            } else {
                ((k % 5) as f64 - 2.0) * q
            };
            d.push(&[u; CHANNELS]);
        }
        for found in d.quanta() {
            assert!((found.expect("a quantum") / q - 1.0).abs() < 1e-12);
        }
    }
}
