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
//!
//! The unit's gyros read a rest rate that follows the specific force
//! (100–560 deg/h/g: a MEMS gyro's g-sensitivity, which imu_tk's model
//! lacks), so the calibration is run twice: with the defaults, and with
//! `gyro_g_sensitivity` carried as states (`--model
//! base-24+gyro_g_sensitivity`), as a MEMS line would.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use nalgebra::{Matrix3, Vector3};
use sinscal_core::calib::{
    estimate, CalibError, CalibrationResult, Effect, ErrorModel, EstimateOptions, RecordSource,
};
use sinscal_core::io::imu_tk::{import_imu_tk, ImuTkImport, NominalTriad};
use sinscal_core::io::RunMetadata;
use sinscal_core::model::units::DEG_PER_H_PER_G;
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

/// A calibration as the figures apply it: the 24 parameters, and the
/// gyros' g-sensitivity G (rad/s per m/s², zero unless estimated), which
/// SPEC §3 adds to the rate output beside the bias.
struct Calibration {
    comp: Compensator,
    g_sensitivity: Matrix3<f64>,
}

impl Calibration {
    fn nominal() -> Self {
        Calibration {
            comp: ErrorParameters::zero().compensator(),
            g_sensitivity: Matrix3::zeros(),
        }
    }

    fn of(result: &CalibrationResult) -> Self {
        let values = result
            .parameters
            .iter()
            .map(|(k, p)| (k.clone(), p.value))
            .collect();
        let axes = ["x", "y", "z"];
        let g_sensitivity = Matrix3::from_fn(|i, j| {
            let name = format!("gyro_g_sensitivity_{}{}", axes[i], axes[j]);
            result
                .effects
                .get(&name)
                .map_or(0.0, |p| p.value * DEG_PER_H_PER_G)
        });
        Calibration {
            comp: ErrorParameters::from_canonical(&values)
                .unwrap()
                .compensator(),
            g_sensitivity,
        }
    }
}

