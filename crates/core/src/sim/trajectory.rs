//! The true motion of a unit: attitude, angular rate, angular
//! acceleration, specific force, and the reference point's path, at any
//! time of a scheme.
//!
//! Every step turns about an axis fixed in the body for its whole
//! duration: a body-axis step and a flip by definition, and a
//! navigation-axis step because the axis u^n, seen from a body turning
//! about it, stays put (a^b = C_n^b(t0) u^n). So within step s,
//! C_b^n(t) = C_b^n(t_s) exp([a×] θ(t − t_s)), and
//! ω_ib^b = C_n^b ω_ie^n + θ̇ a,  ω̇_ib^b = −θ̇ [a×] C_n^b ω_ie^n + θ̈ a.
//!
//! On a turntable the reference point rests: f^b = C_n^b f^n. A flip moves
//! it by a few centimetres relative to the Earth, so
//! f^n = f_rest^n + a^n + 2ω_ie^n × v^n (n is fixed to the Earth at the
//! site, so there is no transport rate). Gravity, its centrifugal part and
//! the Earth rate are those of the site throughout: over centimetres they
//! change by parts in 1e8 of g, far below any sensor's resolution.

use nalgebra::{Matrix3, Vector3};

use super::flip::FlipProfile;
use super::profile::RotationProfile;
use super::scheme::{Frame, Scheme, Step};
use crate::nav::attitude::rotvec_to_dcm;
use crate::nav::Site;

/// What the unit does during a segment.
#[derive(Clone, Copy, Debug)]
pub enum Motion {
    Dwell,
    Rotate {
        /// Rotation axis in body axes (unit vector).
        axis_b: Vector3<f64>,
        profile: RotationProfile,
    },
    /// A turn by hand: the reference point moves too.
    Flip {
        /// Turn axis in body axes (unit vector).
        axis_b: Vector3<f64>,
        profile: FlipProfile,
    },
}

/// One step of the scheme placed in time.
#[derive(Clone, Copy, Debug)]
pub struct Segment {
    pub t0: f64,
    pub t1: f64,
    /// Attitude at t0.
    pub c_b_n0: Matrix3<f64>,
    /// Reference point at t0, n, relative to where the run started, m.
    pub r_n0: Vector3<f64>,
    pub motion: Motion,
}

/// The true state at one instant.
#[derive(Clone, Copy, Debug)]
pub struct Kinematics {
    pub c_b_n: Matrix3<f64>,
    pub omega_ib_b: Vector3<f64>,
    pub omega_dot_ib_b: Vector3<f64>,
    pub f_b: Vector3<f64>,
    /// Reference point relative to where the run started, n, m.
    pub r_n: Vector3<f64>,
    /// Its velocity relative to the Earth, n, m/s.
    pub v_n: Vector3<f64>,
}

/// A scheme unrolled in time from a start attitude at a site.
#[derive(Clone, Debug)]
pub struct Trajectory {
    segments: Vec<Segment>,
    /// Times where the motion's acceleration jumps, ascending.
    breakpoints: Vec<f64>,
    omega_ie_n: Vector3<f64>,
    f_n: Vector3<f64>,
    c_b_n_start: Matrix3<f64>,
    c_b_n_end: Matrix3<f64>,
    r_n_end: Vector3<f64>,
}

impl Trajectory {
    /// Unrolls `scheme` from attitude `c_b_n_start` at t = 0.
    pub fn new(scheme: &Scheme, c_b_n_start: &Matrix3<f64>, site: &Site) -> Result<Self, String> {
        scheme.validate()?;
        let mut segments = Vec::with_capacity(scheme.steps.len());
        let mut breakpoints = vec![0.0];
        let mut t = 0.0;
        let mut c_b_n = *c_b_n_start;
        let mut r_n = Vector3::zeros();
        for step in &scheme.steps {
            match step {
                Step::Dwell { dwell_s } => {
                    if *dwell_s > 0.0 {
                        segments.push(Segment {
                            t0: t,
                            t1: t + dwell_s,
                            c_b_n0: c_b_n,
                            r_n0: r_n,
                            motion: Motion::Dwell,
                        });
                        t += dwell_s;
                    }
                }
                Step::Rotate { rotate } => {
                    let own = Vector3::from(rotate.axis_vector());
                    let axis_b = match rotate.frame() {
                        Frame::Body => own,
                        Frame::Nav => c_b_n.transpose() * own,
                    };
                    let profile = RotationProfile::new(
                        rotate.angle_deg.to_radians(),
                        rotate.rate_dps.to_radians(),
                        rotate.accel_dps2.to_radians(),
                    );
                    let d = profile.duration();
                    if d > 0.0 {
                        segments.push(Segment {
                            t0: t,
                            t1: t + d,
                            c_b_n0: c_b_n,
                            r_n0: r_n,
                            motion: Motion::Rotate { axis_b, profile },
                        });
                        for inner in profile.inner_breakpoints() {
                            breakpoints.push(t + inner);
                        }
                        t += d;
                        c_b_n *= rotvec_to_dcm(&(axis_b * profile.angle));
                    }
                }
                Step::Flip { flip } => {
                    let axis_b = Vector3::from(flip.unit_axis_b());
                    let profile = FlipProfile::new(flip);
                    let d = profile.duration();
                    segments.push(Segment {
                        t0: t,
                        t1: t + d,
                        c_b_n0: c_b_n,
                        r_n0: r_n,
                        motion: Motion::Flip { axis_b, profile },
                    });
                    t += d;
                    c_b_n *= rotvec_to_dcm(&(axis_b * profile.angle));
                    r_n += profile.position_at(d);
                }
            }
            breakpoints.push(t);
        }
        breakpoints.sort_by(f64::total_cmp);
        breakpoints.dedup();
        Ok(Trajectory {
            segments,
            breakpoints,
            omega_ie_n: site.omega_ie_n(),
            f_n: site.f_rest_n(),
            c_b_n_start: *c_b_n_start,
            c_b_n_end: c_b_n,
            r_n_end: r_n,
        })
    }

