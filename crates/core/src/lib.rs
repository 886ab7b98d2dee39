//! sinscal's numerical core: everything that turns a run into numbers,
//! with no async runtime, HTTP or database (the compiler holds that: this
//! crate depends on none of them).
//!
//! Organised by what each module owns (see `docs/ARCHITECTURE.md`): `nav`
//! (Earth model, attitude algebra, strapdown), `model` (the 24-parameter
//! error model, the extra effects, the thermal truth), `sim` (schemes and
//! record generation), `io` (run files, metadata, truth, importers),
//! `calib` (the calibration filter and its checks), `diagnose` (the
//! discrepancy workflow), `design` (schemes made to a target), `noise`
//! (Allan deviation and the noise terms), `thermal` (a unit's thermal model
//! from soaked runs), `compensation` (the file a navigation computer
//! loads), `accept` (product types' limits and the verdict on a result),
//! `pipeline` (a run file in, a document out: what the command line and the
//! server call).

pub mod accept;
pub mod calib;
pub mod compensation;
pub mod design;
pub mod diagnose;
pub mod estimation;
pub mod io;
pub mod model;
pub mod nav;
pub mod noise;
pub mod pipeline;
pub mod record;
pub mod sim;
pub mod thermal;

pub use record::Record;
