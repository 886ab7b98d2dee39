//! sinscal: calibration of strapdown inertial navigation systems with
//! ring-laser gyros.
//!
//! The library is organised by what each module owns (see
//! `docs/ARCHITECTURE.md`): `nav` (Earth model, attitude algebra,
//! strapdown), `model` (the 24-parameter error model and the extra effects),
//! `sim` (schemes and record generation), `io` (run files, metadata, truth).

pub mod calib;
pub mod diagnose;
pub mod io;
pub mod model;
pub mod nav;
pub mod pipeline;
pub mod record;
pub mod sim;

pub use record::Record;
