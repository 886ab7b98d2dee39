//! The sensor noise `plan` and `design` assume, as flags: SPEC §2's white
//! densities and §2a's real-sensor terms, named as `simulate` names them,
//! so that a line predicts the σ its own units will reach.

use sinscal_core::calib::NoiseDensity;

#[derive(clap::Args, Clone, Debug)]
pub struct SensorNoiseArgs {
    /// Gyro angle random walk, deg/√h.
    #[arg(long, default_value_t = 0.0003)]
    pub arw: f64,
    /// Accelerometer velocity random walk, µg/√Hz.
    #[arg(long, default_value_t = 5.0)]
    pub vrw: f64,
    /// Gyro bias instability B, deg/h (SPEC §2a).
    #[arg(long, default_value_t = 0.0)]
    gyro_bias_instability: f64,
    /// Accelerometer bias instability B, µg.
    #[arg(long, default_value_t = 0.0)]
    accel_bias_instability: f64,
    /// Gyro rate random walk K, deg/h/√h.
    #[arg(long, default_value_t = 0.0)]
    gyro_rrw: f64,
    /// Accelerometer bias random walk K, µg/√h.
    #[arg(long, default_value_t = 0.0)]
    accel_rw: f64,
    /// Gyro pulse weight, arcsec.
    #[arg(long, default_value_t = 0.0)]
    gyro_quantum: f64,
    /// Accelerometer pulse weight, m/s.
    #[arg(long, default_value_t = 0.0)]
    accel_quantum: f64,
}

impl SensorNoiseArgs {
    /// The noise model the flags state, refused when a term is negative
    /// or not finite.
    pub fn density(&self) -> anyhow::Result<NoiseDensity> {
        let terms = [
            ("--arw", self.arw),
            ("--vrw", self.vrw),
            ("--gyro-bias-instability", self.gyro_bias_instability),
            ("--accel-bias-instability", self.accel_bias_instability),
            ("--gyro-rrw", self.gyro_rrw),
            ("--accel-rw", self.accel_rw),
            ("--gyro-quantum", self.gyro_quantum),
            ("--accel-quantum", self.accel_quantum),
        ];
        for (flag, v) in terms {
            if !(v.is_finite() && v >= 0.0) {
                anyhow::bail!("{flag} {v}: a noise term is finite and at least 0");
            }
        }
        Ok(NoiseDensity {
            gyro_arw_deg_rt_h: self.arw,
            accel_vrw_ug_rt_hz: self.vrw,
            gyro_bias_instability_deg_h: self.gyro_bias_instability,
            accel_bias_instability_ug: self.accel_bias_instability,
            gyro_rrw_deg_h_rt_h: self.gyro_rrw,
            accel_rw_ug_rt_h: self.accel_rw,
            gyro_quantum_arcsec: self.gyro_quantum,
            accel_quantum_mps: self.accel_quantum,
        })
    }
}
