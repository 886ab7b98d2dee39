//! `sinscal design` as a library: the designed scheme meets its goal by the
//! objective and by `plan`'s filter over simulated records, beats the
//! built-in schemes on the same goal, and refuses what it cannot do.

use sinscal::calib::plan::{plan, PlanInput};
use sinscal::calib::{EstimateOptions, NoiseDensity};
use sinscal::design::detect::DETECT_MARGIN;
use sinscal::design::{design, Axes, DesignRequest, DetectGoal, Target};
use sinscal::nav::Site;

fn tactical() -> DesignRequest {
    DesignRequest {
        target: Some(Target::table1().tightened(0.2)),
        noise: NoiseDensity {
            gyro_arw_deg_rt_h: 0.001,
            accel_vrw_ug_rt_hz: 10.0,
        },
        ..DesignRequest::default()
    }
}

/// The design's prediction against plan's filter on the same scheme, and
/// the design against the built-in schemes' needs.
fn check(req: &DesignRequest) {
    let d = design(req).unwrap();
    eprint!("{}", d.summary());
    for (name, p) in &d.parameters {
        assert!(p.ratio <= 1.0, "{name}: ratio {}", p.ratio);
    }
    let planned = plan(
        &PlanInput {
            scheme: d.scheme.clone(),
            site: Site::REFERENCE,
            sample_rate_hz: 20.0,
            noise: req.noise,
            initial_attitude_error_deg: req.initial_attitude_deg,
        },
        &EstimateOptions::default(),
    )
    .unwrap();
    for (name, p) in &d.parameters {
        let filter = planned.parameters[name].sigma;
        let rel = p.sigma / filter - 1.0;
        assert!(
            rel.abs() < 0.05,
            "{name}: design σ {} vs plan {filter}",
            p.sigma
        );
    }
    for c in &d.comparisons {
        if let Some(t) = c.duration_s {
            assert!(d.duration_s <= t, "{} is shorter: {t} s", c.scheme);
        }
    }
}

#[test]
fn a_body_axis_design_meets_its_goal_and_beats_the_built_in_schemes() {
    check(&tactical());
}

#[test]
fn a_navigation_axis_table_gets_a_navigation_axis_scheme() {
    let req = DesignRequest {
        axes: Axes::Nav,
        ..tactical()
    };
    let d = design(&req).unwrap();
    let json = serde_json::to_string(&d.scheme).unwrap();
    assert!(!json.contains("\"body\""), "{json}");
    check(&req);
}

#[test]
fn impossible_requests_are_refused_with_a_reason() {
    let req = DesignRequest {
        min_dwell_s: 5.0,
        ..tactical()
    };
    let e = design(&req).unwrap_err().to_string();
    assert!(e.contains("shortest dwell"), "{e}");
    // Table 1 / 50 at tactical noise: the gyro biases would need weeks.
    let req = DesignRequest {
        target: Some(Target::table1().tightened(50.0)),
        ..tactical()
    };
    let e = design(&req).unwrap_err().to_string();
    assert!(e.contains("gyro_bias"), "{e}");
    let req = DesignRequest {
        max_duration_s: Some(600.0),
        ..tactical()
    };
    let e = design(&req).unwrap_err().to_string();
    assert!(e.contains("max-duration"), "{e}");
}

/// `--detect`: a lever arm the 24-parameter goal alone would leave
/// unnamed sets the scheme's length, and the discrepancy workflow, run on
/// a noise-free simulation of the answer, names it with the margin asked.
#[test]
fn an_effect_to_detect_shapes_the_scheme_and_the_workflow_confirms_it() {
    let goal: DetectGoal = "accel_lever_arm=6mm".parse().unwrap();
    let req = DesignRequest {
        detect: vec![goal.clone()],
        ..tactical()
    };
    let d = design(&req).unwrap();
    eprint!("{}", d.summary());
    assert_eq!(d.detect.len(), 1);
    let o = &d.detect[0];
    assert!(o.met, "{}", o.describe());
    let checked = o
        .checked_threshold
        .expect("the workflow reports the lever arm");
    assert!(checked * DETECT_MARGIN <= goal.size, "{}", o.describe());
    assert!(
        d.binding.contains(&goal.to_string()),
        "the lever arm should set the length: binding {:?}",
        d.binding
    );
    for (name, p) in &d.parameters {
        assert!(p.ratio <= 1.0, "{name}: ratio {}", p.ratio);
    }
}
