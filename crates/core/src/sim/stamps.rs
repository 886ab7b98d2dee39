//! When the simulated logger stamps its records (SPEC §2a): t_k = kΔt,
//! or with jitter t_k = kΔt + e_k; and which records it loses.
//!
//! The project's choices: e_k is uniform in ±(j/200)·Δt, independent from
//! record to record, so every step t_k − t_{k−1} lies within ±j % of Δt
//! (t_0 = 0, the scheme's start, carries no error). The draws come from
//! ChaCha8 stream 8 of the run's seed, one uniform a record. A record
//! stamped inside a gap [start, start + duration) is lost: the unit made
//! it, the logger did not write it, and the next record written still
//! covers only its own interval.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::sensor_noise::Gap;

/// The jitter's random stream.
pub const STREAM_JITTER: u64 = 8;

/// The stamps of a run's records, in order.
#[derive(Clone, Debug)]
pub struct Stamps {
    rate: f64,
    /// Half-width of e_k, s; 0 without jitter.
    half_width: f64,
    rng: ChaCha8Rng,
    prev: f64,
    gaps: Vec<Gap>,
}

impl Stamps {
    pub fn new(rate: f64, jitter_pct: f64, seed: u64, gaps: &[Gap]) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(STREAM_JITTER);
        Stamps {
            rate,
            half_width: jitter_pct / 200.0 / rate,
            rng,
            prev: 0.0,
            gaps: gaps.to_vec(),
        }
    }

    pub fn jittered(&self) -> bool {
        self.half_width > 0.0
    }

    /// Record k's interval (t_{k−1}, t_k]; called for k = 1, 2, … in turn.
    pub fn interval(&mut self, k: u64) -> (f64, f64) {
        if !self.jittered() {
            return ((k - 1) as f64 / self.rate, k as f64 / self.rate);
        }
        let e = self.half_width * self.rng.gen_range(-1.0..=1.0);
        let t = k as f64 / self.rate + e;
        let t_prev = std::mem::replace(&mut self.prev, t);
        (t_prev, t)
    }

    /// Whether the logger loses the record stamped `t`.
    pub fn lost(&self, t: f64) -> bool {
        self.gaps.iter().any(|g| g.holds(t))
    }

    /// How many of records 1 … n are lost (a pass over a copy of the
    /// stamps: one uniform a record).
    pub fn count_lost(&self, n: u64) -> u64 {
        if self.gaps.is_empty() {
            return 0;
        }
        let mut s = self.clone();
        (1..=n)
            .filter(|&k| {
                let t = s.interval(k).1;
                s.lost(t)
            })
            .count() as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_stay_within_the_jitter() {
        let mut s = Stamps::new(100.0, 5.0, 3, &[]);
        let mut last = 0.0;
        for k in 1..=10_000 {
            let (a, b) = s.interval(k);
            assert_eq!(a, last);
            assert!(((b - a) * 100.0 - 1.0).abs() <= 0.05 + 1e-12, "{k}");
            last = b;
        }
        let mut plain = Stamps::new(100.0, 0.0, 3, &[]);
        assert_eq!(plain.interval(7), (6.0 / 100.0, 7.0 / 100.0));
    }

    #[test]
    fn gaps_lose_the_records_stamped_inside() {
        let s = Stamps::new(10.0, 0.0, 1, &[Gap::from([1.0, 0.5])]);
        assert!(!s.lost(0.9) && s.lost(1.0) && s.lost(1.4) && !s.lost(1.5));
        assert_eq!(s.count_lost(100), 5);
    }
}
