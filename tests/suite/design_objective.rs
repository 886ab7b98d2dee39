//! The design objective against `plan`: on the built-in schemes, a
//! navigation-axis scheme from a tilted start and a hand-turned scheme,
//! the σ computed from the motion alone agrees with the σ of the filter
//! run over simulated records, parameter by parameter, within 5 %.

use sinscal_core::calib::plan::{plan, PlanInput};
use sinscal_core::calib::{EstimateOptions, NoiseDensity};
use sinscal_core::design::information::scheme_information;
use sinscal_core::design::{objective_settings, DesignRequest};
use sinscal_core::model::PARAMETERS;
use sinscal_core::nav::Site;
use sinscal_core::sim::scheme::SchemeRef;
use sinscal_core::sim::{HandTurns, Scheme};

fn nav_axis_scheme() -> Scheme {
    let s: SchemeRef = serde_json::from_str(
        r#"{"name": "nav-axes", "steps": [{"dwell_s": 300},
            {"rotate": {"axis": "n", "angle_deg": 90}}, {"dwell_s": 300},
            {"rotate": {"axis": "e", "angle_deg": 90}}, {"dwell_s": 300},
            {"rotate": {"axis": "u", "angle_deg": 180}}, {"dwell_s": 300},
            {"rotate": {"axis": "n", "angle_deg": -90}}, {"dwell_s": 300},
            {"rotate": {"axis": "e", "angle_deg": 180}}, {"dwell_s": 300},
            {"rotate": {"axis": "u", "angle_deg": 90}}, {"dwell_s": 300},
            {"rotate": {"axis": "n", "angle_deg": 180}}, {"dwell_s": 300}]}"#,
    )
    .unwrap();
    s.resolve(None).unwrap()
}

/// Largest relative difference over the 24 parameters, and where.
fn compare(scheme: &Scheme, noise: NoiseDensity, attitude: [f64; 3], rate: f64) -> (f64, String) {
    let req = DesignRequest {
        noise,
        initial_attitude_deg: attitude,
        ..DesignRequest::default()
    };
    let fast = scheme_information(scheme, &objective_settings(&req)).unwrap();
    let slow = plan(
        &PlanInput {
            scheme: scheme.clone(),
            site: Site::REFERENCE,
            sample_rate_hz: rate,
            noise,
            initial_attitude_error_deg: attitude,
        },
        &EstimateOptions::default(),
    )
    .unwrap();
    let mut worst = (0.0, String::new());
    for (i, p) in PARAMETERS.iter().enumerate() {
        let a = fast.sigma_canonical(i);
        let b = slow.parameters[p.name].sigma;
        let rel = (a / b - 1.0).abs();
        eprintln!(
            "{:<20} fast {a:.6} plan {b:.6} ({:+.2} %)",
            p.name,
            100.0 * (a / b - 1.0)
        );
        if rel > worst.0 {
            worst = (rel, p.name.to_string());
        }
    }
    worst
}

const NAV_GRADE: NoiseDensity = NoiseDensity::white(0.0003, 5.0);

#[test]
fn the_objective_matches_plan_on_the_built_in_schemes() {
    for (name, dwell) in [("ten-position", 600.0), ("ten-position-9+9", 300.0)] {
        let scheme = Scheme::builtin(name, dwell).unwrap();
        let (rel, which) = compare(&scheme, NAV_GRADE, [0.0; 3], 20.0);
        eprintln!(
            "{name} {dwell} s: largest difference {:.2} % ({which})",
            100.0 * rel
        );
        assert!(
            rel < 0.05,
            "{name}: {which} differs by {:.1} %",
            100.0 * rel
        );
    }
}

#[test]
fn the_objective_matches_plan_for_navigation_axes_from_a_tilted_start() {
    let noise = NoiseDensity::white(0.003, 50.0);
    let (rel, which) = compare(&nav_axis_scheme(), noise, [5.0, -3.0, 200.0], 20.0);
    eprintln!(
        "nav axes: largest difference {:.2} % ({which})",
        100.0 * rel
    );
    assert!(rel < 0.05, "{which} differs by {:.1} %", 100.0 * rel);
}

#[test]
fn the_objective_matches_plan_for_turns_by_hand() {
    let nominal = Scheme::builtin("ten-position", 300.0).unwrap();
    let scheme = Scheme::by_hand(&nominal, 7, &HandTurns::default()).unwrap();
    let (rel, which) = compare(&scheme, NAV_GRADE, [0.0; 3], 100.0);
    eprintln!("by hand: largest difference {:.2} % ({which})", 100.0 * rel);
    assert!(rel < 0.05, "{which} differs by {:.1} %", 100.0 * rel);
}

/// The smallest effects the objective says a scheme makes the discrepancy
/// workflow name, against what the workflow itself reports on a
/// noise-free simulated run of the scheme (`plan --detect`), quantity by
/// quantity, along each one's least visible parameter: within 4 % for the
/// lever arm, the delay, the accelerometer drift and the asymmetry; 21 %
/// and 42 % short for the least visible g-sensitivity and gyro drift.
#[test]
fn the_objective_predicts_the_workflow_s_detection_thresholds() {
    use sinscal_core::design::detect::{naming_bar, Detection};
    use sinscal_core::design::DetectGoal;
    use sinscal_core::diagnose::thresholds_before_data;
    use std::sync::atomic::AtomicBool;

    let scheme = Scheme::builtin("ten-position", 300.0).unwrap();
    let goals: Vec<DetectGoal> = [
        "accel_lever_arm=1cm",
        "accel_delay=1ms",
        "gyro_g_sensitivity=0.01deg/h/g",
        "bias_drift=0.01deg/h/h",
        "bias_drift=10ug/h",
        "gyro_scale_asymmetry=10ppm",
    ]
    .iter()
    .map(|g| g.parse().unwrap())
    .collect();
    // One goal at a time: the workflow weighs each effect against the
    // base model alone (and its rivals), the objective against the base
    // model and the other goals.
    for goal in &goals {
        let req = DesignRequest {
            noise: NAV_GRADE,
            detect: vec![goal.clone()],
            ..DesignRequest::default()
        };
        let settings = objective_settings(&req);
        let detection = Detection::new(&req.detect, naming_bar(), settings.priors.grade);
        let info = scheme_information(&scheme, &settings).unwrap();
        let predicted = detection.thresholds(&info)[0];
        let checked = thresholds_before_data(
            &PlanInput {
                scheme: scheme.clone(),
                site: Site::REFERENCE,
                sample_rate_hz: 20.0,
                noise: NAV_GRADE,
                initial_attitude_error_deg: [0.0; 3],
            },
            &AtomicBool::new(false),
        )
        .unwrap()
        .into_iter()
        .filter(|t| t.effect == goal.effect.name() && t.unit == goal.unit)
        .flat_map(|t| t.per_parameter)
        .fold(0.0, f64::max);
        let rel = predicted / checked - 1.0;
        eprintln!(
            "{goal}: objective {predicted:.5} workflow {checked:.5} {} ({:+.1} %)",
            goal.unit,
            100.0 * rel
        );
        // Where the gap fit's nodes see less than the filter's every-window
        // updates (the heading's share, through the Earth rate), the
        // objective promises more than the workflow names: the design
        // checks its answer with the workflow and corrects for that.
        assert!(
            (-0.45..0.10).contains(&rel),
            "{goal}: {:+.1} %",
            100.0 * rel
        );
    }
}
