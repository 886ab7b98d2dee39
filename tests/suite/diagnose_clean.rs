//! On clean runs (five seeds) nothing is named and
//! the gap sits at the noise floor.

use crate::diagnosis_support;

use diagnosis_support::*;
use sinscal_core::diagnose::Verdict;
use sinscal_core::model::Effects;

#[test]
fn clean_runs_name_nothing() {
    let seeds: Vec<u64> = (101..=105).collect();
    // Shorter dwells than the effect tests: only the false-alarm rate is
    // at stake here. The runs are shared between both cores.
    let reps = on_both_cores(&seeds, |&seed| {
        run(&config(nine_plus_nine(300.0), Effects::none(), seed))
    });
    let mut z = Vec::new();
    for (seed, rep) in seeds.into_iter().zip(reps) {
        assert!(rep.named.is_empty(), "seed {seed}: {}", rep.verdict);
        assert_eq!(rep.verdict, Verdict::NoSignificantEffect, "seed {seed}");
        assert!(
            rep.gap_rms_before < 1.2 * rep.noise_floor_rms,
            "seed {seed}: gap {:.3e} vs floor {:.3e}",
            rep.gap_rms_before,
            rep.noise_floor_rms
        );
        z.push(rep.z_before);
    }
    // χ² against its expectation: the noise floor is honest on average.
    let mean = z.iter().sum::<f64>() / z.len() as f64;
    eprintln!("z over seeds: {z:.2?}, mean {mean:.2}");
    assert!(mean.abs() < 1.5, "mean z {mean:.2}");
}

/// A real unit's clean runs (SPEC §2a: pulses, wandering biases, floor
/// vibration): the diagnosis weighs the gap under the noise model the
/// calibration fitted, wander included, so nothing is named and the gap
/// sits at its floor. Weighed under the pre-scan's white densities
/// instead (pulses read as noise 100× too large), seed 4 named a bias
/// drift and the gap's z ran from −10 to 0
/// (`cargo bench --bench diagnose_detect -- --real --clean-only`).
#[test]
fn a_real_units_clean_runs_name_nothing() {
    use sinscal_core::calib::result::NoiseSource;
    let seed = 4;
    let mut cfg = config(nine_plus_nine(300.0), Effects::none(), seed);
    cfg.noise = crate::model_check_support::real_navigation_grade(seed);
    let rep = run(&cfg);
    let noise = rep.base_calibration.noise_model.as_ref().unwrap();
    assert_eq!(noise.source, NoiseSource::Fitted);
    assert_eq!(rep.verdict, Verdict::NoSignificantEffect);
    assert!(rep.z_before.abs() < 3.0, "z {:.2}", rep.z_before);
}
