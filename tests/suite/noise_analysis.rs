//! The noise analysis against noise of known size: a static run whose axes
//! carry white noise, rate (or acceleration) random walk and flicker noise
//! built here, and a run written by `sinscal simulate` (white ARW and VRW);
//! the same through the server is `api_noise`'s.

use std::process::Command;
use std::sync::atomic::AtomicBool;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde_json::Value;

use sinscal_core::model::units::{DEG_PER_H, DEG_PER_RT_H, UG, UG_PER_RT_HZ};
use sinscal_core::noise::fit::FLICKER_FLOOR;
use sinscal_core::noise::{analyse, NoiseError, NoiseOptions, NoiseReport, Span, Stretches, Term};
use sinscal_core::Record;

/// √h in s^½.
const RT_HOUR_S: f64 = 60.0;

/// Flicker noise over a band: first-order Gauss–Markov processes with
/// correlation times two to a decade, each of variance s². Their Lorentzian
/// spectra add up to h/f between the shortest and longest time, whose
/// Allan variance is 2 ln 2 · s²/ln r (r the spacing ratio): B² = π s²/ln r
/// makes its floor (2 ln 2/π) B².
pub(crate) struct Flicker {
    phi: Vec<f64>,
    drive: Vec<f64>,
    state: Vec<f64>,
}

/// Correlation times of the flicker processes, s: 0.1 s to 10⁵ s, so the
/// floor is flat (within 1 %) from 10 s to beyond the longest τ analysed.
fn flicker_times() -> Vec<f64> {
    (-2..=10).map(|k| 10f64.powf(k as f64 / 2.0)).collect()
}

fn flicker_variance(b: f64) -> f64 {
    b * b * 10f64.sqrt().ln() / std::f64::consts::PI
}

impl Flicker {
    pub(crate) fn new(b: f64, dt: f64, rng: &mut ChaCha8Rng) -> Self {
        let s = flicker_variance(b).sqrt();
        let phi: Vec<f64> = flicker_times().iter().map(|t| (-dt / t).exp()).collect();
        Flicker {
            drive: phi.iter().map(|p| s * (1.0 - p * p).sqrt()).collect(),
            // Started stationary.
            state: phi.iter().map(|_| s * gauss(rng)).collect(),
            phi,
        }
    }

    pub(crate) fn next(&mut self, rng: &mut ChaCha8Rng) -> f64 {
        let mut sum = 0.0;
        for i in 0..self.phi.len() {
            self.state[i] = self.phi[i] * self.state[i] + self.drive[i] * gauss(rng);
            sum += self.state[i];
        }
        sum
    }
}

/// The exact Allan variance of the flicker construction at m samples,
/// from its autocovariance R(j) = s² Σ φ_i^|j|: Var(cluster mean) less the
/// covariance of adjacent cluster means.
fn flicker_avar(b: f64, dt: f64, m: usize) -> f64 {
    let s2 = flicker_variance(b);
    let mf = m as f64;
    flicker_times()
        .iter()
        .map(|t| {
            let phi = (-dt / t).exp();
            let r = |j: usize| s2 * phi.powi(j as i32);
            let var: f64 = r(0) * mf + 2.0 * (1..m).map(|j| (mf - j as f64) * r(j)).sum::<f64>();
            let cov: f64 = (1..2 * m)
                .map(|j| (mf - (j as f64 - mf).abs()) * r(j))
                .sum();
            (var - cov) / (mf * mf)
        })
        .sum()
}

pub(crate) fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// The coefficients of each axis, SI (rad/s-based for gyros, m/s²-based
/// for accelerometers): white density, flicker B, random-walk K.
#[derive(Clone, Copy, Default)]
pub(crate) struct Axis {
    pub white: f64,
    pub flicker: f64,
    pub random_walk: f64,
}

/// A static run, regenerated identically on every read: each axis's rate
/// is a constant (Earth rate, gravity) plus its noises, plus `extra(axis,
/// t)`; with `quanta`, each record holds whole quanta of the accumulated
/// increments and carries the remainder (SPEC §2a pulse outputs).
pub(crate) struct StaticRun {
    pub axes: [Axis; 6],
    pub rate_hz: f64,
    pub records: usize,
    pub seed: u64,
    pub quanta: Option<[f64; 6]>,
    pub extra: fn(usize, f64) -> f64,
}

pub(crate) fn nothing(_: usize, _: f64) -> f64 {
    0.0
}

