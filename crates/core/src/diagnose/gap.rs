//! Gap space: the least-squares framework of `calib::lsq`, widened to
//! carry effect parameters and to report its residuals.
//!
//! The measured run is compensated with the calibration and navigated
//! open loop. At rest its velocity is zero, so the navigated velocity at
//! nodes in the dwells is the gap itself: what the calibrated model has
//! not explained. Nodes are placed in every dwell (a few per dwell, as in
//! `calib::lsq`); over each stretch between nodes (a piece of a dwell, or
//! a rotation step)
//!
//!   r_k = x_{k+1} − A_k x_k − B_k δp − E_k θ,   x = [φ; δv],
//!
//! with B_k the base parameters' columns and E_k the effect parameters'
//! columns, both accumulated record by record along the motion the run
//! measured (`calib::sensitivity`, `estimation::effect_columns`): each
//! effect's signature is that effect applied to what actually happened,
//! through the same compensation and navigation, so hand flips, wobbling
//! axes and a reference point that moves between dwells need no model of
//! the scheme. The attitude errors φ_k at the nodes are unknowns, the
//! attitude random walk the process noise; the weighted residual cost
//! Σ r_kᵀ Q_k⁻¹ r_k is the likelihood of model selection, and its
//! expectation under noise alone (from the residual covariance
//! Q_k − L_k N⁻¹ L_kᵀ) the noise floor.

use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, Vector3, Vector6};

use super::candidates::Candidate;
use super::error::DiagnoseError;
use super::gap_wander::WanderPrior;
use crate::calib::nodes::{walk_nodes, Stretch};
use crate::calib::walk::PassContext;
use crate::calib::CalibError;
use crate::estimation::effect_columns::{EffectParameter, EffectTerms};
use crate::estimation::filter::{error_dynamics, transition, NAV};
use crate::estimation::normal::NormalEquations;
use crate::estimation::priors::{prior_sigma, start_attitude_information, white_noise_density};
use crate::model::{bias_parameter, ErrorParameters, N_PARAMS};

/// Prior σ of a scaled effect parameter: a hundred signature sizes, so
/// the prior only keeps an unobservable combination finite.
const EFFECT_PRIOR: f64 = 100.0;

/// The measured run at its nodes.
#[derive(Clone, Debug)]
pub struct Nodes {
    /// Node times (absolute, as in the data), s.
    pub t: Vec<f64>,
    /// Record number (1-based; 0 is the start) of each node.
    pub record: Vec<u64>,
    /// Open-loop measured velocity, m/s.
    pub v: Vec<Vector3<f64>>,
    /// Base columns of the stretch ending at each node (6 × 24, scaled by
    /// the prior σ); zero for the first node.
    pub b: Vec<DMatrix<f64>>,
    /// Effect columns of the stretch ending at each node (6 × effect
    /// parameters, per signature size); zero for the first node.
    pub e: Vec<DMatrix<f64>>,
    /// Segment index (dwell) of each node.
    pub segment: Vec<usize>,
    /// 1 Hz open-loop measured velocity: (record number, v).
    pub series: Vec<(u64, Vector3<f64>)>,
    /// At each 1 Hz sample, the open-loop velocity each effect parameter
    /// makes per signature size (3 × effect parameters).
    pub series_e: Vec<DMatrix<f64>>,
    /// The navigated attitude at the run's end.
    pub c_b_n_end: Matrix3<f64>,
}

