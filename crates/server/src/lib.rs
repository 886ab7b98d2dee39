//! The sinscal server, on `sinscal_core`: `store` (the database, SQLite or
//! PostgreSQL), `runfiles` (run files on disk), `runstore` (where runs are
//! kept: that folder or an S3-compatible store), `jobs` (the durable queue
//! and its workers), `api` (HTTP), `web` (the workbench's pages), `plot`
//! (their charts as SVG text), `metrics` (Prometheus counters), `config`
//! (`serve`'s flags and defaults) and `server` (the application: start,
//! serve, shut down).

pub mod api;
pub mod config;
pub mod jobs;
pub mod metrics;
pub mod plot;
pub mod runfiles;
pub mod runstore;
pub mod server;
pub mod store;
pub mod web;
