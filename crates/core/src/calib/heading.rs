//! The start heading of a unit whose gyro biases hide the Earth rate
//! (`Grade::earth_rate_hidden`), found from the whole run instead of the
//! first dwell.
//!
//! One dwell cannot tell a gyro bias from the Earth rate, but the bias
//! turns with the unit and the Earth rate does not. Let D(t) be the body
//! attitude at t relative to the start, integrated from the compensated
//! increments in inertial space (no navigation frame, so no heading is
//! assumed). A rotation about the Earth's axis leaves the Earth rate
//! unchanged, so at rest at any t the gyros read
//!
//!   ω^b(t) = D(t)ᵀ · C_n^b(0) · ω_ie^n + b,
//!
//! linear in the start heading's sine and cosine and the bias b. With
//! C_b^n(0) = R_up(ψ) · Ĉ(0), Ĉ(0) levelled at the nominal heading,
//! R_up(ψ)ᵀ · ω_ie^n = (Ω_N sin ψ, Ω_N cos ψ, Ω_U): five unknowns, three
//! equations a dwell, each dwell weighted by its length over the white
//! gyro noise. Left out at navigation grade, where the first dwell's
//! gyrocompass is exact enough.

use std::sync::atomic::{AtomicBool, Ordering};

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::error::CalibError;
use super::prescan::{first_dwell, Prescan};
use super::run::{RecordSource, RunInfo};
use super::timed::timed_records;
use crate::estimation::align;
use crate::model::Compensator;
use crate::nav::attitude::rotvec_to_dcm;

/// The σ of a heading the run says nothing about: that of a heading
/// uniform over the circle, π/√3 rad.
const UNKNOWN_HEADING_SIGMA_RAD: f64 = 1.813_799_364_234_217_8;

/// Walks of the run per solution: the first with the compensation as it
/// stands, the next with the bias the first found taken out too, so that
/// D(t) no longer drifts with it (a MEMS bias turns D by degrees a minute).
const BIAS_ROUNDS: usize = 2;

/// The start heading and gyro bias the whole run implies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RunHeading {
    /// The start heading less SPEC §4's nominal one, about up, rad.
    pub offset_rad: f64,
    /// Its 1-σ under white gyro noise, rad (at most that of a heading
    /// known to be nowhere in particular).
    pub sigma_rad: f64,
    /// The gyro bias left after the compensation, body axes, rad/s.
    pub gyro_bias_b: Vector3<f64>,
}

impl RunHeading {
    /// The start attitude `c_level` (levelled at the nominal heading)
    /// turned to this heading.
    pub fn turn(&self, c_level: &Matrix3<f64>) -> Matrix3<f64> {
        rotvec_to_dcm(&(Vector3::z() * self.offset_rad)) * c_level
    }
}

/// What the solution reads: the run, its scan and its white gyro noise.
#[derive(Clone, Copy)]
pub(crate) struct HeadingInputs<'a> {
    pub source: &'a dyn RecordSource,
    pub run: &'a RunInfo,
    pub scan: &'a Prescan,
    /// rad/√s.
    pub arw: f64,
    pub cancel: &'a AtomicBool,
}

/// One dwell's sums over its records: Σ Dᵀ·dt, Σ dθ and Σ dt.
#[derive(Clone, Copy)]
struct DwellSums {
    d_t_dt: Matrix3<f64>,
    dtheta: Vector3<f64>,
    duration_s: f64,
}

/// The start heading and the gyro bias of the records as `comp`
/// compensates them.
pub(crate) fn run_heading(
    ctx: &HeadingInputs,
    comp: &Compensator,
) -> Result<RunHeading, CalibError> {
    let dt = 1.0 / ctx.run.sample_rate_hz;
    let f_b = comp.accel(&(Vector3::from(first_dwell(ctx.scan)?.mean_f_b) * dt), dt) / dt;
    let c_level = align::coarse_level(&f_b)?;
    let mut bias = Vector3::zeros();
    let mut heading = None;
    for _ in 0..BIAS_ROUNDS {
        let sums = dwell_sums(ctx, comp, &bias)?;
        let h = solve(ctx, &c_level, &sums);
        bias = h.gyro_bias_b;
        heading = Some(h);
    }
    Ok(heading.expect("at least one round"))
}

