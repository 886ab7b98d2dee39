//! The 24 error parameters: canonical names, units and their SI values.

use std::collections::BTreeMap;

use nalgebra::{Matrix3, Vector3};

use super::units::{ARCSEC, DEG_PER_H, PPM, UG, UG_PER_G2};

/// Number of parameters in the base model.
pub const N_PARAMS: usize = 24;

/// Families of parameters that share a unit and an accuracy requirement.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Group {
    GyroBias,
    GyroScale,
    GyroMisalign,
    AccelBias,
    AccelScale,
    AccelMisalign,
    AccelQuad,
}

impl Group {
    /// The family's place in [`Group::ALL`].
    pub fn index(self) -> usize {
        Group::ALL
            .iter()
            .position(|g| *g == self)
            .expect("every family is in Group::ALL")
    }

    /// Index of the family's first parameter in the canonical order.
    pub const fn first(self) -> usize {
        match self {
            Group::GyroBias => GYRO_BIAS,
            Group::GyroScale => GYRO_SCALE,
            Group::GyroMisalign => GYRO_MISALIGN,
            Group::AccelBias => ACCEL_BIAS,
            Group::AccelScale => ACCEL_SCALE,
            Group::AccelMisalign => ACCEL_MISALIGN,
            Group::AccelQuad => ACCEL_QUAD,
        }
    }

    /// Indices of the family's parameters in the canonical order.
    pub fn range(self) -> std::ops::Range<usize> {
        let len = match self {
            Group::AccelMisalign => 6,
            _ => 3,
        };
        self.first()..self.first() + len
    }

    /// Every family, in SPEC §2 table order.
    pub const ALL: [Group; 7] = [
        Group::GyroBias,
        Group::GyroScale,
        Group::GyroMisalign,
        Group::AccelBias,
        Group::AccelScale,
        Group::AccelMisalign,
        Group::AccelQuad,
    ];
}

/// A parameter's canonical name, reporting unit and what one unit is in SI.
#[derive(Clone, Copy, Debug)]
pub struct ParameterInfo {
    pub name: &'static str,
    pub unit: &'static str,
    pub si_per_unit: f64,
    pub group: Group,
}

const fn p(name: &'static str, unit: &'static str, si: f64, group: Group) -> ParameterInfo {
    ParameterInfo {
        name,
        unit,
        si_per_unit: si,
        group,
    }
}

/// The parameters in canonical order (SPEC §2 table). Index i of every
/// parameter vector in sinscal refers to `PARAMETERS[i]`.
pub const PARAMETERS: [ParameterInfo; N_PARAMS] = [
    p("gyro_bias_x", "deg/h", DEG_PER_H, Group::GyroBias),
    p("gyro_bias_y", "deg/h", DEG_PER_H, Group::GyroBias),
    p("gyro_bias_z", "deg/h", DEG_PER_H, Group::GyroBias),
    p("gyro_scale_x", "ppm", PPM, Group::GyroScale),
    p("gyro_scale_y", "ppm", PPM, Group::GyroScale),
    p("gyro_scale_z", "ppm", PPM, Group::GyroScale),
    p("gyro_misalign_xy", "arcsec", ARCSEC, Group::GyroMisalign),
    p("gyro_misalign_xz", "arcsec", ARCSEC, Group::GyroMisalign),
    p("gyro_misalign_yz", "arcsec", ARCSEC, Group::GyroMisalign),
    p("accel_bias_x", "ug", UG, Group::AccelBias),
    p("accel_bias_y", "ug", UG, Group::AccelBias),
    p("accel_bias_z", "ug", UG, Group::AccelBias),
    p("accel_scale_x", "ppm", PPM, Group::AccelScale),
    p("accel_scale_y", "ppm", PPM, Group::AccelScale),
    p("accel_scale_z", "ppm", PPM, Group::AccelScale),
    p("accel_misalign_xy", "arcsec", ARCSEC, Group::AccelMisalign),
    p("accel_misalign_xz", "arcsec", ARCSEC, Group::AccelMisalign),
    p("accel_misalign_yx", "arcsec", ARCSEC, Group::AccelMisalign),
    p("accel_misalign_yz", "arcsec", ARCSEC, Group::AccelMisalign),
    p("accel_misalign_zx", "arcsec", ARCSEC, Group::AccelMisalign),
    p("accel_misalign_zy", "arcsec", ARCSEC, Group::AccelMisalign),
    p("accel_quad_x", "ug/g^2", UG_PER_G2, Group::AccelQuad),
    p("accel_quad_y", "ug/g^2", UG_PER_G2, Group::AccelQuad),
    p("accel_quad_z", "ug/g^2", UG_PER_G2, Group::AccelQuad),
];

