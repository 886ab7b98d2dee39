//! Seed k's sensor noise for the real-sensors bench: the terms drawn per
//! seed, and those held at one size on every seed by the command line.

use rand::{Rng, SeedableRng};

use sinscal_core::sim::{Noise, Vibration};

use super::value;

/// A value log-uniform in [lo, hi].
fn log_uniform(rng: &mut impl Rng, lo: f64, hi: f64) -> f64 {
    (lo.ln() + rng.gen::<f64>() * (hi / lo).ln()).exp()
}

/// Seed k's sensor noise.
pub fn real_noise(seed: u64, pulses_only: bool, white: bool) -> Noise {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1000 + seed);
    let mut n = Noise::default_navigation_grade();
    if white {
        return n;
    }
    n.gyro_quantum_arcsec = 1.0;
    n.accel_quantum_mps = 1e-4;
    if pulses_only {
        return n;
    }
    n.gyro_bias_instability_deg_h = log_uniform(&mut rng, 0.0005, 0.003);
    n.accel_bias_instability_ug = log_uniform(&mut rng, 1.0, 5.0);
    n.gyro_rrw_deg_h_rt_h = log_uniform(&mut rng, 0.0001, 0.0005);
    n.accel_rw_ug_rt_h = log_uniform(&mut rng, 1.0, 3.0);
    n.vibration = Some(Vibration {
        rms_ug: 30.0,
        band_hz: [2.0, 30.0],
    });
    n
}

/// Terms held at one size on every seed instead of drawn (SPEC §2a's
/// units: deg/h, µg, deg/h/√h, µg/√h; the VRW µg/√Hz; the quanta ″ and
/// m/s): a size given by its flag, else 0 where a `--no-…` switch
/// removes the term.
#[derive(Default)]
pub struct HeldTerms {
    gyro_instability: Option<f64>,
    accel_instability: Option<f64>,
    gyro_rrw: Option<f64>,
    accel_rw: Option<f64>,
    vrw: Option<f64>,
    gyro_quantum: Option<f64>,
    accel_quantum: Option<f64>,
}

impl HeldTerms {
    pub fn from_args(args: &[String]) -> Self {
        let removed = |flag: &str| args.iter().any(|a| a == flag).then_some(0.0);
        let sized = |flag: &str, removing: &str| value(args, flag).or(removed(removing));
        HeldTerms {
            gyro_instability: sized("--gyro-instability", "--no-instability"),
            accel_instability: sized("--accel-instability", "--no-instability"),
            gyro_rrw: sized("--gyro-rrw", "--no-random-walk"),
            accel_rw: sized("--accel-rw", "--no-random-walk"),
            vrw: value(args, "--vrw"),
            gyro_quantum: removed("--no-pulses").or(removed("--no-gyro-pulses")),
            accel_quantum: removed("--no-pulses"),
        }
    }

    pub fn apply(&self, noise: &mut Noise) {
        let held = [
            (
                self.gyro_instability,
                &mut noise.gyro_bias_instability_deg_h,
            ),
            (self.accel_instability, &mut noise.accel_bias_instability_ug),
            (self.gyro_rrw, &mut noise.gyro_rrw_deg_h_rt_h),
            (self.accel_rw, &mut noise.accel_rw_ug_rt_h),
            (self.vrw, &mut noise.accel_vrw_ug_rt_hz),
            (self.gyro_quantum, &mut noise.gyro_quantum_arcsec),
            (self.accel_quantum, &mut noise.accel_quantum_mps),
        ];
        for (size, term) in held {
            if let Some(size) = size {
                *term = size;
            }
        }
    }
}
