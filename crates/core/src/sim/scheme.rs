//! Rotation schemes: built-in ones and the JSON form of SPEC §4.

use serde::{Deserialize, Serialize};

/// The axis a rotation turns about.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    X,
    Y,
    Z,
    E,
    N,
    U,
}

impl Axis {
    /// Unit vector of the axis in its own frame.
    pub fn unit_vector(self) -> [f64; 3] {
        match self {
            Axis::X | Axis::E => [1.0, 0.0, 0.0],
            Axis::Y | Axis::N => [0.0, 1.0, 0.0],
            Axis::Z | Axis::U => [0.0, 0.0, 1.0],
        }
    }
}

/// Which frame a rotation axis belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Frame {
    /// The unit's own axis, as on a turntable carrying the unit.
    #[default]
    Body,
    /// An axis fixed in the navigation frame (East, North, Up).
    Nav,
}

fn default_rate_dps() -> f64 {
    10.0
}
fn default_accel_dps2() -> f64 {
    20.0
}

/// One rotation step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rotate {
    pub axis: Axis,
    /// Signed angle, right-hand rule.
    pub angle_deg: f64,
    #[serde(default = "default_rate_dps")]
    pub rate_dps: f64,
    #[serde(default = "default_accel_dps2")]
    pub accel_dps2: f64,
    /// Absent means the frame the axis names: x, y, z are body axes and
    /// e, n, u navigation axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame: Option<Frame>,
}

impl Rotate {
    /// The frame of the rotation axis. SPEC §4 makes `body` the default;
    /// an axis named e, n or u without a frame can only mean `nav`.
    pub fn frame(&self) -> Frame {
        self.frame.unwrap_or(match self.axis {
            Axis::X | Axis::Y | Axis::Z => Frame::Body,
            Axis::E | Axis::N | Axis::U => Frame::Nav,
        })
    }

    /// Unit vector of the axis in its own frame.
    pub fn axis_vector(&self) -> [f64; 3] {
        self.axis.unit_vector()
    }
}

/// A turn by hand (SPEC §4): a smooth S-shaped turn about a body-fixed
/// axis while the reference point is lifted and set down elsewhere.
/// Angle a(u) = a·(u − sin 2πu / 2π), height h·sin²(πu), horizontal
/// shift s·(u − sin 2πu / 2π), u = τ/T.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Flip {
    /// Turn axis in body axes; normalised before use.
    pub axis_b: [f64; 3],
    /// Signed angle, right-hand rule about `axis_b`.
    pub angle_deg: f64,
    pub duration_s: f64,
    /// Peak height of the reference point above where it started, m.
    #[serde(default)]
    pub lift_m: f64,
    /// Where the reference point is set down, [east, north] m from where it
    /// was picked up.
    #[serde(default)]
    pub shift_m: [f64; 2],
}

impl Flip {
    /// The unit turn axis in body axes (`validate` ensures |axis_b| > 0).
    pub fn unit_axis_b(&self) -> [f64; 3] {
        let [x, y, z] = self.axis_b;
        let n = (x * x + y * y + z * z).sqrt();
        [x / n, y / n, z / n]
    }

    fn validate(&self) -> Result<(), String> {
        let finite = self.axis_b.iter().all(|v| v.is_finite())
            && self.angle_deg.is_finite()
            && self.duration_s.is_finite()
            && self.lift_m.is_finite()
            && self.shift_m.iter().all(|v| v.is_finite());
        if !finite {
            return Err("flip values must be finite".into());
        }
        if self.axis_b.iter().all(|&v| v == 0.0) {
            return Err("flip axis_b must not be zero".into());
        }
        if self.duration_s <= 0.0 {
            return Err(format!("flip duration_s {} must be > 0", self.duration_s));
        }
        Ok(())
    }
}

/// A step of a scheme: rest, a turntable turn, or a turn by hand.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Step {
    Dwell { dwell_s: f64 },
    Rotate { rotate: Rotate },
    Flip { flip: Flip },
}

