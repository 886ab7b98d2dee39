//! The toolkit's effect columns (`estimation::effect_columns`) checked
//! against the simulator: the change each SPEC §3 effect's parameters
//! make to a hand-turned run's navigation, from the records that carry
//! it, as a measured run does. Here because it walks a simulated run
//! through calibration's sources, which the toolkit does not know.

use nalgebra::{Matrix3, Vector3};

use super::run::RecordSource;
use super::sources::SimSource;
use crate::estimation::effect_columns::*;
use crate::estimation::sensitivity::Rows;
use crate::model::effects::{BiasDrift, LeverArms};
use crate::model::thermal::{TemperatureHistory, ThermalTruth};
use crate::model::{Effects, ErrorParameters};
use crate::nav::Site;
use crate::sim::trajectory::Motion;
use crate::sim::{simulate, Noise, Scheme, SimConfig, Trajectory};

/// A hand-turned run, noise-free, of a unit with the paper's errors:
/// compensated, the records are the true motion and the effect, which
/// compensation passes through J⁻¹ (with J = I, as without base
/// errors, a column that leaves J⁻¹ out cannot be told from one that
/// keeps it).
fn config(effects: Effects) -> SimConfig {
    let nominal = Scheme::builtin("ten-position", 2.0).unwrap();
    let scheme = Scheme::by_hand(&nominal, 5, &Default::default()).unwrap();
    SimConfig {
        site: Site::REFERENCE,
        sample_rate_hz: 20.0,
        scheme,
        params: ErrorParameters::paper(),
        effects,
        noise: Noise::default(),
        initial_attitude_error_deg: [0.2, -0.3, 40.0],
        seed: 0,
        thermal: None,
        temperature: None,
    }
}

/// The change the effect's parameters make (`known_effect_change`,
/// from the records that carry the effect, as a measured run does)
/// against what the simulator's effect does to the increments, rotated
/// to n by the true mid-record attitude (so each record's share counts,
/// as it does in the navigation), summed from the start and compared in
/// the middle of every dwell: the filter only sees sums over windows,
/// and a hand flip's lift starts
/// with a step in acceleration (SPEC §4's height profile) that a
/// central difference spreads over the neighbouring records.
fn check(effects: Effects, params: &[(EffectParameter, f64)], rows: Rows, tolerance: f64) {
    check_against(
        &config(effects),
        &config(Effects::none()),
        params,
        rows,
        tolerance,
    );
}

