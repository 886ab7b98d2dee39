//! Gap space: the least-squares framework of `calib::lsq`, widened to
//! carry effect parameters and to report its residuals.
//!
//! The measured run is compensated with the calibration and navigated
//! open loop; the simulated run (the reconstructed scheme, the calibrated
//! model, no noise) goes through the same compensation and navigation.
//! Nodes are placed in every dwell (a few per dwell, as in `calib::lsq`);
//! the gap at a node is the measured minus the simulated velocity. Over
//! each stretch between nodes (a piece of a dwell, or a rotation step)
//!
//!   r_k = x_{k+1} − A_k x_k − B_k δp − E_k θ,   x = [φ; δv],
//!
//! with B_k the base parameters' columns accumulated record by record and
//! E_k the effect parameters' columns, computed through the simulator:
//! the navigation error that a noise-free run carrying one effect
//! parameter at its signature size makes against the run without it,
//! sampled at the nodes, e_{k+1} − A_k e_k. The attitude errors φ_k at
//! the nodes are unknowns, the attitude random walk the process noise; the
//! weighted residual cost Σ r_kᵀ Q_k⁻¹ r_k is the likelihood of model
//! selection, and its expectation under noise alone (from the residual
//! covariance Q_k − L_k N⁻¹ L_kᵀ) the noise floor.

use std::sync::atomic::{AtomicBool, Ordering};

use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, Vector3, Vector6};

use super::error::DiagnoseError;
use crate::calib::filter::{error_dynamics, NAV};
use crate::calib::nodes::{walk_nodes, Stretch};
use crate::calib::normal::NormalEquations;
use crate::calib::priors::{start_attitude_information, white_noise_density};
use crate::calib::walk::PassContext;
use crate::calib::CalibError;
use crate::model::{Compensator, Effects, ErrorParameters, N_PARAMS};
use crate::nav::attitude::attitude_difference_n;
use crate::nav::{Site, Strapdown};
use crate::sim::{simulate, Noise, Scheme, SimConfig};

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
    /// Segment index (dwell) of each node.
    pub segment: Vec<usize>,
    /// 1 Hz open-loop measured velocity: (record number, v).
    pub series: Vec<(u64, Vector3<f64>)>,
}

/// Walks the measured run once, compensated with `params`, from `c_b_n0`.
pub(crate) fn measured_nodes(
    ctx: &PassContext,
    params: &ErrorParameters,
    c_b_n0: &Matrix3<f64>,
    progress: &mut dyn FnMut(f64),
) -> Result<Nodes, CalibError> {
    let comp = params.compensator();
    let dt = 1.0 / ctx.run.sample_rate_hz;
    let rec_no = |t: f64| ((t - ctx.scan.t_begin) / dt).round() as u64;
    let window_s = ctx.window() as f64 * dt;
    let mut nodes = Nodes {
        t: vec![ctx.scan.t_begin],
        record: vec![0],
        v: vec![Vector3::zeros()],
        b: vec![DMatrix::zeros(NAV, N_PARAMS)],
        segment: vec![0],
        series: vec![(0, Vector3::zeros())],
    };
    walk_nodes(ctx, &comp, c_b_n0, window_s, progress, |w, node| {
        nodes.series.push((rec_no(w.t_end), w.nav.v_n));
        if let Some((d, b)) = node {
            nodes.t.push(w.t_end);
            nodes.record.push(rec_no(w.t_end));
            nodes.v.push(w.nav.v_n);
            nodes.b.push(b);
            nodes.segment.push(d);
        }
    })?;
    if nodes.t.len() < 3 {
        return Err(CalibError::Unusable("too few dwells for the gap".into()));
    }
    Ok(nodes)
}

/// A noise-free simulated run navigated like the measured one, sampled
/// at the nodes and at 1 Hz.
struct SimNav {
    c: Vec<Matrix3<f64>>,
    v: Vec<Vector3<f64>>,
    series: Vec<Vector3<f64>>,
}

/// What every simulation of the reconstructed scheme shares.
pub struct SimSetup<'a> {
    pub site: Site,
    pub sample_rate_hz: f64,
    pub scheme: &'a Scheme,
    pub params: ErrorParameters,
    pub c_b_n0: Matrix3<f64>,
    pub cancel: &'a AtomicBool,
}

