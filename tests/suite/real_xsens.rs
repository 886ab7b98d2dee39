//! imu_tk's own Xsens MTi recording (tests/data/imu_tk: raw 16-bit
//! counts, jittered stamps, about 38 positions turned by hand) imported as
//! recorded, calibrated with the defaults, and scored by two figures that
//! do not depend on the tool that calibrated it:
//!
//! (a) the RMS over the static intervals of |calibrated mean specific
//!     force| − g;
//! (b) the RMS over consecutive intervals of the angle between one
//!     interval's gravity direction carried through the calibrated gyros'
//!     rotation and the next interval's measured gravity direction;
//!
//! the static intervals found by imu_tk's own rule on the raw
//! accelerometer (101-sample window, variance norm below twice that of
//! the first 50 s, at least 100 samples), g = 9.81744 m/s² as imu_tk's
//! app assumes. imu_tk's own calibration of this recording scores
//! (a) 0.00113 m/s², (b) 0.513° in-sample, and fitted on 0–288 s,
//! 0.00148 m/s² and 0.589° on the 20 intervals after.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use nalgebra::{Matrix3, Vector3};
use sinscal_core::calib::{estimate, CalibError, CalibrationResult, EstimateOptions, RecordSource};
use sinscal_core::io::imu_tk::{import_imu_tk, ImuTkImport, NominalTriad};
use sinscal_core::io::RunMetadata;
use sinscal_core::model::{Compensator, ErrorParameters, Grade};
use sinscal_core::nav::attitude::rotvec_to_dcm;
use sinscal_core::nav::Site;
use sinscal_core::pipeline::calibrate_file;
use sinscal_core::pipeline::FileSource;
use sinscal_core::Record;

const GRAVITY: f64 = 9.81744;
const DATA: &str = "tests/data/imu_tk";

/// imu_tk's recording as a counts run in `dir`, with the datasheet's
/// conversion.
fn import(dir: &Path) -> (PathBuf, RunMetadata) {
    let how = ImuTkImport {
        unit_serial: "XSENS-MTI".into(),
        site: Site {
            gravity_mps2: Some(GRAVITY),
            ..Site::new(45.4, 11.9, 12.0)
        },
        accel: NominalTriad {
            offset: [33123.0, 33276.0, 32360.0],
            counts_per_unit: [415.0, 413.0, 415.0],
        },
        gyro: NominalTriad {
            offset: [32768.0, 32466.0, 32485.0],
            counts_per_unit: [4778.0, 4758.0, 4766.0],
        },
    };
    let data = Path::new(DATA);
    let run = import_imu_tk(
        &data.join("xsens_acc.mat.gz"),
        &data.join("xsens_gyro.mat.gz"),
        dir,
        &how,
    )
    .expect("the recording imports");
    let meta = RunMetadata::from_json(&std::fs::read(&run.metadata).unwrap()).unwrap();
    (run.data, meta)
}

/// The recording's samples in physical units after the nominal
/// conversion: (t, ω (rad/s), f (m/s²), raw accelerometer counts).
struct Samples {
    t: Vec<f64>,
    omega: Vec<Vector3<f64>>,
    force: Vec<Vector3<f64>>,
    raw_accel: Vec<Vector3<f64>>,
}

fn samples(data: &Path, meta: &RunMetadata) -> Samples {
    let conv = meta.counts.expect("a counts run");
    let text = std::fs::read_to_string(data).unwrap();
    let mut s = Samples {
        t: Vec::new(),
        omega: Vec::new(),
        force: Vec::new(),
        raw_accel: Vec::new(),
    };
    for line in text.lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let raw = Vector3::new(v[4], v[5], v[6]);
        let phys = |off: [f64; 3], w: [f64; 3], c: [f64; 3]| {
            Vector3::from_fn(|i, _| (c[i] - off[i]) * w[i])
        };
        s.t.push(v[0]);
        s.omega
            .push(phys(conv.gyro.offset, conv.gyro.weight, [v[1], v[2], v[3]]));
        s.force.push(phys(
            conv.accel.offset,
            conv.accel.weight,
            [v[4], v[5], v[6]],
        ));
        s.raw_accel.push(raw);
    }
    s
}

