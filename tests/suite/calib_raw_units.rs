//! Uncalibrated units: errors ten and twenty times the seed paper's Table 1
//! truth (1 deg/h, 10 000 ppm, 4 000″, 4 mg, 20× the quadratic terms) in
//! any mix of signs. Every dwell must be found from the stillness of the
//! signals, every parameter must come within Table 1, and a run that does
//! not begin at rest must be refused saying what it did.
//!
//! Reduced size (`ten-position-9+9`, 300 s dwells, 20 Hz,
//! navigation-grade noise); the full-size figures come from
//! `cargo bench --bench accuracy -- --raw`.

use crate::table1_support;

use rand::SeedableRng;
use sinscal_core::calib::segment::{SegmentKind, Segmenter};
use sinscal_core::calib::sources::calibrate_simulated;
use sinscal_core::calib::RunSegment;
use sinscal_core::calib::{CalibError, CalibrationResult, DetectOptions, EstimateOptions};
use sinscal_core::model::{Effects, ErrorParameters};
use sinscal_core::nav::Site;
use sinscal_core::sim::trajectory::Motion;
use sinscal_core::sim::{simulate, Noise, Scheme, SchemeRef, SimConfig};
use table1_support::{assert_within_table1, worst_against_table1};

fn config(params: ErrorParameters, attitude: [f64; 3], seed: u64) -> SimConfig {
    SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: 20.0,
        scheme: Scheme::builtin("ten-position-9+9", 300.0).unwrap(),
        params,
        effects: Effects::none(),
        noise: Noise::default_navigation_grade(),
        initial_attitude_error_deg: attitude,
        seed,
        thermal: None,
        temperature: None,
    }
}

fn calibrate(cfg: &SimConfig) -> Result<CalibrationResult, CalibError> {
    let opts = EstimateOptions {
        cross_check: false,
        ..EstimateOptions::default()
    };
    calibrate_simulated(cfg, &opts)
}

/// Each parameter `factor` times its paper magnitude, signed by `signs`
/// (cycled over the canonical order).
fn scaled_paper(factor: f64, signs: &[f64]) -> ErrorParameters {
    let mut p = ErrorParameters::paper();
    for (i, v) in p.si.iter_mut().enumerate() {
        *v *= factor * signs[i % signs.len()];
    }
    p
}

/// Every dwell of the scheme found, every parameter within its Table 1
/// bound of the truth. As in the accuracy tests, a gyro bias beyond its
/// bound is accepted while within 3.5 of its own σ (the bound is 2.9–3.4σ
/// at navigation-grade noise), and reported.
fn assert_calibrated(cfg: &SimConfig, what: &str) {
    let res = calibrate(cfg).unwrap_or_else(|e| panic!("{what}: {e}"));
    let truth = &cfg.params;
    let (dwells, _) = cfg.scheme.counts();
    assert_eq!(res.dwell_residuals.len(), dwells, "{what}: dwells found");
    assert_within_table1(&res, truth, what);
    let worst = worst_against_table1(&res, truth);
    eprintln!(
        "{what}: {} passes, worst |err|/bound {:.2} ({})",
        res.passes, worst.0, worst.1
    );
}

#[test]
fn paper_truth_times_ten_one_sign_within_table1() {
    let cfg = config(scaled_paper(10.0, &[1.0]), [0.1, -0.1, 2.0], 41);
    assert_calibrated(&cfg, "paper × 10");
}

#[test]
fn paper_truth_times_twenty_mixed_signs_tilted_any_heading_within_table1() {
    let signs = [1.0, -1.0, -1.0, 1.0, -1.0];
    let starts = [[3.0, -4.0, 37.0], [-5.0, 0.0, 200.0], [0.0, 5.0, -100.0]];
    for (k, start) in starts.iter().enumerate() {
        let cfg = config(scaled_paper(20.0, &signs), *start, 51 + k as u64);
        assert_calibrated(&cfg, &format!("paper × 20 mixed, start {start:?}"));
    }
}

#[test]
fn random_truths_times_ten_within_table1() {
    for seed in [61, 62] {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        // ErrorParameters::random is uniform in ±2× the paper's magnitude.
        let mut truth = ErrorParameters::random(&mut rng);
        truth.si.iter_mut().for_each(|v| *v *= 10.0);
        let cfg = config(truth, [2.0, 2.0, 250.0], seed);
        assert_calibrated(&cfg, &format!("random × 10, seed {seed}"));
    }
}

/// The true dwells of a simulated run, as (start, end).
fn true_dwells(cfg: &SimConfig) -> Vec<(f64, f64)> {
    simulate(cfg)
        .unwrap()
        .trajectory()
        .segments()
        .iter()
        .filter(|s| matches!(s.motion, Motion::Dwell))
        .map(|s| (s.t0, s.t1))
        .collect()
}

fn segment(cfg: &SimConfig) -> Vec<RunSegment> {
    let mut seg = Segmenter::new(
        DetectOptions::default(),
        cfg.sample_rate_hz,
        cfg.site.gravity(),
    );
    for r in simulate(cfg).unwrap() {
        seg.push(&r);
    }
    seg.finish().segments
}

