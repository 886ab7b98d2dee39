//! Noise-free simulated runs navigated by the strapdown: after every
//! rotation of a scheme the attitude must match the one composed from the
//! scheme, and the unit must stay at rest.

use nalgebra::Vector3;
use sinscal_core::model::units::ARCSEC;
use sinscal_core::model::{Effects, ErrorParameters};
use sinscal_core::nav::attitude::attitude_difference_n;
use sinscal_core::nav::{Site, Strapdown};
use sinscal_core::sim::{simulate, Noise, Scheme, SchemeRef, SimConfig};

struct Outcome {
    attitude_error_arcsec: f64,
    max_speed_mps: f64,
    max_displacement_m: f64,
}

fn navigate(scheme: Scheme, params: ErrorParameters, phi_deg: [f64; 3], rate_hz: f64) -> Outcome {
    let cfg = SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: rate_hz,
        scheme,
        params,
        effects: Effects::none(),
        noise: Noise::default(),
        initial_attitude_error_deg: phi_deg,
        seed: 1,
        thermal: None,
        temperature: None,
    };
    let sim = simulate(&cfg).unwrap();
    let traj = sim.trajectory().clone();
    let dt = sim.dt();
    let comp = params.compensator();
    let mut nav = Strapdown::new(&cfg.site, &traj.c_b_n_start(), 0.0, dt);
    let mut max_speed: f64 = 0.0;
    for raw in sim {
        nav.update(&comp.record(&raw, dt));
        max_speed = max_speed.max(nav.v_n.norm());
    }
    assert!((nav.t - traj.duration()).abs() < dt);
    let phi = attitude_difference_n(&nav.c_b_n(), &traj.c_b_n_end());
    Outcome {
        attitude_error_arcsec: phi.norm() / ARCSEC,
        max_speed_mps: max_speed,
        max_displacement_m: nav.r_n.norm(),
    }
}

fn nine_plus_nine() -> Scheme {
    Scheme::builtin("ten-position-9+9", 600.0).unwrap()
}

#[test]
fn error_free_nine_plus_nine_run_navigates_to_the_scheme_attitude() {
    let out = navigate(nine_plus_nine(), ErrorParameters::zero(), [0.0; 3], 100.0);
    assert!(
        out.attitude_error_arcsec < 0.01,
        "attitude {} arcsec",
        out.attitude_error_arcsec
    );
    // The contract asks < 1 mm/s; the mechanization holds ~5 µm/s, so a
    // tenth of the contract catches a regression long before it matters.
    assert!(out.max_speed_mps < 1e-4, "speed {} m/s", out.max_speed_mps);
    eprintln!(
        "error-free 9+9: attitude {:.2e} arcsec, max speed {:.2e} m/s, displacement {:.2e} m",
        out.attitude_error_arcsec, out.max_speed_mps, out.max_displacement_m
    );
}

#[test]
fn paper_errors_compensated_exactly_navigate_like_error_free() {
    // Tilted and turned start: the simulator and strapdown must not rely on
    // the nominal attitude.
    let out = navigate(
        nine_plus_nine(),
        ErrorParameters::paper(),
        [3.0, -2.0, 40.0],
        100.0,
    );
    assert!(
        out.attitude_error_arcsec < 0.01,
        "attitude {} arcsec",
        out.attitude_error_arcsec
    );
    // The contract asks < 1 mm/s; the mechanization holds ~5 µm/s, so a
    // tenth of the contract catches a regression long before it matters.
    assert!(out.max_speed_mps < 1e-4, "speed {} m/s", out.max_speed_mps);
    eprintln!(
        "paper errors 9+9: attitude {:.2e} arcsec, max speed {:.2e} m/s",
        out.attitude_error_arcsec, out.max_speed_mps
    );
}

#[test]
fn navigation_axis_and_negative_turns_at_an_odd_rate() {
    let scheme: SchemeRef = serde_json::from_str(
        r#"{"name": "mixed", "steps": [{"dwell_s": 30},
            {"rotate": {"axis": "u", "angle_deg": -135, "rate_dps": 15, "accel_dps2": 30, "frame": "nav"}},
            {"dwell_s": 30},
            {"rotate": {"axis": "x", "angle_deg": -200, "rate_dps": 20}},
            {"dwell_s": 30},
            {"rotate": {"axis": "e", "angle_deg": 3}},
            {"dwell_s": 30},
            {"rotate": {"axis": "z", "angle_deg": 720, "rate_dps": 30, "accel_dps2": 10}},
            {"dwell_s": 30}]}"#,
    )
    .unwrap();
    // 37 Hz: breakpoints fall inside records.
    let out = navigate(
        scheme.resolve(None).unwrap(),
        ErrorParameters::paper(),
        [0.5, 0.5, -120.0],
        37.0,
    );
    assert!(
        out.attitude_error_arcsec < 0.01,
        "attitude {} arcsec",
        out.attitude_error_arcsec
    );
    // The contract asks < 1 mm/s; the mechanization holds ~5 µm/s, so a
    // tenth of the contract catches a regression long before it matters.
    assert!(out.max_speed_mps < 1e-4, "speed {} m/s", out.max_speed_mps);
}

#[test]
fn navigation_axis_turn_ends_where_the_axis_says() {
    // A quarter turn about Up from the nominal start: x_b ends North.
    let scheme: SchemeRef = serde_json::from_str(
        r#"{"steps": [{"dwell_s": 1}, {"rotate": {"axis": "u", "angle_deg": 90}}, {"dwell_s": 1}]}"#,
    )
    .unwrap();
    let sim = simulate(&SimConfig {
        site: Site::new(45.0, 0.0, 0.0),
        sample_rate_hz: 100.0,
        scheme: scheme.resolve(None).unwrap(),
        params: ErrorParameters::zero(),
        effects: Effects::none(),
        noise: Noise::default(),
        initial_attitude_error_deg: [0.0; 3],
        seed: 0,
        thermal: None,
        temperature: None,
    })
    .unwrap();
    let x_b_in_n = sim.trajectory().c_b_n_end() * Vector3::x();
    assert!((x_b_in_n - Vector3::y()).norm() < 1e-15);
}