/// Each dwell's sums, the records compensated by `comp` and `bias` taken
/// out of them.
fn dwell_sums(
    ctx: &HeadingInputs,
    comp: &Compensator,
    bias: &Vector3<f64>,
) -> Result<Vec<DwellSums>, CalibError> {
    let dwells: Vec<[f64; 2]> = ctx.scan.dwells().map(|d| [d.t_start, d.t_end]).collect();
    let zero = DwellSums {
        d_t_dt: Matrix3::zeros(),
        dtheta: Vector3::zeros(),
        duration_s: 0.0,
    };
    let mut sums = vec![zero; dwells.len()];
    let mut d = Matrix3::identity();
    let mut k = 0;
    for (n, timed) in timed_records(ctx.source, ctx.scan, ctx.run.sample_rate_hz)?.enumerate() {
        if n % 65_536 == 0 && ctx.cancel.load(Ordering::Relaxed) {
            return Err(CalibError::Cancelled);
        }
        let timed = timed?;
        let (t, dt) = (timed.record.t, timed.dt);
        let dtheta = comp.gyro(&Vector3::from(timed.record.dtheta), dt);
        d *= rotvec_to_dcm(&(dtheta - bias * dt));
        let mid = t - 0.5 * dt;
        while k < dwells.len() && mid > dwells[k][1] {
            k += 1;
        }
        if k < dwells.len() && mid >= dwells[k][0] {
            let s = &mut sums[k];
            s.d_t_dt += d.transpose() * dt;
            s.dtheta += dtheta;
            s.duration_s += dt;
        }
    }
    Ok(sums)
}

/// The weighted least-squares solution for (Ω_N sin ψ, Ω_N cos ψ, b).
fn solve(ctx: &HeadingInputs, c_level: &Matrix3<f64>, sums: &[DwellSums]) -> RunHeading {
    let omega_ie_n = ctx.run.site.omega_ie_n();
    let up = omega_ie_n.z;
    let mut normal = SMatrix::<f64, 5, 5>::zeros();
    let mut rhs = SVector::<f64, 5>::zeros();
    for s in sums.iter().filter(|s| s.duration_s > 0.0) {
        // The mean rate is the Earth rate through the mean attitude.
        let m = s.d_t_dt / s.duration_s * c_level.transpose();
        let mut a = SMatrix::<f64, 3, 5>::zeros();
        a.fixed_view_mut::<3, 2>(0, 0)
            .copy_from(&m.fixed_view::<3, 2>(0, 0));
        a.fixed_view_mut::<3, 3>(0, 2)
            .copy_from(&Matrix3::identity());
        let y = s.dtheta / s.duration_s - m.column(2) * up;
        // The mean of white noise over T has variance ARW²/T.
        let weight = s.duration_s / (ctx.arw * ctx.arw);
        normal += a.transpose() * a * weight;
        rhs += a.transpose() * y * weight;
    }
    let Some(cov) = normal.try_inverse() else {
        return RunHeading {
            offset_rad: 0.0,
            sigma_rad: UNKNOWN_HEADING_SIGMA_RAD,
            gyro_bias_b: Vector3::zeros(),
        };
    };
    let z = cov * rhs;
    let (x, y) = (z[0], z[1]);
    let r2 = x * x + y * y;
    // ψ = atan2(x, y): its gradient over (x, y) is (y, −x)/r².
    let g = nalgebra::Vector2::new(y, -x) / r2.max(f64::MIN_POSITIVE);
    let var = (g.transpose() * cov.fixed_view::<2, 2>(0, 0) * g)[(0, 0)];
    // A fit whose horizontal rate is within its noise of zero says
    // nothing of the heading.
    let sigma = if r2 > 0.0 && var.is_finite() {
        var.sqrt().min(UNKNOWN_HEADING_SIGMA_RAD)
    } else {
        UNKNOWN_HEADING_SIGMA_RAD
    };
    RunHeading {
        offset_rad: x.atan2(y),
        sigma_rad: sigma,
        gyro_bias_b: Vector3::new(z[2], z[3], z[4]),
    }
}
