//! WGS-84 and normal gravity exactly as SPEC §1.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// WGS-84 semi-major axis, m.
pub const WGS84_A: f64 = 6_378_137.0;
/// WGS-84 flattening.
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;
/// WGS-84 first eccentricity squared, e² = f(2 − f).
pub const WGS84_E2: f64 = WGS84_F * (2.0 - WGS84_F);
/// Earth rotation rate, rad/s.
pub const OMEGA_IE: f64 = 7.292_115_146_7e-5;
/// Standard gravity, used only to convert µg and g (SPEC §1).
pub const G0: f64 = 9.806_65;

/// Normal gravity magnitude (m/s²) at latitude `lat_rad` and ellipsoidal
/// height `h_m`: the closed form of SPEC §1, plumb-line gravity (gravitation
/// plus centrifugal).
pub fn normal_gravity(lat_rad: f64, h_m: f64) -> f64 {
    let s2 = lat_rad.sin().powi(2);
    9.780_325_335_9 * (1.0 + 0.001_931_852_652_41 * s2) / (1.0 - WGS84_E2 * s2).sqrt()
        - 3.086e-6 * h_m
}

/// The test site: where the unit sits, fixed to the Earth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Site {
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    pub height_m: f64,
    /// A measured local gravity that replaces the normal-gravity formula.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity_mps2: Option<f64>,
}

impl Site {
    /// The site of the contract's metadata example (Changsha, 50 m): the
    /// default of the command line's site flags, and where the simulated
    /// runs of the tests and benchmarks stand.
    pub const REFERENCE: Site = Site {
        latitude_deg: 28.2215,
        longitude_deg: 112.9924,
        height_m: 50.0,
        gravity_mps2: None,
    };

    pub fn new(latitude_deg: f64, longitude_deg: f64, height_m: f64) -> Self {
        Site {
            latitude_deg,
            longitude_deg,
            height_m,
            gravity_mps2: None,
        }
    }

    pub fn latitude_rad(&self) -> f64 {
        self.latitude_deg.to_radians()
    }

    /// Gravity magnitude g, m/s²: the metadata's value if given, else SPEC §1.
    pub fn gravity(&self) -> f64 {
        self.gravity_mps2
            .unwrap_or_else(|| normal_gravity(self.latitude_rad(), self.height_m))
    }

    /// Gravity vector in n (ENU): g^n = [0, 0, −g].
    pub fn g_n(&self) -> Vector3<f64> {
        Vector3::new(0.0, 0.0, -self.gravity())
    }

    /// Specific force sensed at rest, in n: f^n = [0, 0, g].
    pub fn f_rest_n(&self) -> Vector3<f64> {
        Vector3::new(0.0, 0.0, self.gravity())
    }

    /// Earth rate in n: ω_ie^n = [0, ω_ie cos L, ω_ie sin L].
    pub fn omega_ie_n(&self) -> Vector3<f64> {
        let l = self.latitude_rad();
        Vector3::new(0.0, OMEGA_IE * l.cos(), OMEGA_IE * l.sin())
    }

    /// Meridian and prime-vertical radii of curvature (R_M, R_N), m.
    pub fn radii(&self) -> (f64, f64) {
        let s2 = self.latitude_rad().sin().powi(2);
        let w = (1.0 - WGS84_E2 * s2).sqrt();
        let r_n = WGS84_A / w;
        let r_m = WGS84_A * (1.0 - WGS84_E2) / (w * w * w);
        (r_m, r_n)
    }

    /// Checks the site is physically meaningful; returns what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        if !(-90.0..=90.0).contains(&self.latitude_deg) {
            return Err(format!(
                "latitude_deg {} outside [-90, 90]",
                self.latitude_deg
            ));
        }
        if !(-180.0..=360.0).contains(&self.longitude_deg) {
            return Err(format!(
                "longitude_deg {} outside [-180, 360]",
                self.longitude_deg
            ));
        }
        if !self.height_m.is_finite() || self.height_m.abs() > 20_000.0 {
            return Err(format!("height_m {} outside ±20 km", self.height_m));
        }
        if let Some(g) = self.gravity_mps2 {
            if !(9.7..=9.9).contains(&g) {
                return Err(format!("gravity_mps2 {g} outside [9.7, 9.9]"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gravity_matches_wgs84_reference_values() {
        // Somigliana normal gravity: 9.7803253359 at the equator,
        // 9.8321849379 at the poles (WGS-84 defining values).
        assert!((normal_gravity(0.0, 0.0) - 9.780_325_335_9).abs() < 1e-10);
        assert!((normal_gravity(90f64.to_radians(), 0.0) - 9.832_184_937_9).abs() < 1e-8);
        // Free-air gradient.
        let dg = normal_gravity(0.5, 0.0) - normal_gravity(0.5, 1000.0);
        assert!((dg - 3.086e-3).abs() < 1e-12);
    }

    #[test]
    fn metadata_gravity_replaces_formula() {
        let mut s = Site::REFERENCE;
        assert!((s.gravity() - 9.791).abs() < 0.01);
        s.gravity_mps2 = Some(9.79136);
        assert_eq!(s.gravity(), 9.79136);
        assert_eq!(s.g_n().z, -9.79136);
    }

    #[test]
    fn earth_rate_components() {
        let s = Site::new(30.0, 0.0, 0.0);
        let w = s.omega_ie_n();
        assert_eq!(w.x, 0.0);
        assert!((w.norm() - OMEGA_IE).abs() < 1e-18);
        assert!((w.z - OMEGA_IE * 0.5).abs() < 1e-18);
    }
}
