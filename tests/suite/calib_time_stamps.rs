//! Time stamps as loggers write them (SPEC §2a): records whose intervals
//! jitter by up to 10 %, and gaps where records were lost.
//!
//! A jittered run is made exactly, without a jittering simulator: the
//! paper's unit is simulated at ten times the nominal rate with even
//! stamps, and consecutive records are summed in groups of 9, 10 or 11.
//! Each group's increments are then exact over its own interval (noise
//! included), stamped at its end. The same fine records summed in groups
//! of 10 are the evenly stamped run of the same unit, motion and noise,
//! so the two calibrations (and noise analyses) differ only by how the run
//! was cut.

use std::sync::atomic::AtomicBool;

use sinscal_core::calib::prescan::prescan;
use sinscal_core::calib::sources::SliceSource;
use sinscal_core::calib::{
    estimate, CalibError, CalibrationResult, DetectOptions, EstimateOptions, NoiseDensity, RunInfo,
};
use sinscal_core::diagnose::{DiagnoseOptions, Verdict};
use sinscal_core::model::{Effects, ErrorParameters, PARAMETERS};
use sinscal_core::nav::Site;
use sinscal_core::noise::{analyse, NoiseOptions, Span, Stretches};
use sinscal_core::sim::{simulate, Noise, Scheme, SimConfig, Vibration};
use sinscal_core::Record;

/// Nominal rate of the calibrated runs, Hz, and fine records per nominal
/// step.
const RATE_HZ: f64 = 20.0;
const FINE: usize = 10;

/// The paper's unit on `ten-position` with 60 s dwells, at ten times the
/// nominal rate, under white noise.
fn fine_records() -> Vec<Record> {
    fine_records_of(Noise::default_navigation_grade(), 60.0)
}

/// The same unit with `noise` and dwells of `dwell_s`.
fn fine_records_of(noise: Noise, dwell_s: f64) -> Vec<Record> {
    let cfg = SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: RATE_HZ * FINE as f64,
        scheme: Scheme::builtin("ten-position", dwell_s).unwrap(),
        params: ErrorParameters::paper(),
        effects: Effects::none(),
        noise,
        initial_attitude_error_deg: [0.0; 3],
        seed: 11,
        thermal: None,
        temperature: None,
    };
    simulate(&cfg).unwrap().collect()
}

/// Consecutive fine records summed in groups of the sizes `size(k)`
/// gives, each stamped at its last record's end.
fn grouped(fine: &[Record], mut size: impl FnMut(usize) -> usize) -> Vec<Record> {
    let mut out = Vec::new();
    let mut at = 0;
    loop {
        let n = size(out.len());
        let Some(group) = fine.get(at..at + n) else {
            return out;
        };
        let mut r = Record {
            t: group[n - 1].t,
            ..Record::default()
        };
        for g in group {
            for i in 0..3 {
                r.dtheta[i] += g.dtheta[i];
                r.dv[i] += g.dv[i];
            }
        }
        out.push(r);
        at += n;
    }
}