/// Walks the measured run once, compensated with `params` and with the
/// effects `removed` (SI values) taken out, from `c_b_n0`, accumulating
/// the columns of the effect parameters `effects` (each with the SI size
/// of its unit) beside the base ones.
pub(crate) fn measured_nodes(
    ctx: &PassContext,
    params: &ErrorParameters,
    c_b_n0: &Matrix3<f64>,
    effects: &[(EffectParameter, f64)],
    removed: &[(EffectParameter, f64)],
    progress: &mut dyn FnMut(f64),
) -> Result<Nodes, CalibError> {
    let comp = params.compensator();
    let dt = 1.0 / ctx.run.sample_rate_hz;
    let rec_no = |t: f64| ((t - ctx.scan.t_begin) / dt).round() as u64;
    let window_s = ctx.window() as f64 * dt;
    let n_e = effects.len();
    let (states, scale): (Vec<_>, Vec<f64>) = effects.iter().copied().unzip();
    let terms = EffectTerms {
        states,
        scale,
        removed: removed.to_vec(),
    };
    let site = &ctx.run.site;
    let f = error_dynamics(&site.omega_ie_n(), &site.f_rest_n());
    let mut nodes = Nodes {
        t: vec![ctx.scan.t_begin],
        record: vec![0],
        v: vec![Vector3::zeros()],
        b: vec![DMatrix::zeros(NAV, N_PARAMS)],
        e: vec![DMatrix::zeros(NAV, n_e)],
        segment: vec![0],
        series: vec![(0, Vector3::zeros())],
        series_e: vec![DMatrix::zeros(3, n_e)],
        c_b_n_end: *c_b_n0,
    };
    // The effects' open-loop navigation error at the last node.
    let mut at_node = DMatrix::<f64>::zeros(NAV, n_e);
    let mut t_node = ctx.scan.t_begin;
    walk_nodes(
        ctx,
        &comp,
        c_b_n0,
        window_s,
        &terms,
        progress,
        |w, since_node, node| {
            let e_since = since_node.columns(N_PARAMS, n_e);
            let a = transition(&f, w.t_end - t_node);
            let a = DMatrix::from_column_slice(NAV, NAV, a.as_slice());
            let now = &a * &at_node + e_since;
            nodes.series.push((rec_no(w.t_end), w.nav.v_n));
            nodes.series_e.push(now.rows(3, 3).into_owned());
            nodes.c_b_n_end = w.nav.c_b_n();
            if let Some(d) = node {
                nodes.t.push(w.t_end);
                nodes.record.push(rec_no(w.t_end));
                nodes.v.push(w.nav.v_n);
                nodes.b.push(since_node.columns(0, N_PARAMS).into_owned());
                nodes.e.push(e_since.into_owned());
                nodes.segment.push(d);
                at_node = now;
                t_node = w.t_end;
            }
        },
    )?;
    if nodes.t.len() < 3 {
        return Err(CalibError::Unusable("too few dwells for the gap".into()));
    }
    Ok(nodes)
}

/// Where the delay's columns sit in the stretches' effect columns.
#[derive(Clone, Copy, Debug)]
pub struct DelayColumns {
    pub first_order: usize,
    pub second_order: usize,
}

/// Gauss–Newton steps about the delay's estimate: the second-order term
/// is 1 % of the signature, so each step gains two digits.
const DELAY_RELINEARISATIONS: usize = 2;

/// The effect states the gap carries, each with the SI size of its unit:
/// every library parameter at its signature size (library order), then
/// the delay's second-order term (per squared signature size).
pub(crate) struct GapColumns {
    pub states: Vec<(EffectParameter, f64)>,
    pub delay: Option<DelayColumns>,
}

impl GapColumns {
    /// Of the library's `candidates`, in order.
    pub fn of(candidates: &[Candidate]) -> Self {
        let mut states: Vec<(EffectParameter, f64)> = candidates
            .iter()
            .flat_map(|c| c.params.iter())
            .map(|p| (p.state, p.signature_si()))
            .collect();
        let delay = states
            .iter()
            .position(|(s, _)| *s == EffectParameter::AccelDelay)
            .map(|first_order| {
                let size = states[first_order].1;
                states.push((EffectParameter::AccelDelaySquared, size * size));
                DelayColumns {
                    first_order,
                    second_order: states.len() - 1,
                }
            });
        GapColumns { states, delay }
    }
}

/// One stretch between nodes, ready for the normal equations: the error
/// model over it (whose d is the gap's part) and the parameter columns.
struct GapStretch {
    model: Stretch,
    /// −B (6 × 24).
    b: DMatrix<f64>,
    /// −E for every effect parameter (6 × n_effect_params).
    e: DMatrix<f64>,
}

