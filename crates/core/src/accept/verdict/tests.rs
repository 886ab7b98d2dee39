//! The verdict's rules, case by case.

use super::*;

#[test]
fn a_verdict_reads_its_own_spelling_and_names_the_others_when_refused() {
    for v in VerdictStatus::ALL {
        assert_eq!(v.to_string().parse::<VerdictStatus>(), Ok(v));
    }
    assert_eq!(
        "ok".parse::<VerdictStatus>(),
        Err("unknown verdict \"ok\": accepted, rejected or needs_review".to_string())
    );
}

struct Case {
    values: [f64; N_PARAMS],
    sigmas: [f64; N_PARAMS],
    repeat: [Option<f64>; N_PARAMS],
    runs: i64,
    adequate: Option<bool>,
    poorly: Vec<String>,
    flagged: Vec<String>,
    scheme: Option<(i64, i64)>,
}

impl Case {
    fn clean() -> Case {
        Case {
            values: [1.0; N_PARAMS],
            sigmas: [0.1; N_PARAMS],
            repeat: [Some(0.2); N_PARAMS],
            runs: 3,
            adequate: Some(true),
            poorly: Vec::new(),
            flagged: Vec::new(),
            scheme: Some((10, 10)),
        }
    }

    fn judge(&self, product: Product<'_>) -> Verdict {
        let ev = Evidence {
            values: &self.values,
            sigmas: &self.sigmas,
            model_adequate: self.adequate,
            poorly_observable: &self.poorly,
            cross_check_flagged: &self.flagged,
            repeatability: &self.repeat,
            runs: self.runs,
            scheme_dwells: self.scheme,
        };
        judge(&ev, product)
    }
}

fn limits(entries: &[(&str, LimitKind, f64)]) -> ProductLimits {
    let mut l = ProductLimits::default();
    for (name, kind, max) in entries {
        l.set(name, *kind, *max).unwrap();
    }
    l
}

#[test]
fn within_every_limit_is_accepted() {
    let l = limits(&[
        ("gyro_bias_x", LimitKind::MaxAbsValue, 1.0),
        ("gyro_bias_x", LimitKind::MaxSigma, 0.1),
        ("accel_quad_z", LimitKind::MaxRepeatability, 0.25),
    ]);
    // At the bound is within it.
    assert_eq!(Case::clean().judge(Product::Known(&l)), Verdict::Accepted);
    assert_eq!(Case::clean().judge(Product::None), Verdict::Accepted);
}

#[test]
fn each_exceeded_bound_is_named() {
    let mut c = Case::clean();
    c.values[0] = -1.5;
    c.sigmas[3] = 0.3;
    c.repeat[23] = Some(0.4);
    let l = limits(&[
        ("gyro_bias_x", LimitKind::MaxAbsValue, 1.0),
        ("gyro_scale_x", LimitKind::MaxSigma, 0.2),
        ("accel_quad_z", LimitKind::MaxRepeatability, 0.25),
    ]);
    let v = c.judge(Product::Known(&l));
    assert_eq!(v.status(), VerdictStatus::Rejected);
    let named: Vec<(&str, LimitKind, f64)> = v
        .failed()
        .iter()
        .map(|f| (f.parameter.as_str(), f.limit, f.actual))
        .collect();
    assert_eq!(
        named,
        [
            ("gyro_bias_x", LimitKind::MaxAbsValue, 1.5),
            ("gyro_scale_x", LimitKind::MaxSigma, 0.3),
            ("accel_quad_z", LimitKind::MaxRepeatability, 0.4),
        ]
    );
    assert_eq!(v.failed()[0].unit, "deg/h");
    assert_eq!(v.failed()[0].max, 1.0);
}

#[test]
fn doubts_outrank_failures_and_keep_them() {
    let l = limits(&[("gyro_bias_x", LimitKind::MaxAbsValue, 0.5)]);
    let mut c = Case::clean();
    c.adequate = Some(false);
    c.poorly = vec!["accel_quad_x".into()];
    c.flagged = vec!["gyro_bias_y".into()];
    let v = c.judge(Product::Known(&l));
    assert_eq!(v.status(), VerdictStatus::NeedsReview);
    assert_eq!(
        v.reasons(),
        [
            ReviewReason::ModelInadequate,
            ReviewReason::PoorlyObservable {
                parameters: vec!["accel_quad_x".into()]
            },
            ReviewReason::CrossCheckFlagged {
                parameters: vec!["gyro_bias_y".into()]
            },
        ]
    );
    assert_eq!(v.failed().len(), 1);
    // Without a product, the checks alone decide; no check means clear.
    assert_eq!(c.judge(Product::None).status(), VerdictStatus::NeedsReview);
    let mut old = Case::clean();
    old.adequate = None;
    assert_eq!(old.judge(Product::None), Verdict::Accepted);
}

