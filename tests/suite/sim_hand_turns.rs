//! Runs turned by hand (SPEC §4 flips): the simulator's records against an
//! independent integration of the flip's closed-form motion, the strapdown
//! through a whole hand-turned scheme, the calibration of hand-turned runs,
//! and `sinscal simulate --manual`.

use std::f64::consts::{PI, TAU};
use std::process::Command;

use nalgebra::{Matrix3, Rotation3, Unit, Vector3};
use sinscal_core::calib::sources::calibrate_simulated;
use sinscal_core::calib::EstimateOptions;
use sinscal_core::io::data::{DataFormat, RecordReader};
use sinscal_core::io::meta::{read_json, Truth};
use sinscal_core::model::params::paper_accuracy;
use sinscal_core::model::units::ARCSEC;
use sinscal_core::model::{Effects, ErrorParameters, PARAMETERS};
use sinscal_core::nav::attitude::attitude_difference_n;
use sinscal_core::nav::earth::OMEGA_IE;
use sinscal_core::nav::{Site, Strapdown};
use sinscal_core::sim::scheme::{Flip, Step};
use sinscal_core::sim::trajectory::Motion;
use sinscal_core::sim::{simulate, HandTurns, Noise, Scheme, SchemeRef, SimConfig};

fn config(scheme: Scheme, rate_hz: f64, params: ErrorParameters, noise: Noise) -> SimConfig {
    SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: rate_hz,
        scheme,
        params,
        effects: Effects::none(),
        noise,
        initial_attitude_error_deg: [0.3, -0.2, 25.0],
        seed: 3,
        thermal: None,
        temperature: None,
    }
}

fn flip(axis_b: [f64; 3], angle_deg: f64, duration_s: f64, lift_m: f64, shift_m: [f64; 2]) -> Step {
    Step::Flip {
        flip: Flip {
            axis_b,
            angle_deg,
            duration_s,
            lift_m,
            shift_m,
        },
    }
}

/// Three flips about skewed axes, both signs, one nearly a half turn, with
/// dwells whose lengths put the flips' ends inside records.
fn three_flips() -> Scheme {
    Scheme {
        name: "three flips".into(),
        steps: vec![
            Step::Dwell { dwell_s: 0.537 },
            flip([0.05, 1.0, -0.03], 93.7, 1.2345, 0.05, [0.03, -0.02]),
            Step::Dwell { dwell_s: 0.3011 },
            flip([2.0, 0.04, 0.08], -178.2, 1.71, 0.07, [-0.04, 0.01]),
            Step::Dwell { dwell_s: 0.25 },
            flip([0.03, -0.04, 1.0], 88.0, 0.8, 0.02, [0.0, 0.05]),
            Step::Dwell { dwell_s: 0.5 },
        ],
    }
}

/// The motion written out afresh from SPEC §4, without the library's
/// trajectory: piecewise, each piece an attitude at its start and, for a
/// flip, its axis, angle, duration, lift and shift.
struct Reference {
    pieces: Vec<(f64, f64, Matrix3<f64>, Option<Flip>)>,
    omega_ie_n: Vector3<f64>,
    g: f64,
}

impl Reference {
    fn new(scheme: &Scheme, start_deg: [f64; 3]) -> Self {
        let phi = Vector3::from(start_deg) * (PI / 180.0);
        let mut c = Rotation3::new(phi).into_inner();
        let mut t = 0.0;
        let mut pieces = Vec::new();
        for step in &scheme.steps {
            match *step {
                Step::Dwell { dwell_s } => {
                    pieces.push((t, t + dwell_s, c, None));
                    t += dwell_s;
                }
                Step::Flip { flip } => {
                    pieces.push((t, t + flip.duration_s, c, Some(flip)));
                    t += flip.duration_s;
                    c *= Self::turn(&flip, flip.angle_deg.to_radians());
                }
                Step::Rotate { .. } => panic!("the reference knows flips only"),
            }
        }
        let lat = Site::REFERENCE.latitude_rad();
        Reference {
            pieces,
            omega_ie_n: Vector3::new(0.0, OMEGA_IE * lat.cos(), OMEGA_IE * lat.sin()),
            g: Site::REFERENCE.gravity(),
        }
    }

    fn turn(flip: &Flip, angle: f64) -> Matrix3<f64> {
        let axis = Unit::new_normalize(Vector3::from(flip.axis_b));
        Rotation3::from_axis_angle(&axis, angle).into_inner()
    }