/// Index of a parameter by canonical name.
pub fn index_of(name: &str) -> Option<usize> {
    PARAMETERS.iter().position(|p| p.name == name)
}

/// The parameter of bias axis `axis`: gyro x, y, z (0..3), then
/// accelerometer x, y, z (3..6), the order of the noise model's bias axes.
pub const fn bias_parameter(axis: usize) -> usize {
    if axis < 3 {
        GYRO_BIAS + axis
    } else {
        ACCEL_BIAS + axis - 3
    }
}

// Offsets of each family in the canonical order.
const GYRO_BIAS: usize = 0;
const GYRO_SCALE: usize = 3;
const GYRO_MISALIGN: usize = 6;
const ACCEL_BIAS: usize = 9;
const ACCEL_SCALE: usize = 12;
const ACCEL_MISALIGN: usize = 15;
const ACCEL_QUAD: usize = 21;

/// Errors in a canonical parameter map.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ParameterError {
    #[error("unknown parameter {0:?}")]
    Unknown(String),
    #[error("missing parameter {0:?}")]
    Missing(&'static str),
    #[error("parameter {0:?} is not finite")]
    NotFinite(String),
}

/// The 24 parameters of SPEC §2, held in SI (rad/s, rad, m/s², s²/m,
/// dimensionless), in canonical order.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ErrorParameters {
    pub si: [f64; N_PARAMS],
}

impl ErrorParameters {
    pub fn zero() -> Self {
        Self::default()
    }

    /// From a map of canonical names to values in canonical units; every
    /// parameter must be present.
    pub fn from_canonical(map: &BTreeMap<String, f64>) -> Result<Self, ParameterError> {
        if let Some(unknown) = map.keys().find(|k| index_of(k).is_none()) {
            return Err(ParameterError::Unknown(unknown.clone()));
        }
        let mut si = [0.0; N_PARAMS];
        for (i, info) in PARAMETERS.iter().enumerate() {
            let v = *map
                .get(info.name)
                .ok_or(ParameterError::Missing(info.name))?;
            if !v.is_finite() {
                return Err(ParameterError::NotFinite(info.name.to_string()));
            }
            si[i] = v * info.si_per_unit;
        }
        Ok(ErrorParameters { si })
    }

    /// The values in canonical units, by canonical name.
    pub fn to_canonical(&self) -> BTreeMap<String, f64> {
        (0..N_PARAMS)
            .map(|i| (PARAMETERS[i].name.to_string(), self.canonical(i)))
            .collect()
    }

    /// Value of parameter `i` in its canonical unit: of the doubles next to
    /// SI / unit, one that [`Self::from_canonical`] turns back into the
    /// same SI value when there is one, so that a truth written in
    /// canonical units reproduces its run bit for bit.
    pub fn canonical(&self, i: usize) -> f64 {
        let (v, unit) = (self.si[i], PARAMETERS[i].si_per_unit);
        let c = v / unit;
        if c * unit == v || !c.is_finite() || c == 0.0 {
            return c;
        }
        // Neighbouring doubles of the same sign: adjacent bit patterns.
        (1..=8i64)
            .flat_map(|d| [d, -d])
            .map(|d| f64::from_bits((c.to_bits() as i64 + d) as u64))
            .find(|n| n * unit == v)
            .unwrap_or(c)
    }

    fn v3(&self, at: usize) -> Vector3<f64> {
        Vector3::new(self.si[at], self.si[at + 1], self.si[at + 2])
    }

    /// Gyro bias b_g, rad/s.
    pub fn b_g(&self) -> Vector3<f64> {
        self.v3(GYRO_BIAS)
    }

    /// Accelerometer bias b_a, m/s².
    pub fn b_a(&self) -> Vector3<f64> {
        self.v3(ACCEL_BIAS)
    }

    /// Accelerometer quadratic terms diag(D_a), s²/m.
    pub fn d_a(&self) -> Vector3<f64> {
        self.v3(ACCEL_QUAD)
    }