/// A rotation scheme: a list of steps applied in order from the start
/// orientation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scheme {
    #[serde(default)]
    pub name: String,
    pub steps: Vec<Step>,
}

/// A scheme as it appears in metadata and truth: a built-in name or a
/// full object.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum SchemeRef {
    Name(String),
    Inline(Scheme),
}

/// Default dwell of the built-in schemes, s (the seed paper's simulation).
pub const DEFAULT_DWELL_S: f64 = 600.0;

/// Names of the built-in schemes.
pub const BUILTIN_NAMES: [&str; 2] = ["ten-position", "ten-position-9+9"];

impl SchemeRef {
    /// The scheme this names; built-ins take `dwell_s` (default 600 s).
    pub fn resolve(&self, dwell_s: Option<f64>) -> Result<Scheme, String> {
        match self {
            SchemeRef::Name(n) => Scheme::builtin(n, dwell_s.unwrap_or(DEFAULT_DWELL_S))
                .ok_or_else(|| {
                    format!("unknown scheme {n:?}; built-in schemes are {BUILTIN_NAMES:?}")
                }),
            SchemeRef::Inline(s) => {
                s.validate()?;
                Ok(s.clone())
            }
        }
    }
}

fn body(axis: Axis, angle_deg: f64) -> Step {
    Step::Rotate {
        rotate: Rotate {
            axis,
            angle_deg,
            rate_dps: default_rate_dps(),
            accel_dps2: default_accel_dps2(),
            frame: Some(Frame::Body),
        },
    }
}

fn with_dwells(name: &str, rotations: &[(Axis, f64)], dwell_s: f64) -> Scheme {
    let mut steps = vec![Step::Dwell { dwell_s }];
    for &(axis, angle) in rotations {
        steps.push(body(axis, angle));
        steps.push(Step::Dwell { dwell_s });
    }
    Scheme {
        name: name.to_string(),
        steps,
    }
}

/// The seed paper's nine rotations (SPEC §4).
const TEN_POSITION: [(Axis, f64); 9] = [
    (Axis::Y, 90.0),
    (Axis::Y, 180.0),
    (Axis::Y, 180.0),
    (Axis::Z, 90.0),
    (Axis::Z, 180.0),
    (Axis::Z, 180.0),
    (Axis::X, 90.0),
    (Axis::X, 180.0),
    (Axis::X, 180.0),
];

/// The nine quarter turns the 9+9 scheme appends.
const NINE_MORE: [(Axis, f64); 9] = [
    (Axis::X, 90.0),
    (Axis::X, 90.0),
    (Axis::X, 90.0),
    (Axis::Y, 90.0),
    (Axis::Y, 90.0),
    (Axis::Y, 90.0),
    (Axis::Z, 90.0),
    (Axis::Z, 90.0),
    (Axis::Z, 90.0),
];

impl Scheme {
    /// The positions it rests in: each run of consecutive dwells is one.
    pub fn positions(&self) -> usize {
        let dwell = |s: &Step| matches!(s, Step::Dwell { .. });
        let starts = self
            .steps
            .windows(2)
            .filter(|w| !dwell(&w[0]) && dwell(&w[1]));
        starts.count() + usize::from(self.steps.first().is_some_and(dwell))
    }

    /// A built-in scheme by name with the given dwell.
    pub fn builtin(name: &str, dwell_s: f64) -> Option<Scheme> {
        match name {
            "ten-position" => Some(with_dwells(name, &TEN_POSITION, dwell_s)),
            "ten-position-9+9" => {
                let all: Vec<_> = TEN_POSITION
                    .iter()
                    .chain(NINE_MORE.iter())
                    .copied()
                    .collect();
                Some(with_dwells(name, &all, dwell_s))
            }
            _ => None,
        }
    }