    /// Angular rate ω_ib^b and specific force f^b at t inside piece `p`.
    fn rate_and_force(&self, p: usize, t: f64) -> (Vector3<f64>, Vector3<f64>) {
        let (t0, _, c0, flip) = self.pieces[p];
        let mut f_n = Vector3::new(0.0, 0.0, self.g);
        let Some(flip) = flip else {
            let c_n_b = c0.transpose();
            return (c_n_b * self.omega_ie_n, c_n_b * f_n);
        };
        let big_t = flip.duration_s;
        let u = (t - t0) / big_t;
        let a = flip.angle_deg.to_radians();
        let angle = a * (u - (TAU * u).sin() / TAU);
        let rate = a * (1.0 - (TAU * u).cos()) / big_t;
        let c_n_b = (c0 * Self::turn(&flip, angle)).transpose();
        let axis = Vector3::from(flip.axis_b).normalize();
        // Horizontal: shift·s(u); vertical: h sin²(πu).
        let shift = Vector3::new(flip.shift_m[0], flip.shift_m[1], 0.0);
        let v_n = shift * (1.0 - (TAU * u).cos()) / big_t
            + Vector3::z() * (2.0 * flip.lift_m * (PI * u).sin() * (PI * u).cos() * PI / big_t);
        let a_n = shift * (TAU * (TAU * u).sin() / (big_t * big_t))
            + Vector3::z()
                * (2.0 * flip.lift_m * PI * PI * ((PI * u).cos().powi(2) - (PI * u).sin().powi(2))
                    / (big_t * big_t));
        f_n += a_n + 2.0 * self.omega_ie_n.cross(&v_n);
        (c_n_b * self.omega_ie_n + axis * rate, c_n_b * f_n)
    }

    /// ∫ω dt and ∫f dt over (ta, tb], composite Simpson on each piece.
    fn increments(&self, ta: f64, tb: f64) -> (Vector3<f64>, Vector3<f64>) {
        const N: usize = 64;
        let (mut dth, mut dv) = (Vector3::zeros(), Vector3::zeros());
        for (p, &(t0, t1, ..)) in self.pieces.iter().enumerate() {
            let (a, b) = (ta.max(t0), tb.min(t1));
            if b <= a {
                continue;
            }
            let h = (b - a) / N as f64;
            for k in 0..=N {
                let w = if k == 0 || k == N {
                    1.0
                } else if k % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                let (om, f) = self.rate_and_force(p, a + k as f64 * h);
                dth += om * (w * h / 3.0);
                dv += f * (w * h / 3.0);
            }
        }
        (dth, dv)
    }
}

#[test]
fn flip_records_match_an_independent_integration() {
    let scheme = three_flips();
    let cfg = config(
        scheme.clone(),
        100.0,
        ErrorParameters::zero(),
        Noise::default(),
    );
    let sim = simulate(&cfg).unwrap();
    let traj = sim.trajectory().clone();
    let reference = Reference::new(&scheme, cfg.initial_attitude_error_deg);
    let (mut worst_th, mut worst_v, mut motion_v) = (0.0f64, 0.0f64, 0.0f64);
    let mut n = 0;
    for r in sim {
        let (dth, dv) = reference.increments(r.t - 0.01, r.t);
        worst_th = worst_th.max((Vector3::from(r.dtheta) - dth).abs().max());
        worst_v = worst_v.max((Vector3::from(r.dv) - dv).abs().max());
        // How much the point's own motion adds: what a flip without its
        // lift and shift would miss.
        let k = traj.kinematics(r.t - 0.005);
        motion_v = motion_v.max((k.f_b - k.c_b_n.transpose() * Site::REFERENCE.f_rest_n()).norm());
        n += 1;
    }
    eprintln!("{n} records: worst dθ {worst_th:.1e} rad, dv {worst_v:.1e} m/s");
    assert_eq!(n, 533);
    assert!(worst_th < 1e-10, "dθ off by {worst_th:e} rad");
    assert!(worst_v < 1e-9, "dv off by {worst_v:e} m/s");
    assert!(motion_v > 0.5, "the point's acceleration is in f^b");

    // The composed end: attitude and where the point was set down.
    let end = reference.pieces.last().unwrap().2;
    assert!(attitude_difference_n(&traj.c_b_n_end(), &end).norm() < 1e-14);
    let shift = Vector3::new(-0.01, 0.04, 0.0);
    assert!((traj.r_n_end() - shift).norm() < 1e-16);
}