/// `check` for the run `cfg` against `plain`, the same run without
/// what `params` model.
fn check_against(
    cfg: &SimConfig,
    plain: &SimConfig,
    params: &[(EffectParameter, f64)],
    rows: Rows,
    tolerance: f64,
) {
    let effects = &cfg.effects;
    // Both runs compensated with their own base parameters, as the
    // walker reads a run: the columns are changes to that record.
    let dt = 1.0 / cfg.sample_rate_hz;
    let comp = cfg.params.compensator();
    let compensated =
        |c: &SimConfig| -> Vec<_> { simulate(c).unwrap().map(|r| comp.record(&r, dt)).collect() };
    let (with, without) = (compensated(cfg), compensated(plain));
    let curve = SimSource(cfg.clone()).temperature().unwrap();
    let trajectory = Trajectory::new(&cfg.scheme, &Matrix3::identity(), &cfg.site).unwrap();
    let mut checkpoints: Vec<usize> = trajectory
        .segments()
        .iter()
        .filter(|s| matches!(s.motion, Motion::Dwell))
        .map(|s| (0.5 * (s.t0 + s.t1) / dt) as usize)
        .collect();
    checkpoints.reverse();
    let (mut worst, mut largest) = (0.0f64, 0.0f64);
    let (mut predicted, mut actual) = (Vector3::zeros(), Vector3::zeros());
    for k in 0..with.len() {
        let r = |i: usize| &with[i.min(with.len() - 1)];
        let c_b_n = trajectory.kinematics(r(k).t - 0.5 * dt).c_b_n;
        let around = |j: usize| r((k + j).saturating_sub(NEIGHBOURS));
        let j_a = comp.accel_jacobian(&Vector3::from(r(k).dv), dt);
        let m = RecordMotion {
            dtheta: std::array::from_fn(|j| around(j).dtheta.into()),
            dv: std::array::from_fn(|j| around(j).dv.into()),
            dt,
            t_mid: r(k).t - 0.5 * dt,
            delta_c: curve.as_ref().map_or(0.0, |c| c.delta_c(r(k).t - 0.5 * dt)),
            rate_c_per_s: curve
                .as_ref()
                .map_or(0.0, |c| c.rate_c_per_s(r(k).t - 0.5 * dt)),
            accel_jacobian: j_a,
            accel_jacobian_inv: j_a.try_inverse().unwrap(),
            gyro_jacobian_inv: comp.gyro_jacobian_inv(),
        };
        for &(p, value) in params {
            let (got_rows, change) = known_effect_change(p, value, &m);
            assert_eq!(got_rows, rows);
            predicted += c_b_n * change;
        }
        actual += c_b_n
            * match rows {
                Rows::Attitude => Vector3::from(with[k].dtheta) - Vector3::from(without[k].dtheta),
                Rows::Velocity => Vector3::from(with[k].dv) - Vector3::from(without[k].dv),
            };
        if checkpoints.last() == Some(&k) {
            checkpoints.pop();
            worst = worst.max((predicted - actual).norm());
            largest = largest.max(actual.norm());
        }
    }
    assert!(largest > 0.0);
    assert!(
        worst < tolerance * largest,
        "{effects:?}: worst error {worst:e} of the largest change {largest:e}"
    );
}

#[test]
fn lever_arm_columns_follow_the_simulated_effect() {
    let arms = LeverArms {
        x: [40.0, 10.0, -20.0],
        y: [-5.0, -30.0, 15.0],
        z: [25.0, -10.0, 60.0],
    };
    let params: Vec<_> = arms
        .r_b()
        .iter()
        .enumerate()
        .flat_map(|(accel, r)| {
            (0..3).map(move |axis| (EffectParameter::LeverArm { accel, axis }, r[axis]))
        })
        .collect();
    let effects = Effects {
        accel_lever_arm: Some(arms),
        ..Effects::none()
    };
    check(effects, &params, Rows::Velocity, 1e-4);
}

/// The first-order column alone leaves a τ² term of about 1.5 τ/s of
/// the effect on these flips (0.75 % at 5 ms); with the second-order
/// column, as `known_effect_change` takes a delay, the rest is below
/// 1e-4 at 5 ms.
#[test]
fn delay_columns_follow_the_simulated_effect() {
    for tau_ms in [0.5, 5.0] {
        let effects = Effects {
            accel_delay: Some(tau_ms),
            ..Effects::none()
        };
        let tau = tau_ms * 1e-3;
        check(
            effects,
            &[(EffectParameter::AccelDelay, tau)],
            Rows::Velocity,
            1e-4,
        );
    }
}

