//! One Gauss–Newton step of the gap about the named effects: the
//! selection linearises about the base calibration, which had absorbed
//! whatever effect the run carries; about the fitted point what a large
//! effect leaves is linear.

use super::error::DiagnoseError;
use super::gap::{self, DelayColumns, GapColumns, GapProblem};
use super::library::Library;
use super::options::DiagnoseOptions;
use super::select::Selection;
use super::verdict::{Remainder, Verdict};
use crate::calib::walk::{align_start, PassContext};
use crate::estimation::effect_columns::EffectParameter;
use crate::model::ErrorParameters;

/// One Gauss–Newton step of the whole gap problem about the named
/// effects: the base corrections composed into the calibration, the named
/// effects at their fitted values taken out of the records, the run
/// walked again and the same model
/// refitted. A large effect (a 10 cm arm on hand flips: velocity steps of
/// 10 cm/s) moves the base calibration it was linearised about by tens of
/// σ; about the fitted point what is left is linear. The selection's
/// decisions stay as they were; its final fit, and the figures of the
/// step that ended it, are the refit's (the removed values added back),
/// and the verdict's remainder is judged on it.
pub(crate) fn relinearise(
    ctx: &PassContext,
    lib: &Library,
    cols: &GapColumns,
    params: &ErrorParameters,
    prior: &[f64],
    opts: &DiagnoseOptions,
    mut selection: Selection,
) -> Result<(ErrorParameters, Selection), DiagnoseError> {
    let named = lib.columns_of(&selection.named);
    let fit = &selection.current;
    let mut delta = ErrorParameters::zero();
    for ((d, b), s) in delta.si.iter_mut().zip(&fit.base).zip(prior) {
        *d = b * s;
    }
    let point = params.compose(&delta);
    let removed: Vec<(EffectParameter, f64)> = named
        .iter()
        .zip(&fit.theta)
        .map(|(&col, &theta)| (cols.states[col].0, theta * cols.states[col].1))
        .collect();
    // Only the named columns are walked again (and the delay's second-order
    // column when the delay is named): the refit fits nothing else.
    let mut states: Vec<(EffectParameter, f64)> = named.iter().map(|&c| cols.states[c]).collect();
    let delay = cols.delay.and_then(|d| {
        let first_order = named.iter().position(|&c| c == d.first_order)?;
        states.push(cols.states[d.second_order]);
        Some(DelayColumns {
            first_order,
            second_order: states.len() - 1,
        })
    });
    let c_b_n0 = align_start(ctx, &point.compensator())?;
    let nodes = gap::measured_nodes(ctx, &point, &c_b_n0, &states, &removed, &mut |_| {})?;
    let own: Vec<usize> = (0..named.len()).collect();
    let mut refit = GapProblem::new(ctx, &nodes, delay)?.fit(&own)?;
    // Back to the library's columns, which the report reads them by.
    refit.effects = named.clone();
    for (t, before) in refit.theta.iter_mut().zip(&fit.theta) {
        *t += before;
    }
    let significant = refit.z() > opts.significance_sigma;
    if let Verdict::Named { rest, .. } = &mut selection.verdict {
        if matches!(rest, Remainder::Unexplained | Remainder::NothingSignificant) {
            *rest = if significant {
                Remainder::Unexplained
            } else {
                Remainder::NothingSignificant
            };
        }
    }
    if let Some(last) = selection
        .steps
        .last_mut()
        .filter(|s| s.model == selection.named)
    {
        last.fit = refit.clone();
        last.significant = significant;
    }
    selection.current = refit;
    Ok((point, selection))
}