/// A noise-free simulation of `scheme` starting at attitude `c_b_n0`.
pub(crate) fn noise_free_run(
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
    }
}

fn simulate_nav(
    s: &SimSetup,
    effects: Effects,
    node_records: &[u64],
    series_records: &[u64],
) -> Result<SimNav, DiagnoseError> {
    let cfg = noise_free_run(
        s.site,
        s.sample_rate_hz,
        s.scheme.clone(),
        s.params,
        effects,
        &s.c_b_n0,
    );
    let dt = 1.0 / s.sample_rate_hz;
    let comp: Compensator = s.params.compensator();
    let mut nav = Strapdown::new(&s.site, &s.c_b_n0, 0.0, dt);
    let mut out = SimNav {
        c: Vec::with_capacity(node_records.len()),
        v: Vec::with_capacity(node_records.len()),
        series: Vec::with_capacity(series_records.len()),
    };
    let (mut ni, mut si) = (0, 0);
    let mut sample = |k: u64, nav: &Strapdown, out: &mut SimNav| {
        while ni < node_records.len() && node_records[ni] <= k {
            out.c.push(nav.c_b_n());
            out.v.push(nav.v_n);
            ni += 1;
        }
        while si < series_records.len() && series_records[si] <= k {
            out.series.push(nav.v_n);
            si += 1;
        }
    };
    sample(0, &nav, &mut out);
    let sim = simulate(&cfg).map_err(|e| DiagnoseError::Scheme(e.to_string()))?;
    for (k, r) in sim.enumerate() {
        if k % 65_536 == 0 && s.cancel.load(Ordering::Relaxed) {
            return Err(DiagnoseError::Calib(CalibError::Cancelled));
        }
        nav.update(&comp.record(&r, dt));
        sample(k as u64 + 1, &nav, &mut out);
    }
    // A reconstructed scheme a record short of the data: hold the last.
    while out.c.len() < node_records.len() {
        out.c.push(nav.c_b_n());
        out.v.push(nav.v_n);
    }
    while out.series.len() < series_records.len() {
        out.series.push(nav.v_n);
    }
    Ok(out)
}

/// The reference simulation and every effect parameter's signature.
pub struct Signatures {
    /// Simulated open-loop velocity at the nodes (the prediction).
    pub v_sim: Vec<Vector3<f64>>,
    /// Simulated velocity at the 1 Hz series' samples.
    pub series_sim: Vec<Vector3<f64>>,
    /// Per effect parameter (library order): navigation error at each
    /// node per signature size.
    pub x: Vec<Vec<Vector6<f64>>>,
    /// Per effect parameter: the velocity error at the 1 Hz samples.
    pub series: Vec<Vec<Vector3<f64>>>,
}