/// The gap problem: every stretch, fit with any subset of effect columns.
pub struct GapProblem {
    stretches: Vec<GapStretch>,
    /// The delay's column and its second-order column (per squared
    /// signature size), when the library has a delay: a fit carrying the
    /// delay relinearises about its estimate.
    delay: Option<DelayColumns>,
    p0_phi_inv: Matrix3<f64>,
    n_nodes: usize,
    /// Each stretch's mean of each wandering bias, when a bias wanders.
    wander: Option<WanderPrior>,
}

/// A fit of the gap with the base parameters and some effect parameters.
#[derive(Clone, Debug)]
pub struct GapFit {
    /// Effect parameter indices fitted (library order).
    pub effects: Vec<usize>,
    /// Base corrections (scaled by the prior σ) and their σ (scaled).
    pub base: Vec<f64>,
    pub base_sigma: Vec<f64>,
    /// Effect parameters in signature sizes, and σ.
    pub theta: Vec<f64>,
    pub theta_sigma: Vec<f64>,
    /// Correlation matrix of the fitted effect parameters.
    pub theta_corr: DMatrix<f64>,
    /// Their covariance (signature sizes²), the base parameters, the
    /// other effects and the attitudes profiled out.
    pub theta_cov: DMatrix<f64>,
    /// Weighted residual cost of the data (χ²), and with the priors.
    pub chi2: f64,
    pub objective: f64,
    /// Its expectation under noise alone.
    pub dof: f64,
    /// Residual per stretch (φ; δv) and its covariance under noise alone.
    pub residual: Vec<Vector6<f64>>,
    pub residual_cov: Vec<Matrix6<f64>>,
    /// Each stretch's share of `chi2` (r_kᵀ Q_k⁻¹ r_k) and of `dof`
    /// (its expectation): they sum to the totals, so a segment's χ² is
    /// measured in the same weight as the run's.
    pub stretch_chi2: Vec<f64>,
    pub stretch_dof: Vec<f64>,
}

impl GapFit {
    /// Number of velocity observations.
    pub fn n_obs(&self) -> usize {
        3 * self.residual.len()
    }

    /// RMS of the velocity residuals, m/s.
    pub fn gap_rms(&self) -> f64 {
        let s: f64 = self
            .residual
            .iter()
            .map(|r| r.fixed_rows::<3>(3).norm_squared())
            .sum();
        (s / self.n_obs() as f64).sqrt()
    }

    /// The RMS the velocity residuals have under noise alone, m/s.
    pub fn noise_floor_rms(&self) -> f64 {
        let s: f64 = self
            .residual_cov
            .iter()
            .map(|c| c.fixed_view::<3, 3>(3, 3).trace())
            .sum();
        (s / self.n_obs() as f64).sqrt()
    }

    /// (χ² − dof)/√(2 dof): the gap against the noise, in σ of χ².
    pub fn z(&self) -> f64 {
        (self.chi2 - self.dof) / (2.0 * self.dof).sqrt()
    }
}

impl GapProblem {
    /// The problem over `nodes`, whose effect columns hold the library's
    /// and, where `delay` says, the delay's second-order column.
    pub(crate) fn new(
        ctx: &PassContext,
        nodes: &Nodes,
        delay: Option<DelayColumns>,
    ) -> Result<Self, DiagnoseError> {
        let site = &ctx.run.site;
        let f = error_dynamics(&site.omega_ie_n(), &site.f_rest_n());
        let p0_phi_inv = start_attitude_information(site, ctx.priors())
            .ok_or_else(|| DiagnoseError::Numerical("singular attitude prior".into()))?;
        let qc = white_noise_density(ctx.arw, ctx.vrw);
        let k_nodes = nodes.t.len();
        let t0 = ctx.scan.t_begin;
        let windows: Vec<(f64, f64)> = nodes.t.windows(2).map(|w| (w[0] - t0, w[1] - t0)).collect();
        let wander = WanderPrior::new(
            &ctx.noise,
            &windows,
            ctx.scan.duration_s(),
            &prior_sigma(ctx.priors()),
        );
        // The gap holds the same model of the run as the calibration it
        // starts from: a hand motion's velocity forgotten below
        // navigation grade (`Stretch::observed`).
        let mut stretches = Vec::with_capacity(k_nodes - 1);
        for k in 0..k_nodes - 1 {
            let t = nodes.t[k + 1] - nodes.t[k];
            let crosses_motion = nodes.segment[k] != nodes.segment[k + 1];
            let model = Stretch::new(&f, &qc, t, &nodes.v[k], &nodes.v[k + 1])
                .and_then(|s| s.observed(ctx.grade, crosses_motion))
                .ok_or_else(|| DiagnoseError::Numerical("singular process noise".into()))?;
            stretches.push(GapStretch {
                model,
                b: -&nodes.b[k + 1],
                e: -&nodes.e[k + 1],
            });
        }
        Ok(GapProblem {
            stretches,
            delay,
            p0_phi_inv,
            n_nodes: k_nodes,
            wander,
        })
    }

