//! How each parameter of an effect outside the base model (SPEC §3) moves
//! the navigation errors over one record, from the motion the record
//! itself measured.
//!
//! Every SPEC §3 effect is linear in its parameters once the motion is
//! known: the sensed rate and specific force, their rates of change, the
//! time. The compensated records carry that motion, whatever it was (a
//! turntable's trapezoid, a hand flip about a wobbling axis, a unit
//! lifted and set down), so a column here needs no model of the scheme:
//! it is the effect applied to the motion that happened. Each is the
//! change the effect makes to the record's body-frame increment; the
//! walker rotates it to n by the mid-record attitude, as it does the base
//! columns of `sensitivity`, and removes known effects from the records
//! with the same columns.
//!
//! Rates of change come from the neighbouring records: the rate at a
//! record boundary from the four records around it (exact for a cubic),
//! so a record's ∫ω̇ dt and ∫ḟ dt are centred on it and good to fourth
//! order in the record length. Hand flips last a second or two; at 20 Hz
//! a three-point difference missed the lever arm's share by 0.4 %, a
//! hundred times its σ.

use nalgebra::{Matrix3, Vector3};

use crate::estimation::sensitivity::{base_columns, Rows};
use crate::nav::attitude::skew;

/// One effect parameter as an error state, in SI.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EffectParameter {
    /// Component `axis` of accelerometer `accel`'s position from the
    /// reference point, m.
    LeverArm { accel: usize, axis: usize },
    /// G[gyro][axis] of the gyro g-sensitivity, (rad/s)/(m/s²).
    GSensitivity { gyro: usize, axis: usize },
    /// The accelerometer channel's lag behind the gyros, s.
    AccelDelay,
    /// The delay's second-order term, per s² of τ²: ½ (ḟ(t) − ḟ(t − Δt)).
    /// The increment over (t − Δt − τ, t − τ] is the one over (t − Δt, t]
    /// less τ (f(t) − f(t − Δt)) plus τ² times this. Columns come from the
    /// records as the run holds them, delayed: the first-order column
    /// taken from them already carries twice this term, so on measured
    /// records the delay contributes τ E₁ − τ² E₂. A fast hand flip makes
    /// it 1 % of a 5 ms delay's signature, twenty times the noise; a fit
    /// carries it about its estimate.
    AccelDelaySquared,
    /// Gyro bias drift rate, rad/s².
    GyroBiasDrift(usize),
    /// Accelerometer bias drift rate, m/s³.
    AccelBiasDrift(usize),
    /// Gyro scale-factor asymmetry, dimensionless.
    GyroScaleAsymmetry(usize),
    /// SPEC §3a p1 of base parameter `.0` (canonical index; a bias or a
    /// scale factor), SI per °C: the parameter is p + p1 ΔT at every
    /// instant.
    ThermalLinear(usize),
    /// SPEC §3a p2 of base parameter `.0`, SI per °C²: the parameter is
    /// p + p1 ΔT + p2 ΔT². Carried only while the noise model is fitted
    /// to an in-run thermal calibration (`estimate::refit_noise`).
    ThermalQuadratic(usize),
    /// SPEC §3a k of gyro `.0`: the bias k Ṫ, (rad/s) per (°C/s).
    GyroBiasRate(usize),
}

/// What a walk carries beyond the base model: the effect states whose
/// columns it accumulates after the base 24, each in units of `scale`
/// (SI), and effects of known size (SI) it removes from every record
/// first (`known_effect_change`; a filter pass linearised about an
/// earlier pass's effect estimates).
#[derive(Clone, Debug, Default)]
pub struct EffectTerms {
    pub states: Vec<EffectParameter>,
    pub scale: Vec<f64>,
    pub removed: Vec<(EffectParameter, f64)>,
}

impl EffectTerms {
    pub fn none() -> Self {
        Self::default()
    }

