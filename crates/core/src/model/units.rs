//! Conversions between SI and the canonical reporting units (SPEC §2).

use crate::nav::earth::G0;

/// One arcsecond (or deg/h ↔ rad/s), in radians.
pub const ARCSEC: f64 = std::f64::consts::PI / 180.0 / 3600.0;
/// One deg/h in rad/s.
pub const DEG_PER_H: f64 = ARCSEC;
/// One ppm.
pub const PPM: f64 = 1e-6;
/// One µg in m/s².
pub const UG: f64 = 1e-6 * G0;
/// One µg/g² in s²/m.
pub const UG_PER_G2: f64 = 1e-6 / G0;
/// One deg/√h in rad/√s (angle random walk).
pub const DEG_PER_RT_H: f64 = std::f64::consts::PI / 180.0 / 60.0;
/// One µg/√Hz in m/s/√s (velocity random walk).
pub const UG_PER_RT_HZ: f64 = UG;
/// One deg/h/g in (rad/s)/(m/s²) (gyro g-sensitivity).
pub const DEG_PER_H_PER_G: f64 = DEG_PER_H / G0;
/// One hour in seconds.
pub const HOUR: f64 = 3600.0;
