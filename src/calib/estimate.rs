//! The calibration driver: a pre-scan that finds the dwells and the noise,
//! then passes of alignment and the systematic filter, each pass
//! compensating the data with the estimate of the one before
//! (FIELD-NOTES 2, 4), until the correction is small against its σ.

use std::sync::atomic::{AtomicBool, Ordering};

use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, Vector3};
use serde::{Deserialize, Serialize};

use super::align;
use super::filter::{error_dynamics, Innovation, SystematicFilter};
use super::lsq::lsq_pass;
use super::model_check::{CheckAccumulator, ModelCheck};
use super::result::{
    AlignmentReport, CalibrationResult, Convergence, CrossCheck, CrossCheckEntry, DwellResidual,
    ParameterEstimate,
};
use super::segment::{DetectOptions, RunSegment, SegmentKind, Segmenter, StartActivity};
use super::sensitivity::base_columns;
use super::{CalibError, EstimatorKind, Progress, RecordSource, RunInfo};
use crate::model::params::paper_magnitude;
use crate::model::units::{DEG_PER_RT_H, UG_PER_RT_HZ};
use crate::model::{Compensator, ErrorParameters, N_PARAMS, PARAMETERS};
use crate::nav::attitude::euler_from_dcm;
use crate::nav::Strapdown;

/// Sensor noise densities used as process noise.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NoiseDensity {
    pub gyro_arw_deg_rt_h: f64,
    pub accel_vrw_ug_rt_hz: f64,
}

/// Tunable parts of the estimator. The defaults are what the accuracy
/// tests and benchmarks use.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct EstimateOptions {
    pub estimator: EstimatorKind,
    /// Passes with feedback into the compensation, at most. A unit near
    /// the paper's errors converges in two or three; an uncalibrated one
    /// (20× those errors: 1 % scale factors, a degree of attitude error per
    /// turn) is far off linear at first, each pass removing only 75–90 %
    /// of the error until the fourth, and converges in six.
    pub max_passes: u32,
    /// Stop once every parameter's correction is below this many σ.
    pub converged_sigma: f64,
    /// Propagation window and zero-velocity update interval, s.
    pub window_s: f64,
    /// σ of a zero-velocity observation, m/s: what the unit may really
    /// move at rest (table vibration), not a tuning knob for the noise.
    pub zupt_sigma_mps: f64,
    /// Also observe zero velocity while the unit turns. Right only when the
    /// turntable's axes pass through the unit's reference point (as in
    /// simulation); off by default, so off-centre tables and manual flips
    /// are safe. With it the filter gains the rotations' accelerometer
    /// information.
    pub zupt_in_motion: bool,
    pub detect: DetectOptions,
    /// Noise densities; `None` measures them from the dwells' increments.
    pub noise: Option<NoiseDensity>,
    /// Prior 1-σ of each parameter family as a multiple of the seed
    /// paper's magnitude.
    pub prior_scale: f64,
    /// Run the least-squares cross-check after the filter.
    pub cross_check: bool,
    /// Most points in the convergence history. 500 over a 3 h run is a
    /// point every 23 s, finer than any dwell, and wider than a plot.
    pub history_points: usize,
}

impl Default for EstimateOptions {
    fn default() -> Self {
        EstimateOptions {
            estimator: EstimatorKind::Kf,
            max_passes: 10,
            converged_sigma: 0.05,
            window_s: 1.0,
            zupt_sigma_mps: 1e-6,
            zupt_in_motion: false,
            detect: DetectOptions::default(),
            noise: None,
            prior_scale: 4.0,
            cross_check: true,
            history_points: 500,
        }
    }
}

/// What the pre-scan learns about a run.
#[derive(Clone, Debug)]
pub struct Prescan {
    pub segments: Vec<RunSegment>,
    pub n_records: u64,
    /// Start of the first record's interval.
    pub t_begin: f64,
    pub t_end: f64,
    /// Measured noise, rad/√s and m/s/√s.
    pub arw: f64,
    pub vrw: f64,
    /// The run's first seconds, summarised.
    pub start: StartActivity,
}

