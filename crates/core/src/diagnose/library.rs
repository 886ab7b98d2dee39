//! The candidate library as columns of the gap problem: every effect
//! parameter of every candidate flattened into one index, and what a fit
//! over some of those columns says (the effects' estimates, and the
//! sensor it describes).

use super::candidates::{self, library_with, Candidate};
use super::gap::GapFit;
use super::report::EffectEstimate;
use super::separate::Explanation;
use crate::model::{Effects, ErrorParameters};

/// Index of every effect parameter of the library, flattened.
pub(crate) struct Library {
    pub candidates: Vec<Candidate>,
    /// First flattened index of each candidate.
    offset: Vec<usize>,
    pub n: usize,
}

impl Library {
    /// The candidates, with `thermal` for a run whose temperature moves.
    pub fn new(thermal: bool) -> Self {
        let candidates = library_with(thermal);
        let mut offset = Vec::new();
        let mut n = 0;
        for c in &candidates {
            offset.push(n);
            n += c.params.len();
        }
        Library {
            candidates,
            offset,
            n,
        }
    }

    pub fn columns(&self, c: usize) -> std::ops::Range<usize> {
        self.offset[c]..self.offset[c] + self.candidates[c].params.len()
    }
}

/// The effect estimates of candidate `c` in `fit`.
pub(crate) fn effect_estimates(lib: &Library, fit: &GapFit, c: usize) -> Vec<EffectEstimate> {
    let cand = &lib.candidates[c];
    lib.columns(c)
        .enumerate()
        .filter_map(|(j, col)| {
            let pos = fit.effects.iter().position(|&e| e == col)?;
            let size = cand.params[j].signature_size;
            Some(EffectEstimate {
                name: cand.params[j].name.clone(),
                value: fit.theta[pos] * size,
                sigma: fit.theta_sigma[pos] * size,
                unit: cand.params[j].unit.clone(),
            })
        })
        .collect()
}

/// What a fit says the sensor is: the base calibration `params` with the
/// fit's base corrections composed in, and the effects of candidates
/// `cands` at their fitted values.
pub(crate) fn explanation(
    lib: &Library,
    params: &ErrorParameters,
    prior: &[f64],
    fit: &GapFit,
    cands: &[usize],
) -> Explanation {
    let mut delta = ErrorParameters::zero();
    for ((d, b), s) in delta.si.iter_mut().zip(&fit.base).zip(prior) {
        *d = b * s;
    }
    let mut effects = Effects::none();
    for &c in cands {
        let values: Vec<f64> = effect_estimates(lib, fit, c)
            .iter()
            .map(|e| e.value)
            .collect();
        candidates::add_effect(&mut effects, lib.candidates[c].name, &values);
    }
    Explanation {
        params: params.compose(&delta),
        effects,
    }
}

impl Library {
    /// The columns of candidates `cands`, in order.
    pub fn columns_of(&self, cands: &[usize]) -> Vec<usize> {
        cands.iter().flat_map(|&c| self.columns(c)).collect()
    }

    /// The SPEC §3 effect names of candidates `cands`.
    pub fn effects_of(&self, cands: &[usize]) -> Vec<String> {
        cands
            .iter()
            .map(|&c| self.candidates[c].effect.to_string())
            .collect()
    }
}
