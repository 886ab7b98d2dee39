//! `sinscal simulate`'s real-sensor flags (SPEC §2a): wandering biases,
//! pulse outputs, floor vibration, time jitter and lost records, each
//! replacing the truth's own when given, and a preset for a typical
//! navigation-grade ring-laser unit.

use sinscal_core::sim::{Gap, Noise, SimConfig, Vibration};

#[derive(clap::Args)]
pub struct SensorArgs {
    /// A typical navigation-grade RLG unit on a lab floor: bias
    /// instability 0.002 deg/h and 3 µg, rate random walk 0.0003
    /// deg/h/√h and 3 µg/√h, pulses of 1 arcsec and 1e-4 m/s, floor
    /// vibration 30 µg rms over 2–30 Hz. The flags below override it.
    #[arg(long)]
    pub real_sensor: bool,
    /// Gyro bias instability B, deg/h (Allan floor 0.664·B).
    #[arg(long, value_name = "DEG_H", value_parser = non_negative)]
    pub gyro_bias_instability: Option<f64>,
    /// Accelerometer bias instability B, µg.
    #[arg(long, value_name = "UG", value_parser = non_negative)]
    pub accel_bias_instability: Option<f64>,
    /// Gyro rate random walk K, deg/h/√h.
    #[arg(long, value_name = "DEG_H_RT_H", value_parser = non_negative)]
    pub gyro_rrw: Option<f64>,
    /// Accelerometer random walk K, µg/√h.
    #[arg(long, value_name = "UG_RT_H", value_parser = non_negative)]
    pub accel_rw: Option<f64>,
    /// Gyro pulse weight, arcsec (0: no pulses).
    #[arg(long, value_name = "ARCSEC", value_parser = non_negative)]
    pub gyro_quantum: Option<f64>,
    /// Accelerometer pulse weight, m/s (0: no pulses).
    #[arg(long, value_name = "MPS", value_parser = non_negative)]
    pub accel_quantum: Option<f64>,
    /// Floor vibration: rms µg on each navigation axis over a band, Hz:
    /// "RMS,LO,HI".
    #[arg(long, value_name = "RMS,LO,HI", value_parser = parse_vibration)]
    pub vibration: Option<Vibration>,
    /// Time-stamp jitter: every step within ±PCT % of the nominal one.
    #[arg(long, value_name = "PCT", value_parser = non_negative)]
    pub time_jitter: Option<f64>,
    /// Records lost from T s for DUR s: "T,DUR"; repeatable.
    #[arg(long = "gap", value_name = "T,DUR", value_parser = parse_gap)]
    pub gaps: Vec<Gap>,
}

fn non_negative(s: &str) -> Result<f64, String> {
    let x: f64 = s.trim().parse().map_err(|e| format!("{s:?}: {e}"))?;
    if x.is_finite() && x >= 0.0 {
        Ok(x)
    } else {
        Err(format!("{x} must be finite and ≥ 0"))
    }
}

fn numbers<const N: usize>(s: &str) -> Result<[f64; N], String> {
    let v: Vec<f64> = s.split(',').map(non_negative).collect::<Result<_, _>>()?;
    let n = v.len();
    <[f64; N]>::try_from(v).map_err(|_| format!("expected {N} comma-separated numbers, got {n}"))
}

fn parse_vibration(s: &str) -> Result<Vibration, String> {
    let [rms_ug, lo, hi] = numbers(s)?;
    Ok(Vibration {
        rms_ug,
        band_hz: [lo, hi],
    })
}

fn parse_gap(s: &str) -> Result<Gap, String> {
    numbers::<2>(s).map(Gap::from)
}

impl SensorArgs {
    /// Puts the preset and the flags into `cfg.noise`, then checks it (the
    /// message names the truth field at fault).
    pub fn apply(&self, cfg: &mut SimConfig) -> anyhow::Result<()> {
        let n = &mut cfg.noise;
        if self.real_sensor {
            *n = Noise {
                gyro_arw_deg_rt_h: n.gyro_arw_deg_rt_h,
                accel_vrw_ug_rt_hz: n.accel_vrw_ug_rt_hz,
                time_jitter_pct: n.time_jitter_pct,
                gaps: std::mem::take(&mut n.gaps),
                ..Noise::real_navigation_grade()
            };
        }
        let set = |field: &mut f64, flag: Option<f64>| {
            if let Some(x) = flag {
                *field = x;
            }
        };
        set(
            &mut n.gyro_bias_instability_deg_h,
            self.gyro_bias_instability,
        );
        set(
            &mut n.accel_bias_instability_ug,
            self.accel_bias_instability,
        );
        set(&mut n.gyro_rrw_deg_h_rt_h, self.gyro_rrw);
        set(&mut n.accel_rw_ug_rt_h, self.accel_rw);
        set(&mut n.gyro_quantum_arcsec, self.gyro_quantum);
        set(&mut n.accel_quantum_mps, self.accel_quantum);
        set(&mut n.time_jitter_pct, self.time_jitter);
        if self.vibration.is_some() {
            n.vibration = self.vibration;
        }
        if !self.gaps.is_empty() {
            n.gaps = self.gaps.clone();
        }
        n.validate().map_err(|e| anyhow::anyhow!("noise: {e}"))
    }
}
