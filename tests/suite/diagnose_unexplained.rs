//! Never force a name.
//!
//! - A lever arm across the accelerometers' axes is still the SPEC
//!   `accel_lever_arm`: the 6-parameter cross-axis candidate names it.
//! - A slow oscillation of an accelerometer bias (thermal cycling, not a
//!   SPEC §3 effect, added to the records here) is outside the library:
//!   the gap is significant and the verdict must say it is unexplained.

use crate::diagnosis_support;

use std::sync::atomic::AtomicBool;

use diagnosis_support::*;
use sinscal_core::calib::sources::SimSource;
use sinscal_core::calib::{CalibError, RecordSource, RunInfo};
use sinscal_core::diagnose::{diagnose, DiagnoseOptions};
use sinscal_core::model::effects::LeverArms;
use sinscal_core::model::Effects;
use sinscal_core::Record;

#[test]
fn a_lever_arm_across_the_axes_is_named_as_cross_axis() {
    let effects = Effects {
        accel_lever_arm: Some(LeverArms {
            x: [0.0, 0.0, 0.0],
            y: [60.0, 0.0, 0.0],
            z: [0.0, 0.0, 0.0],
        }),
        ..Effects::none()
    };
    let cfg = config(nine_plus_nine(300.0), effects, 12);
    let rep = run(&cfg);
    assert_eq!(
        rep.named_candidates,
        ["accel_lever_arm_cross"],
        "{}",
        rep.verdict
    );
    assert_found(&rep, &cfg, &["accel_lever_arm"]);
}

/// A simulated run with a sinusoidal x-accelerometer bias on top.
struct Thermal(SimSource);

impl RecordSource for Thermal {
    fn records(
        &self,
    ) -> Result<Box<dyn Iterator<Item = Result<Record, CalibError>> + '_>, CalibError> {
        let dt = 1.0 / self.0 .0.sample_rate_hz;
        // 30 µg, period 40 min.
        let amp = 30e-6 * 9.80665;
        let w = 2.0 * std::f64::consts::PI / 2400.0;
        Ok(Box::new(self.0.records()?.map(move |r| {
            r.map(|mut r| {
                r.dv[0] += amp * (w * r.t).sin() * dt;
                r
            })
        })))
    }
}

#[test]
fn an_effect_outside_the_library_is_unexplained() {
    let cfg = config(nine_plus_nine(300.0), Effects::none(), 13);
    let rep = diagnose(
        &Thermal(SimSource(cfg.clone())),
        &RunInfo {
            site: cfg.site,
            sample_rate_hz: cfg.sample_rate_hz,
        },
        &DiagnoseOptions::default(),
        &mut |_| {},
        &AtomicBool::new(false),
    )
    .unwrap();
    eprintln!("{}", rep.summary());
    assert!(rep.z_before > 3.0, "the gap is significant");
    assert!(rep.verdict.is_unexplained(), "verdict: {}", rep.verdict);
}
