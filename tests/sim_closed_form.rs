//! The simulator against integrals worked out by hand: a constant-rate turn
//! about one body axis from the nominal attitude, where every increment has
//! a closed form, and each SPEC §3 effect on a case with a closed form.

use nalgebra::{Matrix3, Vector3};
use sinscal::model::effects::{BiasDrift, LeverArms};
use sinscal::model::units::{DEG_PER_H, DEG_PER_H_PER_G, HOUR, PPM, UG};
use sinscal::model::{Effects, ErrorParameters};
use sinscal::nav::earth::OMEGA_IE;
use sinscal::nav::Site;
use sinscal::sim::scheme::{Axis, Frame, Rotate, Scheme, Step};
use sinscal::sim::{simulate, Noise, SimConfig};
use sinscal::Record;

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
