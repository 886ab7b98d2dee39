//! Pulse outputs (SPEC §2a): the unit counts whole quanta of the
//! accumulated Δθ_meas and Δv_meas and carries the remainder to the next
//! record, so each record holds an integer number of quanta and the running
//! sum of the output stays within one quantum of the running sum of what
//! was sensed.
//!
//! The project's choices: the count is the floor of (carry + increment)/q,
//! so the carry stays in [0, q) and the output's running sum is at most one
//! quantum below the sensed one, never above; the carry starts at zero.
//! Only the carry is kept, never a running sum, so nothing grows with the
//! run's length and the rounding does not accumulate.

use crate::record::Record;

/// One pulse counter per channel (gyro x, y, z, accelerometer x, y, z).
#[derive(Clone, Debug)]
pub struct PulseCounter {
    /// Pulse weight per channel (0: the channel is not quantized).
    quantum: [f64; 6],
    carry: [f64; 6],
}

impl PulseCounter {
    /// Counters for gyro pulses of `gyro_rad` and accelerometer pulses of
    /// `accel_mps` (either 0: that triad is not quantized); `None` when
    /// neither is.
    pub fn new(gyro_rad: f64, accel_mps: f64) -> Option<Self> {
        (gyro_rad > 0.0 || accel_mps > 0.0).then_some(PulseCounter {
            quantum: [
                gyro_rad, gyro_rad, gyro_rad, accel_mps, accel_mps, accel_mps,
            ],
            carry: [0.0; 6],
        })
    }

    /// Replaces the record's increments by whole quanta.
    pub fn count(&mut self, r: &mut Record) {
        for c in 0..6 {
            let q = self.quantum[c];
            if q == 0.0 {
                continue;
            }
            let x = if c < 3 {
                &mut r.dtheta[c]
            } else {
                &mut r.dv[c - 3]
            };
            let total = self.carry[c] + *x;
            let pulses = (total / q).floor();
            *x = pulses * q;
            self.carry[c] = total - *x;
        }
    }

    /// What each channel holds back, in its unit.
    pub fn carry(&self) -> [f64; 6] {
        self.carry
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_quanta_and_a_carry_below_one() {
        let q = 1e-4;
        let mut p = PulseCounter::new(0.0, q).unwrap();
        let (mut sensed, mut counted) = (0.0, 0.0);
        for k in 0..100_000 {
            let x = 3.7e-5 + 2e-5 * ((k as f64) * 0.37).sin();
            let mut r = Record {
                t: k as f64,
                dtheta: [x; 3],
                dv: [x, -x, 0.0],
            };
            p.count(&mut r);
            assert_eq!(r.dtheta, [x; 3]);
            let n = r.dv[0] / q;
            assert!((n - n.round()).abs() < 1e-9, "{n}");
            sensed += x;
            counted += r.dv[0];
            assert!((0.0..q).contains(&(sensed - counted + 1e-12)), "{k}");
        }
        assert!(PulseCounter::new(0.0, 0.0).is_none());
    }
}
