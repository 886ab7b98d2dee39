//! The record type that flows from readers and the simulator to the
//! estimator.

/// One IMU record: the increments sensed over the interval `(t − Δt, t]`.
///
/// `dtheta` is the angle increment in rad, `dv` the velocity increment in
/// m/s, both in body axes (SPEC §2). Readers of rate files convert each
/// sample to an increment over its nominal interval, so everything
/// downstream sees one kind of record.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Record {
    /// End of the record's interval, s.
    pub t: f64,
    /// Angle increment, rad (body axes).
    pub dtheta: [f64; 3],
    /// Velocity increment, m/s (body axes).
    pub dv: [f64; 3],
}

/// What the columns of a data file hold (SPEC §5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DataKind {
    /// `t,dthx,dthy,dthz,dvx,dvy,dvz`: increments over the record interval.
    Increments,
    /// `t,wx,wy,wz,fx,fy,fz`: angular rate (rad/s) and specific force (m/s²)
    /// sampled at `t`.
    Rates,
}
