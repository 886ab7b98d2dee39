//! Issue 5, must show: each SPEC §3 effect at a realistic size is named
//! first, fitted within 3σ, and the gap shrinks to the noise floor.

mod common;

use common::*;
use sinscal::model::Effects;

#[test]
fn accel_delay_is_named() {
    let effects = Effects {
        accel_delay: Some(2.0),
        ..Effects::none()
    };
    let cfg = config(nine_plus_nine(600.0), effects, 3);
    let rep = run(&cfg);
    assert_found(&rep, &cfg, &["accel_delay"]);
}
