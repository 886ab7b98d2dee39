//! The simulator against integrals worked out by hand: a constant-rate turn
//! about one body axis from the nominal attitude, where every increment has
//! a closed form, and each SPEC §3 effect on a case with a closed form.

use nalgebra::{Matrix3, Vector3};
use sinscal_core::model::effects::{BiasDrift, LeverArms};
use sinscal_core::model::units::{DEG_PER_H, DEG_PER_H_PER_G, HOUR, PPM, UG};
use sinscal_core::model::{Effects, ErrorParameters};
use sinscal_core::nav::earth::OMEGA_IE;
use sinscal_core::nav::Site;
use sinscal_core::sim::scheme::{Axis, Frame, Rotate, Scheme, Step};
use sinscal_core::sim::{simulate, Noise, SimConfig};
use sinscal_core::Record;

const DEG: f64 = std::f64::consts::PI / 180.0;
const RATE_HZ: f64 = 100.0;

/// Dwell `lead` s, turn `angle_deg` about body `axis` at 10°/s, 20°/s²,
/// dwell 1 s.
fn one_turn(axis: Axis, angle_deg: f64, lead: f64) -> Scheme {
    Scheme {
        name: "one-turn".into(),
        steps: vec![
            Step::Dwell { dwell_s: lead },
            Step::Rotate {
                rotate: Rotate {
                    axis,
                    angle_deg,
                    rate_dps: 10.0,
                    accel_dps2: 20.0,
                    frame: Some(Frame::Body),
                },
            },
            Step::Dwell { dwell_s: 1.0 },
        ],
    }
}

fn config(scheme: Scheme, params: ErrorParameters, effects: Effects) -> SimConfig {
    SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: RATE_HZ,
        scheme,
        params,
        effects,
        noise: Noise::default(),
        initial_attitude_error_deg: [0.0; 3],
        seed: 7,
        thermal: None,
        temperature: None,
    }
}

fn records(cfg: &SimConfig) -> Vec<Record> {
    simulate(cfg).unwrap().collect()
}

/// Earth rate components (north, up) at the site.
fn earth() -> (f64, f64) {
    let l = Site::REFERENCE.latitude_rad();
    (OMEGA_IE * l.cos(), OMEGA_IE * l.sin())
}

/// Turn angle during the cruise of a turn that starts at `t0`: 2.5° after
/// the 0.5 s acceleration, then 10°/s.
fn cruise_angle(t: f64, t0: f64) -> f64 {
    (2.5 + 10.0 * (t - t0 - 0.5)) * DEG
}

#[test]
fn turn_about_y_matches_closed_form_with_paper_errors() {
    let p = ErrorParameters::paper();
    let recs = records(&config(one_turn(Axis::Y, 90.0, 1.0), p, Effects::none()));
    let (w_n, w_u) = earth();
    let g = Site::REFERENCE.gravity();
    let om = 10.0 * DEG;
    let dt = 1.0 / RATE_HZ;
    let mut checked = 0;
    // Cruise lasts from t = 1.5 to 10.0 s.
    for r in recs
        .iter()
        .filter(|r| r.t > 1.5 + 1e-9 && r.t < 10.0 - 1e-9)
    {
        let (ta, tb) = (cruise_angle(r.t - dt, 1.0), cruise_angle(r.t, 1.0));
        // C_b^n = R_y(θ): f^b = [−g sinθ, 0, g cosθ],
        // ω_ib^b = [−ω_U sinθ, ω_N + Ω, ω_U cosθ].
        let int_s = (ta.cos() - tb.cos()) / om;
        let int_c = (tb.sin() - ta.sin()) / om;
        let int_s2 = dt / 2.0 - ((2.0 * tb).sin() - (2.0 * ta).sin()) / (4.0 * om);
        let int_c2 = dt - int_s2;
        let dtheta = Vector3::new(-w_u * int_s, (w_n + om) * dt, w_u * int_c);
        let dv = Vector3::new(-g * int_s, 0.0, g * int_c);
        let f_sq = Vector3::new(g * g * int_s2, 0.0, g * g * int_c2);
        let i3 = Matrix3::identity();
        let expect_th = (i3 + p.k_g()) * dtheta + p.b_g() * dt;
        let expect_v = (i3 + p.k_a()) * dv + p.b_a() * dt + p.d_a().component_mul(&f_sq);
        let err_th = (Vector3::from(r.dtheta) - expect_th).abs().max();
        let err_v = (Vector3::from(r.dv) - expect_v).abs().max();
        assert!(err_th < 1e-13, "t={} dθ error {err_th:e}", r.t);
        assert!(err_v < 1e-12, "t={} dv error {err_v:e}", r.t);
        checked += 1;
    }
    assert_eq!(checked, 849);
}

