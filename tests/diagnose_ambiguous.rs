//! Two candidates the scheme cannot tell apart, and the turn that parts
//! them. On four quarter turns about body x, all one way, an
//! accelerometer bias drift is explained as well by a gyro scale
//! asymmetry: a scale factor that differs with the sense of rotation
//! cannot be seen on turns of one sense, so the asymmetry's columns take
//! up the drift's gap with the base scale factor. The workflow must say
//! "ambiguous", name neither, and suggest a turn; adding that turn to the
//! scheme must let the same unit's drift be named and fitted.

mod diagnosis_support;

use diagnosis_support::*;
use sinscal::diagnose::candidates::values_in;
use sinscal::diagnose::Verdict;
use sinscal::model::effects::BiasDrift;
use sinscal::model::Effects;
use sinscal::sim::scheme::{Axis, Rotate, Step};
use sinscal::sim::Scheme;

fn quarter_turns_about_x(dwell_s: f64) -> Scheme {
    let mut steps = vec![Step::Dwell { dwell_s }];
    for _ in 0..4 {
        steps.push(Step::Rotate {
            rotate: Rotate {
                axis: Axis::X,
                angle_deg: 90.0,
                rate_dps: 10.0,
                accel_dps2: 20.0,
                frame: None,
            },
        });
        steps.push(Step::Dwell { dwell_s });
    }
    Scheme {
        name: "x-quarter-turns".into(),
        steps,
    }
}

fn accel_drift() -> Effects {
    Effects {
        bias_drift: Some(BiasDrift {
            gyro: [0.0; 3],
            accel: [12.0, 12.0, 12.0],
        }),
        ..Effects::none()
    }
}

#[test]
fn one_way_turns_cannot_part_drift_from_asymmetry_and_the_suggested_turn_does() {
    for seed in 1..=8 {
        ambiguous_then_parted(seed);
    }
}

fn ambiguous_then_parted(seed: u64) {
    let cfg = config(quarter_turns_about_x(300.0), accel_drift(), seed);
    let rep = run(&cfg);
    assert!(rep.named.is_empty(), "seed {seed}: {}", rep.verdict);
    assert!(
        matches!(rep.verdict, Verdict::Ambiguous { .. }),
        "seed {seed}: {}",
        rep.verdict
    );
    let step = rep.steps.last().unwrap();
    let mut pair: Vec<String> = step.indistinguishable.clone();
    pair.push(
        step.candidates
            .iter()
            .max_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic))
            .unwrap()
            .effect
            .clone(),
    );
    pair.sort();
    assert_eq!(pair, ["bias_drift", "gyro_scale_asymmetry"]);
    let turn = step
        .separating_turns
        .first()
        .expect("a separating turn is suggested");
    eprintln!("suggested: {}", turn.describe());
    assert!(turn.sigma_apart > 3.0);
    // Asymmetry shows only against turns of the other sense.
    assert!(turn.rotate.angle_deg < 0.0, "{}", turn.describe());

    // The same unit, the scheme with the suggested turn added.
    let mut scheme = cfg.scheme.clone();
    scheme.steps.push(Step::Rotate {
        rotate: turn.rotate,
    });
    scheme.steps.push(Step::Dwell {
        dwell_s: turn.dwell_s,
    });
    let cfg2 = config(scheme, accel_drift(), seed + 100);
    let rep2 = run(&cfg2);
    assert_eq!(rep2.named, ["bias_drift"], "seed {seed}: {}", rep2.verdict);
    let truth = values_in(&cfg2.effects, &rep2.named_candidates[0]).unwrap();
    let lib = sinscal::diagnose::candidates::library();
    let cand = lib
        .iter()
        .find(|c| c.name == rep2.named_candidates[0])
        .unwrap();
    for (p, t) in cand.params.iter().zip(truth) {
        let e = &rep2.calibration.effects[&p.name];
        let z = (e.value - t) / e.sigma;
        eprintln!(
            "{}: {:.3} ± {:.3}, truth {t} ({z:+.2}σ)",
            p.name, e.value, e.sigma
        );
        assert!(z.abs() < 3.0, "{} off by {z:.2}σ", p.name);
    }
    assert!(rep2.gap_rms_after <= 1.2 * rep2.noise_floor_rms);
}
