//! Runs of units below navigation grade as a line makes them: a tactical
//! or consumer (MEMS) unit turned by hand through `ten-position-9+9` (19
//! positions), each dwell 5–30 s, at 100 Hz, from any heading, with a
//! random truth up to its datasheet's largest errors (±2×
//! `Grade::magnitude`) and SPEC §2a noise at the grade's sizes, each drawn
//! log-uniform from its range:
//!
//! | | tactical | consumer |
//! |---|---|---|
//! | ARW, deg/√h | 0.06–0.3 | 0.2–1 |
//! | VRW, µg/√Hz | 30–100 | 100–300 |
//! | bias instability | 0.1–1 deg/h, 10–50 µg | 2–20 deg/h, 20–200 µg |
//! | pulses | 0.05″, 1e-6 m/s | 0.5″, 2.5e-5 m/s |
//!
//! What the grades' benchmark and tests calibrate; the draws come from
//! stream 3 of the seed, apart from the noise's own.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::hand::HandTurns;
use super::scheme::{Scheme, Step};
use super::sensor_noise::Noise;
use super::SimConfig;
use crate::model::{Effects, ErrorParameters, Grade};
use crate::nav::Site;

/// Where a run's unit starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StartHeading {
    /// Anywhere on the circle, as a unit set down on a bench.
    Anywhere,
    /// SPEC §4's nominal heading (x east), within ±3°.
    Nominal,
}

/// Seed `seed`'s run of a unit of `grade` (tactical or consumer).
pub fn hand_run(grade: Grade, seed: u64, start: StartHeading) -> SimConfig {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(3);
    let params = ErrorParameters::random_sized(&mut rng, |g| grade.magnitude(g));
    let heading = match start {
        StartHeading::Anywhere => rng.gen_range(0.0..360.0),
        StartHeading::Nominal => rng.gen_range(-3.0..=3.0),
    };
    let tilt = [rng.gen_range(-3.0..=3.0), rng.gen_range(-3.0..=3.0)];
    let scheme = hand_scheme(seed, &mut rng);
    SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: 100.0,
        scheme,
        params,
        effects: Effects::none(),
        noise: grade_noise(grade, &mut rng),
        initial_attitude_error_deg: [tilt[0], tilt[1], heading],
        seed,
        thermal: None,
        temperature: None,
    }
}

fn log_uniform(rng: &mut impl Rng, [lo, hi]: [f64; 2]) -> f64 {
    (lo.ln() + rng.gen::<f64>() * (hi / lo).ln()).exp()
}

/// Noise at `grade`'s sizes (the table in the module's doc).
fn grade_noise(grade: Grade, rng: &mut impl Rng) -> Noise {
    let consumer = grade == Grade::Consumer;
    let pick = |tactical: [f64; 2], mems: [f64; 2]| if consumer { mems } else { tactical };
    Noise {
        gyro_arw_deg_rt_h: log_uniform(rng, pick([0.06, 0.3], [0.2, 1.0])),
        accel_vrw_ug_rt_hz: log_uniform(rng, pick([30.0, 100.0], [100.0, 300.0])),
        gyro_bias_instability_deg_h: log_uniform(rng, pick([0.1, 1.0], [2.0, 20.0])),
        accel_bias_instability_ug: log_uniform(rng, pick([10.0, 50.0], [20.0, 200.0])),
        gyro_quantum_arcsec: if consumer { 0.5 } else { 0.05 },
        accel_quantum_mps: if consumer { 2.5e-5 } else { 1e-6 },
        ..Noise::default()
    }
}

/// `ten-position-9+9` turned by hand, each dwell 5–30 s.
fn hand_scheme(seed: u64, rng: &mut impl Rng) -> Scheme {
    let nominal = Scheme::builtin("ten-position-9+9", 1.0).expect("a built-in scheme");
    let mut scheme =
        Scheme::by_hand(&nominal, seed, &HandTurns::default()).expect("default turns are valid");
    for step in &mut scheme.steps {
        if let Step::Dwell { dwell_s } = step {
            *dwell_s = rng.gen_range(5.0..=30.0);
        }
    }
    scheme
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_seed_makes_one_run_and_its_truth_is_the_grades_size() {
        let a = hand_run(Grade::Consumer, 4, StartHeading::Anywhere);
        let b = hand_run(Grade::Consumer, 4, StartHeading::Anywhere);
        assert_eq!(a.params, b.params);
        assert_eq!(a.scheme, b.scheme);
        let largest_bias = a.params.b_g().amax();
        assert!(largest_bias > 2.0 * Grade::Tactical.magnitude(crate::model::Group::GyroBias));
        let dwells: Vec<f64> = a
            .scheme
            .steps
            .iter()
            .filter_map(|s| match s {
                Step::Dwell { dwell_s } => Some(*dwell_s),
                _ => None,
            })
            .collect();
        assert_eq!(dwells.len(), 19);
        assert!(dwells.iter().all(|d| (5.0..=30.0).contains(d)));
    }
}
