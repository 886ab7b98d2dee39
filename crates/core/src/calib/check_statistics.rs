//! The model check's two tests on the shapes' scores (Σ z² against its χ²
//! quantile and the largest |z| against its Bonferroni bound, sharing the
//! false-alarm rate), the verdict in words (the quantiles are the toolkit's).

use super::misfit::{Misfit, ModelCheck, Shape, FALSE_ALARM_RATE};
use crate::estimation::quantile;

/// The two tests, and the verdict in words.
pub(crate) fn judge(scores: Vec<Misfit>, trends: Vec<Misfit>) -> ModelCheck {
    let dof = scores.len();
    let statistic: f64 = scores.iter().map(|s| s.z * s.z).sum();
    let half = 0.5 * FALSE_ALARM_RATE;
    let threshold = if dof > 0 {
        quantile::chi2_upper(dof as f64, half)
    } else {
        0.0
    };
    let n_max = (dof + trends.len()).max(1);
    let z_bound = quantile::normal_upper(half / n_max as f64 / 2.0);
    let mut all: Vec<Misfit> = scores.into_iter().chain(trends).collect();
    all.sort_by(|a, b| b.z.abs().total_cmp(&a.z.abs()));
    let largest_z = all.first().map_or(0.0, |m| m.z.abs());
    let chi2_fails = dof > 0 && statistic > threshold;
    let max_fails = largest_z > z_bound;
    let adequate = !(chi2_fails || max_fails);
    let mut findings: Vec<Misfit> = all
        .iter()
        .filter(|m| m.z.abs() > z_bound)
        .take(20)
        .cloned()
        .collect();
    if !adequate && findings.is_empty() {
        // Only the sum fails: many misfits, none large alone. Name the
        // largest few, which are where it is most.
        findings = all.iter().take(5).cloned().collect();
    }
    let mut check = ModelCheck {
        adequate,
        statistic,
        threshold,
        dof,
        largest_z,
        largest_z_threshold: z_bound,
        false_alarm_rate: FALSE_ALARM_RATE,
        method: "whitened zero-velocity residuals per dwell and navigation axis, projected on \
                 turn step, drift, drift change and curvature; χ² sum and largest |z|, each at \
                 half the false-alarm rate"
            .into(),
        summary: String::new(),
        findings,
    };
    check.summary = summarise(&check, &all);
    check
}

/// The verdict in words: the figures, then the findings grouped by shape;
/// `all` is every score, largest first.
fn summarise(check: &ModelCheck, all: &[Misfit]) -> String {
    use std::fmt::Write;
    let (statistic, threshold, dof) = (check.statistic, check.threshold, check.dof);
    let (largest_z, z_bound) = (check.largest_z, check.largest_z_threshold);
    let findings = &check.findings;
    let mut s = String::new();
    let figures = format!(
        "χ² {statistic:.0} over {dof} scores (threshold {threshold:.0}); largest |z| \
         {largest_z:.1} (threshold {z_bound:.1})"
    );
    if check.adequate {
        let _ = write!(
            s,
            "adequate: the residuals are what the run's noise explains ({figures})"
        );
        return s;
    }
    let _ = write!(
        s,
        "inadequate: the 24-parameter model does not explain this run ({figures})."
    );
    // Group the misfits beyond the bound (or the few named) by shape.
    let shapes = [
        Shape::TurnStep,
        Shape::Drift,
        Shape::DriftChange,
        Shape::Curvature,
        Shape::TrendOverRun,
    ];
    for shape in shapes {
        let of: Vec<&Misfit> = findings.iter().filter(|m| m.shape == shape).collect();
        let Some(top) = of.first() else { continue };
        let mut axes: Vec<&str> = Vec::new();
        for m in &of {
            if !axes.contains(&m.axis.name()) {
                axes.push(m.axis.name());
            }
        }
        let _ = write!(s, " {}: ", shape.words());
        if shape == Shape::TrendOverRun {
            let _ = write!(s, "{} (z {:.1})", axes.join(", "), top.z);
        } else {
            let mut dwells: Vec<usize> = of.iter().filter_map(|m| m.dwell).collect();
            dwells.sort_unstable();
            dwells.dedup();
            let which = if shape == Shape::TurnStep {
                "turns into dwells"
            } else {
                "dwells"
            };
            let _ = write!(
                s,
                "{which} {} on {}; largest in dwell {} ({:.0}–{:.0} s), {}, z {:.1}",
                list(&dwells),
                axes.join(", "),
                top.dwell.unwrap_or(0),
                top.t_start,
                top.t_end,
                top.axis.name(),
                top.z
            );
            if let (Some(size), Some(unit)) = (top.size, top.unit.as_deref()) {
                let _ = write!(s, ", {size:.2e} {unit}");
            }
        }
        s.push('.');
    }
    // Growing with time or not, from the trend scores whether or not they
    // passed the bound.
    let trend = all
        .iter()
        .filter(|m| m.shape == Shape::TrendOverRun)
        .map(|m| m.z.abs())
        .fold(0.0, f64::max);
    if trend > z_bound {
        let _ = write!(
            s,
            " The misfit grows with time over the run (trend z {trend:.1})."
        );
    } else {
        let _ = write!(s, " It does not grow with time over the run.");
    }
    s.push_str(" To name the missing effect, run `sinscal diagnose`.");
    s
}

