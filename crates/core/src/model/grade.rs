//! The grade of a unit — navigation (ring-laser gyros), tactical, consumer
//! (MEMS) — and the size of the 24 parameters each grade's datasheets
//! allow: what the calibration's priors are scaled from.
//!
//! A run does not state its grade; its gyro noise does. The white angle
//! random walk the pre-scan measures spans three decades between grades
//! (ring-laser gyros 0.0005–0.005 deg/√h, tactical fibre-optic and MEMS
//! gyros 0.02–0.3, consumer MEMS 0.2–2), and a unit's noise cannot be
//! calibrated away, so it names the grade before any parameter is known.

use serde::{Deserialize, Serialize};

use super::params::{paper_magnitude, Group};
use super::units::{ARCSEC, DEG_PER_H, DEG_PER_RT_H, PPM, UG, UG_PER_G2};

/// A unit's grade.
/// Ordered from the smallest errors to the largest.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Grade {
    /// Ring-laser gyros and servo accelerometers: the seed paper's units.
    #[default]
    Navigation,
    /// Fibre-optic or tactical MEMS gyros, tactical accelerometers.
    Tactical,
    /// Consumer MEMS.
    Consumer,
}

/// Largest white gyro noise of a navigation-grade unit, rad/√s: ten times
/// the noisiest ring-laser gyro's 0.005 deg/√h.
const NAVIGATION_ARW_MAX: f64 = 0.05 * DEG_PER_RT_H;
/// Largest white gyro noise of a tactical unit, rad/√s.
const TACTICAL_ARW_MAX: f64 = 0.5 * DEG_PER_RT_H;
/// Largest gyro bias of a navigation-grade unit, rad/s: a hundred times
/// the seed paper's 0.05 deg/h, far above any ring-laser gyro.
const NAVIGATION_BIAS_MAX: f64 = 5.0 * DEG_PER_H;
/// Largest gyro bias of a tactical unit, rad/s: twice its datasheet's.
const TACTICAL_BIAS_MAX: f64 = 100.0 * DEG_PER_H;

impl Grade {
    pub const ALL: [Grade; 3] = [Grade::Navigation, Grade::Tactical, Grade::Consumer];