#[test]
fn flip_step_reads_and_writes_as_spec_writes_it() {
    let text = r#"{"name": "by hand", "steps": [{"dwell_s": 10},
        {"flip": {"axis_b": [0.02, 1, 0], "angle_deg": 91.5, "duration_s": 1.4,
                  "lift_m": 0.05, "shift_m": [0.03, -0.01]}}, {"dwell_s": 10}]}"#;
    let scheme = serde_json::from_str::<SchemeRef>(text)
        .unwrap()
        .resolve(None)
        .unwrap();
    let Step::Flip { flip } = scheme.steps[1] else {
        panic!("expected a flip, got {:?}", scheme.steps[1]);
    };
    assert_eq!(flip.shift_m, [0.03, -0.01]);
    let json = serde_json::to_value(&scheme).unwrap();
    assert_eq!(json["steps"][1]["flip"]["duration_s"], 1.4);
    assert_eq!(serde_json::from_value::<Scheme>(json).unwrap(), scheme);

    for (bad, what) in [
        (
            r#"{"axis_b": [0, 0, 0], "angle_deg": 90, "duration_s": 1}"#,
            "zero",
        ),
        (
            r#"{"axis_b": [0, 0, 1], "angle_deg": 90, "duration_s": 0}"#,
            "duration_s",
        ),
        (
            r#"{"axis_b": [0, 0, 1], "angle_deg": 90, "duration_s": -1}"#,
            "duration_s",
        ),
    ] {
        let s: Scheme =
            serde_json::from_str(&format!(r#"{{"steps": [{{"flip": {bad}}}]}}"#)).unwrap();
        let err = s.validate().unwrap_err();
        assert!(err.contains("step 1") && err.contains(what), "{bad}: {err}");
    }
    let unknown = r#"{"steps": [{"flip": {"axis_b": [0, 0, 1], "angle_deg": 90, "duration_s": 1, "speed": 3}}]}"#;
    assert!(serde_json::from_str::<Scheme>(unknown).is_err());
}

#[test]
fn strapdown_follows_a_hand_turned_scheme_and_rests_in_every_dwell() {
    let nominal = Scheme::builtin("ten-position-9+9", 30.0).unwrap();
    let scheme = Scheme::by_hand(&nominal, 11, &HandTurns::default()).unwrap();
    let cfg = config(scheme, 100.0, ErrorParameters::zero(), Noise::default());
    let sim = simulate(&cfg).unwrap();
    let traj = sim.trajectory().clone();
    let dt = sim.dt();
    let mut nav = Strapdown::new(&cfg.site, &traj.c_b_n_start(), 0.0, dt);
    let (mut worst_rest, mut worst_moving, mut fastest) = (0.0f64, 0.0f64, 0.0f64);
    // Growth of the position error over each flip: the trajectory's
    // displacement against the navigated one, separated from the slow
    // drift a small velocity error adds over the dwells.
    let (mut before_flip, mut worst_set_down) = (None::<Vector3<f64>>, 0.0f64);
    let mut seg = 0;
    for r in sim {
        nav.update(&r);
        seg = traj.segment_index(r.t - dt, seg);
        let last = traj.segment_index(r.t, seg);
        let truth = traj.kinematics_in(last, r.t);
        let pos_err = nav.r_n - truth.r_n;
        // A record wholly inside one dwell.
        let resting =
            seg == last && matches!(traj.segments()[seg].motion, Motion::Dwell) && r.t > dt;
        if resting {
            worst_rest = worst_rest.max(nav.v_n.norm());
            if let Some(before) = before_flip.take() {
                worst_set_down = worst_set_down.max((pos_err - before).norm());
            }
        } else {
            worst_moving = worst_moving.max((nav.v_n - truth.v_n).norm());
            fastest = fastest.max(truth.v_n.norm());
            before_flip.get_or_insert(pos_err);
        }
    }
    let attitude = attitude_difference_n(&nav.c_b_n(), &traj.c_b_n_end()).norm() / ARCSEC;
    eprintln!(
        "hand-turned 9+9: speed at rest ≤ {worst_rest:.1e} m/s, velocity error in flips ≤ \
         {worst_moving:.1e} m/s (point up to {fastest:.2} m/s), attitude {attitude:.1e} arcsec, \
         set down {:.3} m away, each flip's displacement off by ≤ {worst_set_down:.1e} m",
        traj.r_n_end().norm()
    );
    assert!(fastest > 0.02, "the point moves in the flips");
    assert!(worst_rest < 1e-4, "speed at rest {worst_rest} m/s");
    assert!(
        worst_moving < 1e-4,
        "velocity error in flips {worst_moving} m/s"
    );
    assert!(attitude < 0.01, "attitude {attitude} arcsec");
    assert!(
        worst_set_down < 3e-4,
        "displacement off by {worst_set_down} m"
    );
}

#[test]
fn hand_turned_nine_plus_nine_calibrates_within_table1() {
    let truth = ErrorParameters::paper();
    let nominal = Scheme::builtin("ten-position-9+9", 300.0).unwrap();
    let opts = EstimateOptions {
        cross_check: false,
        ..EstimateOptions::default()
    };
    for seed in [5, 6] {
        let scheme = Scheme::by_hand(&nominal, seed, &HandTurns::default()).unwrap();
        let cfg = SimConfig {
            seed,
            ..config(scheme, 20.0, truth, Noise::default_navigation_grade())
        };
        let res = calibrate_simulated(&cfg, &opts).unwrap();
        assert_eq!(res.dwell_residuals.len(), 19, "seed {seed}: 19 dwells");
        for (i, p) in PARAMETERS.iter().enumerate() {
            let err = res.parameters[p.name].value - truth.canonical(i);
            let sigma = res.parameters[p.name].sigma;
            let bound = paper_accuracy(p.group);
            eprintln!(
                "seed {seed} {:<18} error {err:+.5} ({:+.2}σ), bound {bound}",
                p.name,
                err / sigma
            );
            assert!(
                err.abs() < bound,
                "seed {seed}: {} error {err} {} exceeds {bound}",
                p.name,
                p.unit
            );
            assert!(
                err.abs() < 3.5 * sigma,
                "seed {seed}: {} at {:.1}σ",
                p.name,
                err / sigma
            );
        }
        eprintln!(
            "seed {seed}: noise measured ARW {:.5} deg/√h, VRW {:.2} µg/√Hz",
            res.noise_arw_deg_rt_h, res.noise_vrw_ug_rt_hz
        );
    }
}

fn sinscal() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sinscal"))
}

