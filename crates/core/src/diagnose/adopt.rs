//! What adopting a diagnosis means for a run's model: the effects the
//! workflow named become states of the run's next calibration, beside the
//! effects its current model already carries.

use super::report::DiagnoseReport;
use crate::calib::{Effect, ErrorModel};

/// Why a diagnosis offers no model to adopt.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum NotAdoptable {
    #[error("the diagnosis named no effect ({verdict}): there is nothing to adopt")]
    NothingNamed { verdict: String },
    /// Named effects are drawn from the candidate library, every one a
    /// model effect (tested); a stored report from elsewhere may not be.
    #[error("the diagnosis names {0:?}, which is not an effect a calibration can carry")]
    UnknownEffect(String),
    #[error("the current model {0} carries every effect the diagnosis names already")]
    AlreadyCarried(ErrorModel),
}

impl DiagnoseReport {
    /// The model a calibration of this run carries once the diagnosis is
    /// adopted: `current` (the model of the run's current result) with
    /// every named effect added. The workflow always starts from the base
    /// model, so effects `current` carries that it did not name (a product
    /// line's model) are kept rather than dropped.
    pub fn adopted_model(&self, current: &ErrorModel) -> Result<ErrorModel, NotAdoptable> {
        if self.named.is_empty() {
            return Err(NotAdoptable::NothingNamed {
                verdict: self.verdict.to_string(),
            });
        }
        let mut model = current.clone();
        for name in &self.named {
            let effect =
                Effect::from_name(name).ok_or_else(|| NotAdoptable::UnknownEffect(name.clone()))?;
            model = model.and(effect);
        }
        if &model == current {
            return Err(NotAdoptable::AlreadyCarried(model));
        }
        Ok(model)
    }
}
