//! Which extra turn would tell two explanations of a gap apart.
//!
//! Two candidates "cannot be told apart" when, each with its own fitted
//! parameters (and the base parameters refitted beside it), they predict
//! the same gap on the run's scheme. Whether they still differ on another
//! motion is a question for the simulator: a short probe — rest, one turn
//! about a body axis, rest — is simulated from each explanation, both are
//! navigated through the same compensation, and the two predicted gaps are
//! compared against the noise. Among turns about the three body axes by
//! ±90° and 180°, at the scheme's rate and at twice it, the probe that sets
//! the explanations furthest apart is the one to add.
//!
//! The probe starts where the run ends, so appending it to the scheme is
//! all the station has to do. The base parameters are held at each
//! explanation's fitted values: a single extra turn barely moves them.

use std::sync::atomic::{AtomicBool, Ordering};

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::error::DiagnoseError;
use crate::calib::CalibError;
use crate::model::{Effects, ErrorParameters};
use crate::nav::{Site, Strapdown};
use crate::sim::profile::RotationProfile;
use crate::sim::scheme::{Axis, Rotate, Step};
use crate::sim::{simulate, Noise, Scheme, SimConfig};

/// Rest before the probe's turn, s.
const LEAD_IN_S: f64 = 2.0;

/// Below this many noise σ apart a probe does not separate anything.
pub const MIN_SEPARATION_SIGMA: f64 = 3.0;

/// One way of explaining the gap: the sensor's parameters and effects.
#[derive(Clone, Debug)]
pub struct Explanation {
    pub params: ErrorParameters,
    pub effects: Effects,
}

/// Where and how the probe would run.
pub struct ProbeContext<'a> {
    pub site: Site,
    pub sample_rate_hz: f64,
    /// Attitude at the end of the run, where the probe starts.
    pub c_b_n_start: Matrix3<f64>,
    /// The compensation both predictions are navigated with.
    pub compensation: &'a ErrorParameters,
    /// The scheme's turn rate and angular acceleration, deg/s and deg/s².
    pub rate_dps: f64,
    pub accel_dps2: f64,
    /// Rest after the turn, s.
    pub dwell_s: f64,
    /// Gyro angle and accelerometer velocity random walks, rad/√s and
    /// m/s/√s (the run's measured noise).
    pub arw: f64,
    pub vrw: f64,
    pub cancel: &'a AtomicBool,
}

/// A turn to append to the scheme, and how far apart it sets the two
/// explanations' predicted gaps.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeparatingTurn {
    /// The candidate named best and its rival.
    pub between: [String; 2],
    pub rotate: Rotate,
    pub dwell_s: f64,
    /// Velocity-step and dwell-drift differences over their noise σ,
    /// root-sum-square over the three axes.
    pub sigma_apart: f64,
}

impl SeparatingTurn {
    pub fn describe(&self) -> String {
        format!(
            "turn about body {} by {:+.0}° at {:.0}°/s, then rest {:.0} s \
             (their predictions differ there by {:.0}σ)",
            axis_name(self.rotate.axis),
            self.rotate.angle_deg,
            self.rotate.rate_dps,
            self.dwell_s,
            self.sigma_apart,
        )
    }
}

fn axis_name(a: Axis) -> &'static str {
    match a {
        Axis::X => "x",
        Axis::Y => "y",
        Axis::Z => "z",
        Axis::E => "e",
        Axis::N => "n",
        Axis::U => "u",
    }
}

/// The velocity step over the probe's turn and the drift over its rest
/// that an explanation predicts, n-frame, m/s.
#[derive(Clone, Copy, Debug)]
struct Prediction {
    step: Vector3<f64>,
    drift: Vector3<f64>,
}

fn probe_scheme(rotate: Rotate, dwell_s: f64) -> Scheme {
    Scheme {
        name: "separating-probe".into(),
        steps: vec![
            Step::Dwell { dwell_s: LEAD_IN_S },
            Step::Rotate { rotate },
            Step::Dwell { dwell_s },
        ],
    }
}

/// How long the table takes for `rotate`, s.
fn turn_duration(rotate: Rotate) -> f64 {
    RotationProfile::new(
        rotate.angle_deg.to_radians(),
        rotate.rate_dps.to_radians(),
        rotate.accel_dps2.to_radians(),
    )
    .duration()
}