    pub fn is_empty(&self) -> bool {
        self.states.is_empty() && self.removed.is_empty()
    }
}

/// Records on either side of the one a column is for.
pub const NEIGHBOURS: usize = 2;

/// What one record measured, compensated, with its neighbours.
#[derive(Clone, Copy, Debug)]
pub struct RecordMotion {
    /// Angle and velocity increments of records k − 2 … k + 2 (the record
    /// is the middle one; at either end of the run the nearest record
    /// stands in for a missing one).
    pub dtheta: [Vector3<f64>; 2 * NEIGHBOURS + 1],
    pub dv: [Vector3<f64>; 2 * NEIGHBOURS + 1],
    pub dt: f64,
    /// Mid-record time from the scheme's start (SPEC §3 `bias_drift`), s.
    pub t_mid: f64,
    /// The unit's temperature at mid-record less 25 °C, and its rate of
    /// change, °C/s (SPEC §3a; both 0 for a run without a temperature
    /// column).
    pub delta_c: f64,
    pub rate_c_per_s: f64,
    /// The accelerometer triad's response to its input at this record
    /// (`Compensator::accel_jacobian`), and its inverse.
    pub accel_jacobian: Matrix3<f64>,
    pub accel_jacobian_inv: Matrix3<f64>,
    /// The gyro triad's inverse response (`Compensator::gyro_jacobian_inv`).
    pub gyro_jacobian_inv: Matrix3<f64>,
}

/// x(t_k) − x(t_k − Δt) for x whose record means times Δt are `inc`:
/// each boundary value from the four record means around it.
fn change_over_record(inc: &[Vector3<f64>; 5], dt: f64) -> Vector3<f64> {
    (inc[0] - inc[1] * 8.0 + inc[3] * 8.0 - inc[4]) / (12.0 * dt)
}

impl RecordMotion {
    /// ∫(Ω̇ + Ω²) dt over the record, Ω = [ω×]: the matrix that takes an
    /// accelerometer's lever arm to the extra specific force it senses
    /// (ω̇ × r + ω × (ω × r)). With ω linear over the record, ∫Ω² dt is
    /// Δt (Ω̄² + Δt² Ω̇² / 12).
    fn lever_arm_matrix(&self) -> Matrix3<f64> {
        let dt = self.dt;
        let omega_change = change_over_record(&self.dtheta, dt);
        let omega = skew(&(self.dtheta[2] / dt));
        let omega_dot = skew(&(omega_change / dt));
        skew(&omega_change) + (omega * omega + omega_dot * omega_dot * (dt * dt / 12.0)) * dt
    }

    /// What a change `sensed` at the sensors' outputs (each component
    /// its own channel's extra output) becomes in the compensated record
    /// the walker reads: J⁻¹ sensed. Compensation inverts the whole
    /// model, and at 1 g an accelerometer's quadratic term alone makes
    /// its J differ from I by 2 D_a g ≈ 0.1 % (0.2 % between axis up and
    /// down): a thermal column taken as the sensed change itself biased a
    /// ramp's accelerometer coefficients by that much.
    fn sensed_to_record(&self, rows: Rows, sensed: Vector3<f64>) -> Vector3<f64> {
        match rows {
            Rows::Attitude => self.gyro_jacobian_inv * sensed,
            Rows::Velocity => self.accel_jacobian_inv * sensed,
        }
    }
}

