//! Calibration: finding the 24 parameters (and any effect states) from a
//! run: walking it through the estimation toolkit's filter (`estimation`),
//! the least-squares cross-check, the noise fit, the model check and
//! covariance planning. No I/O happens here: records come
//! through [`RecordSource`], which the caller implements.

pub(crate) mod check_statistics;
mod detect_options;
#[cfg(test)]
mod effect_columns_check;
pub(crate) mod effect_model;
pub(crate) mod error;
pub(crate) mod estimate;
pub(crate) mod gaps;
pub(crate) mod heading;
pub(crate) mod held_noise;
pub(crate) mod kf_pass;
pub(crate) mod lsq;
pub(crate) mod misfit;
pub mod model_check;
pub(crate) mod nodes;
pub(crate) mod noise_fit;
pub(crate) mod noise_measure;
pub(crate) mod noise_reference;
mod noise_screen;
pub(crate) mod options;
pub(crate) mod passes;
pub mod plan;
pub mod prescan;
pub(crate) mod replay;
mod report;
pub mod result;
pub(crate) mod run;
pub mod segment;
pub mod sources;
pub(crate) mod temperature;
pub mod thermal_states;
pub(crate) mod timed;
pub(crate) mod walk;

pub use crate::estimation::{NoiseModel, TriadNoise};
pub use effect_model::{Effect, ErrorModel};
pub use error::CalibError;
pub use estimate::estimate;
pub use held_noise::{parse_noise_terms, HeldNoise, HeldNoiseUse, NoiseTermsError};
pub use misfit::ModelCheck;
pub use options::{EstimateOptions, NoiseDensity};
pub use result::{CalibrationResult, ParameterEstimate, ResultEstimator};
pub use run::{EstimatorKind, Progress, RecordSource, RunInfo};
pub use segment::{DetectOptions, RunSegment, SegmentKind};