#[test]
fn gyro_columns_follow_the_simulated_effects() {
    let effects = Effects {
        gyro_g_sensitivity: Some([0.01, -0.02, 0.005, 0.0, 0.015, -0.01, 0.02, 0.003, -0.01]),
        ..Effects::none()
    };
    let g = effects.gyro_g_sensitivity_si().unwrap();
    let params: Vec<_> = (0..9)
        .map(|n| {
            let (gyro, axis) = (n / 3, n % 3);
            (
                EffectParameter::GSensitivity { gyro, axis },
                g[(gyro, axis)],
            )
        })
        .collect();
    check(effects, &params, Rows::Attitude, 1e-4);

    let effects = Effects {
        gyro_scale_asymmetry: Some([80.0, -40.0, 25.0]),
        ..Effects::none()
    };
    let a = effects.gyro_scale_asymmetry_si().unwrap();
    let params: Vec<_> = (0..3)
        .map(|i| (EffectParameter::GyroScaleAsymmetry(i), a[i]))
        .collect();
    // |Δθ_i| of a record that carries the asymmetry is off by A_i
    // itself (80 ppm), and a record in which ω_i changes sign holds
    // less than ∫|ω_i| dt.
    check(effects, &params, Rows::Attitude, 2e-4);

    let drift = BiasDrift {
        gyro: [0.02, -0.01, 0.015],
        accel: [0.0; 3],
    };
    let rate = drift.gyro_si();
    let params: Vec<_> = (0..3)
        .map(|i| (EffectParameter::GyroBiasDrift(i), rate[i]))
        .collect();
    let effects = Effects {
        bias_drift: Some(drift),
        ..Effects::none()
    };
    check(effects, &params, Rows::Attitude, 1e-4);
}

/// The thermal states' columns, from the run's temperature as its
/// column gives it, against the simulator's p(T(t)) and k Ṫ on a hand
/// run whose temperature ramps 5 °C/min from 0 °C (fast, so that the
/// short run covers 50 °C) and holds.
#[test]
fn thermal_columns_follow_the_simulated_temperature() {
    let plain = SimConfig {
        temperature: Some(TemperatureHistory::Ramp {
            start_c: 0.0,
            rate_c_per_min: 5.0,
            max_c: 50.0,
        }),
        ..config(Effects::none())
    };
    let linear = [
        ("gyro_bias_x", 0.002),
        ("gyro_scale_y", -0.3),
        ("gyro_misalign_xz", 0.05),
        ("accel_bias_z", 3.0),
        ("accel_scale_x", 0.8),
        ("accel_misalign_zy", -0.04),
    ];
    let k = [0.03, -0.02, 0.01];
    let map = linear.iter().map(|(n, v)| (n.to_string(), *v)).collect();
    let truth = ThermalTruth::from_canonical(&map, &Default::default(), k).unwrap();
    let cfg = SimConfig {
        thermal: Some(truth),
        ..plain.clone()
    };
    for rows in [Rows::Attitude, Rows::Velocity] {
        let params: Vec<_> = linear
            .iter()
            .map(|(n, v)| {
                let i = crate::model::params::index_of(n).unwrap();
                let p = EffectParameter::ThermalLinear(i);
                (p, v * p.si_per_unit())
            })
            .chain((0..3).map(|i| {
                let p = EffectParameter::GyroBiasRate(i);
                (p, k[i] * p.si_per_unit())
            }))
            .filter(|(p, _)| effect_column(*p, &still()).0 == rows)
            .collect();
        check_against(&cfg, &plain, &params, rows, 1e-4);
    }
}

/// A record at rest, for asking which rows a state drives.
fn still() -> RecordMotion {
    RecordMotion {
        dtheta: [Vector3::zeros(); 5],
        dv: [Vector3::zeros(); 5],
        dt: 0.05,
        t_mid: 0.0,
        delta_c: 1.0,
        rate_c_per_s: 1.0,
        accel_jacobian: Matrix3::identity(),
        accel_jacobian_inv: Matrix3::identity(),
        gyro_jacobian_inv: Matrix3::identity(),
    }
}

#[test]
fn accelerometer_drift_columns_follow_the_simulated_effect() {
    let drift = BiasDrift {
        gyro: [0.0; 3],
        accel: [20.0, -10.0, 5.0],
    };
    let rate = drift.accel_si();
    let params: Vec<_> = (0..3)
        .map(|i| (EffectParameter::AccelBiasDrift(i), rate[i]))
        .collect();
    let effects = Effects {
        bias_drift: Some(drift),
        ..Effects::none()
    };
    check(effects, &params, Rows::Velocity, 1e-4);
}