impl StaticRun {
    pub fn records(&self) -> impl Iterator<Item = Result<Record, NoiseError>> + '_ {
        let dt = 1.0 / self.rate_hz;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let constant = [1.2e-5, 6.4e-5, 3.4e-5, 0.02, -0.03, 9.79];
        let mut flicker: Vec<Flicker> = self
            .axes
            .iter()
            .map(|a| Flicker::new(a.flicker, dt, &mut rng))
            .collect();
        let mut walk = [0.0; 6];
        let mut total = [0.0; 6];
        let mut counted = [0.0; 6];
        let axes = self.axes;
        (1..=self.records).map(move |k| {
            let t = k as f64 * dt;
            let mut u = [0.0; 6];
            for c in 0..6 {
                walk[c] += axes[c].random_walk * dt.sqrt() * gauss(&mut rng);
                let rate = constant[c]
                    + axes[c].white / dt.sqrt() * gauss(&mut rng)
                    + flicker[c].next(&mut rng)
                    + walk[c]
                    + (self.extra)(c, t);
                u[c] = rate * dt;
                if let Some(q) = self.quanta {
                    total[c] += u[c];
                    let n = (total[c] / q[c]).floor() - counted[c];
                    counted[c] += n;
                    u[c] = n * q[c];
                }
            }
            Ok(Record {
                t,
                dtheta: [u[0], u[1], u[2]],
                dv: [u[3], u[4], u[5]],
            })
        })
    }

    /// The whole run analysed as one stretch.
    pub fn analyse(&self) -> NoiseReport {
        let stretches = Stretches {
            span: Span::WholeRun,
            windows: vec![(0.0, self.records as f64 / self.rate_hz)],
        };
        let opts = NoiseOptions {
            span: Span::WholeRun,
            ..NoiseOptions::default()
        };
        analyse(
            self.records(),
            self.rate_hz,
            &stretches,
            &opts,
            &AtomicBool::new(false),
        )
        .unwrap()
    }
}

/// A resolved term's value.
pub(crate) fn value(t: &Term) -> f64 {
    t.value.unwrap_or_else(|| panic!("not a value: {}", t.text))
}

pub(crate) fn within(what: &str, got: f64, truth: f64, tolerance: f64) {
    let err = (got - truth) / truth;
    println!(
        "{what:<26} identified {got:12.6}  true {truth:12.6}  ({:+.1} %)",
        100.0 * err
    );
    assert!(err.abs() <= tolerance, "{what}: {got} against {truth}");
}

/// Eight hours at rest, 20 Hz, each axis with a known mix: white alone;
/// white and random walk; white and flicker; on both triads (the random
/// walk and the flicker take over from the white noise near τ = 10 s).
/// Each term is identified within 10 % of its truth; the flicker's truth is
/// the floor of its construction's exact Allan variance over the τ it
/// dominates. (Over seeds 1–10 the worst errors were 0.6 % for ARW and
/// VRW, 3.1 % for B, 8.3 % for a random walk: the term a single run pins
/// down least, as its τ range holds the fewest independent clusters.)
#[test]
fn terms_of_known_noise_are_identified_within_ten_percent() {
    let arw = 0.0005 * DEG_PER_RT_H;
    let vrw = 10.0 * UG_PER_RT_HZ;
    let gyro_rrw = 0.3 * DEG_PER_H / RT_HOUR_S;
    let gyro_b = 0.015 * DEG_PER_H;
    let accel_rw = 100.0 * UG / RT_HOUR_S;
    let accel_b = 5.0 * UG;
    let axis = |white, flicker, random_walk| Axis {
        white,
        flicker,
        random_walk,
    };
    let rate_hz = 20.0;
    let dt = 1.0 / rate_hz;
    for seed in [1, 2] {
        let run = StaticRun {
            axes: [
                axis(arw, 0.0, 0.0),
                axis(arw, 0.0, gyro_rrw),
                axis(arw, gyro_b, 0.0),
                axis(vrw, 0.0, 0.0),
                axis(vrw, accel_b, 0.0),
                axis(vrw, 0.0, accel_rw),
            ],
            rate_hz,
            records: (8.0 * 3600.0 * rate_hz) as usize,
            seed,
            quanta: None,
            extra: nothing,
        };
        let report = run.analyse();
        // Every record but the first, whose interval its stamp does not
        // give (SPEC §2a).
        assert_eq!(report.computed_over.records_used, run.records as u64 - 1);
        assert!(report.warnings.is_empty(), "{:?}", report.warnings);
        // The true B of each flicker construction: its exact Allan
        // variance averaged over 10 s … the longest τ, as a floor.
        let taus = &report.curves.tau_s;
        let true_b = |b: f64| {
            let band: Vec<f64> = taus
                .iter()
                .filter(|t| **t >= 10.0)
                .map(|t| flicker_avar(b, dt, (t / dt).round() as usize))
                .collect();
            let mean = band.iter().sum::<f64>() / band.len() as f64;
            for v in &band {
                assert!((v / mean - 1.0).abs() < 0.02, "flicker floor not flat");
            }
            (mean / FLICKER_FLOOR).sqrt()
        };
        println!(
            "seed {seed}: tau {:.2}–{:.0} s",
            taus[0],
            taus[taus.len() - 1]
        );
        let (g, a) = (&report.gyro, &report.accel);
        for (name, got) in [
            ("gyro x ARW", value(&g.x.arw_deg_rt_h)),
            ("gyro y ARW", value(&g.y.arw_deg_rt_h)),
            ("gyro z ARW", value(&g.z.arw_deg_rt_h)),
        ] {
            within(name, got, 0.0005, 0.10);
        }
        within(
            "gyro y RRW deg/h/sqrt(h)",
            value(&g.y.rate_random_walk_deg_h_rt_h),
            0.3,
            0.10,
        );
        within(
            "gyro z BI deg/h",
            value(&g.z.bias_instability_deg_h),
            true_b(gyro_b) / DEG_PER_H,
            0.10,
        );
        for (name, got) in [
            ("accel x VRW", value(&a.x.vrw_ug_rt_hz)),
            ("accel y VRW", value(&a.y.vrw_ug_rt_hz)),
            ("accel z VRW", value(&a.z.vrw_ug_rt_hz)),
        ] {
            within(name, got, 10.0, 0.10);
        }
        within(
            "accel y BI ug",
            value(&a.y.bias_instability_ug),
            true_b(accel_b) / UG,
            0.10,
        );
        within(
            "accel z acc. RW ug/sqrt(h)",
            value(&a.z.acceleration_random_walk_ug_rt_h),
            100.0,
            0.10,
        );
        println!("{}", report.table());
    }
}

