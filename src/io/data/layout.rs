//! The record layout of SPEC §5 and the timing tolerances a run is held
//! to: constants that the readers, the writer, the checks and the error
//! messages all quote, kept in a leaf so none of them depends on another
//! for a name.

/// Largest accepted relative deviation of a time step from 1/sample_rate_hz.
pub const STEP_TOLERANCE: f64 = 0.01;

/// Largest accepted relative deviation of the mean step (time since the
/// first record over the steps taken) from 1/sample_rate_hz. A unit's
/// clock is good to a few parts in 10⁵; a step tolerance of 1 % alone lets
/// a run at 100.5 Hz pass as 100 Hz and then fail in the estimator.
pub const MEAN_RATE_TOLERANCE: f64 = 0.001;

/// Column names of the increments kind, in file order.
pub(crate) const INCREMENT_COLUMNS: [&str; 7] = ["t", "dthx", "dthy", "dthz", "dvx", "dvy", "dvz"];
/// Column names of the rates kind, in file order.
pub(crate) const RATE_COLUMNS: [&str; 7] = ["t", "wx", "wy", "wz", "fx", "fy", "fz"];

/// The optional last column of either header: the unit's temperature, °C
/// (SPEC §3a, §5).
pub(crate) const TEMPERATURE_COLUMN: &str = "temp_c";
/// Most values a record has: seven, and the temperature.
pub(crate) const MAX_COLUMNS: usize = 8;