#[test]
fn dwell_records_are_the_resting_values() {
    let recs = records(&config(
        one_turn(Axis::Z, 90.0, 2.0),
        ErrorParameters::zero(),
        Effects::none(),
    ));
    let (w_n, w_u) = earth();
    let g = Site::REFERENCE.gravity();
    let dt = 0.01;
    let first = recs[0];
    assert!((first.t - 0.01).abs() < 1e-15);
    let expect_th = [0.0, w_n * dt, w_u * dt];
    let expect_v = [0.0, 0.0, g * dt];
    for r in &recs[..200] {
        for i in 0..3 {
            // Record edges are k/rate, so Δt carries rounding of ~1e-16·t.
            assert!((r.dtheta[i] - expect_th[i]).abs() < 1e-18);
            assert!((r.dv[i] - expect_v[i]).abs() < 1e-14);
        }
    }
    // 2 s + 9.5 s + 1 s at 100 Hz.
    assert_eq!(recs.len(), 1250);
    assert!((recs.last().unwrap().t - 12.5).abs() < 1e-12);
}

/// The difference an effect makes to each record: records with it minus
/// records without.
fn effect_delta(scheme: Scheme, effects: Effects) -> Vec<(f64, Vector3<f64>, Vector3<f64>)> {
    let base = records(&config(
        scheme.clone(),
        ErrorParameters::zero(),
        Effects::none(),
    ));
    let with = records(&config(scheme, ErrorParameters::zero(), effects));
    base.iter()
        .zip(with.iter())
        .map(|(a, b)| {
            (
                a.t,
                Vector3::from(b.dtheta) - Vector3::from(a.dtheta),
                Vector3::from(b.dv) - Vector3::from(a.dv),
            )
        })
        .collect()
}

#[test]
fn lever_arm_adds_centripetal_force_during_a_turn_about_z() {
    let r = 0.05;
    let effects = Effects {
        accel_lever_arm: Some(LeverArms {
            x: [r * 1e3, 0.0, 0.0],
            y: [0.0; 3],
            z: [0.0; 3],
        }),
        ..Effects::none()
    };
    let (w_n, w_u) = earth();
    let om = 10.0 * DEG;
    let dt = 0.01;
    let deltas = effect_delta(one_turn(Axis::Z, 90.0, 1.0), effects);
    let mut checked = 0;
    for (t, dth, dv) in deltas {
        assert_eq!(dth, Vector3::zeros());
        if t < 1.0 + 1e-9 {
            // At rest only Earth rate turns the arm: −r(ω_N² + ω_U²)Δt.
            assert!((dv.x + r * (w_n * w_n + w_u * w_u) * dt).abs() < 1e-18);
        }
        if t > 1.5 + 1e-9 && t < 10.0 - 1e-9 {
            // C_b^n = R_z(θ): ω^b = [ω_N sinθ, ω_N cosθ, ω_U + Ω]; the x
            // accelerometer senses −r(ω_y² + ω_z²); ω̇ × r has no x part.
            let (ta, tb) = (cruise_angle(t - dt, 1.0), cruise_angle(t, 1.0));
            let int_c2 = dt / 2.0 + ((2.0 * tb).sin() - (2.0 * ta).sin()) / (4.0 * om);
            let expect = -r * ((w_u + om).powi(2) * dt + w_n * w_n * int_c2);
            assert!((dv.x - expect).abs() < 1e-15, "t={t}: {} vs {expect}", dv.x);
            assert!(dv.y.abs() < 1e-12 && dv.z.abs() < 1e-12);
            checked += 1;
        }
    }
    assert_eq!(checked, 849);
}

