//! Simulation of calibration runs: rotation schemes (SPEC §4), turns by
//! hand, the true trajectory of a unit on its turntable or in an
//! operator's hands, and records generated from it with the error model,
//! effects and noise (SPEC §2–3).

pub mod flip;
pub mod generator;
pub mod hand;
pub mod profile;
pub mod scheme;
pub mod trajectory;

pub use generator::{simulate, Noise, SimConfig, SimError, Simulator};
pub use hand::HandTurns;
pub use scheme::{Scheme, SchemeRef};
pub use trajectory::Trajectory;