    /// Checks every step can be executed.
    pub fn validate(&self) -> Result<(), String> {
        if self.steps.is_empty() {
            return Err("scheme has no steps".into());
        }
        for (i, step) in self.steps.iter().enumerate() {
            let n = i + 1;
            match step {
                Step::Dwell { dwell_s } => {
                    if !(dwell_s.is_finite() && *dwell_s >= 0.0) {
                        return Err(format!("step {n}: dwell_s {dwell_s} must be ≥ 0"));
                    }
                }
                Step::Rotate { rotate: r } => {
                    if !r.angle_deg.is_finite() {
                        return Err(format!("step {n}: angle_deg is not finite"));
                    }
                    if !(r.rate_dps.is_finite() && r.rate_dps > 0.0) {
                        return Err(format!("step {n}: rate_dps {} must be > 0", r.rate_dps));
                    }
                    if !(r.accel_dps2.is_finite() && r.accel_dps2 > 0.0) {
                        return Err(format!("step {n}: accel_dps2 {} must be > 0", r.accel_dps2));
                    }
                    let named_body = matches!(r.axis, Axis::X | Axis::Y | Axis::Z);
                    if named_body != (r.frame() == Frame::Body) {
                        return Err(format!(
                            "step {n}: axis {:?} does not belong to frame {:?} (x, y, z are body axes; e, n, u navigation axes)",
                            r.axis,
                            r.frame()
                        ));
                    }
                }
                Step::Flip { flip } => flip.validate().map_err(|e| format!("step {n}: {e}"))?,
            }
        }
        Ok(())
    }

    /// Number of dwells and turns (turntable or by hand).
    pub fn counts(&self) -> (usize, usize) {
        let dwells = self
            .steps
            .iter()
            .filter(|s| matches!(s, Step::Dwell { .. }))
            .count();
        (dwells, self.steps.len() - dwells)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_have_the_paper_shape() {
        let s = Scheme::builtin("ten-position", 600.0).unwrap();
        assert_eq!(s.counts(), (10, 9));
        let s = Scheme::builtin("ten-position-9+9", 600.0).unwrap();
        assert_eq!(s.counts(), (19, 18));
        assert!(Scheme::builtin("eleven-position", 600.0).is_none());
    }

    #[test]
    fn json_form_parses_with_defaults() {
        let s: SchemeRef = serde_json::from_str(
            r#"{"name": "custom", "steps": [{"dwell_s": 60},
                {"rotate": {"axis": "y", "angle_deg": -90}},
                {"rotate": {"axis": "u", "angle_deg": 45, "rate_dps": 5, "accel_dps2": 10, "frame": "nav"}},
                {"dwell_s": 60}]}"#,
        )
        .unwrap();
        let s = s.resolve(None).unwrap();
        match s.steps[1] {
            Step::Rotate { rotate } => {
                assert_eq!(rotate.rate_dps, 10.0);
                assert_eq!(rotate.accel_dps2, 20.0);
                assert_eq!(rotate.frame(), Frame::Body);
            }
            _ => panic!("expected a rotation"),
        }
        let named: SchemeRef = serde_json::from_str(r#""ten-position""#).unwrap();
        assert_eq!(
            named.resolve(Some(60.0)).unwrap().steps[0],
            Step::Dwell { dwell_s: 60.0 }
        );
    }

    #[test]
    fn inconsistent_axis_and_frame_is_refused() {
        let s: Scheme = serde_json::from_str(
            r#"{"steps": [{"rotate": {"axis": "x", "angle_deg": 90, "frame": "nav"}}]}"#,
        )
        .unwrap();
        assert!(s.validate().unwrap_err().contains("step 1"));
    }

    #[test]
    fn positions_count_each_run_of_dwells_once() {
        assert_eq!(
            Scheme::builtin("ten-position", 30.0).unwrap().positions(),
            10
        );
        assert_eq!(
            Scheme::builtin("ten-position-9+9", 30.0)
                .unwrap()
                .positions(),
            19
        );
        let mut s = Scheme::builtin("ten-position", 30.0).unwrap();
        s.steps.insert(1, Step::Dwell { dwell_s: 5.0 });
        assert_eq!(s.positions(), 10);
    }
}