#[test]
fn g_sensitivity_adds_g_times_column_at_rest() {
    let gs = [0.01, -0.02, 0.015, 0.0, 0.005, -0.01, 0.02, 0.0, 0.01];
    let effects = Effects {
        gyro_g_sensitivity: Some(gs),
        ..Effects::none()
    };
    let g = Site::REFERENCE.gravity();
    let deltas = effect_delta(one_turn(Axis::Z, 90.0, 1.0), effects);
    // Nominal attitude, f^b = [0, 0, g]: the record gains G[:, z]·g·Δt.
    for (t, dth, dv) in deltas.iter().filter(|d| d.0 < 1.0 + 1e-9) {
        assert_eq!(*dv, Vector3::zeros());
        for i in 0..3 {
            let expect = gs[3 * i + 2] * DEG_PER_H_PER_G * g * 0.01;
            assert!((dth[i] - expect).abs() < 1e-20, "t={t}");
        }
    }
}

#[test]
fn accel_delay_shifts_the_accelerometer_interval() {
    let tau_ms = 2.5;
    let effects = Effects {
        accel_delay: Some(tau_ms),
        ..Effects::none()
    };
    let scheme = one_turn(Axis::Y, 90.0, 1.0);
    let with = records(&config(scheme, ErrorParameters::zero(), effects));
    let g = Site::REFERENCE.gravity();
    let om = 10.0 * DEG;
    let tau = tau_ms * 1e-3;
    let dt = 0.01;
    // Before the run the unit rests: the first record is a resting one.
    assert!((with[0].dv[2] - g * dt).abs() < 1e-15);
    let mut checked = 0;
    for r in with.iter().filter(|r| r.t > 1.6 && r.t < 9.9) {
        let (ta, tb) = (
            cruise_angle(r.t - dt - tau, 1.0),
            cruise_angle(r.t - tau, 1.0),
        );
        let dv_x = -g * (ta.cos() - tb.cos()) / om;
        let dv_z = g * (tb.sin() - ta.sin()) / om;
        assert!((r.dv[0] - dv_x).abs() < 1e-13, "t={}", r.t);
        assert!((r.dv[2] - dv_z).abs() < 1e-13, "t={}", r.t);
        checked += 1;
    }
    assert!(checked > 800);
}

#[test]
fn bias_drift_integrates_linearly_in_time() {
    let effects = Effects {
        bias_drift: Some(BiasDrift {
            gyro: [0.01, -0.02, 0.005],
            accel: [10.0, -5.0, 20.0],
        }),
        ..Effects::none()
    };
    let deltas = effect_delta(one_turn(Axis::X, 180.0, 1.0), effects);
    for (t, dth, dv) in &deltas {
        let (t0, t1) = (t - 0.01, *t);
        let span = 0.5 * (t1 * t1 - t0 * t0);
        let expect_th = Vector3::new(0.01, -0.02, 0.005) * (DEG_PER_H / HOUR) * span;
        let expect_v = Vector3::new(10.0, -5.0, 20.0) * (UG / HOUR) * span;
        // The deltas are differences of records of size 1e-3 rad and
        // 0.1 m/s, so their rounding (≈4e-19, 3e-17) bounds the tolerance.
        assert!((dth - expect_th).abs().max() < 1e-17);
        assert!((dv - expect_v).abs().max() < 1e-15);
    }
}

#[test]
fn scale_asymmetry_integrates_the_rate_magnitude_across_a_zero() {
    let a = [50.0, 80.0, 20.0];
    let effects = Effects {
        gyro_scale_asymmetry: Some(a),
        ..Effects::none()
    };
    let (w_n, w_u) = earth();
    let om = 10.0 * DEG;
    let dt = 0.01;
    // A 270° turn about z that starts at t = 1.005: θ = π at t = 19.255,
    // inside record (19.25, 19.26], where ω_x = ω_N sinθ changes sign.
    let t0 = 1.005;
    let deltas = effect_delta(one_turn(Axis::Z, 270.0, t0), effects);
    let rec = deltas.iter().find(|d| (d.0 - 19.26).abs() < 1e-9).unwrap();
    let (ta, tb) = (cruise_angle(19.25, t0), cruise_angle(19.26, t0));
    assert!(ta < std::f64::consts::PI && tb > std::f64::consts::PI);
    let int_abs_x = w_n * ((ta.cos() + 1.0) + (tb.cos() + 1.0)) / om;
    let int_abs_y = w_n * (ta.sin() - tb.sin()).abs() / om;
    let int_abs_z = (w_u + om) * dt;
    let expect =
        Vector3::new(int_abs_x, int_abs_y, int_abs_z).component_mul(&(Vector3::from(a) * PPM));
    // Rounding of the 1.7e-3 rad records the delta is taken between.
    assert!(
        (rec.1 - expect).abs().max() < 1e-17,
        "{:?} vs {expect:?}",
        rec.1
    );
    // At rest: A_i |ω_i| Δt with the nominal attitude's Earth rate.
    let first = deltas[0].1;
    assert!((first.y - a[1] * PPM * w_n * dt).abs() < 1e-22);
    assert!(first.x.abs() < 1e-25);
}

