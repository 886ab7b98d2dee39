//! Issue 5, must show: on clean runs nothing is named.

mod common;

use common::*;
use sinscal::model::Effects;

#[test]
fn clean_runs_name_nothing() {
    for seed in 1..=1 {
        let cfg = config(nine_plus_nine(600.0), Effects::none(), seed);
        let rep = run(&cfg);
        assert!(rep.named.is_empty(), "seed {seed}: {}", rep.verdict);
    }
}