/// Group sizes 9, 10, 11 in a scrambled order (the top bits of a Weyl
/// sequence), a quarter each short and long: steps ±10 % off nominal.
fn jittered_size(k: usize) -> usize {
    match (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 62 {
        0 => FINE - 1,
        3 => FINE + 1,
        _ => FINE,
    }
}

fn calibrate(records: &[Record]) -> Result<CalibrationResult, CalibError> {
    calibrate_with(records, &EstimateOptions::default())
}

fn calibrate_with(
    records: &[Record],
    opts: &EstimateOptions,
) -> Result<CalibrationResult, CalibError> {
    estimate(
        &SliceSource(records),
        &RunInfo {
            site: Site::REFERENCE,
            sample_rate_hz: RATE_HZ,
        },
        opts,
        &mut |_| {},
        &AtomicBool::new(false),
    )
}

/// The largest difference between two results over the 24 parameters, in
/// σ of the reference, and the parameter it is on.
fn largest_difference(a: &CalibrationResult, reference: &CalibrationResult) -> (f64, &'static str) {
    PARAMETERS
        .iter()
        .map(|p| {
            let d = a.value(p.name).unwrap() - reference.value(p.name).unwrap();
            (d.abs() / reference.sigma(p.name).unwrap(), p.name)
        })
        .fold((0.0, ""), |m, x| if x.0 > m.0 { x } else { m })
}

/// Records with stamps in (from, to] removed.
fn without(records: &[Record], from: f64, to: f64) -> Vec<Record> {
    records
        .iter()
        .filter(|r| r.t <= from || r.t > to)
        .copied()
        .collect()
}

#[test]
fn jittered_stamps_and_a_gap_at_rest_calibrate_as_the_even_run_and_a_gap_in_a_turn_is_refused() {
    let fine = fine_records();
    let even = grouped(&fine, |_| FINE);
    let jittered = grouped(&fine, jittered_size);
    let steps = jittered.windows(2).map(|w| (w[1].t - w[0].t) * RATE_HZ);
    let (short, long) = steps.fold((f64::MAX, 0.0f64), |(s, l), x| (s.min(x), l.max(x)));
    assert!(
        short < 0.91 && long > 1.09,
        "steps from {short} to {long} of nominal"
    );

    let reference = calibrate(&even).unwrap();
    assert!(reference.gaps.is_empty());
    let from_jittered = calibrate(&jittered).unwrap();
    let (worst, name) = largest_difference(&from_jittered, &reference);
    println!("jittered against even: largest difference {worst:.3} σ ({name})");
    assert!(worst < 0.3, "{name} differs by {worst:.2} σ");
    assert!(from_jittered.gaps.is_empty());

    // The jittered increments read as if each covered the nominal step:
    // what the estimator did before stamps were read. The test can fail.
    let restamped: Vec<Record> = jittered
        .iter()
        .enumerate()
        .map(|(k, r)| Record {
            t: (k + 1) as f64 / RATE_HZ,
            ..*r
        })
        .collect();
    let nominal = calibrate(&restamped).map(|r| largest_difference(&r, &reference));
    println!("jittered read at nominal steps against even: {nominal:?}");
    assert!(
        !matches!(nominal, Ok((off, _)) if off < 1.0),
        "nominal steps came within a σ: {nominal:?}"
    );

    // Two seconds lost in the middle of the third dwell (148 s to 208 s).
    let gap_at = 170.0;
    let last_before = jittered.iter().rev().find(|r| r.t <= gap_at).unwrap().t;
    let with_gap = without(&jittered, gap_at, gap_at + 2.0);
    let bridged = calibrate(&with_gap).unwrap();
    let (worst, name) = largest_difference(&bridged, &from_jittered);
    println!("gap bridged against none: largest difference {worst:.3} σ ({name})");
    assert!(worst < 0.3, "{name} differs by {worst:.2} σ");
    assert_eq!(bridged.gaps.len(), 1, "{:?}", bridged.gaps);
    let gap = &bridged.gaps[0];
    assert!(gap.bridged && gap.t_s == last_before);
    assert!((gap.length_s - 2.0).abs() < 0.06, "{gap:?}");
    assert!(
        bridged
            .warnings
            .iter()
            .any(|w| w.contains(&format!("after t = {last_before:.3} s")) && w.contains("bridged")),
        "{:?}",
        bridged.warnings
    );

    // One second lost in the first turn (Y+90 from 60 s to 69.5 s).
    let turn_at = 64.0;
    let last_before = jittered.iter().rev().find(|r| r.t <= turn_at).unwrap().t;
    let err = calibrate(&without(&jittered, turn_at, turn_at + 1.0)).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, CalibError::Unusable(_)), "{msg}");
    assert!(
        msg.contains(&format!("after t = {last_before:.3} s")) && msg.contains("in the motion"),
        "{msg}"
    );
}

/// A unit whose biases wander and whose floor shakes (SPEC §2a) reads its
/// stamps as the white one does, under its own noise model (given, so
/// that the comparison is of the stamps' handling alone: the model a fit
/// finds on a run this short moves with the cut, see the bench figures in
/// docs/FIGURES.md, "Real sensors").
///
/// Without pulses: two cuts of a pulsed run carry different quantization
/// errors (the remainder at each record's end depends on where the
/// record ends), so they differ by the pulses' own share of σ, not by the
/// stamps' handling. On this run 1″ gyro pulses alone move a parameter by
/// 0.25 σ between the two cuts, 1e-4 m/s accelerometer pulses by 0.32 σ.
#[test]
fn a_wandering_units_jittered_stamps_and_gap_at_rest_calibrate_as_its_even_run() {
    let mut noise = Noise::default_navigation_grade();
    noise.gyro_bias_instability_deg_h = 0.002;
    noise.accel_bias_instability_ug = 3.0;
    noise.gyro_rrw_deg_h_rt_h = 0.0003;
    noise.accel_rw_ug_rt_h = 2.0;
    noise.vibration = Some(Vibration {
        rms_ug: 30.0,
        band_hz: [2.0, 9.0],
    });
    let opts = EstimateOptions {
        noise: Some(NoiseDensity {
            gyro_quantum_arcsec: 0.0,
            accel_quantum_mps: 0.0,
            ..NoiseDensity::from(&noise)
        }),
        ..EstimateOptions::default()
    };
    // Five-minute dwells: the wander has time to show.
    let fine = fine_records_of(noise, 300.0);
    let reference = calibrate_with(&grouped(&fine, |_| FINE), &opts).unwrap();
    let jittered = grouped(&fine, jittered_size);
    let from_jittered = calibrate_with(&jittered, &opts).unwrap();
    let (worst, name) = largest_difference(&from_jittered, &reference);
    println!("wandering unit, jittered against even: largest difference {worst:.3} σ ({name})");
    assert!(worst < 0.3, "{name} differs by {worst:.2} σ");

    // Two seconds lost in the middle of the second dwell (309.5 s to 609.5 s).
    let bridged = calibrate_with(&without(&jittered, 450.0, 452.0), &opts).unwrap();
    let (worst, name) = largest_difference(&bridged, &from_jittered);
    println!("wandering unit, gap bridged against none: largest difference {worst:.3} σ ({name})");
    assert!(worst < 0.3, "{name} differs by {worst:.2} σ");
    assert!(bridged.gaps.len() == 1 && bridged.gaps[0].bridged);
}