    /// Fits the base parameters, the effect parameters `effects` (library
    /// indices) and the attitude at every node. A fit carrying the delay
    /// is relinearised about its estimate θ̂: on the measured records the
    /// delay contributes θ E₁ − θ² E₂ (`EffectParameter::AccelDelaySquared`),
    /// which near θ̂ is θ (E₁ − 2θ̂ E₂) + θ̂² E₂.
    pub fn fit(&self, effects: &[usize]) -> Result<GapFit, DiagnoseError> {
        let mut fit = self.fit_about(effects, 0.0)?;
        let delay = self.delay.and_then(|d| {
            let pos = effects.iter().position(|&j| j == d.first_order)?;
            Some(pos)
        });
        if let Some(pos) = delay {
            for _ in 0..DELAY_RELINEARISATIONS {
                fit = self.fit_about(effects, fit.theta[pos])?;
            }
        }
        Ok(fit)
    }

    /// The stretch's column of effect `j`, and its data, with the delay's
    /// linearised about `delay_at` (signature sizes).
    fn linearised(&self, s: &GapStretch, j: usize, delay_at: f64) -> DVector<f64> {
        match self.delay {
            Some(d) if j == d.first_order && delay_at != 0.0 => {
                s.e.column(j) - s.e.column(d.second_order) * (2.0 * delay_at)
            }
            _ => s.e.column(j).into_owned(),
        }
    }

    fn data(&self, s: &GapStretch, effects: &[usize], delay_at: f64) -> DVector<f64> {
        match self.delay {
            Some(d) if delay_at != 0.0 && effects.contains(&d.first_order) => {
                // s.e holds −E: the known part θ̂² E₂ moves into the data.
                &s.model.d + s.e.column(d.second_order) * (delay_at * delay_at)
            }
            _ => s.model.d.clone(),
        }
    }

