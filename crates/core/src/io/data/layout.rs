//! The record layout of SPEC §5 and the timing tolerances a run is held
//! to: constants that the readers, the writer, the checks and the error
//! messages all quote, kept in a leaf so none of them depends on another
//! for a name.

/// Largest relative deviation of a normal time step from
/// 1/sample_rate_hz (SPEC §2a): the record module's rule, which every
/// consumer of records shares.
pub use crate::record::STEP_TOLERANCE;

/// Largest accepted relative deviation of the mean normal step from
/// 1/sample_rate_hz, beyond what the steps' own jitter explains (five
/// standard errors of their spread). A unit's clock is good to a few parts
/// in 10⁵; a step tolerance of 10 % alone lets a run at 105 Hz pass as
/// 100 Hz.
pub const MEAN_RATE_TOLERANCE: f64 = 0.001;

/// Standard errors of the mean step that its jitter may explain.
pub(crate) const MEAN_RATE_SIGMAS: f64 = 5.0;

/// Column names of the increments kind, in file order.
pub(crate) const INCREMENT_COLUMNS: [&str; 7] = ["t", "dthx", "dthy", "dthz", "dvx", "dvy", "dvz"];
/// Column names of the rates kind, in file order.
pub(crate) const RATE_COLUMNS: [&str; 7] = ["t", "wx", "wy", "wz", "fx", "fy", "fz"];

/// Column names of the counts kind, in file order.
pub(crate) const COUNT_COLUMNS: [&str; 7] = ["t", "cgx", "cgy", "cgz", "cax", "cay", "caz"];

/// The optional last column of either header: the unit's temperature, °C
/// (SPEC §3a, §5).
pub(crate) const TEMPERATURE_COLUMN: &str = "temp_c";
/// Most values a record has: seven, and the temperature.
pub(crate) const MAX_COLUMNS: usize = 8;
