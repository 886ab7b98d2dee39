use nalgebra::{DVector, Matrix6, Vector3, Cholesky, DMatrix};
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use sinscal::calib::filter::{error_dynamics, process_noise, transition, SystematicFilter};
use sinscal::calib::sensitivity::Rows;
fn main() {
    let win: f64 = std::env::args().nth(1).map(|s| s.parse().unwrap()).unwrap_or(1.0);
    let f = error_dynamics(&Vector3::new(0.0, 6.4e-5, 3.4e-5), &Vector3::new(0.0, 0.0, 9.79));
    let arw = 0.0003 * 0.000290888; let vrw = 5.0 * 9.80665e-6;
    let mut qc = Matrix6::zeros(); for i in 0..3 { qc[(i,i)] = arw*arw; qc[(i+3,i+3)] = vrw*vrw; }
    let a = transition(&f, win); let q = process_noise(&f, &qc, win);
    let lq = Cholesky::new(q).unwrap().l();
    let np = 6;
    let prior = vec![1e-3; np];
    let mut p0 = Matrix6::zeros(); for i in 0..3 { p0[(i,i)] = 1e-6; p0[(i+3,i+3)] = 1e-8; }
    let mut z2 = vec![0.0; np];
    let trials = 40;
    let nwin = (3000.0 / win) as usize;
    for trial in 0..trials {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(trial);
        let ptrue: Vec<f64> = (0..np).map(|_| rng.sample::<f64, _>(StandardNormal) * 1e-3).collect();
        let mut x = nalgebra::Vector6::<f64>::zeros();
        for i in 0..3 { x[i] = rng.sample::<f64,_>(StandardNormal) * 1e-3; x[i+3] = rng.sample::<f64,_>(StandardNormal) * 1e-4; }
        let mut kf = SystematicFilter::new(f, &p0, &prior, arw, vrw, 1e-6);
        for k in 0..nwin {
            // B: one column per param, pattern changes every 300 s
            let phase = ((k as f64 * win) / 300.0) as usize;
            let mut bmat = DMatrix::<f64>::zeros(6, np);
            for j in 0..np {
                let ang = (phase * 7 + j * 3) as f64;
                let col = Vector3::new(ang.sin(), ang.cos(), (ang*0.3).sin()) * 1e-2 * win;
                let rows = if j % 2 == 0 { Rows::Attitude } else { Rows::Velocity };
                let r0 = if j % 2 == 0 { 0 } else { 3 };
                // add as single mid-window record
                kf.add_column(j, rows, &(col / prior[j] * prior[j]), 0.5 * win);
                for r in 0..3 { bmat[(r0 + r, j)] = col[r]; }
            }
            // truth propagation consistent with filter's expansion of a single mid-window record
            let fm = DMatrix::from_column_slice(6,6,f.as_slice());
            let beff = &bmat + &fm * &bmat * (0.5*win) + (&fm * &fm) * &bmat * (0.125*win*win);
            let w: nalgebra::Vector6<f64> = lq * nalgebra::Vector6::from_fn(|_, _| rng.sample::<f64,_>(StandardNormal));
            let pv = DVector::from_vec(ptrue.clone());
            let bp = &beff * pv;
            x = a * x + nalgebra::Vector6::from_column_slice(bp.as_slice()) + w;
            kf.propagate(win);
            let zv = Vector3::new(x[3], x[4], x[5]) + Vector3::from_fn(|_, _| rng.sample::<f64,_>(StandardNormal) * 1e-6);
            kf.update_zero_velocity(&zv).unwrap();
            let (phi, dv) = kf.take_navigation_errors();
            for i in 0..3 { x[i] -= phi[i]; x[i+3] -= dv[i]; }
        }
        let (d, s) = kf.parameters();
        for j in 0..np { let z = (d[j] - ptrue[j]) / s[j]; z2[j] += z*z; }
    }
    println!("win {win}: rms z {:?}", z2.iter().map(|v| format!("{:.2}", (v / trials as f64).sqrt())).collect::<Vec<_>>());
}