#[test]
fn cli_simulate_manual_writes_flips_that_reproduce_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let common = [
        "simulate",
        "--scheme",
        "ten-position",
        "--dwell",
        "20",
        "--params",
        "paper",
        "--rate",
        "20",
        "--seed",
        "8",
        "--manual",
    ];
    let status = sinscal()
        .args(common)
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let truth: Truth = read_json(&out.join("truth.json")).unwrap();
    let cfg = truth.to_sim_config().unwrap();
    // Default seed of the turns: the run's.
    let nominal = Scheme::builtin("ten-position", 20.0).unwrap();
    let expected = Scheme::by_hand(&nominal, 8, &HandTurns::default()).unwrap();
    assert_eq!(cfg.scheme, expected);
    let flips = cfg
        .scheme
        .steps
        .iter()
        .filter(|s| matches!(s, Step::Flip { .. }))
        .count();
    assert_eq!(flips, 9);
    // The records on disk are those the truth file describes, to the bit.
    let want: Vec<_> = simulate(&cfg).unwrap().collect();
    let reader = RecordReader::open(out.join("run.csv"), DataFormat::Csv, 20.0).unwrap();
    let got: Vec<_> = reader.collect::<Result<_, _>>().unwrap();
    assert_eq!(got, want);

    // A seed of their own changes the turns, not the noise stream's seed.
    let out2 = dir.path().join("run2");
    let status = sinscal()
        .args(common)
        .args(["--manual-seed", "9", "--out"])
        .arg(&out2)
        .status()
        .unwrap();
    assert!(status.success());
    let truth2: Truth = read_json(&out2.join("truth.json")).unwrap();
    assert_eq!(truth2.seed, 8);
    let scheme2 = truth2.to_sim_config().unwrap().scheme;
    assert_eq!(
        scheme2,
        Scheme::by_hand(&nominal, 9, &HandTurns::default()).unwrap()
    );

    let refused = sinscal()
        .args(["simulate", "--scheme", "ten-position", "--params", "zero"])
        .args(["--manual-seed", "3", "--out"])
        .arg(dir.path().join("x"))
        .output()
        .unwrap();
    assert!(!refused.status.success());
}