/// "3, 5, 7–9".
fn list(v: &[usize]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < v.len() {
        let mut j = i;
        while j + 1 < v.len() && v[j + 1] == v[j] + 1 {
            j += 1;
        }
        parts.push(if j > i + 1 {
            format!("{}–{}", v[i], v[j])
        } else if j == i + 1 {
            format!("{}, {}", v[i], v[j])
        } else {
            v[i].to_string()
        });
        i = j + 1;
    }
    parts.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::misfit::NavAxis;

    #[test]
    fn ranges_are_listed_compactly() {
        assert_eq!(list(&[1, 2, 3, 5, 7, 8]), "1–3, 5, 7, 8");
        assert_eq!(list(&[4]), "4");
    }

    fn misfit(shape: Shape, dwell: usize, z: f64) -> Misfit {
        Misfit {
            shape,
            dwell: Some(dwell),
            t_start: 100.0 * dwell as f64,
            t_end: 100.0 * dwell as f64 + 90.0,
            axis: NavAxis::N,
            z,
            size: None,
            unit: None,
        }
    }

    #[test]
    fn scores_of_the_noise_pass_and_a_large_step_fails() {
        // 40 scores at ±1: χ² 40, nothing large.
        let noise: Vec<Misfit> = (0..40)
            .map(|i| misfit(Shape::Drift, i + 1, if i % 2 == 0 { 1.0 } else { -1.0 }))
            .collect();
        assert!(judge(noise.clone(), Vec::new()).adequate);
        let mut one = noise;
        one.push(misfit(Shape::TurnStep, 7, 9.0));
        let check = judge(one, Vec::new());
        assert!(!check.adequate);
        assert_eq!(check.findings[0].shape, Shape::TurnStep);
        assert!(check.summary.contains("turn"), "{}", check.summary);
        assert!(check.summary.contains("sinscal diagnose"));
    }

    #[test]
    fn many_moderate_scores_fail_the_sum_alone() {
        // 100 scores at 2.5: none beyond the Bonferroni bound (≈ 4.4), but
        // χ² = 625 ≫ 149.
        let v: Vec<Misfit> = (0..100).map(|i| misfit(Shape::Drift, i + 1, 2.5)).collect();
        let check = judge(v, Vec::new());
        assert!(!check.adequate);
        assert!(check.largest_z < check.largest_z_threshold);
        assert_eq!(check.findings.len(), 5);
    }
}
