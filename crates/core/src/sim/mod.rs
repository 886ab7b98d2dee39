//! Simulation of calibration runs: rotation schemes (SPEC §4), turns by
//! hand, the true trajectory of a unit on its turntable or in an
//! operator's hands, and records generated from it with the error model,
//! effects and noise (SPEC §2–3), and what real sensors add (SPEC §2a):
//! wandering biases, pulse outputs, floor vibration, time stamps.

pub mod flip;
pub mod generator;
pub mod grade_runs;
pub mod hand;
pub mod profile;
pub mod pulses;
pub mod scheme;
pub mod sensor_noise;
pub mod stamps;
pub mod trajectory;
pub mod vibration;
pub mod wander;

pub use generator::{simulate, SimConfig, SimError, Simulator};
pub use hand::HandTurns;
pub use scheme::{Scheme, SchemeRef};
pub use sensor_noise::{Gap, Noise, Vibration};
pub use trajectory::Trajectory;
pub use wander::BiasMean;
