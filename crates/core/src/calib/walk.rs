//! The run walker every estimator's pass shares: the context of a pass
//! (source, options, scan, noise densities), the start alignment, and one
//! navigated walk over the compensated records that hands each window to
//! the estimator. Every record is taken over its own interval from its
//! stamps, and gaps at rest are bridged (`timed::timed_records`).

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};

use nalgebra::{Matrix3, Vector3};

use super::error::CalibError;
use super::heading::{run_heading, HeadingInputs, RunHeading};
use super::options::EstimateOptions;
use super::prescan::{first_dwell, Prescan};
use super::run::{RecordSource, RunInfo};
use super::temperature::TemperatureCurve;
use super::timed::{timed_records, Timed, TimedRecords};
use crate::estimation::align;
use crate::estimation::effect_columns::{
    effect_column, known_effect_change, EffectParameter, EffectTerms, RecordMotion, NEIGHBOURS,
};
use crate::estimation::filter::{error_dynamics, SystematicFilter};
use crate::estimation::noise_model::NoiseModel;
use crate::estimation::priors::{initial_navigation_covariance, prior_sigma, Priors};
use crate::estimation::sensitivity::base_columns;
use crate::estimation::sensitivity::Rows;
use crate::model::units::{DEG_PER_RT_H, UG_PER_RT_HZ};
use crate::model::{Compensator, ErrorParameters, Grade, N_PARAMS};
use crate::nav::attitude::skew;
use crate::nav::Strapdown;
use crate::record::Record;

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
    /// The sensor noise the filter assumes (SPEC §2, §2a).
    pub noise: NoiseModel,
    /// Its white densities as one value per triad (the RMS over the
    /// axes), rad/√s and m/s/√s: what the estimators that take one density
    /// use (alignment, the cross-check, the discrepancy workflow).
    pub arw: f64,
    pub vrw: f64,
    pub cancel: &'a AtomicBool,
    /// The unit's temperature through the run (SPEC §3a), when the run
    /// has a temperature column: what the thermal states' columns follow.
    pub temperature: Option<TemperatureCurve>,
    /// The unit's grade: given, or named by the run's gyro noise.
    pub grade: Grade,
    /// Where the Earth rate is hidden: the start heading and gyro bias of
    /// the uncompensated run (`heading`), whose σ every pass's start
    /// attitude prior takes.
    pub start_heading: Option<RunHeading>,
}

impl PassContext<'_> {
    /// What the estimator's priors are made of.
    pub fn priors(&self) -> Priors {
        Priors {
            scale: self.opts.prior_scale,
            grade: self.grade,
            start_heading_sigma: self.start_heading.map(|h| h.sigma_rad.min(0.1)),
        }
    }

    /// What the start heading's solution reads.
    pub(crate) fn heading_inputs(&self) -> HeadingInputs<'_> {
        HeadingInputs {
            source: self.source,
            run: self.run,
            scan: self.scan,
            arw: self.arw,
            cancel: self.cancel,
        }
    }

    /// Records per window.
    pub fn window(&self) -> usize {
        ((self.opts.window_s * self.run.sample_rate_hz).round() as usize).max(1)
    }

    /// The systematic filter a pass starts from: the error dynamics at the
    /// run's site, the start covariance and the priors, the noise in use,
    /// and zero-velocity observations of σ `zupt_sigma_mps` (a pass that
    /// only accumulates the parameter columns makes none), and effect
    /// states after the base 24, one state unit of each being
    /// `effect_scale` (SI).
    pub fn filter_with_effects(
        &self,
        zupt_sigma_mps: f64,
        effect_scale: &[f64],
    ) -> SystematicFilter {
        self.filter_with_noise(zupt_sigma_mps, effect_scale, &self.noise)
    }

    /// The same filter with white noise only: for a walk that only
    /// accumulates the parameter columns (the wander states would be
    /// carried for nothing).
    pub fn column_accumulator(&self, effect_scale: &[f64]) -> SystematicFilter {
        let white = NoiseModel::white(self.arw, self.vrw);
        self.filter_with_noise(1.0, effect_scale, &white)
    }

    /// The filter under another noise model, `zupt_sigma_mps` and effect
    /// states scaled by `effect_scale`.
    pub(crate) fn filter_for(
        &self,
        noise: &NoiseModel,
        zupt_sigma_mps: f64,
        effect_scale: &[f64],
    ) -> SystematicFilter {
        self.filter_with_noise(zupt_sigma_mps, effect_scale, noise)
    }

    fn filter_with_noise(
        &self,
        zupt_sigma_mps: f64,
        effect_scale: &[f64],
        noise: &NoiseModel,
    ) -> SystematicFilter {
        let site = &self.run.site;
        let mut scale = prior_sigma(self.priors());
        scale.extend_from_slice(effect_scale);
        SystematicFilter::new(
            error_dynamics(&site.omega_ie_n(), &site.f_rest_n()),
            &initial_navigation_covariance(site, self.priors()),
            &scale,
            noise,
            self.scan.duration_s(),
            zupt_sigma_mps,
        )
    }
}