impl Prescan {
    pub fn dwells(&self) -> impl Iterator<Item = &RunSegment> {
        self.segments
            .iter()
            .filter(|s| s.kind == SegmentKind::Dwell)
    }
}

/// Lowest noise densities used, so that a noise-free run still gives a
/// well-posed filter: 1e-5 deg/√h and 0.1 µg/√Hz (thirty and fifty times
/// below the quietest navigation-grade units).
const MIN_ARW: f64 = 1e-5 * DEG_PER_RT_H;
const MIN_VRW: f64 = 0.1 * UG_PER_RT_HZ;

/// One streaming read: the segmentation, and the noise from the still
/// blocks the segmentation found (one still decision for both).
pub fn prescan(
    source: &dyn RecordSource,
    run: &RunInfo,
    detect: &DetectOptions,
    cancel: &AtomicBool,
) -> Result<Prescan, CalibError> {
    let dt = 1.0 / run.sample_rate_hz;
    let mut seg = Segmenter::new(*detect, run.sample_rate_hz, run.site.gravity());
    let (mut n, mut t_begin, mut t_end) = (0u64, f64::NAN, f64::NAN);
    for r in source.records()? {
        let r = r?;
        if n == 0 {
            t_begin = r.t - dt;
        }
        t_end = r.t;
        n += 1;
        if n % 65_536 == 0 && cancel.load(Ordering::Relaxed) {
            return Err(CalibError::Cancelled);
        }
        seg.push(&r);
    }
    if n == 0 {
        return Err(CalibError::Unusable("the run holds no records".into()));
    }
    let found = seg.finish();
    Ok(Prescan {
        segments: found.segments,
        n_records: n,
        t_begin,
        t_end,
        arw: found.noise.arw,
        vrw: found.noise.vrw,
        start: found.start,
    })
}

/// Sums over one dwell's zero-velocity innovations, from which the
/// post-fit residual ȳ − M p̂ follows for the final estimate p̂ without
/// storing the innovations: Σ(y_i − m_i·p)² = Σy_i² − 2 p·Σy_i m_i + pᵀ(Σ m_i m_iᵀ)p.
struct DwellAccumulator {
    n: usize,
    sum_y: Vector3<f64>,
    sum_y2: Vector3<f64>,
    sum_m: DMatrix<f64>,
    sum_ym: DMatrix<f64>,
    sum_mm: [DMatrix<f64>; 3],
}

impl DwellAccumulator {
    fn new(n_p: usize) -> Self {
        DwellAccumulator {
            n: 0,
            sum_y: Vector3::zeros(),
            sum_y2: Vector3::zeros(),
            sum_m: DMatrix::zeros(3, n_p),
            sum_ym: DMatrix::zeros(3, n_p),
            sum_mm: std::array::from_fn(|_| DMatrix::zeros(n_p, n_p)),
        }
    }

    fn add(&mut self, innov: &Innovation) {
        let y = innov.y_bar;
        self.n += 1;
        self.sum_y += y;
        self.sum_y2 += y.component_mul(&y);
        self.sum_m += &innov.m;
        for i in 0..3 {
            let col = innov.m.row(i).transpose();
            for k in 0..col.len() {
                self.sum_ym[(i, k)] += y[i] * col[k];
            }
            self.sum_mm[i].ger(1.0, &col, &col, 1.0);
        }
    }

    /// RMS and mean of the post-fit innovations per axis.
    fn post_fit(&self, p: &DVector<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let n = self.n.max(1) as f64;
        let mp = &self.sum_m * p;
        let mut rms = Vector3::zeros();
        let mut mean = Vector3::zeros();
        for i in 0..3 {
            let cross = self.sum_ym.row(i).dot(&p.transpose());
            let quad = (p.transpose() * &self.sum_mm[i] * p)[(0, 0)];
            rms[i] = ((self.sum_y2[i] - 2.0 * cross + quad) / n).max(0.0).sqrt();
            mean[i] = (self.sum_y[i] - mp[i]) / n;
        }
        (rms, mean)
    }
}