/// A noise-free simulation of `scheme` starting at attitude `c_b_n0`.
fn noise_free_run(
    site: Site,
    sample_rate_hz: f64,
    scheme: Scheme,
    params: ErrorParameters,
    effects: Effects,
    c_b_n0: &Matrix3<f64>,
) -> SimConfig {
    // The simulator starts from the nominal attitude turned by this
    // rotation vector, so the whole start attitude goes in as the "error".
    let phi0 = crate::nav::attitude::dcm_to_rotvec(c_b_n0);
    SimConfig {
        site,
        sample_rate_hz,
        scheme,
        params,
        effects,
        noise: Noise::default(),
        initial_attitude_error_deg: phi0.map(f64::to_degrees).into(),
        seed: 0,
        thermal: None,
        temperature: None,
    }
}

fn predict(
    ctx: &ProbeContext,
    expl: &Explanation,
    rotate: Rotate,
) -> Result<Prediction, DiagnoseError> {
    let cfg = noise_free_run(
        ctx.site,
        ctx.sample_rate_hz,
        probe_scheme(rotate, ctx.dwell_s),
        expl.params,
        expl.effects,
        &ctx.c_b_n_start,
    );
    let dt = 1.0 / ctx.sample_rate_hz;
    let turn_s = turn_duration(rotate);
    let k_turn = (LEAD_IN_S / dt).round() as usize;
    let k_rest = ((LEAD_IN_S + turn_s) / dt).round() as usize;
    let comp = ctx.compensation.compensator();
    let mut nav = Strapdown::new(&ctx.site, &ctx.c_b_n_start, 0.0, dt);
    let (mut v_turn, mut v_rest) = (Vector3::zeros(), Vector3::zeros());
    let sim = simulate(&cfg).map_err(|e| DiagnoseError::Scheme(e.to_string()))?;
    for (k, r) in sim.enumerate() {
        if k % 65_536 == 0 && ctx.cancel.load(Ordering::Relaxed) {
            return Err(DiagnoseError::Calib(CalibError::Cancelled));
        }
        if k == k_turn {
            v_turn = nav.v_n;
        }
        if k == k_rest {
            v_rest = nav.v_n;
        }
        nav.update(&comp.record(&r, dt));
    }
    Ok(Prediction {
        step: v_rest - v_turn,
        drift: nav.v_n - v_rest,
    })
}

/// Noise σ of a velocity change over `t` seconds, per n-frame axis: the
/// accelerometer's random walk, and on the level axes the tilt the gyro's
/// random walk builds (g ∫φ dt).
fn velocity_sigma(ctx: &ProbeContext, t: f64) -> Vector3<f64> {
    let g = ctx.site.gravity();
    let level = ctx.vrw * ctx.vrw * t + (g * ctx.arw).powi(2) * t.powi(3) / 3.0;
    let up = ctx.vrw * ctx.vrw * t;
    Vector3::new(level.sqrt(), level.sqrt(), up.sqrt())
}

/// How far apart, in noise σ, two explanations are on one probe turn.
fn separation(
    ctx: &ProbeContext,
    a: &Explanation,
    b: &Explanation,
    rotate: Rotate,
) -> Result<f64, DiagnoseError> {
    let (pa, pb) = (predict(ctx, a, rotate)?, predict(ctx, b, rotate)?);
    let s_step = velocity_sigma(ctx, turn_duration(rotate));
    let s_drift = velocity_sigma(ctx, ctx.dwell_s);
    let d_step = (pa.step - pb.step).component_div(&s_step);
    let d_drift = (pa.drift - pb.drift).component_div(&s_drift);
    Ok((d_step.norm_squared() + d_drift.norm_squared()).sqrt())
}

/// The probe turns tried: each body axis, ±90° and 180°, at the scheme's
/// rate and at twice it (rate-dependent effects such as a lever arm's
/// centripetal term part from rate-independent ones there).
fn probe_turns(ctx: &ProbeContext) -> Vec<Rotate> {
    let mut turns = Vec::new();
    for rate in [ctx.rate_dps, 2.0 * ctx.rate_dps] {
        for axis in [Axis::X, Axis::Y, Axis::Z] {
            for angle_deg in [90.0, -90.0, 180.0] {
                turns.push(Rotate {
                    axis,
                    angle_deg,
                    rate_dps: rate,
                    accel_dps2: ctx.accel_dps2,
                    frame: None,
                });
            }
        }
    }
    turns
}

