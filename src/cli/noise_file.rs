//! `calibrate --noise FILE` and `--noise-reference FILE`: a noise model the
//! unit is known to have, read from a JSON object with the truth file's
//! `noise` names (SPEC §2 and §2a, canonical units), checked as the core's
//! held models are (`sinscal_core::calib::held_noise`).

use std::path::Path;

use sinscal_core::calib::{parse_noise_terms, NoiseDensity};

/// Reads and checks a noise file, naming the file and the term refused.
pub fn read_noise_file(path: &Path) -> anyhow::Result<NoiseDensity> {
    let in_file = |e: &dyn std::fmt::Display| anyhow::anyhow!("{}: {e}", path.display());
    let text = std::fs::read_to_string(path).map_err(|e| in_file(&e))?;
    let value: serde_json::Value = serde_json::from_str(&text).map_err(|e| in_file(&e))?;
    parse_noise_terms(&value).map_err(|e| in_file(&e))
}