/// The white noise terms of the noise analysis over the dwells the
/// estimator's pre-scan finds (as `pipeline::noise_file` chooses them).
fn white_noise(records: &[Record]) -> [f64; 6] {
    let run = RunInfo {
        site: Site::REFERENCE,
        sample_rate_hz: RATE_HZ,
    };
    let cancel = AtomicBool::new(false);
    let scan = prescan(
        &SliceSource(records),
        &run,
        &DetectOptions::default(),
        &cancel,
    )
    .unwrap();
    let stretches = Stretches {
        span: Span::Dwells,
        windows: scan.dwells().map(|d| (d.t_start, d.t_end)).collect(),
    };
    let report = analyse(
        records.iter().copied().map(Ok),
        RATE_HZ,
        &stretches,
        &NoiseOptions::default(),
        &cancel,
    )
    .unwrap();
    let (g, a) = (&report.gyro, &report.accel);
    [
        &g.x.arw_deg_rt_h,
        &g.y.arw_deg_rt_h,
        &g.z.arw_deg_rt_h,
        &a.x.vrw_ug_rt_hz,
        &a.y.vrw_ug_rt_hz,
        &a.z.vrw_ug_rt_hz,
    ]
    .map(|t| t.value.unwrap_or_else(|| panic!("not a value: {}", t.text)))
}

/// The noise analysis reads jittered stamps and a gap at rest as it reads
/// the even run: taken as increments over nominal steps, a resting
/// accelerometer's jittered records differ by g·(Δt_k − Δt_{k−1}), some
/// thousand times their noise, and a cluster across a gap would hold
/// two seconds too few of gravity.
#[test]
fn the_noise_analysis_reads_jittered_stamps_and_a_gap_at_rest_as_the_even_run() {
    let fine = fine_records();
    let even = white_noise(&grouped(&fine, |_| FINE));
    let jittered = grouped(&fine, jittered_size);
    let runs = [
        ("jittered", white_noise(&jittered)),
        ("gap", white_noise(&without(&jittered, 170.0, 172.0))),
    ];
    let truth = Noise::default_navigation_grade();
    for (what, got) in runs {
        for (i, (g, e)) in got.iter().zip(even).enumerate() {
            println!("{what} axis {i}: {g:.4e} against {e:.4e} even");
            assert!((g / e - 1.0).abs() < 0.03, "{what} axis {i}: {g} vs {e}");
        }
    }
    // The even run's own terms are the simulated ones.
    for (i, (e, t)) in even
        .iter()
        .zip(
            [truth.gyro_arw_deg_rt_h; 3]
                .into_iter()
                .chain([truth.accel_vrw_ug_rt_hz; 3]),
        )
        .enumerate()
    {
        assert!((e / t - 1.0).abs() < 0.1, "axis {i}: {e} vs {t}");
    }
}

/// The discrepancy workflow bridges and refuses as the calibration does:
/// a jittered clean run with a gap at rest names nothing, its
/// calibrations report the gap, and a gap in a turn refuses it.
#[test]
fn the_discrepancy_workflow_bridges_a_gap_at_rest_and_refuses_one_in_a_turn() {
    let jittered = grouped(&fine_records(), jittered_size);
    let diagnose = |records: &[Record]| {
        sinscal_core::diagnose::diagnose(
            &SliceSource(records),
            &RunInfo {
                site: Site::REFERENCE,
                sample_rate_hz: RATE_HZ,
            },
            &DiagnoseOptions::default(),
            &mut |_| {},
            &AtomicBool::new(false),
        )
    };
    let report = diagnose(&without(&jittered, 170.0, 172.0)).unwrap();
    assert!(report.named.is_empty(), "{}", report.verdict);
    assert_eq!(report.verdict, Verdict::NoSignificantEffect);
    for result in [&report.base_calibration, &report.calibration] {
        assert_eq!(result.gaps.len(), 1, "{:?}", result.gaps);
        assert!(result.gaps[0].bridged);
    }
    let last_before = jittered.iter().rev().find(|r| r.t <= 64.0).unwrap().t;
    let msg = diagnose(&without(&jittered, 64.0, 65.0))
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains(&format!("after t = {last_before:.3} s")) && msg.contains("in the motion"),
        "{msg}"
    );
}