/// The probe turn that best separates explanations `a` and `b` (named by
/// `between`), or `None` when none sets them `MIN_SEPARATION_SIGMA` apart.
pub fn separating_turn(
    ctx: &ProbeContext,
    between: [&str; 2],
    a: &Explanation,
    b: &Explanation,
) -> Result<Option<SeparatingTurn>, DiagnoseError> {
    let mut best: Option<(Rotate, f64)> = None;
    for rotate in probe_turns(ctx) {
        let s = separation(ctx, a, b, rotate)?;
        if best.map_or(true, |(_, bs)| s > bs) {
            best = Some((rotate, s));
        }
    }
    let Some((rotate, sigma_apart)) = best.filter(|(_, s)| *s >= MIN_SEPARATION_SIGMA) else {
        return Ok(None);
    };
    Ok(Some(SeparatingTurn {
        between: [between[0].to_string(), between[1].to_string()],
        rotate,
        dwell_s: ctx.dwell_s,
        sigma_apart,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::candidates::{add_effect, library, unit_effect};
    use crate::model::units::{DEG_PER_RT_H, UG_PER_RT_HZ};
    use nalgebra::{DMatrix, DVector};

    fn ctx<'a>(comp: &'a ErrorParameters, cancel: &'a AtomicBool) -> ProbeContext<'a> {
        ProbeContext {
            site: Site::REFERENCE,
            sample_rate_hz: 20.0,
            c_b_n_start: Matrix3::identity(),
            compensation: comp,
            rate_dps: 10.0,
            accel_dps2: 20.0,
            dwell_s: 120.0,
            arw: 0.0003 * DEG_PER_RT_H,
            vrw: 5.0 * UG_PER_RT_HZ,
            cancel,
        }
    }

    fn predictions(c: &ProbeContext, e: &Explanation, turn: Rotate) -> DVector<f64> {
        let p = predict(c, e, turn).unwrap();
        DVector::from_iterator(6, p.step.iter().chain(p.drift.iter()).copied())
    }

    /// A delay, and the lever arms that mimic it best on the scheme's own
    /// turn about x: they agree there, and the turn suggested sets them
    /// far apart.
    #[test]
    fn explanations_that_agree_on_one_turn_are_parted_by_another() {
        let params = ErrorParameters::paper();
        let cancel = AtomicBool::new(false);
        let c = ctx(&params, &cancel);
        let own_turn = Rotate {
            axis: Axis::X,
            angle_deg: 90.0,
            rate_dps: 10.0,
            accel_dps2: 20.0,
            frame: None,
        };
        let delay = Explanation {
            params,
            effects: Effects {
                accel_delay: Some(2.0),
                ..Effects::none()
            },
        };
        let none = Explanation {
            params,
            effects: Effects::none(),
        };
        // Least-squares lever arms matching the delay's prediction.
        let base = predictions(&c, &none, own_turn);
        let target = predictions(&c, &delay, own_turn) - &base;
        let lever = &library()[0];
        let cols: Vec<DVector<f64>> = (0..3)
            .map(|j| {
                let e = Explanation {
                    params,
                    effects: unit_effect(lever, j),
                };
                predictions(&c, &e, own_turn) - &base
            })
            .collect();
        let a = DMatrix::from_columns(&cols);
        let x = a.clone().svd(true, true).solve(&target, 1e-12).unwrap();
        let values: Vec<f64> = (0..3)
            .map(|j| x[j] * lever.params[j].signature_size)
            .collect();
        let mut effects = Effects::none();
        add_effect(&mut effects, lever.name, &values);
        let mimic = Explanation { params, effects };

        let on_own = separation(&c, &delay, &mimic, own_turn).unwrap();
        let turn = separating_turn(&c, ["accel_delay", "accel_lever_arm"], &delay, &mimic)
            .unwrap()
            .expect("some turn separates a delay from a lever arm");
        eprintln!("own turn {on_own:.2}σ; suggested: {}", turn.describe());
        assert!(on_own < 1.0, "the mimic agrees on its own turn: {on_own}");
        assert!(
            turn.sigma_apart > 10.0 && turn.sigma_apart > 10.0 * on_own,
            "{} vs {on_own}",
            turn.describe()
        );
        assert!(turn.describe().contains("turn about body"));
    }

    #[test]
    fn one_explanation_is_not_separated_from_itself() {
        let params = ErrorParameters::paper();
        let cancel = AtomicBool::new(false);
        let c = ctx(&params, &cancel);
        let e = Explanation {
            params,
            effects: Effects {
                accel_delay: Some(1.0),
                ..Effects::none()
            },
        };
        assert!(separating_turn(&c, ["a", "b"], &e, &e.clone())
            .unwrap()
            .is_none());
    }
}
