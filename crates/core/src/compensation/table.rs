//! The compensation file as CSV: one row per quantity, for loaders and
//! spreadsheets that do not read JSON. The JSON file is the reference; the
//! CSV says the same in SI, with the convention in its comment lines.

use std::fmt::Write;

use super::file::{CompensationFile, FORMAT_TAG, FORMAT_VERSION};
use super::thermal::{ThermalSource, ThermalTerms};
use crate::model::{Group, PARAMETERS};

/// The CSV's column header.
pub const CSV_HEADER: &str = "name,symbol,value,unit,sigma";

/// The SI unit of a family's values.
pub fn si_unit(group: Group) -> &'static str {
    match group {
        Group::GyroBias => "rad/s",
        Group::GyroScale | Group::AccelScale => "1",
        Group::GyroMisalign | Group::AccelMisalign => "rad",
        Group::AccelBias => "m/s^2",
        Group::AccelQuad => "s^2/m",
    }
}

/// Where parameter `i` sits in the model (SPEC §2): `b_g[0]`, `K_a[1][0]`,
/// `D_a[2]`, indices 0-based, row = sensor, column = input axis.
pub fn symbol(i: usize) -> String {
    let names = |s: &str, at: usize| format!("{s}[{at}]");
    let info = PARAMETERS[i];
    let k = i - info.group.first();
    match info.group {
        Group::GyroBias => names("b_g", k),
        Group::AccelBias => names("b_a", k),
        Group::AccelQuad => names("D_a", k),
        Group::GyroScale => format!("K_g[{k}][{k}]"),
        Group::AccelScale => format!("K_a[{k}][{k}]"),
        // gyro_misalign_xy, _xz, _yz: the entries above the diagonal.
        Group::GyroMisalign => {
            let (r, c) = [(0, 1), (0, 2), (1, 2)][k];
            format!("K_g[{r}][{c}]")
        }
        // accel_misalign_xy, _xz, _yx, _yz, _zx, _zy.
        Group::AccelMisalign => {
            let (r, c) = [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)][k];
            format!("K_a[{r}][{c}]")
        }
    }
}

fn number(v: f64) -> String {
    // Shortest text that reads back to the same double.
    ryu::Buffer::new().format(v).to_string()
}

impl CompensationFile {
    /// The CSV form: `#` comment lines (format, provenance, convention),
    /// the header `name,symbol,value,unit,sigma`, then the 24 parameters
    /// in canonical order, SI values; `sigma` is empty when unknown.
    pub fn to_csv(&self) -> String {
        let mut out = String::new();
        let p = &self.provenance;
        let _ = writeln!(
            out,
            "# {FORMAT_TAG} {FORMAT_VERSION}, sinscal {}",
            self.sinscal_version
        );
        let optional = [
            ("unit_serial", p.unit_serial.clone()),
            ("run_id", p.run_id.clone()),
            ("source", p.source.clone()),
            ("model", Some(p.model.clone())),
            ("estimator", p.estimator.clone()),
            (
                "model_check_adequate",
                p.model_check_adequate.map(|a| a.to_string()),
            ),
            ("verdict", p.verdict.clone()),
            (
                "verdict_override_by",
                p.verdict_override.as_ref().map(|o| o.by.clone()),
            ),
            (
                "verdict_override_reason",
                p.verdict_override.as_ref().map(|o| o.reason.clone()),
            ),
        ];
        for (name, value) in optional {
            if let Some(v) = value {
                let _ = writeln!(out, "# {name}: {v}");
            }
        }
        if !p.effects_not_applied.is_empty() {
            let _ = writeln!(
                out,
                "# effects not applied: {}",
                p.effects_not_applied.join(", ")
            );
        }
        let c = &self.convention;
        for (name, text) in [
            ("units", &c.units),
            ("frames", &c.frames),
            ("measurement model", &c.measurement_model),
            ("gyro compensation", &c.gyro_compensation),
            ("accel compensation", &c.accel_compensation),
            ("record interval", &c.record_interval),
        ] {
            let _ = writeln!(out, "# {name}: {text}");
        }
        let _ = writeln!(out, "{CSV_HEADER}");
        let values = self.parameters();
        let sigma = self.sigma();
        for (i, info) in PARAMETERS.iter().enumerate() {
            let s = sigma.map(|s| number(s[i])).unwrap_or_default();
            let _ = writeln!(
                out,
                "{},{},{},{},{s}",
                info.name,
                symbol(i),
                number(values.si[i]),
                si_unit(info.group)
            );
        }
        if let Some(t) = &self.thermal {
            thermal_rows(&mut out, t);
        }
        out
    }
}

/// The thermal terms as rows after the parameters: every parameter's
/// linear coefficient (`gyro_bias_x.linear`, `b_g[0]/degC`), the quadratic
/// ones when the model has them, and k per gyro (`gyro_bias_rate_x`,
/// `k[0]`); the source, reference and range in a comment line before them.
fn thermal_rows(out: &mut String, t: &ThermalTerms) {
    let source = match t.source {
        ThermalSource::Run => "run",
        ThermalSource::Unit => "unit",
    };
    let _ = writeln!(
        out,
        "# thermal ({source}): term(T) = term + linear dT + quadratic dT^2, dT = T - {} degC, \
         fitted over {}..{} degC; gyro bias + k dT/dt",
        t.reference_c, t.range_c[0], t.range_c[1]
    );
    let mut terms = vec![("linear", "degC", t.linear_per_c.si())];
    if let Some(q) = &t.quadratic_per_c2 {
        terms.push(("quadratic", "degC^2", q.si()));
    }
    for (term, per, values) in terms {
        for (i, info) in PARAMETERS.iter().enumerate() {
            let _ = writeln!(
                out,
                "{}.{term},{}/{per},{},{}/{per},",
                info.name,
                symbol(i),
                number(values[i]),
                si_unit(info.group)
            );
        }
    }
    for (i, k) in t.gyro_bias_rad_per_s_per_c_per_s.iter().enumerate() {
        let _ = writeln!(
            out,
            "gyro_bias_rate_{},k[{i}],{},rad/s/(degC/s),",
            ["x", "y", "z"][i],
            number(*k)
        );
    }
}