/// The result of one filter pass.
struct Pass {
    /// Residual parameter estimate, SI.
    delta: Vec<f64>,
    sigma: Vec<f64>,
    c_b_n0: Matrix3<f64>,
    history: Convergence,
    dwell_residuals: Vec<DwellResidual>,
    /// Whether the model explains the pass's zero-velocity residuals.
    model_check: Option<ModelCheck>,
}

/// Prior 1-σ of the 24 parameters, SI.
pub fn prior_sigma(scale: f64) -> Vec<f64> {
    PARAMETERS
        .iter()
        .map(|p| scale * paper_magnitude(p.group))
        .collect()
}

/// Index of the dwell holding time t, if any.
pub(crate) fn dwell_at(segments: &[RunSegment], t: f64) -> Option<usize> {
    let i = segments.partition_point(|s| s.t_end < t);
    segments
        .get(i)
        .filter(|s| s.kind == SegmentKind::Dwell && s.t_start <= t && t <= s.t_end)
        .map(|_| i)
}

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
}

pub(crate) fn first_dwell(scan: &Prescan) -> Result<&RunSegment, CalibError> {
    let first = scan
        .segments
        .first()
        .ok_or_else(|| CalibError::Unusable("no segments".into()))?;
    if first.kind == SegmentKind::Dwell {
        return Ok(first);
    }
    let s = &scan.start;
    let later = match scan.dwells().next() {
        Some(d) => format!(
            "the first still stretch long enough to align on runs from t = {:.2} s to {:.2} s",
            d.t_start, d.t_end
        ),
        None => "no still stretch long enough to align on was found anywhere".into(),
    };
    Err(CalibError::Unusable(format!(
        "the run must begin at rest: over its first {:.1} s ({:.2} s blocks) the angular rate \
         is {:.3} deg/s (spread {:.3}) and |f| is {:.4} m/s² (spread {:.4}); {later}",
        s.span_s,
        s.block_s,
        s.rate_mean_dps,
        s.rate_spread_dps,
        s.force_mean_mps2,
        s.force_spread_mps2,
    )))
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

/// One pass of alignment and the filter over the records compensated with
/// `params`.
fn kf_pass(
    ctx: &PassContext,
    params: &ErrorParameters,
    progress: &mut dyn FnMut(f64),
) -> Result<Pass, CalibError> {
    let site = &ctx.run.site;
    let comp = params.compensator();
    let c_b_n0 = align_start(ctx, &comp)?;

    let prior = prior_sigma(ctx.opts.prior_scale);
    let mut kf = SystematicFilter::new(
        error_dynamics(&site.omega_ie_n(), &site.f_rest_n()),
        &initial_navigation_covariance(ctx),
        &prior,
        ctx.arw,
        ctx.vrw,
        ctx.opts.zupt_sigma_mps,
    );

    let n_windows = (ctx.scan.n_records as usize).div_ceil(ctx.window()).max(1);
    // One slot kept for the last window, so the history never exceeds
    // `history_points`.
    let every = n_windows
        .div_ceil(ctx.opts.history_points.saturating_sub(1).max(1))
        .max(1);
    let mut history = Convergence {
        names: PARAMETERS.iter().map(|p| p.name.to_string()).collect(),
        ..Default::default()
    };
    let mut dwell_acc: Vec<DwellAccumulator> = (0..ctx.scan.segments.len())
        .map(|_| DwellAccumulator::new(N_PARAMS))
        .collect();
    let mut check = CheckAccumulator::new(&ctx.scan.segments, N_PARAMS);

    walk(ctx, &comp, &c_b_n0, &mut kf, progress, |kf, w| {
        let d0 = dwell_at(&ctx.scan.segments, w.t_start);
        let dwell = d0.filter(|_| d0 == dwell_at(&ctx.scan.segments, w.t_end));
        if dwell.is_some() || ctx.opts.zupt_in_motion {
            let innov = kf.update_zero_velocity(&w.nav.v_n)?;
            if let Some(d) = dwell {
                dwell_acc[d].add(&innov);
                check.add(d, 0.5 * (w.t_start + w.t_end), &innov)?;
            }
            let (phi, dv) = kf.take_navigation_errors();
            w.nav.correct(&phi, &dv, &Vector3::zeros());
            w.corrected = true;
        }
        if w.index % every == 0 || w.index + 1 == n_windows {
            let (d, s) = kf.parameters()?;
            history.t.push(w.t_end);
            history.value.push(
                (0..N_PARAMS)
                    .map(|i| ((params.si[i] + d[i]) / PARAMETERS[i].si_per_unit) as f32)
                    .collect(),
            );
            history.sigma.push(
                (0..N_PARAMS)
                    .map(|i| (s[i] / PARAMETERS[i].si_per_unit) as f32)
                    .collect(),
            );
        }
        Ok(())
    })?;

    let (delta, sigma) = kf.parameters()?;
    if sigma.iter().any(|s| !s.is_finite()) || delta.iter().any(|d| !d.is_finite()) {
        return Err(CalibError::Numerical("the filter diverged".into()));
    }
    let p_hat = kf.scaled_estimate()?;
    let mut dwell_residuals = Vec::new();
    for (i, seg) in ctx.scan.segments.iter().enumerate() {
        if seg.kind == SegmentKind::Dwell {
            let (rms, mean) = dwell_acc[i].post_fit(&p_hat);
            dwell_residuals.push(DwellResidual {
                dwell: dwell_residuals.len() + 1,
                t_start: seg.t_start,
                t_end: seg.t_end,
                rms_mps: rms.into(),
                drift_mps2: (mean / ctx.opts.window_s).into(),
            });
        }
    }
    let model_check = Some(check.finish(&p_hat, &dwell_residuals));
    Ok(Pass {
        delta,
        sigma,
        c_b_n0,
        history,
        dwell_residuals,
        model_check,
    })
}

/// Covariance of the navigation errors at the run's start. The attitude
/// left after alignment is what the residual biases imply (tilt ≈ δb_a/g,
/// heading ≈ δb_g,E/ω_ie,N); the bounds are three priors wide, so the
/// prior adds no information the run must supply. The unit starts at rest.
pub(crate) fn initial_navigation_covariance(ctx: &PassContext) -> Matrix6<f64> {
    let site = &ctx.run.site;
    let prior = prior_sigma(ctx.opts.prior_scale);
    let tilt = 3.0 * prior[9] / site.gravity();
    let heading = (3.0 * prior[0] / site.omega_ie_n().y).min(0.1);
    let mut p0 = Matrix6::zeros();
    for (i, s) in [tilt, tilt, heading, 1e-4, 1e-4, 1e-4].iter().enumerate() {
        p0[(i, i)] = s * s;
    }
    p0
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

/// The scan every calibration starts from, after checking the rate.
pub(crate) fn scan_run(
    source: &dyn RecordSource,
    run: &RunInfo,
    opts: &EstimateOptions,
    cancel: &AtomicBool,
) -> Result<Prescan, CalibError> {
    if !(run.sample_rate_hz.is_finite() && run.sample_rate_hz > 0.0) {
        return Err(CalibError::Unusable(format!(
            "sample rate {} Hz",
            run.sample_rate_hz
        )));
    }
    prescan(source, run, &opts.detect, cancel)
}

/// Calibrates a run: the one entry point the CLI and the server call.
pub fn estimate(
    source: &dyn RecordSource,
    run: &RunInfo,
    opts: &EstimateOptions,
    progress: &mut dyn FnMut(Progress),
    cancel: &AtomicBool,
) -> Result<CalibrationResult, CalibError> {
    progress(Progress {
        fraction: 0.0,
        stage: "scanning the run".into(),
    });
    let scan = scan_run(source, run, opts, cancel)?;
    estimate_scanned(
        &PassContext::new(source, run, opts, &scan, cancel),
        progress,
    )
}

/// Calibrates a run already scanned (the discrepancy workflow keeps the
/// scan for its own passes).
pub(crate) fn estimate_scanned(
    ctx: &PassContext,
    progress: &mut dyn FnMut(Progress),
) -> Result<CalibrationResult, CalibError> {
    let (opts, scan) = (ctx.opts, ctx.scan);
    first_dwell(scan)?;
    // One attitude observes the gravity and Earth-rate projections on one
    // set of axes only: the filter would converge to the prior and report
    // it as a calibration.
    let dwells = scan.dwells().count();
    if dwells < 2 {
        return Err(CalibError::Unusable(format!(
            "the run holds {dwells} dwell: a calibration needs the unit at rest in at least two attitudes, with a turn between them"
        )));
    }
    let mut params = ErrorParameters::zero();
    let max_passes = opts.max_passes.max(1);
    let mut last: Option<Pass> = None;
    let mut passes = 0;
    // Largest correction of the last pass against its σ: the estimate is
    // the linearisation point's only once this is small.
    let mut last_worst = f64::INFINITY;
    // The cross-check is one more pass; reserve its share of the progress.
    let share = if opts.cross_check { 0.8 } else { 0.9 };
    for pass in 1..=max_passes {
        passes = pass;
        let base = 0.05 + share * (pass - 1) as f64 / max_passes as f64;
        let span = share / max_passes as f64;
        let stage = format!(
            "{} pass {pass} of at most {max_passes}",
            opts.estimator.name()
        );
        let mut report = |f: f64| {
            progress(Progress {
                fraction: base + span * f,
                stage: stage.clone(),
            })
        };
        let p = match opts.estimator {
            EstimatorKind::Kf => kf_pass(ctx, &params, &mut report)?,
            EstimatorKind::Lsq => lsq_as_pass(ctx, &params, &mut report)?,
        };
        let mut delta = ErrorParameters::zero();
        delta.si.copy_from_slice(&p.delta);
        params = params.compose(&delta);
        let worst = p
            .delta
            .iter()
            .zip(p.sigma.iter())
            .map(|(d, s)| d.abs() / s)
            .fold(0.0, f64::max);
        last = Some(p);
        last_worst = worst;
        if pass >= 2 && worst < opts.converged_sigma {
            break;
        }
    }
    let mut last = last.ok_or_else(|| CalibError::Numerical("no pass ran".into()))?;
    let unsettled = (max_passes >= 2 && last_worst >= opts.converged_sigma).then(|| {
        format!(
            "the estimate had not settled after {passes} passes: the last one still moved a \
             parameter by {last_worst:.2}σ (more than {}σ)",
            opts.converged_sigma
        )
    });

    let cross_check = if opts.cross_check {
        let stage = "cross-check".to_string();
        let mut report = |f: f64| {
            progress(Progress {
                fraction: 0.85 + 0.1 * f,
                stage: stage.clone(),
            })
        };
        // The other estimator, linearised at this one's answer.
        let other = match opts.estimator {
            EstimatorKind::Kf => lsq_as_pass(ctx, &params, &mut report)?,
            EstimatorKind::Lsq => kf_pass(ctx, &params, &mut report)?,
        };
        let (kf_sigma, lsq_sigma) = match opts.estimator {
            EstimatorKind::Kf => (&last.sigma, &other.sigma),
            EstimatorKind::Lsq => (&other.sigma, &last.sigma),
        };
        let mut d = ErrorParameters::zero();
        d.si.copy_from_slice(&other.delta);
        let other_params = params.compose(&d);
        let (kf_p, lsq_p) = match opts.estimator {
            EstimatorKind::Kf => (&params, &other_params),
            EstimatorKind::Lsq => (&other_params, &params),
        };
        let check = cross_check_report(kf_p, kf_sigma, lsq_p, lsq_sigma);
        if opts.estimator == EstimatorKind::Lsq {
            last.dwell_residuals = other.dwell_residuals;
            last.history = other.history;
            last.model_check = other.model_check;
        }
        Some(check)
    } else {
        None
    };
    // The least squares alone makes no zero-velocity innovations: one
    // filter pass at its answer gives the model check every result carries.
    if last.model_check.is_none() {
        let mut report = |_: f64| {};
        last.model_check = kf_pass(ctx, &params, &mut report)?.model_check;
    }
    progress(Progress {
        fraction: 0.95,
        stage: "reporting".into(),
    });

    let prior = prior_sigma(opts.prior_scale);
    let mut warnings: Vec<String> = unsettled.into_iter().collect();
    let mut parameters = std::collections::BTreeMap::new();
    for (i, info) in PARAMETERS.iter().enumerate() {
        let sigma = last.sigma[i];
        if sigma > 0.5 * prior[i] {
            warnings.push(format!(
                "{} is poorly observable on this run's scheme: its σ is {:.0}% of the prior",
                info.name,
                100.0 * sigma / prior[i]
            ));
        }
        parameters.insert(
            info.name.to_string(),
            ParameterEstimate {
                value: params.canonical(i),
                sigma: sigma / info.si_per_unit,
                unit: info.unit.to_string(),
            },
        );
    }
    if let Some(check) = &cross_check {
        for name in &check.flagged {
            warnings.push(format!(
                "{name}: the filter and the least-squares cross-check differ by more than 3 combined σ"
            ));
        }
    }
    let n_dwells = scan.dwells().count();
    if n_dwells < 10 {
        warnings.push(format!(
            "only {n_dwells} dwells found; the base model needs a multi-position scheme"
        ));
    }
    let (roll, pitch, heading) = euler_from_dcm(&last.c_b_n0);
    let dwell1 = first_dwell(scan)?;
    progress(Progress {
        fraction: 1.0,
        stage: "done".into(),
    });
    Ok(CalibrationResult {
        estimator: opts.estimator.name().into(),
        model: "base-24".into(),
        parameters,
        effects: Default::default(),
        warnings,
        passes,
        records: scan.n_records,
        duration_s: scan.t_end - scan.t_begin,
        alignment: AlignmentReport {
            roll_deg: roll.to_degrees(),
            pitch_deg: pitch.to_degrees(),
            heading_deg: heading.to_degrees(),
            duration_s: dwell1.t_end - dwell1.t_start,
        },
        noise_arw_deg_rt_h: ctx.arw / DEG_PER_RT_H,
        noise_vrw_ug_rt_hz: ctx.vrw / UG_PER_RT_HZ,
        segments: scan.segments.clone(),
        dwell_residuals: last.dwell_residuals,
        convergence: last.history,
        cross_check,
        model_check: last.model_check,
    })
}

/// A least-squares solution in the form of a filter pass.
fn lsq_as_pass(
    ctx: &PassContext,
    params: &ErrorParameters,
    progress: &mut dyn FnMut(f64),
) -> Result<Pass, CalibError> {
    let sol = lsq_pass(ctx, params, progress)?;
    Ok(Pass {
        delta: sol.delta,
        sigma: sol.sigma,
        c_b_n0: sol.c_b_n0,
        history: Convergence::default(),
        dwell_residuals: Vec::new(),
        model_check: None,
    })
}

/// Compares the two estimators parameter by parameter.
fn cross_check_report(
    kf: &ErrorParameters,
    kf_sigma: &[f64],
    lsq: &ErrorParameters,
    lsq_sigma: &[f64],
) -> CrossCheck {
    let mut entries = Vec::with_capacity(N_PARAMS);
    let mut flagged = Vec::new();
    for (i, info) in PARAMETERS.iter().enumerate() {
        let combined = (kf_sigma[i].powi(2) + lsq_sigma[i].powi(2)).sqrt();
        let nd = (kf.si[i] - lsq.si[i]).abs() / combined;
        let flag = nd > 3.0;
        if flag {
            flagged.push(info.name.to_string());
        }
        entries.push(CrossCheckEntry {
            name: info.name.to_string(),
            kf: kf.canonical(i),
            lsq: lsq.canonical(i),
            lsq_sigma: lsq_sigma[i] / info.si_per_unit,
            normalized_difference: nd,
            flagged: flag,
        });
    }
    CrossCheck {
        method: "velocity-error-rate least squares over dwell stretches and rotation steps".into(),
        entries,
        flagged,
    }
}
