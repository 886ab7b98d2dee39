//! The report's numbers: every figure finite, the per-segment χ² summing
//! to the step's, the RMS figures agreeing with each other; and what a
//! run could see: the smallest effect it would name, which an effect
//! twice that size is; and the same thresholds before any data exists
//! (`plan --detect`), which agree with what a run of the scheme reports.

use crate::diagnosis_support;

use diagnosis_support::*;
use sinscal_core::calib::plan::PlanInput;
use sinscal_core::calib::NoiseDensity;
use sinscal_core::diagnose::candidates::{add_effect, library};
use sinscal_core::diagnose::detect::DetectionThreshold;
use sinscal_core::diagnose::thresholds_before_data;
use sinscal_core::diagnose::{DiagnoseReport, Verdict};
use sinscal_core::model::Effects;
use sinscal_core::sim::SimConfig;
use std::sync::OnceLock;

fn close(a: f64, b: f64, what: &str) {
    assert!(
        (a - b).abs() <= 1e-6 * a.abs().max(b.abs()).max(1.0),
        "{what}: {a} vs {b}"
    );
}

/// Every number the report carries is finite and the figures agree.
fn assert_sane(rep: &DiagnoseReport) {
    let top = [
        ("gap_rms_before", rep.gap_rms_before),
        ("gap_rms_after", rep.gap_rms_after),
        ("noise_floor_rms", rep.noise_floor_rms),
        ("gap_excess_before", rep.gap_excess_before),
        ("gap_excess_after", rep.gap_excess_after),
        ("z_before", rep.z_before),
        ("z_after", rep.z_after),
    ];
    for (name, v) in top {
        assert!(v.is_finite(), "{name} = {v}");
    }
    for (which, segs) in [
        ("before", &rep.segments_before),
        ("after", &rep.segments_after),
    ] {
        assert!(!segs.is_empty(), "no segments {which}");
        for s in segs.iter() {
            let all = [s.t_start, s.t_end, s.chi2, s.dof]
                .into_iter()
                .chain(s.gap_mps)
                .chain(s.sigma_mps);
            for v in all {
                assert!(v.is_finite(), "{which} {} {}: {s:?}", s.kind, s.index);
            }
            assert!(s.chi2 >= 0.0 && s.dof > 0.0, "{which}: {s:?}");
            // A segment's χ² is its gap against its noise: not beyond what
            // a gap of a thousand σ per observation would give.
            assert!(s.chi2 < 1e6 * s.dof, "{which}: {s:?}");
        }
    }
    // The segments partition the gap: their χ² and expectations sum to
    // the first step's (before) and give the final z (after).
    let sum = |segs: &[sinscal_core::diagnose::SegmentGap]| {
        let chi2: f64 = segs.iter().map(|s| s.chi2).sum();
        let dof: f64 = segs.iter().map(|s| s.dof).sum();
        (chi2, dof)
    };
    let (chi2_before, dof_before) = sum(&rep.segments_before);
    close(chi2_before, rep.steps[0].chi2, "chi2 before");
    close(dof_before, rep.steps[0].dof, "dof before");
    let z = |(chi2, dof): (f64, f64)| (chi2 - dof) / (2.0 * dof).sqrt();
    close(z((chi2_before, dof_before)), rep.z_before, "z before");
    close(z(sum(&rep.segments_after)), rep.z_after, "z after");
    for s in &rep.steps {
        for v in [s.gap_rms, s.noise_floor_rms, s.chi2, s.dof, s.z] {
            assert!(v.is_finite(), "step {:?}: {v}", s.model);
        }
        for c in &s.candidates {
            for v in [c.delta_chi2, c.dispersion, c.delta_bic, c.probability] {
                assert!(v.is_finite(), "{}: {v}", c.candidate);
            }
            for p in &c.params {
                assert!(p.value.is_finite() && p.sigma.is_finite(), "{p:?}");
            }
        }
    }
    // The excess is √(rms² − floor²), zero below the floor.
    let excess = |rms: f64| (rms * rms - rep.noise_floor_rms.powi(2)).max(0.0).sqrt();
    close(
        rep.gap_excess_before,
        excess(rep.gap_rms_before),
        "excess before",
    );
    close(
        rep.gap_excess_after,
        excess(rep.gap_rms_after),
        "excess after",
    );
    if rep.named.is_empty() {
        assert_eq!(rep.gap_rms_after, rep.gap_rms_before);
    } else {
        // Effects are fitted on top of the same base columns: the
        // residual cannot grow.
        assert!(
            rep.gap_rms_after <= rep.gap_rms_before,
            "{} -> {}",
            rep.gap_rms_after,
            rep.gap_rms_before
        );
        assert!(rep.z_after <= rep.z_before);
    }
}

