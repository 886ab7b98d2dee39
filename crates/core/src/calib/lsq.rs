//! The cross-check: the velocity-error-rate method of the seed paper
//! (its eqs. 15–24 for the 10-position scheme), generalised to any scheme
//! and solved as one weighted least-squares problem.
//!
//! The run is navigated open loop. Each dwell is cut into a few stretches
//! (nodes at their ends) and each rotation lies between the last node of
//! one dwell and the first of the next, so the observations are the
//! velocity changes over every stretch: each dwell's drift, sampled a few
//! times so its curvature is seen, and each rotation's velocity step. The
//! true velocity is zero at every node, so the navigated velocity there is
//! the velocity error itself. Between nodes k and k+1 the error model gives
//!
//!   [φ; δv]_{k+1} = A_k [φ; δv]_k + B_k p + w_k,   w_k ~ N(0, Q_k),
//!
//! with A_k, Q_k exact for the stretch's length and B_k accumulated record
//! by record. Unknowns are the parameters p and the attitude error φ_k at
//! every node; the attitude random walk the gyro noise drives is what w_k
//! carries, so successive drifts are not treated as independent (at
//! navigation-grade noise that walk, not the accelerometer noise, limits a
//! single dwell's drift). Minimising Σ w_kᵀ Q_k⁻¹ w_k plus the priors is a
//! dense linear problem of 24 + 3K unknowns, solved once by Cholesky.
//!
//! It shares the navigation and the error model with the filter but not the
//! recursion, the feedback or the update schedule, so a disagreement
//! points at the filter's mechanics.

use nalgebra::{DMatrix, Matrix3, Vector3};

use super::error::CalibError;
use super::kf_pass::effect_terms;
use super::nodes::{walk_nodes, Stretch};
use super::walk::{align_start, PassContext};
use crate::estimation::effect_columns::EffectTerms;
use crate::estimation::filter::{error_dynamics, NAV};
use crate::estimation::normal::NormalEquations;
use crate::estimation::priors::{prior_sigma, start_attitude_information, white_noise_density};
use crate::model::{ErrorParameters, N_PARAMS};

/// A node: the open-loop velocity there and what led to it.
struct Node {
    /// The dwell it lies in.
    dwell: usize,
    v: Vector3<f64>,
    /// B of the stretch ending here (scaled parameters).
    b: DMatrix<f64>,
    /// Length of the stretch ending here, s.
    t: f64,
}

/// The least-squares estimate linearised at `params`: the residual
/// correction (SI), its σ (SI), and the start attitude used.
pub(super) struct LsqSolution {
    pub delta: Vec<f64>,
    pub sigma: Vec<f64>,
    pub c_b_n0: Matrix3<f64>,
}

pub(super) fn lsq_pass(
    ctx: &PassContext,
    params: &ErrorParameters,
    effects: &[f64],
    progress: &mut dyn FnMut(f64),
) -> Result<LsqSolution, CalibError> {
    // The least squares carries no effect states: the model's effects are
    // held at `effects` (the filter's answer) and taken out of the records.
    let terms = EffectTerms {
        removed: effect_terms(&ctx.opts.model, effects, ctx.priors().grade).removed,
        ..EffectTerms::none()
    };
    let site = &ctx.run.site;
    let comp = params.compensator();
    let c_b_n0 = align_start(ctx, &comp)?;
    let prior = prior_sigma(ctx.priors());
    let f = error_dynamics(&site.omega_ie_n(), &site.f_rest_n());
    let window_s = ctx.window() as f64 / ctx.run.sample_rate_hz;
    let mut nodes: Vec<Node> = vec![Node {
        dwell: 0,
        v: Vector3::zeros(),
        b: DMatrix::zeros(NAV, N_PARAMS),
        t: 0.0,
    }];
    let mut since_node = 0.0;
    walk_nodes(
        ctx,
        &comp,
        &c_b_n0,
        window_s,
        &terms,
        progress,
        |w, b, node| {
            since_node += w.t_end - w.t_start;
            if let Some(dwell) = node {
                nodes.push(Node {
                    dwell,
                    v: w.nav.v_n,
                    b: b.clone(),
                    t: since_node,
                });
                since_node = 0.0;
            }
        },
    )?;
    if nodes.len() < 3 {
        return Err(CalibError::Unusable(
            "too few dwells for the least-squares cross-check".into(),
        ));
    }
    solve(ctx, &f, &prior, &nodes).map(|(delta, sigma)| LsqSolution {
        delta,
        sigma,
        c_b_n0,
    })
}

/// Builds and solves the normal equations.
fn solve(
    ctx: &PassContext,
    f: &nalgebra::Matrix6<f64>,
    prior: &[f64],
    nodes: &[Node],
) -> Result<(Vec<f64>, Vec<f64>), CalibError> {
    let n_p = N_PARAMS;
    let k_nodes = nodes.len();
    let phi = |k: usize| n_p + 3 * k;
    let mut normal = NormalEquations::new(n_p + 3 * k_nodes);
    // Priors: scaled parameters have unit variance; φ at the start as the
    // filter's.
    normal.add_diagonal(0..n_p, 1.0);
    let p0_phi_inv = start_attitude_information(&ctx.run.site, ctx.priors())
        .ok_or_else(|| CalibError::Numerical("singular attitude prior".into()))?;
    normal.add_block3(phi(0), &p0_phi_inv);

    let qc = white_noise_density(ctx.arw, ctx.vrw);
    for k in 0..k_nodes - 1 {
        let next = &nodes[k + 1];
        // The filter forgets the velocity across a hand motion below
        // navigation grade; so does this check of its mechanics.
        let crosses_motion = next.dwell != nodes[k].dwell;
        let stretch = Stretch::new(f, &qc, next.t, &nodes[k].v, &next.v)
            .and_then(|s| s.observed(ctx.grade, crosses_motion))
            .ok_or_else(|| CalibError::Numerical("singular process noise".into()))?;
        // r = L u + d over the unknowns (p, φ_k, φ_{k+1}).
        let mut l = DMatrix::<f64>::zeros(6, n_p + 6);
        l.view_mut((0, 0), (6, n_p)).copy_from(&(-&next.b));
        stretch.attitude_columns(&mut l, n_p);
        let idx: Vec<usize> = (0..n_p)
            .chain(phi(k)..phi(k) + 3)
            .chain(phi(k + 1)..phi(k + 1) + 3)
            .collect();
        normal.add_observation(&idx, &l, &stretch.w, &stretch.d);
    }
    let sol = normal.solve().ok_or_else(|| {
        CalibError::Numerical("least-squares normal equations are singular".into())
    })?;
    let cov_diag = sol.cov.diagonal();
    Ok((0..n_p)
        .map(|i| (sol.u[i] * prior[i], cov_diag[i].max(0.0).sqrt() * prior[i]))
        .unzip())
}