    /// Gyro scale-and-misalignment matrix K_g (upper triangular, SPEC §2).
    pub fn k_g(&self) -> Matrix3<f64> {
        let s = self.v3(GYRO_SCALE);
        let m = &self.si[GYRO_MISALIGN..GYRO_MISALIGN + 3];
        Matrix3::new(s.x, m[0], m[1], 0.0, s.y, m[2], 0.0, 0.0, s.z)
    }

    /// Accelerometer scale-and-misalignment matrix K_a (SPEC §2).
    pub fn k_a(&self) -> Matrix3<f64> {
        let s = self.v3(ACCEL_SCALE);
        let m = &self.si[ACCEL_MISALIGN..ACCEL_MISALIGN + 6];
        // m = [xy, xz, yx, yz, zx, zy]
        Matrix3::new(s.x, m[0], m[1], m[2], s.y, m[3], m[4], m[5], s.z)
    }

    /// Builds the parameters from the model's matrices and vectors. The
    /// entries of K_g below the diagonal must be zero (the body frame is
    /// defined by the gyros); they are ignored.
    pub fn from_parts(
        b_g: &Vector3<f64>,
        k_g: &Matrix3<f64>,
        b_a: &Vector3<f64>,
        k_a: &Matrix3<f64>,
        d_a: &Vector3<f64>,
    ) -> Self {
        let mut si = [0.0; N_PARAMS];
        si[GYRO_BIAS..GYRO_BIAS + 3].copy_from_slice(b_g.as_slice());
        si[GYRO_SCALE..GYRO_SCALE + 3].copy_from_slice(&[k_g[(0, 0)], k_g[(1, 1)], k_g[(2, 2)]]);
        si[GYRO_MISALIGN..GYRO_MISALIGN + 3].copy_from_slice(&[
            k_g[(0, 1)],
            k_g[(0, 2)],
            k_g[(1, 2)],
        ]);
        si[ACCEL_BIAS..ACCEL_BIAS + 3].copy_from_slice(b_a.as_slice());
        si[ACCEL_SCALE..ACCEL_SCALE + 3].copy_from_slice(&[k_a[(0, 0)], k_a[(1, 1)], k_a[(2, 2)]]);
        si[ACCEL_MISALIGN..ACCEL_MISALIGN + 6].copy_from_slice(&[
            k_a[(0, 1)],
            k_a[(0, 2)],
            k_a[(1, 0)],
            k_a[(1, 2)],
            k_a[(2, 0)],
            k_a[(2, 1)],
        ]);
        si[ACCEL_QUAD..ACCEL_QUAD + 3].copy_from_slice(d_a.as_slice());
        ErrorParameters { si }
    }

    /// The seed paper's Table 1 truth: 0.05 deg/h, 500 ppm, 200″, 200 µg,
    /// 500 ppm, 200″ and 50e-6 s²/m, all positive.
    pub fn paper() -> Self {
        let mut si = [0.0; N_PARAMS];
        for (i, info) in PARAMETERS.iter().enumerate() {
            si[i] = paper_magnitude(info.group);
        }
        ErrorParameters { si }
    }

    /// Composes a residual estimate with these parameters: if `self` was
    /// used to compensate the data and `delta` is what remains in the
    /// compensated data, the total is K = K̂ + (I + K̂) δK, b = b̂ + (I + K̂) δb
    /// (CONTRACT §8.4), which keeps K_g upper triangular. A quadratic term
    /// scales with its own channel, D_i = D̂_i + (1 + K̂_ii) δD_i; the cross
    /// terms K̂_ij δD_j are of second order and dropped.
    pub fn compose(&self, delta: &ErrorParameters) -> ErrorParameters {
        let i3 = Matrix3::identity();
        let (kg, ka) = (self.k_g(), self.k_a());
        let k_g = kg + (i3 + kg) * delta.k_g();
        let b_g = self.b_g() + (i3 + kg) * delta.b_g();
        let k_a = ka + (i3 + ka) * delta.k_a();
        let b_a = self.b_a() + (i3 + ka) * delta.b_a();
        let d_a = self.d_a() + (i3 + ka).diagonal().component_mul(&delta.d_a());
        ErrorParameters::from_parts(&b_g, &k_g, &b_a, &k_a, &d_a)
    }
}