/// The thermal truth of the temperature checks, in canonical units per °C
/// and per °C² (SPEC §3a), with k in deg/h per (°C/min).
const THERMAL_LINEAR: [(&str, f64); 8] = [
    ("gyro_bias_x", 0.01),
    ("gyro_bias_z", -0.02),
    ("gyro_scale_y", 3.0),
    ("gyro_misalign_xz", 1.5),
    ("accel_bias_x", 8.0),
    ("accel_bias_z", -5.0),
    ("accel_scale_z", 4.0),
    ("accel_misalign_zx", 2.0),
];
const THERMAL_QUADRATIC: [(&str, f64); 3] = [
    ("gyro_bias_y", 0.001),
    ("accel_bias_z", 0.2),
    ("accel_quad_z", 0.5),
];
const GYRO_BIAS_RATE: [f64; 3] = [0.05, -0.03, 0.02];

/// The temperature of the check, written out here: from 10 °C at 1 °C/s
/// until 16.005 °C (mid-record, mid-turn), then held.
const RAMP_END_S: f64 = 6.005;
fn ramp_c(t: f64) -> f64 {
    10.0 + t.clamp(0.0, RAMP_END_S)
}
fn ramp_rate_c_per_min(t: f64) -> f64 {
    if (0.0..RAMP_END_S).contains(&t) {
        60.0
    } else {
        0.0
    }
}

/// p(T) as SPEC §3a states it, from the canonical maps above.
fn params_at(p25: &ErrorParameters, temp_c: f64) -> ErrorParameters {
    let d = temp_c - 25.0;
    let mut map = p25.to_canonical();
    for (name, p1) in THERMAL_LINEAR {
        *map.get_mut(name).unwrap() += p1 * d;
    }
    for (name, p2) in THERMAL_QUADRATIC {
        *map.get_mut(name).unwrap() += p2 * d * d;
    }
    ErrorParameters::from_canonical(&map).unwrap()
}

/// The turn about y of `one_turn(Axis::Y, 90, 1)`, in closed form: angle
/// and rate (rad, rad/s) at t.
fn y_turn(t: f64) -> (f64, f64) {
    let (a, w) = (20.0 * DEG, 10.0 * DEG);
    match t {
        t if t <= 1.0 => (0.0, 0.0),
        t if t <= 1.5 => (0.5 * a * (t - 1.0).powi(2), a * (t - 1.0)),
        t if t <= 10.0 => (cruise_angle(t, 1.0), w),
        t if t <= 10.5 => {
            let u = t - 10.0;
            (87.5 * DEG + w * u - 0.5 * a * u * u, w - a * u)
        }
        _ => (90.0 * DEG, 0.0),
    }
}

