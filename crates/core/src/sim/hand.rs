//! Runs turned by hand (SPEC §4): a nominal scheme's turns as an operator
//! makes them, each a fast smooth flip about an axis a few degrees off the
//! nominal one, by roughly the nominal angle, the unit lifted and set down
//! a few centimetres away.
//!
//! The draws come from a ChaCha8 stream of their own (stream 2 of `seed`),
//! so a run's noise (stream 0) and random parameters (stream 1) do not
//! shift when the same seed also turns the scheme.

use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::scheme::{Flip, Frame, Scheme, Step};
use crate::nav::attitude::rotvec_to_dcm;

/// How far hand turns stray from the nominal ones; each value is drawn
/// uniformly from its range.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HandTurns {
    /// Angle between the flip's axis and the nominal axis, deg; the
    /// direction of the tilt is uniform around the nominal axis.
    pub axis_error_deg: [f64; 2],
    /// Largest error of the turned angle, deg (uniform in ±).
    pub angle_error_deg: f64,
    /// Mean rate of a flip (angle / duration), deg/s; the peak is twice it.
    pub rate_dps: [f64; 2],
    /// Peak height the reference point is lifted to, m.
    pub lift_m: [f64; 2],
    /// Distance the reference point is set down from where it was picked
    /// up, m, in a uniform direction.
    pub shift_m: [f64; 2],
}

impl Default for HandTurns {
    /// SPEC §4's hand-turned runs: axes 1–5° off, ±2° in angle, 30–120 °/s,
    /// lifted 2–8 cm and set down 1–5 cm away.
    fn default() -> Self {
        HandTurns {
            axis_error_deg: [1.0, 5.0],
            angle_error_deg: 2.0,
            rate_dps: [30.0, 120.0],
            lift_m: [0.02, 0.08],
            shift_m: [0.01, 0.05],
        }
    }
}

impl HandTurns {
    pub fn validate(&self) -> Result<(), String> {
        let ranges = [
            ("axis_error_deg", self.axis_error_deg),
            ("rate_dps", self.rate_dps),
            ("lift_m", self.lift_m),
            ("shift_m", self.shift_m),
        ];
        for (name, [lo, hi]) in ranges {
            if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo <= hi) {
                return Err(format!(
                    "{name} [{lo}, {hi}] must be finite with 0 ≤ lo ≤ hi"
                ));
            }
        }
        if self.rate_dps[0] <= 0.0 {
            return Err(format!("rate_dps {} must be > 0", self.rate_dps[0]));
        }
        if !(self.angle_error_deg.is_finite() && self.angle_error_deg >= 0.0) {
            return Err(format!(
                "angle_error_deg {} must be ≥ 0",
                self.angle_error_deg
            ));
        }
        Ok(())
    }
}

/// Rounds to `decimals` places as the nearest double to that decimal
/// (an integer divided by an exact power of ten), so that a truth file
/// carries short numbers that parse back to the very same values.
fn round_to(x: f64, decimals: i32) -> f64 {
    let scale = 10f64.powi(decimals);
    (x * scale).round() / scale
}

fn uniform(rng: &mut ChaCha8Rng, [lo, hi]: [f64; 2]) -> f64 {
    if hi > lo {
        rng.gen_range(lo..hi)
    } else {
        lo
    }
}

/// Two unit vectors that complete the unit vector `a` to an orthonormal
/// basis.
fn perpendiculars(a: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    // The coordinate axis least aligned with a keeps the cross product
    // well conditioned.
    let i = a.iamin();
    let mut other = Vector3::zeros();
    other[i] = 1.0;
    let e1 = a.cross(&other).normalize();
    (e1, a.cross(&e1))
}

