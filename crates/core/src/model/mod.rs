//! The sensor error model of SPEC §2 (24 parameters, canonical names and
//! units, generation and exact compensation) and the effects of SPEC §3
//! that lie outside it.

pub mod effects;
pub mod grade;
pub mod params;
pub mod thermal;
pub mod units;

pub use effects::Effects;
pub use grade::Grade;
pub use params::{bias_parameter, ErrorParameters, Group, ParameterInfo, N_PARAMS, PARAMETERS};
pub use thermal::{TemperatureHistory, ThermalTruth};
pub mod error_model;
pub use error_model::Compensator;