/// Composite Simpson's rule with `n` (even) panels of a 6-vector integrand.
fn simpson(a: f64, b: f64, n: usize, f: &impl Fn(f64) -> [f64; 6]) -> [f64; 6] {
    let h = (b - a) / n as f64;
    let mut sum = [0.0; 6];
    for i in 0..=n {
        let w = if i == 0 || i == n {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        let v = f(a + i as f64 * h);
        for (s, v) in sum.iter_mut().zip(v) {
            *s += w * v;
        }
    }
    sum.map(|s| s * h / 3.0)
}

#[test]
fn a_temperature_ramp_matches_simpson_integrals_of_the_thermal_model() {
    let p25 = ErrorParameters::paper();
    let linear: String = THERMAL_LINEAR
        .iter()
        .map(|(n, v)| format!("\"{n}\": {v}"))
        .collect::<Vec<_>>()
        .join(", ");
    let quadratic: String = THERMAL_QUADRATIC
        .iter()
        .map(|(n, v)| format!("\"{n}\": {v}"))
        .collect::<Vec<_>>()
        .join(", ");
    let thermal = format!(
        r#"{{"linear": {{{linear}}}, "quadratic": {{{quadratic}}}, "gyro_bias_rate": {GYRO_BIAS_RATE:?}}}"#
    );
    let mut cfg = config(one_turn(Axis::Y, 90.0, 1.0), p25, Effects::none());
    cfg.thermal = Some(serde_json::from_str(&thermal).unwrap());
    cfg.temperature = Some(
        serde_json::from_str(&format!(
            r#"{{"start_c": 10, "rate_c_per_min": 60, "max_c": {}}}"#,
            10.0 + RAMP_END_S
        ))
        .unwrap(),
    );
    let recs = records(&cfg);
    assert_eq!(recs.len(), 1150);

    let (w_n, w_u) = earth();
    let g = Site::REFERENCE.gravity();
    // The rates the record integrates at t: (I + K_g(T)) ω + b_g(T) + k Ṫ
    // and (I + K_a(T)) f + b_a(T) + D_a(T) (f ∘ f); Ṫ is the piece's own,
    // since the ends of a piece lie on a kink.
    let integrand = |t: f64, t_dot: f64| {
        let (th, th_dot) = y_turn(t);
        let omega = Vector3::new(-w_u * th.sin(), w_n + th_dot, w_u * th.cos());
        let f = Vector3::new(-g * th.sin(), 0.0, g * th.cos());
        let p = params_at(&p25, ramp_c(t));
        let i3 = Matrix3::identity();
        let k_rate = Vector3::from(GYRO_BIAS_RATE) * (t_dot * DEG_PER_H);
        let w = (i3 + p.k_g()) * omega + p.b_g() + k_rate;
        let a = (i3 + p.k_a()) * f + p.b_a() + p.d_a().component_mul(&f.component_mul(&f));
        [w.x, w.y, w.z, a.x, a.y, a.z]
    };
    let dt = 1.0 / RATE_HZ;
    let (mut worst_th, mut worst_v) = (0.0f64, 0.0f64);
    for (k, r) in recs.iter().enumerate() {
        let (ta, tb) = (k as f64 * dt, (k + 1) as f64 * dt);
        // Simpson needs a smooth integrand: split where Ṫ jumps.
        let piece = |a: f64, b: f64| {
            let t_dot = ramp_rate_c_per_min(0.5 * (a + b));
            simpson(a, b, 16, &|t| integrand(t, t_dot))
        };
        let expect = if ta < RAMP_END_S && RAMP_END_S < tb {
            let (x, y) = (piece(ta, RAMP_END_S), piece(RAMP_END_S, tb));
            std::array::from_fn(|i| x[i] + y[i])
        } else {
            piece(ta, tb)
        };
        for i in 0..3 {
            worst_th = worst_th.max((r.dtheta[i] - expect[i]).abs());
            worst_v = worst_v.max((r.dv[i] - expect[3 + i]).abs());
        }
    }
    eprintln!("worst record: dθ {worst_th:e} rad, dv {worst_v:e} m/s");
    assert!(worst_th < 1e-10, "dθ error {worst_th:e} rad");
    assert!(worst_v < 1e-9, "dv error {worst_v:e} m/s");
    // The check sees the temperature: without it the records differ by
    // far more than the tolerance.
    let cold = records(&config(one_turn(Axis::Y, 90.0, 1.0), p25, Effects::none()));
    let moved = (Vector3::from(cold[700].dv) - Vector3::from(recs[700].dv)).norm();
    assert!(moved > 1e-7, "{moved:e}");
}

#[test]
fn a_soak_moves_every_record_to_the_parameters_at_its_temperature() {
    let p25 = ErrorParameters::paper();
    let mut cfg = config(one_turn(Axis::Z, 90.0, 1.0), p25, Effects::none());
    cfg.thermal = Some(
        serde_json::from_str(r#"{"linear": {"accel_bias_x": 10, "gyro_scale_z": 2}}"#).unwrap(),
    );
    cfg.temperature = Some(serde_json::from_str("45").unwrap());
    assert!(!cfg.temperature_column());
    let hot = records(&cfg);
    let mut p45 = p25.to_canonical();
    *p45.get_mut("accel_bias_x").unwrap() += 200.0;
    *p45.get_mut("gyro_scale_z").unwrap() += 40.0;
    let plain = records(&config(
        one_turn(Axis::Z, 90.0, 1.0),
        ErrorParameters::from_canonical(&p45).unwrap(),
        Effects::none(),
    ));
    for (a, b) in hot.iter().zip(&plain) {
        for i in 0..3 {
            assert!((a.dtheta[i] - b.dtheta[i]).abs() < 1e-15);
            assert!((a.dv[i] - b.dv[i]).abs() < 1e-15);
        }
    }
}
