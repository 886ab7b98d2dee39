//! The convention a compensation file states about itself, in words a
//! navigation computer's loader can be checked against. Written once here
//! so the file, its CSV header and the docs cannot drift apart.

use serde::{Deserialize, Serialize};

/// What the numbers in a compensation file mean (SPEC §2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Convention {
    pub units: String,
    pub frames: String,
    pub measurement_model: String,
    pub gyro_compensation: String,
    pub accel_compensation: String,
    pub record_interval: String,
}

impl Convention {
    /// The convention of this version's files.
    pub fn current() -> Self {
        Convention {
            units: "SI: rad/s, rad, m/s^2, s^2/m; scale factors and misalignments \
                    dimensionless (rad for misalignments); sigma is the estimator's 1-sigma \
                    in the same unit"
                .into(),
            frames: "body frame b built from the gyros: z_b along the z-gyro, y_b in the \
                     plane of the y- and z-gyros, so K_g is upper triangular; matrices \
                     are row = sensor, column = input axis"
                .into(),
            measurement_model: "generation convention: omega_meas = (I + K_g) omega + b_g, \
                                f_meas = (I + K_a) f + b_a + D_a (f o f); on increments \
                                dtheta_meas = (I + K_g) dtheta + b_g dt, \
                                dv_meas = (I + K_a) dv + b_a dt + D_a integral(f o f) dt; \
                                o is the element-wise product, D_a = diag(quadratic)"
                .into(),
            gyro_compensation: "exact: dtheta = (I + K_g)^-1 (dtheta_meas - b_g dt); \
                                rates: omega = (I + K_g)^-1 (omega_meas - b_g)"
                .into(),
            accel_compensation: "integral(f o f) dt is taken as (dv o dv)/dt (exact for a \
                                 specific force constant over the record), then \
                                 (I + K_a) dv + D_a (dv o dv)/dt = dv_meas - b_a dt is solved \
                                 by fixed-point iteration: dv_0 = (I + K_a)^-1 (dv_meas - b_a dt), \
                                 dv_(n+1) = (I + K_a)^-1 (dv_meas - b_a dt - D_a (dv_n o dv_n)/dt), \
                                 four steps. Each step multiplies the error by about \
                                 2 |D_a f| (1e-3 at 50e-6 s^2/m and 1 g), so after n steps it \
                                 is (2|D_a f|)^n |D_a (f o f)| dt, of order n + 1 in D_a: \
                                 after four, 5e-17 m/s at 50e-6 s^2/m, 1 g and 100 Hz. In a \
                                 turn the approximation of the integral adds D_a times the \
                                 within-record variance of f times dt (order dt^3: 2e-11 m/s \
                                 at 10 deg/s, 100 Hz, 1e-4 s^2/m). Rates: the same with dt = 1 \
                                 and f for dv"
                .into(),
            record_interval: "dt is each record's own interval t_k - t_(k-1) from its time \
                              stamps, as the estimator uses it; the first record, and a \
                              record after a gap (a step more than 10 % over the nominal \
                              1/sample_rate_hz of the run's metadata), cover one nominal step"
                .into(),
        }
    }
}