fn sinscal() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sinscal"))
}

fn run_ok(cmd: &mut Command) -> String {
    let out = cmd.output().expect("run sinscal");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// A run written by `sinscal simulate` (the 9+9 scheme, 120 s dwells, 50 Hz,
/// white ARW and VRW only), analysed over its dwells by `sinscal noise`:
/// ARW and VRW within 10 %, the 19 dwells used, the turns left out.
#[test]
fn a_simulated_run_gives_back_its_arw_and_vrw() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    run_ok(
        sinscal()
            .args([
                "simulate",
                "--scheme",
                "ten-position-9+9",
                "--dwell",
                "120",
                "--params",
                "paper",
                "--rate",
                "50",
                "--arw",
                "0.002",
                "--vrw",
                "20",
                "--format",
                "f64le",
                "--seed",
                "3",
                "--out",
            ])
            .arg(&run),
    );
    let out = dir.path().join("NOISE.json");
    let table = run_ok(
        sinscal()
            .arg("noise")
            .arg(run.join("run.bin"))
            .arg("--out")
            .arg(&out),
    );
    println!("{table}");
    assert!(table.contains("over 19 dwells"), "{table}");
    let report: Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(report["computed_over"]["span"], "dwells");
    assert_eq!(
        report["computed_over"]["stretches"]
            .as_array()
            .unwrap()
            .len(),
        19
    );
    // 19 dwells of 120 s less their guards: the turns are not in.
    let at_rest = report["computed_over"]["seconds_used"].as_f64().unwrap();
    assert!((2200.0..2280.0).contains(&at_rest), "{at_rest}");
    for axis in ["x", "y", "z"] {
        within(
            &format!("simulated gyro {axis} ARW"),
            report["gyro"][axis]["arw_deg_rt_h"]["value"]
                .as_f64()
                .unwrap(),
            0.002,
            0.10,
        );
        within(
            &format!("simulated accel {axis} VRW"),
            report["accel"][axis]["vrw_ug_rt_hz"]["value"]
                .as_f64()
                .unwrap(),
            20.0,
            0.10,
        );
    }
    let curves = &report["curves"];
    let n = curves["tau_s"].as_array().unwrap().len();
    for key in ["cluster_records", "terms"] {
        assert_eq!(curves[key].as_array().unwrap().len(), n);
    }
    assert_eq!(
        curves["gyro"]["x"]["adev_deg_h"].as_array().unwrap().len(),
        n
    );
    assert_eq!(curves["accel"]["z"]["edf"].as_array().unwrap().len(), n);
}
