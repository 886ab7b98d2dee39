//! `calibrate --noise FILE`: a noise model the unit is known to have, read
//! from a JSON object with the truth file's `noise` names (SPEC §2 and
//! §2a, canonical units), used as given instead of measured and fitted.
//!
//! Why a line gives one: from a single run a navigation-grade unit's gyro
//! ARW and bias instability lie under its pulse quantization at every τ a
//! dwell offers, so the fit can trade one for the other, and the two imply
//! different σ for parameters seen over different times (docs/FIGURES.md,
//! "Real sensors"). A unit characterised once (a long static recording,
//! `sinscal noise --static`) settles that split for all its runs.

use std::path::Path;

use sinscal_core::calib::NoiseDensity;

/// The terms a noise file may hold: the estimator's noise model. The
/// truth's simulation-only fields (vibration, jitter, gaps) are refused
/// by name, since the estimator would silently drop them.
const TERMS: [&str; 8] = [
    "gyro_arw_deg_rt_h",
    "accel_vrw_ug_rt_hz",
    "gyro_bias_instability_deg_h",
    "accel_bias_instability_ug",
    "gyro_rrw_deg_h_rt_h",
    "accel_rw_ug_rt_h",
    "gyro_quantum_arcsec",
    "accel_quantum_mps",
];

/// The two white densities every noise model states.
const REQUIRED: [&str; 2] = ["gyro_arw_deg_rt_h", "accel_vrw_ug_rt_hz"];

/// Reads and checks a noise file: a JSON object of [`TERMS`], both white
/// densities present and above 0, every term a finite number ≥ 0.
pub fn read_noise_file(path: &Path) -> anyhow::Result<NoiseDensity> {
    let text =
        std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    parse_noise(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

fn parse_noise(text: &str) -> anyhow::Result<NoiseDensity> {
    let value: serde_json::Value = serde_json::from_str(text)?;
    let object = value
        .as_object()
        .ok_or_else(|| anyhow::anyhow!("a noise model is a JSON object of its terms"))?;
    for (name, v) in object {
        if !TERMS.contains(&name.as_str()) {
            anyhow::bail!(
                "\"{name}\" is not a term of the estimator's noise model (one of {})",
                TERMS.join(", ")
            );
        }
        let ok = v.as_f64().is_some_and(|x| x.is_finite() && x >= 0.0);
        if !ok {
            anyhow::bail!("\"{name}\": {v} is not a finite number at least 0");
        }
    }
    for name in REQUIRED {
        if object.get(name).and_then(|v| v.as_f64()).unwrap_or(0.0) <= 0.0 {
            anyhow::bail!("\"{name}\" is required and above 0");
        }
    }
    Ok(serde_json::from_value(value)?)
}

#[cfg(test)]
mod tests {
    use super::parse_noise;

    #[test]
    fn a_real_units_terms_are_read_in_canonical_units() {
        let d = parse_noise(
            r#"{"gyro_arw_deg_rt_h": 0.0003, "accel_vrw_ug_rt_hz": 5,
                "gyro_bias_instability_deg_h": 0.0015, "gyro_quantum_arcsec": 1}"#,
        )
        .unwrap();
        assert_eq!(d.gyro_arw_deg_rt_h, 0.0003);
        assert_eq!(d.gyro_bias_instability_deg_h, 0.0015);
        assert_eq!(d.gyro_quantum_arcsec, 1.0);
        assert_eq!(d.accel_rw_ug_rt_h, 0.0);
    }

    #[test]
    fn a_misspelt_missing_or_negative_term_is_refused_by_name() {
        let white = r#""gyro_arw_deg_rt_h": 0.0003, "accel_vrw_ug_rt_hz": 5"#;
        let e = parse_noise(&format!(r#"{{{white}, "gyro_bias_instabilty_deg_h": 1}}"#));
        assert!(e
            .unwrap_err()
            .to_string()
            .contains("gyro_bias_instabilty_deg_h"));
        let e = parse_noise(&format!(r#"{{{white}, "vibration": {{"rms_ug": 30}}}}"#));
        assert!(e
            .unwrap_err()
            .to_string()
            .contains("\"vibration\" is not a term"));
        let e = parse_noise(r#"{"gyro_arw_deg_rt_h": 0.0003}"#);
        assert!(e.unwrap_err().to_string().contains("accel_vrw_ug_rt_hz"));
        let e = parse_noise(&format!(r#"{{{white}, "accel_rw_ug_rt_h": -1}}"#));
        assert!(e.unwrap_err().to_string().contains("accel_rw_ug_rt_h"));
        assert!(parse_noise("[1, 2]").is_err());
    }
}