/// Figures (a) (m/s²) and (b) (deg) of a calibration over `intervals`
/// (for (b), the consecutive pairs among them).
fn figures(s: &Samples, intervals: &[(usize, usize)], cal: &Calibration) -> (f64, f64) {
    let dt = 0.01;
    let comp = &cal.comp;
    let force = |f: &Vector3<f64>| comp.accel(&(f * dt), dt) / dt;
    let rate = |j: usize| {
        let w = s.omega[j] - cal.g_sensitivity * force(&s.force[j]);
        comp.gyro(&(w * dt), dt) / dt
    };
    let means: Vec<Vector3<f64>> = intervals
        .iter()
        .map(|&(a, b)| s.force[a..=b].iter().map(force).sum::<Vector3<f64>>() / (b + 1 - a) as f64)
        .collect();
    let a = rms(means.iter().map(|m| m.norm() - GRAVITY));
    let angles = intervals.windows(2).zip(means.windows(2)).map(|(iv, m)| {
        let mut c = Matrix3::identity();
        for j in iv[0].1 + 1..=iv[1].0 {
            c *= rotvec_to_dcm(&(rate(j) * (s.t[j] - s.t[j - 1])));
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

/// The defaults, or with the gyros' g-sensitivity as states.
fn options(g_sensitivity: bool) -> EstimateOptions {
    let mut opts = EstimateOptions::default();
    if g_sensitivity {
        opts.model = ErrorModel::with(&[Effect::GyroGSensitivity]);
    }
    opts
}

fn calibrate(data: &Path, meta: &RunMetadata, opts: &EstimateOptions) -> CalibrationResult {
    let cancel = AtomicBool::new(false);
    calibrate_file(data, meta, opts, &mut |_| {}, &cancel).expect("the recording calibrates")
}

/// Every parameter (and effect) with a finite σ, and the model check's
/// verdict stated.
fn assert_complete(result: &CalibrationResult, what: &str) {
    assert_eq!(result.parameters.len(), 24);
    for (name, p) in result.parameters.iter().chain(&result.effects) {
        assert!(
            p.sigma.is_finite() && p.sigma > 0.0,
            "{name}: σ {}",
            p.sigma
        );
    }
    let check = result.model_check.as_ref().expect("a model check");
    eprintln!("{what}: model check {}", check.summary);
}

/// The whole recording, as recorded: a consumer unit by its noise, every
/// parameter with a finite σ, the model check's verdict stated. With the
/// defaults (24 parameters) the gyro figure (b) beats imu_tk's and (a)
/// ties it to within 3 %; with the g-sensitivity carried both beat it,
/// (b) by a factor of four.
#[test]
fn imu_tks_xsens_recording_calibrates_as_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let (data, meta) = import(dir.path());
    let s = samples(&data, &meta);
    let intervals = static_intervals(&s);
    assert_eq!(intervals.len(), 42, "imu_tk's rule finds 42 intervals");
    let nominal = figures(&s, &intervals, &Calibration::nominal());
    assert!((nominal.0 - 0.0403).abs() < 5e-5 && (nominal.1 - 3.55).abs() < 5e-3);

    let base = calibrate(&data, &meta, &options(false));
    assert_eq!(base.grade, Some(Grade::Consumer), "named by its gyro noise");
    assert_complete(&base, "24 parameters");
    let (a, b) = figures(&s, &intervals, &Calibration::of(&base));
    eprintln!("in-sample, 24 parameters: (a) {a:.6} m/s², (b) {b:.3}° (imu_tk 0.00113, 0.513)");
    assert!(b <= 0.513, "(b) {b:.3}° against imu_tk's 0.513°");
    assert!(a <= 0.00116, "(a) {a:.6} m/s²");
    // The least squares trusts every rest's velocity drift with white
    // noise alone, where the filter's wander takes up the rate the
    // g-sensitivity leaves: the cross-check sees the missing effect (in
    // one warning) where the model check does not.
    let flagged = &base.cross_check.as_ref().expect("a cross-check").flagged;
    assert!(flagged.len() > 10, "{flagged:?}");
    let said = base.warnings.iter().filter(|w| w.contains("cross-check"));
    assert_eq!(said.count(), 1, "{:?}", base.warnings);

    let with_g = calibrate(&data, &meta, &options(true));
    assert_complete(&with_g, "with g-sensitivity");
    let (a, b) = figures(&s, &intervals, &Calibration::of(&with_g));
    eprintln!("in-sample, with g-sensitivity: (a) {a:.6} m/s², (b) {b:.3}°");
    assert!(a <= 0.00113, "(a) {a:.6} m/s² against imu_tk's 0.00113");
    assert!(b <= 0.513 / 2.0, "(b) {b:.3}° against imu_tk's 0.513°");
    let cross = with_g.cross_check.as_ref().expect("a cross-check");
    assert!(cross.flagged.is_empty(), "{:?}", cross.entries);
    // The cross-axis terms the dwells' rest rates show (100–560 deg/h/g),
    // each far above its σ; the diagonal ones show only in azimuth
    // (SPEC §3) and stay near their prior.
    let g = &with_g.effects;
    for name in ["xz", "yx", "yz", "zx", "zy"] {
        let p = &g[&format!("gyro_g_sensitivity_{name}")];
        eprintln!(
            "gyro_g_sensitivity_{name} {:.0} ± {:.0} deg/h/g",
            p.value, p.sigma
        );
        assert!(p.value.abs() > 5.0 * p.sigma, "{name}: {p:?}");
    }
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
/// (0.00148 m/s², 0.589°). Before 288 s the unit rests with its x axis up
/// once, for 3.6 s. Held: the fits calibrate with an adequate model
/// check; with the 24 parameters alone the |f| figure (a) is imu_tk's or
/// better, with the g-sensitivity the attitude figure (b). Printed: (a)
/// with the g-sensitivity, which one held-out position the fit never saw
/// decides (docs/FIGURES.md, "Real recordings").
#[test]
fn fitted_on_the_first_288_s_and_scored_on_the_rest() {
    let dir = tempfile::tempdir().unwrap();
    let (data, meta) = import(dir.path());
    let s = samples(&data, &meta);
    let after: Vec<_> = static_intervals(&s)
        .into_iter()
        .filter(|&(a, _)| s.t[a] > 288.0)
        .collect();
    assert_eq!(after.len(), 20);
    for (g_sensitivity, what) in [(false, "24 parameters"), (true, "with g-sensitivity")] {
        let (inner, run) = FileSource::of_run(&data, &meta);
        let source = Until {
            inner,
            t_end: 288.0,
        };
        let cancel = AtomicBool::new(false);
        let result = estimate(&source, &run, &options(g_sensitivity), &mut |_| {}, &cancel)
            .expect("the first 288 s calibrate");
        assert_complete(&result, &format!("0–288 s, {what}"));
        let check = result.model_check.as_ref().unwrap();
        assert!(check.adequate, "0–288 s, {what}: {}", check.summary);
        let (a, b) = figures(&s, &after, &Calibration::of(&result));
        eprintln!("held out, {what}: (a) {a:.6} m/s², (b) {b:.3}° (imu_tk 0.00148, 0.589)");
        let bound = if g_sensitivity { 0.589 } else { 0.65 };
        assert!(b <= bound, "(b) {b:.3}°");
        if !g_sensitivity {
            assert!(a <= 0.00148, "(a) {a:.6} m/s² against imu_tk's 0.00148");
        }
    }
}