impl ErrorParameters {
    /// A random truth: each parameter uniform in ±2× its paper magnitude,
    /// so signs are mixed (`sinscal simulate --params random`).
    pub fn random(rng: &mut impl rand::Rng) -> Self {
        Self::random_sized(rng, paper_magnitude)
    }

    /// A random truth with each parameter uniform in ±2× `magnitude` of
    /// its family, SI (a grade's sizes: `Grade::magnitude`).
    pub fn random_sized(rng: &mut impl rand::Rng, magnitude: impl Fn(Group) -> f64) -> Self {
        let mut si = [0.0; N_PARAMS];
        for (v, info) in si.iter_mut().zip(PARAMETERS.iter()) {
            *v = rng.gen_range(-2.0..=2.0) * magnitude(info.group);
        }
        ErrorParameters { si }
    }
}

/// The magnitude of each family in the seed paper's Table 1, in SI.
pub fn paper_magnitude(group: Group) -> f64 {
    match group {
        Group::GyroBias => 0.05 * DEG_PER_H,
        Group::GyroScale => 500.0 * PPM,
        Group::GyroMisalign => 200.0 * ARCSEC,
        Group::AccelBias => 200.0 * UG,
        Group::AccelScale => 500.0 * PPM,
        Group::AccelMisalign => 200.0 * ARCSEC,
        Group::AccelQuad => 50e-6,
    }
}

/// The seed paper's Table 1 accuracy for each family, canonical units
/// (deg/h, ppm, arcsec, ug, ug/g²): what a calibration of its simulated
/// runs must come within.
pub fn paper_accuracy(group: Group) -> f64 {
    match group {
        Group::GyroBias => 0.00075,
        Group::GyroScale => 2.0,
        Group::GyroMisalign => 1.5,
        Group::AccelBias => 5.0,
        Group::AccelScale => 2.0,
        Group::AccelMisalign => 1.5,
        Group::AccelQuad => 1.47,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_round_trip_and_units() {
        let p = ErrorParameters::paper();
        let map = p.to_canonical();
        assert_eq!(map.len(), 24);
        assert!((map["gyro_bias_x"] - 0.05).abs() < 1e-15);
        assert!((map["accel_bias_z"] - 200.0).abs() < 1e-12);
        // 50e-6 s²/m = 490.3325 µg/g².
        assert!((map["accel_quad_y"] - 490.3325).abs() < 1e-9);
        let back = ErrorParameters::from_canonical(&map).unwrap();
        for i in 0..N_PARAMS {
            assert!((back.si[i] - p.si[i]).abs() <= 1e-15 * p.si[i].abs());
        }
    }

    #[test]
    fn matrices_place_each_named_term() {
        let mut map: BTreeMap<String, f64> = PARAMETERS
            .iter()
            .map(|p| (p.name.to_string(), 0.0))
            .collect();
        map.insert("gyro_misalign_xz".into(), 1.0);
        map.insert("accel_misalign_zy".into(), 2.0);
        map.insert("accel_misalign_yx".into(), 3.0);
        let p = ErrorParameters::from_canonical(&map).unwrap();
        assert_eq!(p.k_g()[(0, 2)], ARCSEC);
        assert_eq!(p.k_a()[(2, 1)], 2.0 * ARCSEC);
        assert_eq!(p.k_a()[(1, 0)], 3.0 * ARCSEC);
        let q = ErrorParameters::from_parts(&p.b_g(), &p.k_g(), &p.b_a(), &p.k_a(), &p.d_a());
        assert_eq!(p, q);
    }

    #[test]
    fn unknown_and_missing_names_are_refused() {
        let mut map = ErrorParameters::zero().to_canonical();
        map.insert("gyro_bias_w".into(), 1.0);
        assert_eq!(
            ErrorParameters::from_canonical(&map),
            Err(ParameterError::Unknown("gyro_bias_w".into()))
        );
        let mut map = ErrorParameters::zero().to_canonical();
        map.remove("accel_quad_z");
        assert_eq!(
            ErrorParameters::from_canonical(&map),
            Err(ParameterError::Missing("accel_quad_z"))
        );
    }
}

#[cfg(test)]
mod group_tests {
    use super::*;

    #[test]
    fn family_ranges_tile_the_table() {
        let mut next = 0;
        for g in Group::ALL {
            assert_eq!(g.range().start, next);
            assert!(g.range().all(|i| PARAMETERS[i].group == g));
            next = g.range().end;
        }
        assert_eq!(next, N_PARAMS);
    }
}
