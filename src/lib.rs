//! sinscal: calibration of strapdown inertial navigation systems with
//! ring-laser gyros.
//!
//! The library is organised by what each module owns (see
//! `docs/ARCHITECTURE.md`): `nav` (Earth model, attitude algebra,
//! strapdown), `model` (the 24-parameter error model and the extra effects),
//! `sim` (schemes and record generation), `io` (run files, metadata, truth),
//! `noise` (Allan deviation and the noise terms), `accept` (product
//! types' limits and the verdict on a result), `plot` (charts as SVG text
//! for the server's pages);
//! and the server: `store` (SQLite), `runfiles` (the run files on disk),
//! `runstore` (where runs are kept: that folder or an S3-compatible store),
//! `jobs` (durable queue, workers), `api` (HTTP), `web` (the workbench's
//! pages), `server` (configuration, application).

pub mod accept;
pub mod api;
pub mod calib;
pub mod compensation;
pub mod config;
pub mod design;
pub mod diagnose;
pub mod io;
pub mod jobs;
pub mod metrics;
pub mod model;
pub mod nav;
pub mod noise;
pub mod pipeline;
pub mod plot;
pub mod record;
pub mod runfiles;
pub mod runstore;
pub mod server;
pub mod sim;
pub mod store;
pub mod thermal;
pub mod web;

pub use record::Record;
