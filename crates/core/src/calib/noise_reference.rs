//! The noise model a line holds for its unit, tested against the model
//! fitted to one of its runs (`EstimateOptions::noise_reference`): does
//! this run's noise still match the unit's characterisation?
//!
//! Both are scored over the same traced pass the fit used: by the
//! fit's own likelihood (the parameters held at the pass's estimate, the
//! decimated replay) and by the likelihood with the parameters integrated
//! out (the whole pass replayed), which does not favour a model for
//! fitting residuals the estimate was made from. Three replays, no read
//! of the run, and no estimate changed.

use super::error::CalibError;
use super::result::NoiseReferenceTest;
use super::walk::PassContext;
use crate::estimation::noise_model::NoiseModel;
use crate::estimation::quantile::chi2_upper;

/// The tail probability at which the test of a held noise model against
/// the fit ([`reference_test`]) says the run's noise is another.
const REFERENCE_TEST_LEVEL: f64 = 0.01;

/// The likelihood-ratio test of the model the caller holds for the unit
/// against the likeliest the fit found with every term free (`peak`: the
/// model and its profile ln L̂), over the same replayed pass: how much
/// likelier the run is under its own noise. Against the model the
/// calibration then uses, from which the fit drops each wander term its
/// 1 % test does not keep, the held one could win by up to 5.4 a dropped
/// term without being any likelier than the run's own noise. The
/// statistic 2 (ln L̂ − ln L₀) is never negative (unless the search
/// stopped short of the held model) and follows
/// about χ² with as many degrees of freedom as the fit had free terms when
/// the held model is the unit's noise (fewer in effect, since a term on
/// the boundary of its range counts half). Beyond the 99 % point the run
/// says its noise is not that model; within it, the run cannot tell them
/// apart, whatever σ each gives.
pub(crate) fn reference_test(
    ctx: &PassContext,
    profile: &dyn Fn(&NoiseModel) -> Result<f64, CalibError>,
    marginal: &dyn Fn(&NoiseModel) -> Result<f64, CalibError>,
    (peak, peak_ln_l): (&NoiseModel, f64),
    free_terms: usize,
) -> Result<Option<NoiseReferenceTest>, CalibError> {
    let Some(density) = &ctx.opts.noise_reference else {
        return Ok(None);
    };
    let held = ctx.with_noise(NoiseModel::from_density(density)).noise;
    let statistic = 2.0 * (peak_ln_l - profile(&held)?);
    let marginal_statistic = 2.0 * (marginal(peak)? - marginal(&held)?);
    let threshold = chi2_upper(free_terms as f64, REFERENCE_TEST_LEVEL);
    Ok(Some(NoiseReferenceTest {
        statistic,
        marginal_statistic,
        degrees_of_freedom: free_terms,
        threshold,
        consistent: statistic <= threshold,
    }))
}