    fn fit_about(&self, effects: &[usize], delay_at: f64) -> Result<GapFit, DiagnoseError> {
        let n_p = N_PARAMS;
        let n_e = effects.len();
        let phi = |k: usize| n_p + n_e + 3 * k;
        let n_w = self.wander.as_ref().map_or(0, WanderPrior::per_stretch);
        let wander_at = phi(self.n_nodes);
        let wander = |k: usize| wander_at + n_w * k;
        let n = wander(self.stretches.len());
        let mut normal = NormalEquations::new(n);
        normal.add_diagonal(0..n_p, 1.0);
        normal.add_diagonal(n_p..n_p + n_e, 1.0 / (EFFECT_PRIOR * EFFECT_PRIOR));
        normal.add_block3(phi(0), &self.p0_phi_inv);
        if let Some(w) = &self.wander {
            for (a, info) in w.information.iter().enumerate() {
                let idx: Vec<usize> = (0..self.stretches.len()).map(|k| wander(k) + a).collect();
                normal.add_information(&idx, info);
            }
        }
        let local = |k: usize| -> Vec<usize> {
            (0..n_p + n_e)
                .chain(phi(k)..phi(k) + 6)
                .chain(wander(k)..wander(k) + n_w)
                .collect::<Vec<_>>()
        };
        let design = |s: &GapStretch| -> DMatrix<f64> {
            let mut l = DMatrix::<f64>::zeros(6, n_p + n_e + 6 + n_w);
            l.view_mut((0, 0), (6, n_p)).copy_from(&s.b);
            for (c, &j) in effects.iter().enumerate() {
                l.view_mut((0, n_p + c), (6, 1))
                    .copy_from(&self.linearised(s, j, delay_at));
            }
            s.model.attitude_columns(&mut l, n_p + n_e);
            // A stretch's wander acts through its own bias columns.
            if let Some(w) = &self.wander {
                for (a, &axis) in w.axes.iter().enumerate() {
                    l.set_column(n_p + n_e + 6 + a, &s.b.column(bias_parameter(axis)));
                }
            }
            l
        };
        for (k, s) in self.stretches.iter().enumerate() {
            let d = self.data(s, effects, delay_at);
            normal.add_observation(&local(k), &design(s), &s.model.w, &d);
        }
        let sol = normal.solve().ok_or_else(|| {
            DiagnoseError::Numerical("the gap's normal equations are singular".into())
        })?;
        let (u, cov) = (sol.u, sol.cov);
        let mut chi2 = 0.0;
        let mut dof = 0.0;
        let mut residual = Vec::with_capacity(self.stretches.len());
        let mut residual_cov = Vec::with_capacity(self.stretches.len());
        let mut stretch_chi2 = Vec::with_capacity(self.stretches.len());
        let mut stretch_dof = Vec::with_capacity(self.stretches.len());
        for (k, s) in self.stretches.iter().enumerate() {
            let l = design(s);
            let idx = local(k);
            let u_loc = DVector::from_iterator(idx.len(), idx.iter().map(|&i| u[i]));
            let r = &l * &u_loc + self.data(s, effects, delay_at);
            let chi2_k = (r.transpose() * &s.model.w * &r)[(0, 0)];
            chi2 += chi2_k;
            let c_loc = DMatrix::from_fn(idx.len(), idx.len(), |a, b| cov[(idx[a], idx[b])]);
            let hc = &l * c_loc * l.transpose();
            let mut rc = s.model.q;
            for i in 0..6 {
                for j in 0..6 {
                    rc[(i, j)] -= hc[(i, j)];
                }
            }
            let rc_d = DMatrix::from_column_slice(6, 6, rc.as_slice());
            let dof_k = (&s.model.w * rc_d).trace();
            dof += dof_k;
            stretch_chi2.push(chi2_k);
            stretch_dof.push(dof_k);
            residual.push(Vector6::from_iterator(r.iter().copied()));
            residual_cov.push(rc);
        }
        let prior_terms: f64 = (0..n_p).map(|i| u[i] * u[i]).sum::<f64>()
            + (0..n_e)
                .map(|i| (u[n_p + i] / EFFECT_PRIOR).powi(2))
                .sum::<f64>()
            + self
                .wander
                .as_ref()
                .map_or(0.0, |w| w.prior_cost(&u.as_slice()[wander_at..]));
        let sd = |i: usize| cov[(i, i)].max(0.0).sqrt();
        let theta_corr = DMatrix::from_fn(n_e, n_e, |a, b| {
            cov[(n_p + a, n_p + b)] / (sd(n_p + a) * sd(n_p + b)).max(f64::MIN_POSITIVE)
        });
        let theta_cov = DMatrix::from_fn(n_e, n_e, |a, b| cov[(n_p + a, n_p + b)]);
        Ok(GapFit {
            effects: effects.to_vec(),
            base: (0..n_p).map(|i| u[i]).collect(),
            base_sigma: (0..n_p).map(sd).collect(),
            theta: (0..n_e).map(|i| u[n_p + i]).collect(),
            theta_sigma: (0..n_e).map(|i| sd(n_p + i)).collect(),
            theta_corr,
            theta_cov,
            chi2,
            objective: chi2 + prior_terms,
            dof,
            residual,
            residual_cov,
            stretch_chi2,
            stretch_dof,
        })
    }
}