#[test]
fn report_numbers_are_finite_and_consistent() {
    // A delay: the runs on which a segment's χ² read 1e270.
    let effects = Effects {
        accel_delay: Some(2.0),
        ..Effects::none()
    };
    let cfg = config(nine_plus_nine(300.0), effects, 3);
    let rep = run(&cfg);
    assert_eq!(rep.named, ["accel_delay"], "{}", rep.verdict);
    assert_sane(&rep);
}

/// The effects of `t`'s quantity at `factor` times its threshold, along
/// its most visible direction.
fn at_threshold(t: &DetectionThreshold, factor: f64) -> Effects {
    let cand = library()
        .into_iter()
        .find(|c| c.name == t.candidate)
        .unwrap();
    let mut values = vec![0.0; cand.params.len()];
    for (name, d) in t.params.iter().zip(&t.direction) {
        let i = cand.params.iter().position(|p| &p.name == name).unwrap();
        values[i] = factor * t.size * d;
    }
    let mut effects = Effects::none();
    add_effect(&mut effects, cand.name, &values);
    effects
}

/// The clean run of seed 121 and its diagnosis, made once for the two
/// tests that read it.
fn clean_run() -> &'static (SimConfig, DiagnoseReport) {
    static CLEAN: OnceLock<(SimConfig, DiagnoseReport)> = OnceLock::new();
    CLEAN.get_or_init(|| {
        let cfg = config(nine_plus_nine(300.0), Effects::none(), 121);
        let rep = run(&cfg);
        (cfg, rep)
    })
}

#[test]
fn an_effect_at_twice_the_reported_threshold_is_named() {
    let (clean, rep) = clean_run();
    let seed = clean.seed;
    assert_eq!(rep.verdict, Verdict::NoSignificantEffect);
    assert_sane(rep);
    assert!(
        rep.summary()
            .contains("no significant effect; this run would have named a "),
        "{}",
        rep.summary()
    );
    // Every candidate, every unit among its parameters.
    for cand in library() {
        let mut units: Vec<&str> = cand.params.iter().map(|p| p.unit.as_str()).collect();
        units.dedup();
        for unit in units {
            let t = rep
                .detectable
                .iter()
                .find(|t| t.candidate == cand.name && t.unit == unit)
                .unwrap_or_else(|| panic!("no threshold for {} in {unit}", cand.name));
            assert!(t.size.is_finite() && t.size > 0.0, "{t:?}");
            assert!(t.size >= t.size_without_rivals, "{t:?}");
            // The most visible direction is where the bar is met first.
            for &x in &t.per_parameter {
                assert!(
                    x.is_finite() && x >= t.size_without_rivals * (1.0 - 1e-9),
                    "{t:?}"
                );
            }
            let norm: f64 = t.direction.iter().map(|d| d * d).sum();
            assert!((norm - 1.0).abs() < 1e-9, "{t:?}");
        }
    }
    // The same noise with each quantity at twice its threshold, the runs
    // shared between both cores.
    let named = on_both_cores(&rep.detectable, |t| {
        run_quiet(&config(nine_plus_nine(300.0), at_threshold(t, 2.0), seed))
    });
    let mut missed = Vec::new();
    for (t, with) in rep.detectable.iter().zip(named) {
        eprintln!(
            "{} {} at 2x {:.4} {}: named {:?} ({})",
            t.candidate, t.quantity, t.size, t.unit, with.named, with.verdict
        );
        if with.named.first() != Some(&t.effect) {
            missed.push(format!("{}: {}", t.quantity, with.verdict));
        }
    }
    assert!(missed.is_empty(), "{missed:#?}");
}

#[test]
fn thresholds_before_data_agree_with_what_a_run_reports() {
    let (clean, rep) = clean_run();
    let input = PlanInput {
        scheme: clean.scheme.clone(),
        site: clean.site,
        sample_rate_hz: clean.sample_rate_hz,
        noise: NoiseDensity::white(
            clean.noise.gyro_arw_deg_rt_h,
            clean.noise.accel_vrw_ug_rt_hz,
        ),
        initial_attitude_error_deg: clean.initial_attitude_error_deg,
    };
    let before =
        thresholds_before_data(&input, &std::sync::atomic::AtomicBool::new(false)).unwrap();
    assert_eq!(before.len(), rep.detectable.len());
    for t in &rep.detectable {
        let b = before
            .iter()
            .find(|b| b.candidate == t.candidate && b.unit == t.unit)
            .unwrap();
        let ratio = b.size / t.size;
        eprintln!(
            "{} ({}): before data {:.4}, from the run {:.4} (ratio {ratio:.3})",
            t.quantity, t.unit, b.size, t.size
        );
        // The run's own noise estimate and its dispersion (≥ 1) move its
        // thresholds a little (0.3 % on this run).
        assert!(
            (0.95..1.05).contains(&ratio),
            "{} ({}): ratio {ratio}",
            t.quantity,
            t.unit
        );
    }
}
