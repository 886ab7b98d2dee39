//! `sinscal simulate`'s temperature flags (SPEC §3a): a thermal truth and
//! temperature history from a file, or a soak at one temperature.

use std::path::PathBuf;

use anyhow::bail;
use sinscal_core::io::meta::read_json;
use sinscal_core::model::{TemperatureHistory, ThermalTruth};
use sinscal_core::sim::SimConfig;

#[derive(clap::Args)]
pub struct ThermalArgs {
    /// A JSON file with a truth's SPEC §3a members, either optional:
    /// `{"thermal": {"linear": …, "quadratic": …, "gyro_bias_rate": […]},
    /// "temperature": {"start_c": …, "rate_c_per_min": …, "max_c": …} or
    /// {"points": [[t_s, T_c], …]}}`. Replaces the truth's own.
    #[arg(long)]
    pub thermal: Option<PathBuf>,
    /// A soaked run at this temperature, °C: stated as metadata
    /// `temperature_c`, no column.
    #[arg(long, allow_hyphen_values = true)]
    pub temperature_c: Option<f64>,
}

/// The `--thermal` file.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ThermalFile {
    #[serde(default)]
    thermal: Option<ThermalTruth>,
    #[serde(default)]
    temperature: Option<TemperatureHistory>,
}

impl ThermalArgs {
    /// Puts the flags' thermal truth and temperature into `cfg`.
    pub fn apply(&self, cfg: &mut SimConfig) -> anyhow::Result<()> {
        if let Some(path) = &self.thermal {
            let file: ThermalFile = read_json(path)?;
            if file.thermal.is_some() {
                cfg.thermal = file.thermal;
            }
            if file.temperature.is_some() {
                cfg.temperature = file.temperature;
            }
        }
        if let Some(t) = self.temperature_c {
            if cfg
                .temperature
                .as_ref()
                .is_some_and(|h| h.soak_c().is_none())
            {
                bail!("--temperature-c is a soak: the run already has a temperature history");
            }
            let soak = TemperatureHistory::Soak(t);
            soak.validate()?;
            cfg.temperature = Some(soak);
        }
        Ok(())
    }
}
