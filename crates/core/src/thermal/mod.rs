//! Thermal calibration (SPEC §3a): a unit's parameters as functions of its
//! temperature, fitted from its calibrated runs.
//!
//! `fit` owns one parameter's weighted polynomial; `model` the unit's
//! model from runs soaked at several temperatures, its check and its
//! prediction. Nothing here reads files or knows the server.

pub mod fit;
pub mod model;

pub use model::{
    fit_thermal_model, Prediction, SoakedRun, ThermalCheck, ThermalModel, ThermalParameter,
    REFERENCE_C,
};

#[derive(Debug, thiserror::Error)]
pub enum ThermalError {
    /// The runs cannot give a model (one temperature, no shared
    /// parameter, a temperature that is not a number).
    #[error("{0}")]
    Input(String),
    #[error(
        "{temperature_c} °C is outside the model's range {}–{} °C; predicting there is \
         extrapolation and must be asked for",
        range_c[0], range_c[1]
    )]
    OutOfRange {
        temperature_c: f64,
        range_c: [f64; 2],
    },
}