impl Scheme {
    /// The scheme `nominal` as turned by hand: every turntable turn becomes
    /// a flip (SPEC §4) with the errors of `opts`, drawn from `seed`;
    /// dwells and flips are kept. A navigation-axis turn becomes a flip
    /// about the body axis that the nominal attitude (the nominal start,
    /// then the nominal turns) puts on that navigation axis: the operator
    /// turns the unit as they believe it sits.
    pub fn by_hand(nominal: &Scheme, seed: u64, opts: &HandTurns) -> Result<Scheme, String> {
        nominal.validate()?;
        opts.validate()?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(2);
        let mut c_b_n_nominal = Matrix3::identity();
        let mut steps = Vec::with_capacity(nominal.steps.len());
        for step in &nominal.steps {
            match step {
                Step::Dwell { .. } => steps.push(*step),
                Step::Flip { flip } => {
                    let axis_b = Vector3::from(flip.unit_axis_b());
                    c_b_n_nominal *= rotvec_to_dcm(&(axis_b * flip.angle_deg.to_radians()));
                    steps.push(*step);
                }
                Step::Rotate { rotate } => {
                    if rotate.angle_deg == 0.0 {
                        continue;
                    }
                    let own = Vector3::from(rotate.axis_vector());
                    let axis_b = match rotate.frame() {
                        Frame::Body => own,
                        Frame::Nav => c_b_n_nominal.transpose() * own,
                    };
                    c_b_n_nominal *= rotvec_to_dcm(&(axis_b * rotate.angle_deg.to_radians()));

                    let tilt = uniform(&mut rng, opts.axis_error_deg).to_radians();
                    let around = rng.gen_range(0.0..std::f64::consts::TAU);
                    let (e1, e2) = perpendiculars(&axis_b);
                    let off = e1 * around.cos() + e2 * around.sin();
                    let axis = axis_b * tilt.cos() + off * tilt.sin();
                    let angle_deg =
                        rotate.angle_deg + opts.angle_error_deg * rng.gen_range(-1.0..=1.0);
                    let rate_dps = uniform(&mut rng, opts.rate_dps);
                    let lift_m = uniform(&mut rng, opts.lift_m);
                    let shift = uniform(&mut rng, opts.shift_m);
                    let heading = rng.gen_range(0.0..std::f64::consts::TAU);
                    let flip = Flip {
                        axis_b: axis.map(|v| round_to(v, 9)).into(),
                        angle_deg: round_to(angle_deg, 4),
                        duration_s: round_to(angle_deg.abs() / rate_dps, 4).max(1e-4),
                        lift_m: round_to(lift_m, 5),
                        shift_m: [
                            round_to(shift * heading.sin(), 5),
                            round_to(shift * heading.cos(), 5),
                        ],
                    };
                    steps.push(Step::Flip { flip });
                }
            }
        }
        let scheme = Scheme {
            name: format!("{} by hand", nominal.name),
            steps,
        };
        scheme.validate()?;
        Ok(scheme)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_turn_becomes_a_flip_within_the_ranges() {
        let nominal = Scheme::builtin("ten-position-9+9", 300.0).unwrap();
        let opts = HandTurns::default();
        let hand = Scheme::by_hand(&nominal, 5, &opts).unwrap();
        assert_eq!(hand.counts(), nominal.counts());
        assert_eq!(hand, Scheme::by_hand(&nominal, 5, &opts).unwrap());
        assert_ne!(hand, Scheme::by_hand(&nominal, 6, &opts).unwrap());
        for (n, h) in nominal.steps.iter().zip(&hand.steps) {
            match (n, h) {
                (Step::Dwell { .. }, _) => assert_eq!(n, h),
                (Step::Rotate { rotate }, Step::Flip { flip }) => {
                    let cos = Vector3::from(rotate.axis_vector()).dot(&Vector3::from(flip.axis_b));
                    let off = cos.clamp(-1.0, 1.0).acos().to_degrees();
                    assert!((1.0 - 1e-6..=5.0 + 1e-6).contains(&off), "axis {off}° off");
                    assert!((flip.angle_deg - rotate.angle_deg).abs() <= 2.0 + 1e-4);
                    let rate = flip.angle_deg.abs() / flip.duration_s;
                    assert!((29.9..=120.1).contains(&rate), "rate {rate}");
                    assert!((0.02..=0.08).contains(&flip.lift_m));
                    let s = flip.shift_m[0].hypot(flip.shift_m[1]);
                    assert!((0.01 - 1e-5..=0.05 + 1e-5).contains(&s));
                }
                _ => panic!("{n:?} became {h:?}"),
            }
        }
    }

    #[test]
    fn navigation_axis_turns_follow_the_nominal_attitude() {
        // After y+90 (x → down, z → east), a turn about Up is a turn about
        // −x of the body.
        let nominal: Scheme = serde_json::from_str(
            r#"{"steps": [{"rotate": {"axis": "y", "angle_deg": 90}},
                          {"rotate": {"axis": "u", "angle_deg": 90}}]}"#,
        )
        .unwrap();
        let hand = Scheme::by_hand(&nominal, 1, &HandTurns::default()).unwrap();
        let Step::Flip { flip } = hand.steps[1] else {
            panic!("expected a flip");
        };
        assert!(flip.axis_b[0] < -0.99, "{:?}", flip.axis_b);
    }
}