#[test]
fn an_unknown_product_or_a_missing_parameter_needs_review() {
    let v = Case::clean().judge(Product::Unknown("SINS-X"));
    assert_eq!(
        v.reasons(),
        [ReviewReason::UnknownProduct {
            product: "SINS-X".into()
        }]
    );
    let mut c = Case::clean();
    c.values[5] = f64::NAN;
    let l = limits(&[("gyro_scale_z", LimitKind::MaxSigma, 1.0)]);
    assert_eq!(
        c.judge(Product::Known(&l)).reasons(),
        [ReviewReason::MissingParameters {
            parameters: vec!["gyro_scale_z".into()]
        }]
    );
}

#[test]
fn repeatability_needs_two_runs_but_a_failure_is_final() {
    let mut c = Case::clean();
    c.repeat = [None; N_PARAMS];
    c.runs = 1;
    let l = limits(&[
        ("gyro_bias_x", LimitKind::MaxRepeatability, 0.1),
        ("gyro_bias_x", LimitKind::MaxAbsValue, 2.0),
    ]);
    let v = c.judge(Product::Known(&l));
    assert_eq!(
        v.reasons(),
        [ReviewReason::TooFewRuns { runs: 1, needed: 2 }]
    );
    c.values[0] = 3.0;
    assert_eq!(
        c.judge(Product::Known(&l)).status(),
        VerdictStatus::Rejected
    );
}

#[test]
fn the_wire_form_round_trips_and_refuses_contradictions() {
    let l = limits(&[("gyro_bias_x", LimitKind::MaxAbsValue, 0.5)]);
    let mut c = Case::clean();
    c.adequate = Some(false);
    for v in [
        Case::clean().judge(Product::None),
        Case::clean().judge(Product::Known(&l)),
        c.judge(Product::Known(&l)),
    ] {
        let text = serde_json::to_string(&v).unwrap();
        assert_eq!(serde_json::from_str::<Verdict>(&text).unwrap(), v);
    }
    let json = serde_json::to_value(Case::clean().judge(Product::Known(&l))).unwrap();
    assert_eq!(json["status"], "rejected");
    assert_eq!(json["failed"][0]["limit"], "max_abs_value");
    assert_eq!(json["reasons"], serde_json::json!([]));
    let too_few = serde_json::to_value(ReviewReason::TooFewRuns { runs: 1, needed: 2 });
    assert_eq!(
        too_few.unwrap(),
        serde_json::json!({"reason": "too_few_runs", "runs": 1, "needed": 2})
    );
    assert!(serde_json::from_str::<Verdict>(r#"{"status": "rejected"}"#).is_err());
    assert!(serde_json::from_str::<Verdict>(r#"{"status": "needs_review"}"#).is_err());
}

#[test]
fn under_an_inadequate_model_check_a_value_within_its_limits_is_unverified() {
    let wide = limits(&[("gyro_bias_x", LimitKind::MaxAbsValue, 1e9)]);
    let v = Case::clean().judge(Product::Known(&wide));
    assert_eq!(v.parameter_check("gyro_bias_x", true), ParameterCheck::Pass);
    assert_eq!(
        v.parameter_check("gyro_bias_y", false),
        ParameterCheck::NoLimit
    );
    let mut c = Case::clean();
    c.adequate = Some(false);
    let v = c.judge(Product::Known(&wide));
    assert_eq!(
        v.parameter_check("gyro_bias_x", true),
        ParameterCheck::Unverified
    );
    let tight = limits(&[("gyro_bias_x", LimitKind::MaxAbsValue, 0.5)]);
    let v = c.judge(Product::Known(&tight));
    assert_eq!(v.parameter_check("gyro_bias_x", true), ParameterCheck::Fail);
}

#[test]
fn a_run_short_of_its_declared_scheme_needs_review() {
    let mut c = Case::clean();
    c.scheme = Some((7, 10));
    let v = c.judge(Product::None);
    assert_eq!(
        v.reasons(),
        [ReviewReason::ShortOfScheme {
            dwells: 7,
            declared: 10
        }]
    );
    assert!(v.reasons()[0].describe().contains("7 of 10 positions"));
    c.scheme = None;
    assert_eq!(c.judge(Product::None), Verdict::Accepted);
}
