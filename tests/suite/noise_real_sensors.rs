//! The noise analysis on what real sensors add (SPEC §2a): pulse outputs,
//! terms a short run cannot resolve, a disturbance the model does not
//! hold. Record streams are built here, at 20 Hz and for under an hour.

use crate::noise_analysis::{nothing, value, Axis, StaticRun};

use sinscal_core::model::units::{ARCSEC, DEG_PER_RT_H, UG, UG_PER_RT_HZ};
use sinscal_core::noise::departures::Cause;
use sinscal_core::noise::TermStatus;

const RATE_HZ: f64 = 20.0;

fn white(gyro_arw_deg_rt_h: f64, accel_vrw_ug_rt_hz: f64) -> [Axis; 6] {
    std::array::from_fn(|c| Axis {
        white: if c < 3 {
            gyro_arw_deg_rt_h * DEG_PER_RT_H
        } else {
            accel_vrw_ug_rt_hz * UG_PER_RT_HZ
        },
        ..Axis::default()
    })
}

/// Pulse outputs of 0.1″ and 100 µg·s: every record's quantum found to
/// rounding and Q held at q/√12 (the fit says so); the same noise without
/// pulses has no quantum, and Q is fitted. ARW stays within 10 % of the
/// truth under pulses 30 times its per-record size.
#[test]
fn quanta_are_detected_exactly_and_only_on_pulse_outputs() {
    let q_gyro = 0.1 * ARCSEC;
    let q_accel = 100.0 * UG;
    let quanta = [q_gyro, q_gyro, q_gyro, q_accel, q_accel, q_accel];
    let mut run = StaticRun {
        axes: white(0.003, 20.0),
        rate_hz: RATE_HZ,
        records: (1800.0 * RATE_HZ) as usize,
        seed: 21,
        quanta: Some(quanta),
        extra: nothing,
    };
    let pulsed = run.analyse();
    println!("{}", pulsed.table());
    for (axis, g) in pulsed.gyro.iter() {
        let q = g
            .quantum_arcsec
            .unwrap_or_else(|| panic!("gyro {axis}: none"));
        assert!((q / 0.1 - 1.0).abs() < 1e-9, "gyro {axis}: {q}");
        assert_eq!(g.angle_quantization_arcsec.status, TermStatus::Fixed);
        let held = g.angle_quantization_arcsec.value.unwrap();
        assert!((held - 0.1 / 12f64.sqrt()).abs() < 1e-9, "{held}");
        let arw = value(&g.arw_deg_rt_h);
        assert!((arw / 0.003 - 1.0).abs() < 0.1, "gyro {axis} ARW {arw}");
    }
    for (axis, a) in pulsed.accel.iter() {
        let q = a
            .quantum_mps
            .unwrap_or_else(|| panic!("accel {axis}: none"));
        assert!((q / q_accel - 1.0).abs() < 1e-9, "accel {axis}: {q}");
        assert_eq!(a.velocity_quantization_mm_s.status, TermStatus::Fixed);
    }
    assert!(pulsed.method.contains("q/sqrt(12)"));

    run.quanta = None;
    let plain = run.analyse();
    for (axis, g) in plain.gyro.iter() {
        assert_eq!(g.quantum_arcsec, None, "gyro {axis}");
        assert_ne!(g.angle_quantization_arcsec.status, TermStatus::Fixed);
    }
    for (axis, a) in plain.accel.iter() {
        assert_eq!(a.quantum_mps, None, "accel {axis}");
    }
}

/// White noise alone over 40 minutes (τ up to 400 s): N read with a σ that
/// covers its error, B and K bounds over the τ covered — never 0, never a
/// value — and no departure.
#[test]
fn terms_white_noise_cannot_show_are_bounds() {
    let run = StaticRun {
        axes: white(0.002, 30.0),
        rate_hz: RATE_HZ,
        records: (2400.0 * RATE_HZ) as usize,
        seed: 4,
        quanta: None,
        extra: nothing,
    };
    let report = run.analyse();
    println!("{}", report.table());
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    for (axis, g) in report.gyro.iter() {
        let n = &g.arw_deg_rt_h;
        assert_eq!(n.status, TermStatus::Resolved, "{}", n.text);
        let (v, s) = (n.value.unwrap(), n.sigma.unwrap());
        assert!(
            s > 0.0 && (v - 0.002).abs() < 4.0 * s,
            "gyro {axis}: {}",
            n.text
        );
        for t in [&g.bias_instability_deg_h, &g.rate_random_walk_deg_h_rt_h] {
            assert_eq!(t.status, TermStatus::NotResolved, "gyro {axis}: {}", t.text);
            assert!(t.value.is_none() && t.upper_bound.unwrap() > 0.0);
            assert!(t.text.starts_with("not resolved: below"), "{}", t.text);
            assert!(t.text.contains("at tau <= "), "{}", t.text);
            assert_eq!(t.tau_s[1], report.computed_over.max_tau_s);
        }
    }
    for (axis, a) in report.accel.iter() {
        for t in [&a.bias_instability_ug, &a.acceleration_random_walk_ug_rt_h] {
            assert_eq!(
                t.status,
                TermStatus::NotResolved,
                "accel {axis}: {}",
                t.text
            );
        }
    }
}

/// A sinusoid of period 20 s on the x gyro (0.05 deg/h amplitude) and a
/// burst of vibration on the y accelerometer (a 2.5 Hz oscillation in the
/// run's middle minutes): each flagged on its own axis with its band, the
/// sinusoid as a bump near 0.37 × 20 s; the axes without them clean.
#[test]
fn a_sinusoid_and_a_burst_are_flagged_with_their_band() {
    fn extra(c: usize, t: f64) -> f64 {
        let tau = std::f64::consts::TAU;
        match c {
            0 => 0.05 * ARCSEC * (tau * t / 20.0).sin(),
            4 if (900.0..1200.0).contains(&t) => 3000.0 * UG * (tau * 2.5 * t).sin(),
            _ => 0.0,
        }
    }
    let run = StaticRun {
        axes: white(0.001, 20.0),
        rate_hz: RATE_HZ,
        records: (2400.0 * RATE_HZ) as usize,
        seed: 9,
        quanta: None,
        extra,
    };
    let report = run.analyse();
    println!("{}", report.table());
    let bump = report
        .gyro
        .x
        .departures
        .iter()
        .find(|d| d.tau_s[0] <= 7.4 && d.tau_s[1] >= 7.4)
        .unwrap_or_else(|| panic!("{:?}", report.gyro.x.departures));
    assert_eq!(bump.cause, Cause::Bump, "{}", bump.text);
    assert!((4.0..12.0).contains(&bump.peak_tau_s), "{}", bump.text);
    assert!(report
        .warnings
        .iter()
        .any(|w| w.starts_with("gyro x: a bump")));
    let burst = &report.accel.y.departures;
    assert!(!burst.is_empty(), "the burst is not flagged");
    assert!(burst.iter().any(|d| d.tau_s[0] < 0.5), "{burst:?}");
    for (name, deps) in [
        ("gyro y", &report.gyro.y.departures),
        ("gyro z", &report.gyro.z.departures),
        ("accel x", &report.accel.x.departures),
        ("accel z", &report.accel.z.departures),
    ] {
        assert!(deps.is_empty(), "{name}: {deps:?}");
    }
}
