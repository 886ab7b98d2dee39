//! Strapdown mechanization on increments at a fixed site.
//!
//! Each record is advanced over its own interval Δt (SPEC §2a: stamps
//! jitter), which gravity, Coriolis and the navigation frame's turn
//! integrate over. The navigation frame n is East-North-Up at the site and turns with the
//! Earth, ω_in^n = ω_ie^n (the unit does not travel: ω_en^n is dropped, its
//! size at calibration speeds being below 1e-12 rad/s). Per record k:
//!
//! - attitude: C_b^n(k) = exp(−[ζ×]) C_b^n(k−1) exp([φ×]) with the body
//!   rotation vector φ = Δθ_k + (1/12) Δθ_{k−1} × Δθ_k (two-sample coning)
//!   and the navigation-frame rotation ζ = ω_ie^n Δt;
//! - velocity: Δv_sf^n = (I − ½[ζ×]) C_b^n(k−1) (Δv_k + δv_rot + δv_scul)
//!   with the rotation term δv_rot = ½ Δθ_k × Δv_k + (1/6) Δθ_k × (Δθ_k × Δv_k)
//!   and the two-sample sculling term
//!   δv_scul = (1/12)(Δθ_{k−1} × Δv_k + Δv_{k−1} × Δθ_k), then
//!   v^n(k) = v^n(k−1) + Δv_sf^n + (g^n − 2 ω_ie^n × v^n(k−1)) Δt.
//!
//! The ½[ζ×] term is what keeps a resting unit at rest: the body rotation
//! term ½Δθ×Δv contains the Earth rate the unit senses, and only the
//! matching navigation-frame term cancels it (CONTRACT §8.1). The
//! second-order rotation term matters on a turntable: for a steady turn at
//! rate ω under gravity, dropping it leaves −(1/6)[ω×]²f Δt³ per record,
//! which the sculling term (−1/12) does not cancel but doubles; together
//! with it the error vanishes at third order. At 10°/s and 100 Hz that is
//! 4e-5 m/s per quarter turn without it.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::attitude::rotvec_to_quat;
use super::earth::Site;
use crate::record::Record;

/// Navigation state of a unit at a fixed site, advanced one record at a time.
#[derive(Clone, Debug)]
pub struct Strapdown {
    /// Attitude, body to navigation.
    pub q_b_n: UnitQuaternion<f64>,
    /// Velocity relative to the Earth, in n (m/s).
    pub v_n: Vector3<f64>,
    /// Displacement from the site, in n (m).
    pub r_n: Vector3<f64>,
    /// Time of the last record processed (s).
    pub t: f64,
    dt: f64,
    g_n: Vector3<f64>,
    omega_ie_n: Vector3<f64>,
    /// Previous record's increments, for coning and sculling; `None` before
    /// the first record.
    prev: Option<(Vector3<f64>, Vector3<f64>)>,
    /// The navigation frame's turn exp(−[ζ×]) over the last interval met
    /// and that interval: evenly stamped records reuse it, saving two
    /// sines a record.
    frame_turn: (f64, UnitQuaternion<f64>),
}

impl Strapdown {
    /// Starts at rest at the site with attitude `c_b_n` at time `t0`, for
    /// records of nominal interval `dt`.
    pub fn new(site: &Site, c_b_n: &Matrix3<f64>, t0: f64, dt: f64) -> Self {
        Strapdown {
            q_b_n: UnitQuaternion::from_matrix(c_b_n),
            v_n: Vector3::zeros(),
            r_n: Vector3::zeros(),
            t: t0,
            dt,
            g_n: site.g_n(),
            omega_ie_n: site.omega_ie_n(),
            prev: None,
            frame_turn: (0.0, UnitQuaternion::identity()),
        }
    }

    pub fn c_b_n(&self) -> Matrix3<f64> {
        self.q_b_n.to_rotation_matrix().into_inner()
    }

    /// The nominal record interval, which [`Strapdown::update`] takes.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Forgets the previous increments, e.g. after a gap or when the
    /// increments' compensation changed, so no coning or sculling term
    /// mixes records of different meaning.
    pub fn reset_history(&mut self) {
        self.prev = None;
    }

    /// Advances by one record of compensated increments over the nominal
    /// interval (evenly stamped records, as a simulation makes them).
    pub fn update(&mut self, rec: &Record) {
        self.update_over(rec, self.dt);
    }

    /// Advances by one record of compensated increments over its own
    /// interval `dt` (s). The coning and sculling terms keep their
    /// equal-step coefficients: across steps that differ by a fraction ε
    /// they are right to about ε of their own (second-order) size.
    pub fn update_over(&mut self, rec: &Record, dt: f64) {
        let dtheta = Vector3::from(rec.dtheta);
        let dv = Vector3::from(rec.dv);
        let (dtheta_prev, dv_prev) = self.prev.unwrap_or((dtheta, dv));

        let zeta = self.omega_ie_n * dt;
        let c_prev = self.q_b_n;

        // Velocity first: it uses the attitude at the start of the record.
        let sculling = (dtheta_prev.cross(&dv) + dv_prev.cross(&dtheta)) / 12.0;
        let rot = dtheta.cross(&dv);
        let dv_b = dv + 0.5 * rot + dtheta.cross(&rot) / 6.0 + sculling;
        let dv_n_start = c_prev * dv_b;
        let dv_sf_n = dv_n_start - 0.5 * zeta.cross(&dv_n_start);
        let coriolis = 2.0 * self.omega_ie_n.cross(&self.v_n);
        let v_prev = self.v_n;
        self.v_n += dv_sf_n + (self.g_n - coriolis) * dt;
        self.r_n += 0.5 * (v_prev + self.v_n) * dt;

        let phi = dtheta + dtheta_prev.cross(&dtheta) / 12.0;
        self.q_b_n = self.frame_turn_over(dt) * c_prev * rotvec_to_quat(&phi);
        self.q_b_n.renormalize();

        self.prev = Some((dtheta, dv));
        self.t = rec.t;
    }

    /// exp(−[ζ×]), ζ = ω_ie^n Δt: the navigation frame's turn over `dt`.
    fn frame_turn_over(&mut self, dt: f64) -> UnitQuaternion<f64> {
        if self.frame_turn.0 != dt {
            self.frame_turn = (dt, rotvec_to_quat(&(-self.omega_ie_n * dt)));
        }
        self.frame_turn.1
    }

    /// Applies a feedback correction: the attitude error φ (in n, with
    /// C̃_b^n = exp([φ×]) C_b^n) and velocity error δv^n are removed.
    pub fn correct(&mut self, phi_n: &Vector3<f64>, dv_n: &Vector3<f64>, dr_n: &Vector3<f64>) {
        self.q_b_n = rotvec_to_quat(&(-phi_n)) * self.q_b_n;
        self.v_n -= dv_n;
        self.r_n -= dr_n;
    }
}