impl<'a> PassContext<'a> {
    /// The context under other options (the same run, scan and noise).
    pub(crate) fn with_options<'b>(&self, opts: &'b EstimateOptions) -> PassContext<'b>
    where
        'a: 'b,
    {
        PassContext {
            opts,
            temperature: self.temperature.clone(),
            ..*self
        }
    }

    /// The context under another noise model.
    pub(crate) fn with_noise(&self, noise: NoiseModel) -> PassContext<'a> {
        let noise = noise.floored(MIN_ARW, MIN_VRW);
        PassContext {
            noise,
            arw: noise.gyro.white_rms(),
            vrw: noise.accel.white_rms(),
            temperature: self.temperature.clone(),
            ..*self
        }
    }

    /// The passes' context over a scanned run: the noise model from the
    /// options, else as the dwells measured it, its white densities
    /// floored.
    pub fn new(
        source: &'a dyn RecordSource,
        run: &'a RunInfo,
        opts: &'a EstimateOptions,
        scan: &'a Prescan,
        cancel: &'a AtomicBool,
    ) -> Self {
        let noise = match &opts.noise {
            Some(n) => NoiseModel::from_density(n),
            None => NoiseModel::white(scan.arw, scan.vrw),
        }
        .floored(MIN_ARW, MIN_VRW);
        let grade = opts.grade.unwrap_or_else(|| {
            // The first still stretch's rate; a run with none is refused
            // before its grade matters.
            let rate = first_dwell(scan).map_or(0.0, |d| Vector3::from(d.mean_omega_b).norm());
            Grade::of_gyros(scan.arw, rate, run.site.omega_ie_n().norm())
        });
        PassContext {
            grade,
            source,
            run,
            opts,
            scan,
            noise,
            arw: noise.gyro.white_rms(),
            vrw: noise.accel.white_rms(),
            cancel,
            temperature: None,
            start_heading: None,
        }
    }

    /// The context with the start heading found from the whole run, for a
    /// unit whose gyros cannot gyrocompass on one dwell; unchanged for
    /// others.
    pub fn with_run_heading(self) -> Result<Self, CalibError> {
        if !self.grade.earth_rate_hidden() {
            return Ok(self);
        }
        let raw = ErrorParameters::zero().compensator();
        let start_heading = Some(run_heading(&self.heading_inputs(), &raw)?);
        Ok(PassContext {
            start_heading,
            ..self
        })
    }

    /// The context with the run's temperature history.
    pub fn with_temperature(self, temperature: Option<TemperatureCurve>) -> Self {
        PassContext {
            temperature,
            ..self
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
    let c_coarse = if ctx.grade.earth_rate_hidden() {
        run_heading(&ctx.heading_inputs(), comp)?.turn(&align::coarse_level(&f_b)?)
    } else {
        align::coarse(&f_b, &w_b)?
    };
    let t_align_end = dwell1.t_end;
    let align_records = timed_records(ctx.source, ctx.scan, ctx.run.sample_rate_hz)?
        .map_while(|r| r.ok())
        .take_while(|r| r.record.t <= t_align_end + 1e-9)
        .map(|r| (comp.record(&r.record, r.dt), r.dt));
    Ok(align::fine(
        &ctx.run.site,
        &c_coarse,
        align_records,
        &align::FineAlignment {
            t0: ctx.scan.t_begin,
            nominal_dt: dt,
            window: ctx.window(),
            arw: ctx.arw,
            vrw: ctx.vrw,
        },
    )?)
}

/// Where the passes start: no error, or, for a unit whose gyro biases
/// hide the Earth rate (a MEMS gyro's 0.3 deg/s is 70 times it), the gyro
/// biases the whole run implies (`heading`). Left to the first pass, a
/// bias that size turns the unit by degrees in every turn, and the
/// filter's linear error model would take passes to catch up with it.
pub(crate) fn starting_point(ctx: &PassContext) -> Result<ErrorParameters, CalibError> {
    let Some(start) = ctx.start_heading else {
        return Ok(ErrorParameters::zero());
    };
    let (none, zero) = (Matrix3::zeros(), Vector3::zeros());
    Ok(ErrorParameters::from_parts(
        &start.gyro_bias_b,
        &none,
        &zero,
        &none,
        &zero,
    ))
}

/// Takes effects of known size out of a compensated record: each one's
/// body-frame change to the record subtracted.
fn remove_known_effects(r: &mut Record, removed: &[(EffectParameter, f64)], m: &RecordMotion) {
    for &(p, value) in removed {
        let (rows, change) = known_effect_change(p, value, m);
        let target = match rows {
            Rows::Attitude => &mut r.dtheta,
            Rows::Velocity => &mut r.dv,
        };
        for (x, c) in target.iter_mut().zip(change.iter()) {
            *x -= c;
        }
    }
}

/// The compensated records around the one being walked: up to
/// [`NEIGHBOURS`] on each side, the effect columns taking rates of change
/// from both.
struct Around<'a> {
    records: TimedRecords<'a>,
    comp: &'a Compensator,
    held: VecDeque<Timed>,
    /// Index in `held` of the record being walked.
    at: usize,
}

