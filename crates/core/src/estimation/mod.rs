//! The estimation toolkit calibration, diagnosis and design share as
//! peers: the navigation-error dynamics and the systematic filter over
//! them (`filter`, `error_dynamics`, `nav_errors`, `window_columns`), the
//! noise model it runs under (`noise_model`, `wander`: wandering biases
//! as states), the parameters' sensitivity columns (`sensitivity`),
//! normal equations (`normal`), priors (`priors`) and the coarse
//! alignment at rest (`align`). Nothing here reads a run or knows a
//! result: `calib` walks runs through it and reports.

pub(crate) mod align;
pub(crate) mod effect_columns;
pub(crate) mod error;
pub(crate) mod error_dynamics;
pub(crate) mod filter;
pub(crate) mod nav_errors;
pub(crate) mod noise_model;
pub(crate) mod normal;
pub(crate) mod priors;
pub mod quantile;
pub(crate) mod sensitivity;
pub(crate) mod wander;
pub(crate) mod window_columns;

pub use error::EstimationError;
pub use noise_model::{NoiseDensity, NoiseModel, TriadNoise};