    /// Total duration T of the scheme, s.
    pub fn duration(&self) -> f64 {
        self.segments.last().map_or(0.0, |s| s.t1)
    }

    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    pub fn breakpoints(&self) -> &[f64] {
        &self.breakpoints
    }

    pub fn c_b_n_start(&self) -> Matrix3<f64> {
        self.c_b_n_start
    }

    /// The attitude after the last step, composed step by step (not
    /// integrated): the reference a navigated run must reach.
    pub fn c_b_n_end(&self) -> Matrix3<f64> {
        self.c_b_n_end
    }

    /// Where the reference point ends, relative to where it started, n, m.
    pub fn r_n_end(&self) -> Vector3<f64> {
        self.r_n_end
    }

    /// Index of the segment holding time t (the first for t < 0, the last
    /// for t beyond the end); `hint` speeds up forward scans.
    pub fn segment_index(&self, t: f64, hint: usize) -> usize {
        let n = self.segments.len();
        let mut i = hint.min(n.saturating_sub(1));
        while i > 0 && t < self.segments[i].t0 {
            i -= 1;
        }
        while i + 1 < n && t >= self.segments[i].t1 {
            i += 1;
        }
        i
    }

    /// The true state at time t, evaluated in segment `seg` (the caller
    /// picks the segment so that a breakpoint's one-sided value is chosen).
    /// Before t = 0 the unit rests in its start attitude; after the end, in
    /// its end attitude.
    pub fn kinematics_in(&self, seg: usize, t: f64) -> Kinematics {
        let rest = |c_b_n: Matrix3<f64>, r_n: Vector3<f64>| {
            let c_n_b = c_b_n.transpose();
            Kinematics {
                c_b_n,
                omega_ib_b: c_n_b * self.omega_ie_n,
                omega_dot_ib_b: Vector3::zeros(),
                f_b: c_n_b * self.f_n,
                r_n,
                v_n: Vector3::zeros(),
            }
        };
        let Some(s) = self.segments.get(seg) else {
            return rest(self.c_b_n_start, Vector3::zeros());
        };
        if t < 0.0 {
            return rest(self.c_b_n_start, Vector3::zeros());
        }
        // The turn's axis, angle, rate and acceleration; and the point's
        // displacement, velocity and acceleration (zero on a turntable).
        let (axis_b, angle, rate, accel, dr_n, v_n, a_n) = match s.motion {
            Motion::Dwell => return rest(s.c_b_n0, s.r_n0),
            Motion::Rotate { axis_b, profile } => {
                let tau = (t - s.t0).clamp(0.0, profile.duration());
                let zero = Vector3::zeros();
                (
                    axis_b,
                    profile.angle_at(tau),
                    profile.rate_at(tau),
                    profile.accel_at(tau),
                    zero,
                    zero,
                    zero,
                )
            }
            Motion::Flip { axis_b, profile } => {
                let tau = (t - s.t0).clamp(0.0, profile.duration());
                (
                    axis_b,
                    profile.angle_at(tau),
                    profile.rate_at(tau),
                    profile.accel_at(tau),
                    profile.position_at(tau),
                    profile.velocity_at(tau),
                    profile.acceleration_at(tau),
                )
            }
        };
        let c_b_n = s.c_b_n0 * rotvec_to_dcm(&(axis_b * angle));
        let c_n_b = c_b_n.transpose();
        let earth_b = c_n_b * self.omega_ie_n;
        let f_n = self.f_n + a_n + 2.0 * self.omega_ie_n.cross(&v_n);
        Kinematics {
            c_b_n,
            omega_ib_b: earth_b + axis_b * rate,
            omega_dot_ib_b: -rate * axis_b.cross(&earth_b) + axis_b * accel,
            f_b: c_n_b * f_n,
            r_n: s.r_n0 + dr_n,
            v_n,
        }
    }

    /// The true state at time t.
    pub fn kinematics(&self, t: f64) -> Kinematics {
        self.kinematics_in(self.segment_index(t, 0), t)
    }

    /// How far the motion within [ta, tb] in segment `seg` turns, rad,
    /// used to size quadrature pieces: the angle turned, and for a flip
    /// also the phase its harmonics (period T) advance, since the lift
    /// and shift vary on that scale even when the angle does not.
    pub fn angle_span(&self, seg: usize, ta: f64, tb: f64) -> f64 {
        match self.segments.get(seg).map(|s| (s.t0, s.motion)) {
            Some((t0, Motion::Rotate { profile, .. })) => {
                (profile.angle_at(tb - t0) - profile.angle_at(ta - t0)).abs()
            }
            Some((t0, Motion::Flip { profile, .. })) => {
                let turned = (profile.angle_at(tb - t0) - profile.angle_at(ta - t0)).abs();
                let phase = std::f64::consts::TAU * (tb - ta) / profile.duration();
                turned.max(phase)
            }
            _ => 0.0,
        }
    }
}