/// Simulates the reference run and one run per effect parameter.
pub fn signatures(
    s: &SimSetup,
    nodes: &Nodes,
    effects: &[Effects],
    progress: &mut dyn FnMut(f64),
) -> Result<Signatures, DiagnoseError> {
    let series_records: Vec<u64> = nodes.series.iter().map(|x| x.0).collect();
    let base = simulate_nav(s, Effects::none(), &nodes.record, &series_records)?;
    let mut out = Signatures {
        v_sim: base.v.clone(),
        series_sim: base.series.clone(),
        x: Vec::with_capacity(effects.len()),
        series: Vec::with_capacity(effects.len()),
    };
    // Two threads: the simulations are independent and each streams.
    let results: Vec<Result<SimNav, DiagnoseError>> = std::thread::scope(|scope| {
        let half = effects.len().div_ceil(2);
        let (a, b) = effects.split_at(half);
        let (nr, sr) = (&nodes.record, &series_records);
        let h = scope.spawn(move || {
            b.iter()
                .map(|e| simulate_nav(s, *e, nr, sr))
                .collect::<Vec<_>>()
        });
        let mut first: Vec<_> = Vec::with_capacity(effects.len());
        for (i, e) in a.iter().enumerate() {
            first.push(simulate_nav(s, *e, nr, sr));
            progress((i + 1) as f64 / a.len().max(1) as f64);
        }
        let second = h.join().unwrap_or_else(|_| {
            vec![Err(DiagnoseError::Scheme(
                "a simulation thread failed".into(),
            ))]
        });
        first.extend(second);
        first
    });
    for r in results {
        let sim = r?;
        let x = (0..nodes.t.len())
            .map(|k| {
                let phi = attitude_difference_n(&sim.c[k], &base.c[k]);
                let dv = sim.v[k] - base.v[k];
                Vector6::new(phi.x, phi.y, phi.z, dv.x, dv.y, dv.z)
            })
            .collect();
        let series = sim
            .series
            .iter()
            .zip(base.series.iter())
            .map(|(a, b)| a - b)
            .collect();
        out.x.push(x);
        out.series.push(series);
    }
    Ok(out)
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
    p0_phi_inv: Matrix3<f64>,
    n_nodes: usize,
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
    pub(crate) fn new(
        ctx: &PassContext,
        nodes: &Nodes,
        sig: &Signatures,
        n_effect_params: usize,
    ) -> Result<Self, DiagnoseError> {
        let site = &ctx.run.site;
        let f = error_dynamics(&site.omega_ie_n(), &site.f_rest_n());
        let p0_phi_inv = start_attitude_information(site, ctx.opts.prior_scale)
            .ok_or_else(|| DiagnoseError::Numerical("singular attitude prior".into()))?;
        let qc = white_noise_density(ctx.arw, ctx.vrw);
        let k_nodes = nodes.t.len();
        let mut stretches = Vec::with_capacity(k_nodes - 1);
        let gap = |k: usize| nodes.v[k] - sig.v_sim[k];
        for k in 0..k_nodes - 1 {
            let t = nodes.t[k + 1] - nodes.t[k];
            let model = Stretch::new(&f, &qc, t, &gap(k), &gap(k + 1))
                .ok_or_else(|| DiagnoseError::Numerical("singular process noise".into()))?;
            let a = model.a;
            let mut e = DMatrix::<f64>::zeros(6, n_effect_params);
            for j in 0..n_effect_params {
                let col = sig.x[j][k + 1] - a * sig.x[j][k];
                for i in 0..6 {
                    e[(i, j)] = -col[i];
                }
            }
            stretches.push(GapStretch {
                model,
                b: -&nodes.b[k + 1],
                e,
            });
        }
        Ok(GapProblem {
            stretches,
            p0_phi_inv,
            n_nodes: k_nodes,
        })
    }

    /// Fits the base parameters, the effect parameters `effects` (library
    /// indices) and the attitude at every node.
    pub fn fit(&self, effects: &[usize]) -> Result<GapFit, DiagnoseError> {
        let n_p = N_PARAMS;
        let n_e = effects.len();
        let phi = |k: usize| n_p + n_e + 3 * k;
        let n = n_p + n_e + 3 * self.n_nodes;
        let mut normal = NormalEquations::new(n);
        normal.add_diagonal(0..n_p, 1.0);
        normal.add_diagonal(n_p..n_p + n_e, 1.0 / (EFFECT_PRIOR * EFFECT_PRIOR));
        normal.add_block3(phi(0), &self.p0_phi_inv);
        let local = |k: usize| -> Vec<usize> {
            (0..n_p + n_e).chain(phi(k)..phi(k) + 6).collect::<Vec<_>>()
        };
        let design = |k: usize, s: &GapStretch| -> DMatrix<f64> {
            let mut l = DMatrix::<f64>::zeros(6, n_p + n_e + 6);
            l.view_mut((0, 0), (6, n_p)).copy_from(&s.b);
            for (c, &j) in effects.iter().enumerate() {
                l.view_mut((0, n_p + c), (6, 1)).copy_from(&s.e.column(j));
            }
            s.model.attitude_columns(&mut l, n_p + n_e);
            let _ = k;
            l
        };
        for (k, s) in self.stretches.iter().enumerate() {
            normal.add_observation(&local(k), &design(k, s), &s.model.w, &s.model.d);
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
            let l = design(k, s);
            let idx = local(k);
            let u_loc = DVector::from_iterator(idx.len(), idx.iter().map(|&i| u[i]));
            let r = &l * &u_loc + &s.model.d;
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
                .sum::<f64>();
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
