//! Calibration: finding the 24 parameters (and any effect states) from a
//! run. Alignment, the systematic Kalman filter, the least-squares
//! cross-check and covariance planning. No I/O happens here: records come
//! through [`RecordSource`], which the caller implements.

pub mod align;
pub mod check_statistics;
pub mod effect_model;
pub mod effect_sensitivity;
pub mod error;
pub(crate) mod error_dynamics;
pub mod estimate;
pub mod filter;
pub mod gaps;
pub mod kf_pass;
pub mod lsq;
pub mod misfit;
pub mod model_check;
pub(crate) mod nav_errors;
pub(crate) mod nodes;
pub(crate) mod noise_fit;
pub(crate) mod noise_measure;
pub mod noise_model;
pub(crate) mod normal;
pub mod options;
pub(crate) mod passes;
pub mod plan;
pub mod prescan;
pub mod priors;
pub(crate) mod replay;
mod report;
pub mod result;
pub mod run;
pub mod segment;
pub mod sensitivity;
pub mod sources;
pub mod temperature;
pub mod thermal_states;
pub mod timed;
pub mod walk;
pub(crate) mod wander;

pub use effect_model::{Effect, ErrorModel};
pub use error::CalibError;
pub use estimate::estimate;
pub use misfit::ModelCheck;
pub use noise_model::{NoiseModel, TriadNoise};
pub use options::{EstimateOptions, NoiseDensity};
pub use result::{CalibrationResult, ParameterEstimate};
pub use run::{EstimatorKind, Progress, RecordSource, RunInfo};
pub use segment::{DetectOptions, RunSegment, SegmentKind};
