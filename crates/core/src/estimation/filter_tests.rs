//! The filter on data drawn from its own linear model.

use super::*;
use crate::estimation::sensitivity::Rows;

/// The filter on data drawn from its own linear model: every
/// parameter's error over many trials must be as large as its σ says,
/// at navigation grade (0.0003 deg/√h, 5 µg/√Hz) and at the noisy end
/// of tactical grade (0.003 deg/√h, 50 µg/√Hz).
#[test]
fn estimates_are_consistent_on_the_linear_model() {
    for (arw, vrw) in [(8.7e-8, 4.9e-5), (8.7e-7, 4.9e-4)] {
        check_linear_model_consistency(arw, vrw);
    }
}

fn check_linear_model_consistency(arw: f64, vrw: f64) {
    use nalgebra::{Matrix6xX, Vector6};
    use rand::{Rng, SeedableRng};
    use rand_distr::StandardNormal;
    let window = 1.0;
    let f = error_dynamics(
        &Vector3::new(0.0, 6.4e-5, 3.4e-5),
        &Vector3::new(0.0, 0.0, 9.79),
    );
    let mut qc = Matrix6::zeros();
    for i in 0..3 {
        qc[(i, i)] = arw * arw;
        qc[(i + 3, i + 3)] = vrw * vrw;
    }
    let a = transition(&f, window);
    let lq = process_noise(&f, &qc, window).cholesky().unwrap().l();
    let n_p = 4;
    let prior = vec![1e-3; n_p];
    let mut p0 = Matrix6::zeros();
    for i in 0..3 {
        p0[(i, i)] = 1e-6;
        p0[(i + 3, i + 3)] = 1e-8;
    }
    let trials = 30;
    let mut z2 = vec![0.0; n_p];
    for trial in 0..trials {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(trial);
        let mut normal = || rng.sample::<f64, _>(StandardNormal);
        let p_true: Vec<f64> = (0..n_p).map(|_| normal() * 1e-3).collect();
        let mut x = Vector6::from_fn(|i, _| if i < 3 { 1e-3 } else { 1e-4 });
        let noise = NoiseModel::white(arw, vrw);
        let mut kf = SystematicFilter::new(f, &p0, &prior, &noise, 0.0, 1e-6);
        for k in 0..1500 {
            // Each parameter drives a direction that changes every
            // 300 s, like a multi-position scheme.
            let phase = k / 300;
            let mut b = Matrix6xX::zeros(n_p);
            kf.add_record(0.5 * window, |cols| {
                for j in 0..n_p {
                    let ang = (phase * 7 + j * 3) as f64;
                    let col = Vector3::new(ang.sin(), ang.cos(), (0.3 * ang).sin()) * 1e-2;
                    let (rows, r0) = if j % 2 == 0 {
                        (Rows::Attitude, 0)
                    } else {
                        (Rows::Velocity, 3)
                    };
                    cols.set(j, rows, &col);
                    b.fixed_view_mut::<3, 1>(r0, j).copy_from(&col);
                }
            });
            // The same single mid-window record the filter expands.
            let fm = nalgebra::DMatrix::from_column_slice(6, 6, f.as_slice());
            let bd = nalgebra::DMatrix::from_column_slice(6, n_p, b.as_slice());
            let b_eff =
                &bd + &fm * &bd * (0.5 * window) + (&fm * &fm) * &bd * (0.125 * window * window);
            let bp = b_eff * DVector::from_vec(p_true.clone());
            let w = lq * Vector6::from_fn(|_, _| normal());
            x = a * x + Vector6::from_column_slice(bp.as_slice()) + w;
            kf.propagate(window, &Matrix3::identity());
            let z = Vector3::new(x[3], x[4], x[5]) + Vector3::from_fn(|_, _| normal() * 1e-6);
            kf.update_zero_velocity(&z, &Matrix3::identity()).unwrap();
            let (phi, dv) = kf.take_navigation_errors();
            for i in 0..3 {
                x[i] -= phi[i];
                x[i + 3] -= dv[i];
            }
        }
        let (d, s) = kf.parameters(0.0).unwrap();
        for j in 0..n_p {
            z2[j] += ((d[j] - p_true[j]) / s[j]).powi(2);
        }
    }
    for (j, v) in z2.iter().enumerate() {
        let rms = (v / trials as f64).sqrt();
        assert!(
            (0.7..1.3).contains(&rms),
            "ARW {arw} rad/√s, VRW {vrw} m/s/√s, parameter {j}: rms err/σ {rms}"
        );
    }
}