impl<'a> Around<'a> {
    fn new(records: TimedRecords<'a>, comp: &'a Compensator) -> Result<Self, CalibError> {
        let mut around = Around {
            records,
            comp,
            held: VecDeque::with_capacity(2 * NEIGHBOURS + 1),
            at: 0,
        };
        for _ in 0..=NEIGHBOURS {
            around.read_one()?;
        }
        Ok(around)
    }

    /// Reads and compensates the next record of the run, if any.
    #[inline(always)]
    fn read_one(&mut self) -> Result<(), CalibError> {
        if let Some(r) = self.records.next() {
            let r = r?;
            self.held.push_back(Timed {
                record: self.comp.record(&r.record, r.dt),
                ..r
            });
        }
        Ok(())
    }

    /// The record being walked, none past the run's end.
    fn current(&self) -> Option<Timed> {
        self.held.get(self.at).copied()
    }

    /// Moves on by one record, keeping [`NEIGHBOURS`] behind the next.
    /// Inlined, as `base_columns` is: both run for every record of every
    /// pass.
    #[inline(always)]
    fn advance(&mut self) -> Result<(), CalibError> {
        self.read_one()?;
        if self.at == NEIGHBOURS {
            self.held.pop_front();
        } else {
            self.at += 1;
        }
        Ok(())
    }