/// The change effect parameter `p` makes to the record `m`'s body-frame
/// increment (SI per SI unit of the parameter), and the rows it drives:
/// attitude for the angle increment, velocity for the velocity one.
pub fn effect_column(p: EffectParameter, m: &RecordMotion) -> (Rows, Vector3<f64>) {
    use Rows::{Attitude as A, Velocity as V};
    let axis = |i: usize| Vector3::ith(i, 1.0);
    let (dtheta, dv) = (m.dtheta[NEIGHBOURS], m.dv[NEIGHBOURS]);
    match p {
        EffectParameter::LeverArm { accel, axis: j } => {
            // Accelerometer i senses (Ω̇ + Ω²) r_i more, through its own
            // row of the sensor model; compensation inverts the whole
            // triad's. The scale factors and misalignments then leak
            // ~1e-3 of each arm's share into the other axes: on hand flips,
            // whose arm signature is a hundred times the noise, that was a
            // remainder of z ≈ 8.
            let sensed = m.accel_jacobian.row(accel) * m.lever_arm_matrix().column(j);
            let body = m.accel_jacobian_inv.column(accel) * sensed[(0, 0)];
            (V, body)
        }
        EffectParameter::GSensitivity { gyro, axis: j } => sensed(m, A, axis(gyro) * dv[j]),
        EffectParameter::AccelDelay => {
            // The increment over (t − Δt − τ, t − τ] differs from the one
            // over (t − Δt, t] by −τ (f(t) − f(t − Δt)) to first order.
            // The delay acts on the input, which compensation returns.
            (V, -change_over_record(&m.dv, m.dt))
        }
        EffectParameter::AccelDelaySquared => {
            let curvature = m.dv[NEIGHBOURS + 1] - m.dv[NEIGHBOURS] * 2.0 + m.dv[NEIGHBOURS - 1];
            (V, curvature * (0.5 / (m.dt * m.dt)))
        }
        EffectParameter::GyroBiasDrift(i) => sensed(m, A, axis(i) * (m.t_mid * m.dt)),
        EffectParameter::AccelBiasDrift(i) => sensed(m, V, axis(i) * (m.t_mid * m.dt)),
        EffectParameter::GyroScaleAsymmetry(i) => sensed(m, A, axis(i) * dtheta[i].abs()),
        EffectParameter::ThermalLinear(i) => {
            let (rows, col) = base_column_b(i, &dtheta, &dv, m.dt);
            sensed(m, rows, col * m.delta_c)
        }
        EffectParameter::ThermalQuadratic(i) => {
            let (rows, col) = base_column_b(i, &dtheta, &dv, m.dt);
            sensed(m, rows, col * (m.delta_c * m.delta_c))
        }
        EffectParameter::GyroBiasRate(i) => sensed(m, A, axis(i) * (m.rate_c_per_s * m.dt)),
    }
}

/// An effect that adds to the sensors' outputs (SPEC §3, §3a): its rows
/// and its change to the compensated record.
fn sensed(m: &RecordMotion, rows: Rows, at_output: Vector3<f64>) -> (Rows, Vector3<f64>) {
    (rows, m.sensed_to_record(rows, at_output))
}

/// Base parameter `i`'s column over one record in body axes
/// (`sensitivity::base_columns` with the body as the frame).
fn base_column_b(
    i: usize,
    dtheta: &Vector3<f64>,
    dv: &Vector3<f64>,
    dt: f64,
) -> (Rows, Vector3<f64>) {
    let mut found = (Rows::Attitude, Vector3::zeros());
    base_columns(&Matrix3::identity(), dtheta, dv, dt, |k, rows, col| {
        if k == i {
            found = (rows, col);
        }
    });
    found
}

/// The change an effect parameter `p` of known size `value` (SI) makes
/// to the record `m`'s body-frame increment, and the rows it drives: its
/// column times the value, and for the delay, which is not linear at the
/// sizes a fast flip meets, with the second-order term (on the delayed
/// records a delay τ adds τE₁ − τ²E₂).
pub fn known_effect_change(
    p: EffectParameter,
    value: f64,
    m: &RecordMotion,
) -> (Rows, Vector3<f64>) {
    let (rows, col) = effect_column(p, m);
    let change = match p {
        EffectParameter::AccelDelay => {
            let (_, second) = effect_column(EffectParameter::AccelDelaySquared, m);
            col * value - second * (value * value)
        }
        _ => col * value,
    };
    (rows, change)
}