    pub fn as_str(self) -> &'static str {
        match self {
            Grade::Navigation => "navigation",
            Grade::Tactical => "tactical",
            Grade::Consumer => "consumer",
        }
    }

    /// The grade whose gyros have the white noise `arw` (rad/√s) a run
    /// measured.
    pub fn of_gyro_noise(arw: f64) -> Grade {
        if arw <= NAVIGATION_ARW_MAX {
            Grade::Navigation
        } else if arw <= TACTICAL_ARW_MAX {
            Grade::Tactical
        } else {
            Grade::Consumer
        }
    }

    /// The grade of a unit whose gyros read `rate_at_rest` (rad/s, the
    /// magnitude of a still stretch's mean rate) with white noise `arw`:
    /// the grade of its noise or of its bias, whichever is lower. A quiet
    /// MEMS gyro (0.2 deg/√h is tactical noise) still has a MEMS bias, and
    /// tactical priors would hold its 1 deg/s and 3° mountings back. The
    /// bias is at least the rate less the Earth rate `omega_ie` (rad/s).
    pub fn of_gyros(arw: f64, rate_at_rest: f64, omega_ie: f64) -> Grade {
        let bias_at_least = rate_at_rest - omega_ie;
        let by_bias = if bias_at_least > TACTICAL_BIAS_MAX {
            Grade::Consumer
        } else if bias_at_least > NAVIGATION_BIAS_MAX {
            Grade::Tactical
        } else {
            Grade::Navigation
        };
        Grade::of_gyro_noise(arw).max(by_bias)
    }

    /// The typical size of a parameter family at this grade, SI: the seed
    /// paper's Table 1 for navigation units; for the others half the
    /// largest error their datasheets allow (consumer MEMS: biases to
    /// 1 deg/s and 50 mg, scale factors to 2 %, mountings to 3°), so that
    /// the estimator's prior of four magnitudes spans twice the datasheet.
    pub fn magnitude(self, group: Group) -> f64 {
        const DEG: f64 = 3600.0 * ARCSEC;
        let datasheet_max = match (self, group) {
            (Grade::Navigation, _) => return paper_magnitude(group),
            (Grade::Tactical, Group::GyroBias) => 50.0 * DEG_PER_H,
            (Grade::Tactical, Group::GyroScale | Group::AccelScale) => 2000.0 * PPM,
            (Grade::Tactical, Group::GyroMisalign | Group::AccelMisalign) => 0.5 * DEG,
            (Grade::Tactical, Group::AccelBias) => 5000.0 * UG,
            (Grade::Tactical, Group::AccelQuad) => 1500.0 * UG_PER_G2,
            (Grade::Consumer, Group::GyroBias) => 3600.0 * DEG_PER_H,
            (Grade::Consumer, Group::GyroScale | Group::AccelScale) => 20_000.0 * PPM,
            (Grade::Consumer, Group::GyroMisalign | Group::AccelMisalign) => 3.0 * DEG,
            (Grade::Consumer, Group::AccelBias) => 50_000.0 * UG,
            (Grade::Consumer, Group::AccelQuad) => 2000.0 * UG_PER_G2,
        };
        0.5 * datasheet_max
    }

    /// Whether the horizontal Earth rate (Ω cos L, at most 15 deg/h) is
    /// below what this grade's gyro bias leaves uncertain at the start, so
    /// that the start heading cannot be found by gyrocompassing.
    pub fn earth_rate_hidden(self) -> bool {
        self != Grade::Navigation
    }

    /// Whether the velocity a motion leaves at the next rest is evidence
    /// about the parameters. For navigation units it is: the model
    /// follows a turn to micro-g. A MEMS unit turned by hand leaves
    /// velocity from what no 24-parameter model holds (its gyros' and
    /// accelerometers' bandwidths and sampling skew at 100 deg/s and
    /// more, a hand that does not put it down still), and on imu_tk's
    /// Xsens recording trusting it made every accelerometer parameter
    /// disagree with the least-squares cross-check. Its attitude through
    /// the motion is kept either way.
    pub fn trusts_motion_velocity(self) -> bool {
        self == Grade::Navigation
    }
}

impl std::fmt::Display for Grade {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gyro_noise_names_the_grade() {
        assert_eq!(
            Grade::of_gyro_noise(0.001 * DEG_PER_RT_H),
            Grade::Navigation
        );
        assert_eq!(Grade::of_gyro_noise(0.15 * DEG_PER_RT_H), Grade::Tactical);
        assert_eq!(Grade::of_gyro_noise(1.0 * DEG_PER_RT_H), Grade::Consumer);
    }

    #[test]
    fn a_mems_bias_names_the_grade_whatever_the_noise() {
        let earth = 15.04 * DEG_PER_H;
        let quiet = 0.2 * DEG_PER_RT_H;
        let of = |bias_deg_h: f64| Grade::of_gyros(quiet, bias_deg_h * DEG_PER_H + earth, earth);
        assert_eq!(of(0.0), Grade::Tactical);
        assert_eq!(of(3600.0), Grade::Consumer);
        let rlg = 0.0005 * DEG_PER_RT_H;
        assert_eq!(Grade::of_gyros(rlg, earth, earth), Grade::Navigation);
        assert_eq!(
            Grade::of_gyros(rlg, earth + 20.0 * DEG_PER_H, earth),
            Grade::Tactical
        );
    }

    #[test]
    fn every_grade_above_navigation_allows_larger_errors() {
        for group in Group::ALL {
            let [nav, tac, con] = Grade::ALL.map(|g| g.magnitude(group));
            assert!(nav < tac && tac < con, "{group:?}: {nav} {tac} {con}");
        }
    }
}