/// imu_tk's static intervals (inclusive sample ranges) on the raw
/// accelerometer.
fn static_intervals(s: &Samples) -> Vec<(usize, usize)> {
    const HALF: usize = 50;
    let var = |from: usize, to: usize| {
        let n = (to - from + 1) as f64;
        let mean: Vector3<f64> = s.raw_accel[from..=to].iter().sum::<Vector3<f64>>() / n;
        s.raw_accel[from..=to]
            .iter()
            .map(|x| (x - mean).component_mul(&(x - mean)))
            .sum::<Vector3<f64>>()
            / (n - 1.0)
    };
    let init_end = s.t.iter().position(|&t| t >= s.t[0] + 50.0).unwrap() - 1;
    let threshold = 2.0 * var(0, init_end).norm();
    let (mut out, mut start) = (Vec::new(), None);
    for i in HALF..s.t.len() - HALF {
        let still = var(i - HALF, i + HALF).norm() < threshold;
        match (start, still) {
            (None, true) => start = Some(i),
            (Some(from), false) => {
                out.push((from, i - 1));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(from) = start {
        out.push((from, s.t.len() - HALF - 1));
    }
    out.retain(|&(a, b)| b + 1 - a >= 100);
    out
}

/// Figures (a) (m/s²) and (b) (deg) of `result`'s calibration over the
/// intervals `from..` of `intervals` (for (b), the pairs among them).
fn figures(s: &Samples, intervals: &[(usize, usize)], comp: &Compensator) -> (f64, f64) {
    let dt = 0.01;
    let rate = |w: &Vector3<f64>| comp.gyro(&(w * dt), dt) / dt;
    let force = |f: &Vector3<f64>| comp.accel(&(f * dt), dt) / dt;
    let means: Vec<Vector3<f64>> = intervals
        .iter()
        .map(|&(a, b)| s.force[a..=b].iter().map(force).sum::<Vector3<f64>>() / (b + 1 - a) as f64)
        .collect();
    let a = rms(means.iter().map(|m| m.norm() - GRAVITY));
    let angles = intervals.windows(2).zip(means.windows(2)).map(|(iv, m)| {
        let mut c = Matrix3::identity();
        for j in iv[0].1 + 1..=iv[1].0 {
            c *= rotvec_to_dcm(&(rate(&s.omega[j]) * (s.t[j] - s.t[j - 1])));
        }
        let carried = c.transpose() * m[0].normalize();
        carried.angle(&m[1].normalize()).to_degrees()
    });
    (a, rms(angles))
}

fn rms(x: impl Iterator<Item = f64>) -> f64 {
    let (mut sum, mut n) = (0.0, 0.0);
    for v in x {
        sum += v * v;
        n += 1.0;
    }
    (sum / n).sqrt()
}

fn compensator(result: &CalibrationResult) -> Compensator {
    let values = result
        .parameters
        .iter()
        .map(|(k, p)| (k.clone(), p.value))
        .collect();
    ErrorParameters::from_canonical(&values)
        .unwrap()
        .compensator()
}

fn calibrate(data: &Path, meta: &RunMetadata) -> CalibrationResult {
    let cancel = AtomicBool::new(false);
    calibrate_file(
        data,
        meta,
        &EstimateOptions::default(),
        &mut |_| {},
        &cancel,
    )
    .expect("the recording calibrates")
}

/// The whole recording, as recorded: a consumer unit by its noise, every
/// parameter with a finite σ, the model check's verdict stated, and the
/// two figures at least as good as the datasheet's by far; (b) at least as
/// good as imu_tk's.
#[test]
fn imu_tks_xsens_recording_calibrates_as_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let (data, meta) = import(dir.path());
    let result = calibrate(&data, &meta);
    assert_eq!(result.parameters.len(), 24);
    assert_eq!(
        result.grade,
        Some(Grade::Consumer),
        "named by its gyro noise"
    );
    for (name, p) in &result.parameters {
        assert!(
            p.sigma.is_finite() && p.sigma > 0.0,
            "{name}: σ {}",
            p.sigma
        );
    }
    let check = result.model_check.as_ref().expect("a model check");
    eprintln!("model check: {}", check.summary);
    let s = samples(&data, &meta);
    let intervals = static_intervals(&s);
    assert_eq!(intervals.len(), 42, "imu_tk's rule finds 42 intervals");
    let nominal = figures(&s, &intervals, &ErrorParameters::zero().compensator());
    assert!((nominal.0 - 0.0403).abs() < 5e-5 && (nominal.1 - 3.55).abs() < 5e-3);
    let (a, b) = figures(&s, &intervals, &compensator(&result));
    eprintln!("in-sample: (a) {a:.5} m/s², (b) {b:.3}° (imu_tk 0.00113, 0.513)");
    assert!(b <= 0.513, "(b) {b:.3}° against imu_tk's 0.513°");
    // Not yet imu_tk's 0.00113: see docs/FIGURES.md, "Real recordings".
    assert!(a <= 0.0016, "(a) {a:.5} m/s²");
}

/// The records of a run up to a time: a calibration fitted on the first
/// part of a recording.
struct Until {
    inner: FileSource,
    t_end: f64,
}

impl RecordSource for Until {
    fn records(
        &self,
    ) -> Result<Box<dyn Iterator<Item = Result<Record, CalibError>> + '_>, CalibError> {
        let t_end = self.t_end;
        Ok(Box::new(
            self.inner
                .records()?
                .take_while(move |r| !matches!(r, Ok(r) if r.t > t_end)),
        ))
    }
}

/// Fitted on 0–288 s and scored on the 20 intervals after, as imu_tk was
/// (0.00148 m/s², 0.589°). Printed, not yet held to imu_tk's figures:
/// before 288 s the unit rests with its x axis up only once, for 3.6 s,
/// and the x accelerometer's bias, scale factor and quadratic term are
/// not separated (docs/FIGURES.md). What is held: the fit calibrates and
/// states its verdict, and the held-out attitude figure stays within
/// 0.75°.
#[test]
fn fitted_on_the_first_288_s_and_scored_on_the_rest() {
    let dir = tempfile::tempdir().unwrap();
    let (data, meta) = import(dir.path());
    let (inner, run) = FileSource::of_run(&data, &meta);
    let source = Until {
        inner,
        t_end: 288.0,
    };
    let cancel = AtomicBool::new(false);
    let result = estimate(
        &source,
        &run,
        &EstimateOptions::default(),
        &mut |_| {},
        &cancel,
    )
    .expect("the first 288 s calibrate");
    let check = result.model_check.as_ref().expect("a model check");
    eprintln!("model check (0–288 s): {}", check.summary);
    let s = samples(&data, &meta);
    let intervals = static_intervals(&s);
    let after: Vec<_> = intervals
        .iter()
        .copied()
        .filter(|&(a, _)| s.t[a] > 288.0)
        .collect();
    assert_eq!(after.len(), 20);
    let (a, b) = figures(&s, &after, &compensator(&result));
    eprintln!("held out: (a) {a:.5} m/s², (b) {b:.3}° (imu_tk 0.00148, 0.589)");
    assert!(b <= 0.75, "(b) {b:.3}°");
}