/// Turns at every rate a calibration meets — hand flips at 120 and
/// 30 °/s, a turntable's 10 °/s, a trapezoid that starts and stops at
/// 1 °/s², a slow turn about the vertical (which leaves f^b unchanged) —
/// on a unit 20 times the paper's errors, at navigation and at tactical
/// noise: every dwell is found once, and lies inside a true dwell.
#[test]
fn turns_at_any_rate_are_never_rest_and_every_dwell_is_found() {
    let scheme: SchemeRef = serde_json::from_str(
        r#"{"steps": [
            {"dwell_s": 40},
            {"rotate": {"axis": "x", "angle_deg": 180, "rate_dps": 120, "accel_dps2": 600}},
            {"dwell_s": 40},
            {"rotate": {"axis": "y", "angle_deg": -90, "rate_dps": 30, "accel_dps2": 60}},
            {"dwell_s": 40},
            {"rotate": {"axis": "z", "angle_deg": 90}},
            {"dwell_s": 40},
            {"rotate": {"axis": "x", "angle_deg": 90, "rate_dps": 10, "accel_dps2": 1}},
            {"dwell_s": 40},
            {"rotate": {"axis": "u", "angle_deg": 30, "rate_dps": 2, "accel_dps2": 0.5}},
            {"dwell_s": 40}
        ]}"#,
    )
    .unwrap();
    let signs = [-1.0, 1.0, 1.0, -1.0, 1.0, -1.0, -1.0];
    for (what, noise) in [
        ("navigation grade", Noise::default_navigation_grade()),
        (
            "tactical grade",
            Noise {
                gyro_arw_deg_rt_h: 0.003,
                accel_vrw_ug_rt_hz: 50.0,
                ..Noise::default()
            },
        ),
    ] {
        let cfg = SimConfig {
            sample_rate_hz: 100.0,
            scheme: scheme.resolve(None).unwrap(),
            noise,
            ..config(scaled_paper(20.0, &signs), [4.0, -3.0, 120.0], 71)
        };
        let truth = true_dwells(&cfg);
        let found: Vec<_> = segment(&cfg)
            .into_iter()
            .filter(|s| s.kind == SegmentKind::Dwell)
            .collect();
        assert_eq!(found.len(), truth.len(), "{what}: {found:?}");
        for (d, (t0, t1)) in found.iter().zip(&truth) {
            assert!(
                d.t_start >= *t0 && d.t_end <= *t1,
                "{what}: dwell {:.2}–{:.2} s reaches outside the true {t0:.2}–{t1:.2} s",
                d.t_start,
                d.t_end
            );
            // Little of the true dwell is lost: the guards and a block.
            assert!(
                d.t_end - d.t_start > t1 - t0 - 1.5,
                "{what}: dwell {:.2}–{:.2} s of the true {t0:.2}–{t1:.2} s",
                d.t_start,
                d.t_end
            );
        }
    }
}

/// A run that starts with a turn is refused with what it did: its rate
/// and specific force over the first seconds, and where rest began.
#[test]
fn a_raw_unit_that_starts_moving_is_refused_naming_its_rates() {
    let scheme: SchemeRef = serde_json::from_str(
        r#"{"steps": [{"rotate": {"axis": "y", "angle_deg": 90, "rate_dps": 10}}, {"dwell_s": 60},
                      {"rotate": {"axis": "x", "angle_deg": 90}}, {"dwell_s": 60}]}"#,
    )
    .unwrap();
    let cfg = SimConfig {
        scheme: scheme.resolve(None).unwrap(),
        ..config(scaled_paper(20.0, &[1.0, -1.0]), [0.0, 0.0, 30.0], 81)
    };
    let msg = match calibrate(&cfg) {
        Err(CalibError::Unusable(msg)) => msg,
        other => panic!("expected Unusable, got {other:?}"),
    };
    eprintln!("{msg}");
    assert!(msg.contains("begin at rest"), "{msg}");
    // 10 °/s after a 0.5 s ramp: the mean over the first 5 s is 9.5 °/s.
    let rate: f64 = number_after(&msg, "angular rate is ");
    assert!((9.0..10.0).contains(&rate), "{msg}");
    let force: f64 = number_after(&msg, "|f| is ");
    assert!((9.0..10.5).contains(&force), "{msg}");
    // The first dwell begins after the 9.5 s turn and its guard.
    let start: f64 = number_after(&msg, "runs from t = ");
    assert!((9.5..10.5).contains(&start), "{msg}");
}

fn number_after(msg: &str, key: &str) -> f64 {
    let rest = &msg[msg.find(key).unwrap_or_else(|| panic!("{key:?} in {msg}")) + key.len()..];
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .unwrap_or(rest.len());
    rest[..end]
        .parse()
        .unwrap_or_else(|_| panic!("a number after {key:?} in {msg}"))
}
