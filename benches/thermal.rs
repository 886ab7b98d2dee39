//! Thermal model from soaked runs over many seeds (`cargo bench --bench
//! thermal [-- SEEDS]`, default 20): five soaks of `ten-position` (600 s
//! dwells, 20 Hz, navigation-grade noise) at −20, 5, 25, 45, 65 °C of the
//! unit of `tests/thermal_support` (16 linear, 3 quadratic coefficients),
//! seeds 1..=SEEDS. Prints RMS err/σ of the 25 °C values, the linear and
//! the quadratic coefficients; the seeds with a quadratic term invented or
//! missed; the seeds with every coefficient within 3σ; and the check's
//! verdict on the clean runs and with one run's accelerometer bias jumped
//! by 30 µg.

#[path = "../tests/thermal_support/mod.rs"]
mod thermal_support;

use std::time::Instant;

use sinscal::thermal::fit_thermal_model;
use thermal_support::*;

fn main() {
    let seeds: u64 = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(20);
    let start = Instant::now();
    let (mut z2, mut n) = ([0.0f64; 3], [0usize; 3]);
    let (mut invented, mut missed, mut within, mut adequate, mut jump_flagged) = (0, 0, 0, 0, 0);
    let mut worst = 0.0f64;
    for seed in 1..=seeds {
        let runs = soaked_runs(seed);
        let model = fit_thermal_model(&runs).unwrap();
        let zs = coefficient_z(&model);
        for (_, term, z) in &zs {
            let k = match *term {
                "value" => 0,
                "linear" => 1,
                _ => 2,
            };
            z2[k] += z * z;
            n[k] += 1;
            worst = worst.max(z.abs());
        }
        if zs.iter().all(|(_, _, z)| z.abs() < 3.0) {
            within += 1;
        }
        let (inv, mis) = quadratic_errors(&model);
        if !inv.is_empty() {
            invented += 1;
            println!("seed {seed}: quadratic terms invented: {inv:?}");
        }
        if !mis.is_empty() {
            missed += 1;
            println!("seed {seed}: quadratic terms missed: {mis:?}");
        }
        if model.check.adequate {
            adequate += 1;
        } else {
            println!("seed {seed}: clean runs called {}", model.check.summary);
        }
        let mut jumped = runs.clone();
        jumped[2].parameters.get_mut("accel_bias_y").unwrap().value += 30.0;
        let bad = fit_thermal_model(&jumped).unwrap();
        if !bad.check.adequate
            && bad.check.outliers.first().map(|o| o.parameter.as_str()) == Some("accel_bias_y")
        {
            jump_flagged += 1;
        }
    }
    let rms = |k: usize| (z2[k] / n[k].max(1) as f64).sqrt();
    println!(
        "{seeds} seeds ({:.0} s): RMS err/σ value at 25 °C {:.2}, linear {:.2}, quadratic {:.2} \
         (n = {}, {}, {}); largest |z| {worst:.2}",
        start.elapsed().as_secs_f64(),
        rms(0),
        rms(1),
        rms(2),
        n[0],
        n[1],
        n[2]
    );
    println!(
        "seeds with a quadratic term invented: {invented}, missed: {missed}; every coefficient \
         within 3σ: {within}/{seeds}; clean runs adequate: {adequate}/{seeds}; a 30 µg jump \
         named: {jump_flagged}/{seeds}"
    );
}