    /// The motion of the record being walked and its neighbours, for the
    /// effect columns: the neighbours' mean rates over this record's
    /// interval, so the differences are taken on an even grid.
    fn motion(&self, ctx: &PassContext) -> RecordMotion {
        let Timed { record: r, dt, .. } = self.held[self.at];
        let jacobian = self.comp.accel_jacobian(&Vector3::from(r.dv), dt);
        let last = self.held.len() - 1;
        let over_dt = |j: usize, inc: fn(&Record) -> [f64; 3]| {
            let n = self.held[(self.at + j).saturating_sub(NEIGHBOURS).min(last)];
            Vector3::from(inc(&n.record)) * (dt / n.dt)
        };
        let t_mid = r.t - 0.5 * dt;
        let (delta_c, rate_c_per_s) = ctx
            .temperature
            .as_ref()
            .map_or((0.0, 0.0), |c| (c.delta_c(t_mid), c.rate_c_per_s(t_mid)));
        RecordMotion {
            dtheta: std::array::from_fn(|j| over_dt(j, |r| r.dtheta)),
            dv: std::array::from_fn(|j| over_dt(j, |r| r.dv)),
            dt,
            t_mid: t_mid - ctx.scan.t_begin,
            delta_c,
            rate_c_per_s,
            accel_jacobian: jacobian,
            accel_jacobian_inv: jacobian.try_inverse().unwrap_or(jacobian),
            gyro_jacobian_inv: self.comp.gyro_jacobian_inv(),
        }
    }
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
/// `sens` (the base 24, then one per effect state of `effects`, from the
/// record's own motion; the effects of known size removed first),
/// propagates `sens` at each window's end and hands the window to
/// `on_window` (which may update and correct). Each record counts over
/// its own interval; a window is `ctx.window()` records of the run, and
/// the records that bridge a gap add to the window that holds it.
pub(crate) fn walk(
    ctx: &PassContext,
    comp: &Compensator,
    c_b_n0: &Matrix3<f64>,
    sens: &mut SystematicFilter,
    effects: &EffectTerms,
    progress: &mut dyn FnMut(f64),
    mut on_window: impl FnMut(&mut SystematicFilter, &mut WindowEnd) -> Result<(), CalibError>,
) -> Result<(), CalibError> {
    let nominal = 1.0 / ctx.run.sample_rate_hz;
    let window = ctx.window();
    let mut nav = Strapdown::new(&ctx.run.site, c_b_n0, ctx.scan.t_begin, nominal);
    let mut c_prev = nav.c_b_n();
    let (mut in_window, mut index, mut count) = (0usize, 0usize, 0u64);
    let mut t_ws = ctx.scan.t_begin;
    let mut around = Around::new(
        timed_records(ctx.source, ctx.scan, ctx.run.sample_rate_hz)?,
        comp,
    )?;
    while let Some(Timed {
        record: mut r,
        dt,
        extra,
    }) = around.current()
    {
        let motion = (!effects.is_empty()).then(|| around.motion(ctx));
        if let Some(m) = &motion {
            remove_known_effects(&mut r, &effects.removed, m);
        }
        nav.update_over(&r, dt);
        let c_now = nav.c_b_n();
        // The attitude at mid-record: the record's first half-turn applied
        // to its start, to second order (the chord (C₀ + C₁)/2 shrinks
        // by 0.1 % on a 6° record, a hand flip at 20 Hz).
        let half = skew(&(Vector3::from(r.dtheta) * 0.5));
        let c_mid = c_prev * (Matrix3::identity() + half + half * half * 0.5);
        c_prev = c_now;
        let tau = r.t - 0.5 * dt - t_ws;
        sens.add_record(tau, |cols| {
            base_columns(
                &c_mid,
                &Vector3::from(r.dtheta),
                &Vector3::from(r.dv),
                dt,
                |i, rows, col| cols.set(i, rows, &col),
            );
            if let Some(m) = &motion {
                for (j, &p) in effects.states.iter().enumerate() {
                    let (rows, col_b) = effect_column(p, m);
                    cols.set(N_PARAMS + j, rows, &(c_mid * col_b));
                }
            }
        });
        around.advance()?;
        if extra {
            continue;
        }
        in_window += 1;
        count += 1;
        if in_window == window || count == ctx.scan.n_records {
            sens.propagate(r.t - t_ws, &nav.c_b_n());
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
