//! The run walker every estimator's pass shares: the context of a pass
//! (source, options, scan, noise densities), the start alignment, and one
//! navigated walk over the compensated records that hands each window to
//! the estimator.

use std::sync::atomic::{AtomicBool, Ordering};

use nalgebra::{Matrix3, Vector3};

use super::align;
use super::error::CalibError;
use super::filter::{error_dynamics, SystematicFilter};
use super::options::EstimateOptions;
use super::prescan::{first_dwell, Prescan};
use super::priors::{initial_navigation_covariance, prior_sigma};
use super::run::{RecordSource, RunInfo};
use super::sensitivity::base_columns;
use crate::model::units::{DEG_PER_RT_H, UG_PER_RT_HZ};
use crate::model::Compensator;
use crate::nav::Strapdown;

/// Lowest noise densities used, so that a noise-free run still gives a
/// well-posed filter: 1e-5 deg/√h and 0.1 µg/√Hz (thirty and fifty times
/// below the quietest navigation-grade units).
const MIN_ARW: f64 = 1e-5 * DEG_PER_RT_H;
const MIN_VRW: f64 = 0.1 * UG_PER_RT_HZ;

/// What every pass over a run shares.
pub(crate) struct PassContext<'a> {
    pub source: &'a dyn RecordSource,
    pub run: &'a RunInfo,
    pub opts: &'a EstimateOptions,
    pub scan: &'a Prescan,
    /// Noise densities in use, rad/√s and m/s/√s.
    pub arw: f64,
    pub vrw: f64,
    pub cancel: &'a AtomicBool,
}

impl PassContext<'_> {
    /// Records per window.
    pub fn window(&self) -> usize {
        ((self.opts.window_s * self.run.sample_rate_hz).round() as usize).max(1)
    }

    /// The systematic filter a pass starts from: the error dynamics at the
    /// run's site, the start covariance and the priors, the noise in use,
    /// and zero-velocity observations of σ `zupt_sigma_mps` (a pass that
    /// only accumulates the parameter columns makes none).
    pub fn filter(&self, zupt_sigma_mps: f64) -> SystematicFilter {
        let site = &self.run.site;
        SystematicFilter::new(
            error_dynamics(&site.omega_ie_n(), &site.f_rest_n()),
            &initial_navigation_covariance(site, self.opts.prior_scale),
            &prior_sigma(self.opts.prior_scale),
            self.arw,
            self.vrw,
            zupt_sigma_mps,
        )
    }
}

impl<'a> PassContext<'a> {
    /// The passes' context over a scanned run: the noise densities from
    /// the options, else as the dwells measured them, floored.
    pub fn new(
        source: &'a dyn RecordSource,
        run: &'a RunInfo,
        opts: &'a EstimateOptions,
        scan: &'a Prescan,
        cancel: &'a AtomicBool,
    ) -> Self {
        let (arw, vrw) = match opts.noise {
            Some(n) => (
                n.gyro_arw_deg_rt_h * DEG_PER_RT_H,
                n.accel_vrw_ug_rt_hz * UG_PER_RT_HZ,
            ),
            None => (scan.arw, scan.vrw),
        };
        PassContext {
            source,
            run,
            opts,
            scan,
            arw: arw.max(MIN_ARW),
            vrw: vrw.max(MIN_VRW),
            cancel,
        }
    }
}

/// The attitude at the run's start: coarse alignment from the first
/// dwell's compensated means, then fine alignment over that dwell.
pub(crate) fn align_start(
    ctx: &PassContext,
    comp: &Compensator,
) -> Result<Matrix3<f64>, CalibError> {
    let dt = 1.0 / ctx.run.sample_rate_hz;
    let dwell1 = first_dwell(ctx.scan)?;
    let f_b = comp.accel(&(Vector3::from(dwell1.mean_f_b) * dt), dt) / dt;
    let w_b = comp.gyro(&(Vector3::from(dwell1.mean_omega_b) * dt), dt) / dt;
    let c_coarse = align::coarse(&f_b, &w_b)?;
    let t_align_end = dwell1.t_end;
    let align_records = ctx
        .source
        .records()?
        .map_while(|r| r.ok())
        .take_while(|r| r.t <= t_align_end + 1e-9)
        .map(|r| comp.record(&r, dt));
    align::fine(
        &ctx.run.site,
        &c_coarse,
        align_records,
        &align::FineAlignment {
            t0: ctx.scan.t_begin,
            dt,
            window: ctx.window(),
            arw: ctx.arw,
            vrw: ctx.vrw,
        },
    )
}

/// What a window's end offers the estimator that walks the run.
pub(crate) struct WindowEnd<'a> {
    pub t_start: f64,
    pub t_end: f64,
    /// 0-based window number.
    pub index: usize,
    pub nav: &'a mut Strapdown,
    /// Set when the callback corrected the navigation.
    pub corrected: bool,
}

/// Walks the run once: compensates each record with `comp`, navigates it
/// from `c_b_n0`, feeds the parameter columns of each record to
/// `sens`, propagates `sens` at each window's end and hands the window to
/// `on_window` (which may update and correct).
pub(crate) fn walk(
    ctx: &PassContext,
    comp: &Compensator,
    c_b_n0: &Matrix3<f64>,
    sens: &mut SystematicFilter,
    progress: &mut dyn FnMut(f64),
    mut on_window: impl FnMut(&mut SystematicFilter, &mut WindowEnd) -> Result<(), CalibError>,
) -> Result<(), CalibError> {
    let dt = 1.0 / ctx.run.sample_rate_hz;
    let window = ctx.window();
    let mut nav = Strapdown::new(&ctx.run.site, c_b_n0, ctx.scan.t_begin, dt);
    let mut c_prev = nav.c_b_n();
    let (mut in_window, mut index, mut count) = (0usize, 0usize, 0u64);
    let mut t_ws = ctx.scan.t_begin;
    for r in ctx.source.records()? {
        let r = comp.record(&r?, dt);
        nav.update(&r);
        let c_now = nav.c_b_n();
        // The attitude at mid-record, to first order in the record's turn.
        let c_mid = (c_prev + c_now) * 0.5;
        c_prev = c_now;
        let tau = r.t - 0.5 * dt - t_ws;
        base_columns(
            &c_mid,
            &Vector3::from(r.dtheta),
            &Vector3::from(r.dv),
            dt,
            |i, rows, col| sens.add_column(i, rows, &col, tau),
        );
        in_window += 1;
        count += 1;
        if in_window == window || count == ctx.scan.n_records {
            sens.propagate(r.t - t_ws);
            let mut end = WindowEnd {
                t_start: t_ws,
                t_end: r.t,
                index,
                nav: &mut nav,
                corrected: false,
            };
            on_window(sens, &mut end)?;
            if end.corrected {
                c_prev = nav.c_b_n();
            }
            index += 1;
            in_window = 0;
            t_ws = r.t;
            if index % 64 == 0 {
                if ctx.cancel.load(Ordering::Relaxed) {
                    return Err(CalibError::Cancelled);
                }
                progress(count as f64 / ctx.scan.n_records as f64);
            }
        }
    }
    Ok(())
}
