//! `sinscal thermal`: a unit's thermal model (SPEC §3a) from its results of
//! runs soaked at several temperatures, written as MODEL.json with a table
//! and the fit's check.

use std::path::PathBuf;

use anyhow::Context;
use sinscal_core::calib::CalibrationResult;
use sinscal_core::compensation::{CompensationFile, Provenance};
use sinscal_core::io::meta::write_json;
use sinscal_core::model::PARAMETERS;
use sinscal_core::thermal::{fit_thermal_model, SoakedRun};

/// A run's temperature span beyond which it is not a soak.
const SOAK_SPAN_C: f64 = 2.0;

#[derive(clap::Args)]
pub struct ThermalArgs {
    /// Results of soaked runs (`calibrate --out`), each at the temperature
    /// it carries (metadata `temperature_c`), or at `RESULT.json@T` (°C).
    #[arg(required = true, num_args = 2..)]
    pub results: Vec<String>,
    /// Write the model here.
    #[arg(long)]
    pub out: PathBuf,
    /// Also print every parameter predicted at this temperature (°C).
    #[arg(long)]
    pub at: Option<f64>,
    /// Predict at `--at` even outside the fitted range.
    #[arg(long)]
    pub extrapolate: bool,
    /// Also write the model as a compensation file (CONTRACT §5a): its
    /// 25 °C values, and its coefficients as thermal terms; CSV when the
    /// name ends in `.csv`.
    #[arg(long)]
    pub compensation: Option<PathBuf>,
}

fn soaked_run(arg: &str) -> anyhow::Result<SoakedRun> {
    let (path, given) = match arg.rsplit_once('@') {
        Some((p, t)) => {
            let t: f64 = t
                .parse()
                .with_context(|| format!("{arg}: the temperature after @ is not a number"))?;
            (p, Some(t))
        }
        None => (arg, None),
    };
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {path}"))?;
    let result: CalibrationResult =
        serde_json::from_str(&text).with_context(|| format!("{path} is not a result"))?;
    let temperature_c = match (given, result.temperature) {
        (Some(t), _) => t,
        (None, Some(t)) => {
            if t.max_c - t.min_c > SOAK_SPAN_C {
                anyhow::bail!(
                    "{path}: the run spans {:.1}–{:.1} °C, not a soak; its mean would place it \
                     wrongly (give RESULT.json@T to use it anyway)",
                    t.min_c,
                    t.max_c
                );
            }
            t.mean_c
        }
        (None, None) => anyhow::bail!(
            "{path} carries no temperature (its run's metadata had no temperature_c): give it \
             as {path}@T"
        ),
    };
    Ok(SoakedRun {
        label: path.to_string(),
        temperature_c,
        parameters: result.parameters,
    })
}

pub fn run_thermal(a: &ThermalArgs) -> anyhow::Result<()> {
    let runs = a
        .results
        .iter()
        .map(|r| soaked_run(r))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let model = fit_thermal_model(&runs)?;
    println!(
        "{:<20} {:>13} {:>10} {:>22} {:>22}  unit (per °C, per °C²)",
        "parameter", "at 25 °C", "1-sigma", "linear ± σ", "quadratic ± σ"
    );
    for p in PARAMETERS.iter() {
        if let Some(m) = model.parameters.get(p.name) {
            let term = |t: Option<sinscal_core::thermal::model::Term>| {
                t.map_or("—".to_string(), |t| {
                    format!("{:.4e} ± {:.1e}", t.value, t.sigma)
                })
            };
            println!(
                "{:<20} {:>13.5} {:>10.2e} {:>22} {:>22}  {}",
                p.name,
                m.value,
                m.sigma,
                term(m.linear),
                term(m.quadratic),
                m.unit
            );
        }
    }
    println!(
        "fitted over {:.1}–{:.1} °C from {} runs; check: {}",
        model.range_c[0],
        model.range_c[1],
        runs.len(),
        model.check.summary
    );
    if let Some(t) = a.at {
        println!("at {t} °C:");
        for p in PARAMETERS.iter() {
            if model.parameters.contains_key(p.name) {
                let pr = model.predict(p.name, t, a.extrapolate)?;
                println!(
                    "  {:<20} {:>13.5} ± {:.2e} {}{}",
                    p.name,
                    pr.value,
                    pr.sigma,
                    p.unit,
                    if pr.extrapolated {
                        "  (extrapolated)"
                    } else {
                        ""
                    }
                );
            }
        }
    }
    write_json(&a.out, &model)?;
    eprintln!("wrote {}", a.out.display());
    if let Some(path) = &a.compensation {
        let provenance = Provenance {
            source: Some(a.out.display().to_string()),
            model: "base-24".into(),
            model_check_adequate: Some(model.check.adequate),
            ..Provenance::default()
        };
        let file = CompensationFile::from_thermal_model(&model, provenance)?;
        super::compensate::write_file(&file, path)?;
    }
    Ok(())
}
