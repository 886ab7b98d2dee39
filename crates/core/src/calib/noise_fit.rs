//! The noise model fitted to the run's own zero-velocity observations.
//!
//! What a real unit's raw outputs say about its noise is limited: a gyro
//! that outputs 1″ pulses hides an ARW of 0.0003 deg/√h under its
//! quantization at every τ a 600 s dwell offers, and a navigation-grade
//! gyro's bias instability sits below its white noise there too. The
//! zero-velocity observations see both plainly: a tilt that wanders makes
//! the velocity curve within minutes. So the terms are chosen to maximise
//! the likelihood of the pass's innovations, the parameters held at the
//! pass's estimate (`ProfileReplay::log_likelihood`), over the pass
//! replayed from its trace (`replay`, prepared once for every
//! evaluation), starting from what the Allan curves said.
//!
//! The search is a Nelder–Mead simplex in the logarithm of each term,
//! which follows the ridge that correlated terms make (a gyro's white
//! noise and the fast end of its flicker bank trade against each other)
//! where a coordinate search zigzags. It stops once the simplex's
//! likelihoods agree within a twentieth of a unit of ln L, a change of
//! the model the data cannot tell apart. It runs twice: the white
//! densities alone without wander (the still model), then every term. A
//! wander term the likelihood drives below a hundredth of its start is
//! dropped.
//!
//! A flat likelihood is no evidence of wander: where the data cannot tell
//! a bias instability from none, the search stops wherever the simplex
//! lies, and a term kept there widens every σ for nothing (a pulsed unit
//! without any wander kept 0.0002 deg/h and reported σ 1.8 times its
//! own). So wander must earn its place: the whole of it must beat the
//! still model, and then each term is dropped unless the likelihood falls
//! by more than [`KEEP_WANDER_LN_L`] without it, a likelihood-ratio test
//! at 1 % (the term sits on the boundary of its range, so the statistic
//! is half χ²₀ and half χ²₁).

use super::error::CalibError;
use super::noise_reference::reference_test;
use super::replay::PassTrace;
use super::walk::PassContext;
use crate::estimation::noise_model::{NoiseModel, TriadNoise};
use crate::model::Grade;

/// The terms the fit adjusts, as factors on the start model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum FreeTerm {
    GyroWhite,
    AccelWhite,
    GyroInstability,
    AccelInstability,
    GyroRandomWalk,
    AccelRandomWalk,
}

impl FreeTerm {
    /// What a run's zero-velocity observations settle: each triad's white
    /// noise, bias instability and bias random walk. The random walk is
    /// its own term: the flicker bank's amplitude is held by its fast end,
    /// so its slow end cannot stand in for a walk (a unit with K = 2.2
    /// µg/√h and B = 1 µg, fitted without K, drifted 1.5 µg in its last
    /// dwell at 5.6σ).
    pub const SETTLED: [FreeTerm; 6] = [
        FreeTerm::GyroWhite,
        FreeTerm::AccelWhite,
        FreeTerm::GyroInstability,
        FreeTerm::AccelInstability,
        FreeTerm::GyroRandomWalk,
        FreeTerm::AccelRandomWalk,
    ];

    pub(super) fn values(self, m: &mut NoiseModel) -> &mut [f64; 3] {
        use FreeTerm::*;
        let triad: &mut TriadNoise = match self {
            GyroWhite | GyroInstability | GyroRandomWalk => &mut m.gyro,
            AccelWhite | AccelInstability | AccelRandomWalk => &mut m.accel,
        };
        match self {
            GyroWhite | AccelWhite => &mut triad.white,
            GyroInstability | AccelInstability => &mut triad.instability,
            GyroRandomWalk | AccelRandomWalk => &mut triad.random_walk,
        }
    }

    /// Where a term the Allan curves did not resolve starts: a typical
    /// unit's size at `grade` (the search moves it by orders of magnitude
    /// if the run says so, but from a navigation unit's 0.001 deg/h a
    /// MEMS gyro's 10 deg/h is more than its evaluations can climb).
    pub(super) fn nominal(self, grade: Grade) -> f64 {
        use crate::model::units::{DEG_PER_H, DEG_PER_RT_H, HOUR, UG, UG_PER_RT_HZ};
        let per_rt_h = 1.0 / HOUR.sqrt();
        let (v, _) = self.typical(grade);
        match self {
            FreeTerm::GyroWhite => v * DEG_PER_RT_H,
            FreeTerm::AccelWhite => v * UG_PER_RT_HZ,
            FreeTerm::GyroInstability => v * DEG_PER_H,
            FreeTerm::AccelInstability => v * UG,
            FreeTerm::GyroRandomWalk => v * DEG_PER_H * per_rt_h,
            FreeTerm::AccelRandomWalk => v * UG * per_rt_h,
        }
    }

    /// [`FreeTerm::nominal`] in the units a datasheet gives, and those
    /// units.
    pub(super) fn typical(self, grade: Grade) -> (f64, &'static str) {
        let [gyro_b, gyro_k, accel_b, accel_k] = match grade {
            Grade::Navigation => [0.001, 0.0003, 2.0, 2.0],
            Grade::Tactical => [0.3, 0.1, 20.0, 20.0],
            Grade::Consumer => [5.0, 3.0, 50.0, 100.0],
        };
        match self {
            FreeTerm::GyroWhite => (0.0003, "deg/√h"),
            FreeTerm::AccelWhite => (5.0, "µg/√Hz"),
            FreeTerm::GyroInstability => (gyro_b, "deg/h"),
            FreeTerm::AccelInstability => (accel_b, "µg"),
            FreeTerm::GyroRandomWalk => (gyro_k, "deg/h/√h"),
            FreeTerm::AccelRandomWalk => (accel_k, "µg/√h"),
        }
    }

    /// The term as a result names it.
    pub(super) fn name(self) -> &'static str {
        match self {
            FreeTerm::GyroWhite => "gyro angle random walk",
            FreeTerm::AccelWhite => "accelerometer velocity random walk",
            FreeTerm::GyroInstability => "gyro bias instability",
            FreeTerm::AccelInstability => "accelerometer bias instability",
            FreeTerm::GyroRandomWalk => "gyro rate random walk",
            FreeTerm::AccelRandomWalk => "accelerometer bias random walk",
        }
    }

    /// Whether the term may vanish (wander may; white noise never does).
    pub(super) fn may_vanish(self) -> bool {
        !matches!(self, FreeTerm::GyroWhite | FreeTerm::AccelWhite)
    }
}

/// The first simplex's steps from the start (natural log, downwards: the
/// start's white densities are upper estimates).
const SIMPLEX_STEP: f64 = 0.7;

/// The search stops when the simplex's log-likelihoods agree within this
/// (a change of the noise model the data cannot tell apart)...
const VALUE_TOLERANCE: f64 = 0.05;

/// ... or it is this small (natural log: 3 %).
const SIZE_TOLERANCE: f64 = 0.03;

/// The most likelihood evaluations the search spends.
const MAX_EVALUATIONS: usize = 100;

/// Windows merged into one for the likelihood: zero-velocity updates every
/// 2 s instead of every second, at half the cost, which the noise terms'
/// estimates hardly feel (their information comes from hundreds of
/// thousands of seconds of rest).
pub(super) const DECIMATION: usize = 2;

/// How far below its start a white density may go (natural log).
const WHITE_FLOOR_LN: f64 = -9.2;

/// A wander term this far below its start (natural log) is dropped.
const VANISH_LN: f64 = -4.6;

/// The fall of ln L without a wander term above which the term is kept:
/// half the 98 % point of χ²₁ (5.41), the 1 % level of the boundary test.
pub(super) const KEEP_WANDER_LN_L: f64 = 2.71;

/// The rise of ln L over the still model above which `k` wander terms
/// together are kept: the 1 % level of the boundary test for k terms at
/// once, whose statistic 2 ΔlnL is the χ̄² mixture Σⱼ C(k, j) 2⁻ᵏ χ²ⱼ.
/// Judged by the one-term level, four free terms passed about one white
/// run in six by chance alone.
fn keep_joint_wander_ln_l(k: usize) -> f64 {
    // Half the mixture's 99 % points for k = 1…4 (5.41, 7.29, 8.75,
    // 10.02); `tests` recomputes them.
    const HALF_POINTS: [f64; 4] = [2.71, 3.64, 4.37, 5.01];
    HALF_POINTS[k.clamp(1, HALF_POINTS.len()) - 1]
}

/// The fitted model and how the search went.
#[derive(Clone, Debug)]
pub(crate) struct NoiseFit {
    pub model: NoiseModel,
    pub evaluations: usize,
    /// The wander terms the run did not resolve, carried at a typical
    /// unit's size for its grade ([`FreeTerm::nominal`]).
    pub assumed: Vec<FreeTerm>,
    /// The model the caller holds for the unit
    /// (`EstimateOptions::noise_reference`), when it holds one, tested
    /// against the likeliest model the search found.
    pub reference: Option<super::result::NoiseReferenceTest>,
}

impl NoiseFit {
    /// What the result says of the terms carried at a typical size.
    pub fn warnings(&self, grade: Grade) -> Vec<String> {
        let assumed = self.assumed.iter().map(|t| {
            let (value, unit) = t.typical(grade);
            format!(
                "the run does not resolve the {}: the filter carries a typical {grade} unit's {value} {unit}, and every σ allows for it",
                t.name()
            )
        });
        let reference = self.reference.filter(|r| !r.consistent).map(|r| {
            format!(
                "the run's noise is not the model held for the unit (likelihood ratio {:.1} against the 99 % point {:.1} of χ² with {} degrees of freedom): its noise has changed or the held model is wrong; the calibration rests on the run's own",
                r.statistic, r.threshold, r.degrees_of_freedom
            )
        });
        assumed.chain(reference).collect()
    }
}

/// Fits `free` terms of `start` to the trace of a pass of `ctx` (whose
/// effect states are scaled by `effect_scale`). Each term keeps its axes'
/// ratios; a term that starts at zero on every axis starts at its
/// [`FreeTerm::nominal`] size.
pub(crate) fn fit_noise(
    ctx: &PassContext,
    trace: &PassTrace,
    effect_scale: &[f64],
    start: &NoiseModel,
    free: &[FreeTerm],
) -> Result<NoiseFit, CalibError> {
    let mut start = *start;
    for t in free {
        let v = t.values(&mut start);
        if v.iter().all(|x| *x <= 0.0) {
            *v = [t.nominal(ctx.grade); 3];
        }
    }
    let space = LogSpace {
        start,
        free: free.to_vec(),
    };
    let filter = |m: &NoiseModel| ctx.filter_for(m, ctx.opts.zupt_sigma_mps, effect_scale);
    let replay = trace.profile(filter(&start), DECIMATION)?;
    let evaluate_model =
        |m: &NoiseModel| -> Result<f64, CalibError> { replay.log_likelihood(filter(m)) };
    let evaluate = |ln: &[f64]| evaluate_model(&space.model_at(ln));
    let marginal = |m: &NoiseModel| trace.log_likelihood(filter(m));
    // The white densities alone first, every wander term at zero: the
    // model without wander that the full one must beat.
    let wander: Vec<bool> = free.iter().map(|t| t.may_vanish()).collect();
    let white: Vec<bool> = wander.iter().map(|w| !w).collect();
    let x0: Vec<f64> = wander
        .iter()
        .map(|w| if *w { VANISH_LN } else { 0.0 })
        .collect();
    let (still, still_value, mut evaluations) = space.search(&evaluate, &x0, &white)?;
    if !wander.contains(&true) {
        let model = space.model_at(&still);
        return Ok(NoiseFit {
            reference: reference_test(
                ctx,
                &evaluate_model,
                &marginal,
                (&model, still_value),
                free.len(),
            )?,
            model,
            evaluations,
            assumed: Vec::new(),
        });
    }
    // Then every term, the wander from its start.
    let x1: Vec<f64> = still
        .iter()
        .zip(&wander)
        .map(|(v, w)| if *w { 0.0 } else { *v })
        .collect();
    let (mut ln, mut best, n) = space.search(&evaluate, &x1, &vec![true; free.len()])?;
    // The likeliest model found with every term free: what a held model is
    // tested against, whatever terms the tests below then drop.
    let peak = if best >= still_value {
        (space.model_at(&ln), best)
    } else {
        (space.model_at(&still), still_value)
    };
    evaluations += n;
    let wander_terms = wander.iter().filter(|w| **w).count();
    if best - still_value < keep_joint_wander_ln_l(wander_terms) {
        (ln, best) = (still, still_value);
    }
    // Each wander term in turn, those dropped staying dropped: a term
    // another explains as well goes. The white densities are fitted again
    // without it, since at rest they trade against wander (a gyro's ARW
    // tilts the unit as an accelerometer random walk of g·ARW would: 0.0003
    // deg/√h is 5.2 µg/√h), and a term judged against white densities
    // lowered to make room for it would always look needed.
    for (k, w) in wander.iter().enumerate() {
        if !*w || ln[k] <= VANISH_LN {
            continue;
        }
        let mut without = ln.clone();
        without[k] = VANISH_LN;
        let (refit, value, n) = space.search(&evaluate, &without, &white)?;
        evaluations += n;
        if best - value < KEEP_WANDER_LN_L {
            (ln, best) = (refit, value.max(best));
        }
    }
    let mut model = space.model_at(&ln);
    let assumed = carry_unresolved_wander(ctx.grade, free, &mut model);
    Ok(NoiseFit {
        reference: reference_test(
            ctx,
            &evaluate_model,
            &marginal,
            (&peak.0, peak.1),
            free.len(),
        )?,
        model,
        evaluations,
        assumed,
    })
}

/// Below navigation grade, each wander term the run did not resolve is
/// carried at a typical unit's size for the grade rather than at none:
/// the terms that are. A MEMS or tactical unit always wanders, but a
/// dwell of 5–30 s does not show 2–20 deg/h beside 0.2–1 deg/√h of white
/// noise, and the likelihood-ratio test keeps the term on no run; without
/// it the filter trusts the attitude it carries through the turns as if
/// the bias held still, and the σ came out 1.3 times too small (consumer
/// accelerometer scale factors; the simulated model given: 0.99). At
/// navigation grade a term the run does not ask for stays out: there the
/// wander is small beside the white noise over the run, and a term kept
/// without evidence widened σ 1.8 times.
fn carry_unresolved_wander(
    grade: Grade,
    free: &[FreeTerm],
    model: &mut NoiseModel,
) -> Vec<FreeTerm> {
    if grade == Grade::Navigation {
        return Vec::new();
    }
    let mut assumed = Vec::new();
    for t in free.iter().filter(|t| t.may_vanish()) {
        let v = t.values(model);
        if v.iter().all(|x| *x <= 0.0) {
            *v = [t.nominal(grade); 3];
            assumed.push(*t);
        }
    }
    assumed
}

/// The search space: each free term's natural-log factor on the start
/// model, a wander term at or below [`VANISH_LN`] dropped.
struct LogSpace {
    start: NoiseModel,
    free: Vec<FreeTerm>,
}

impl LogSpace {
    fn model_at(&self, ln: &[f64]) -> NoiseModel {
        let mut m = self.start;
        for (t, l) in self.free.iter().zip(ln) {
            let f = if *l <= VANISH_LN && t.may_vanish() {
                0.0
            } else {
                l.exp()
            };
            t.values(&mut m).iter_mut().for_each(|v| *v *= f);
        }
        m
    }

    /// Each factor raised to its floor: wander to where it vanishes, white
    /// noise to [`WHITE_FLOOR_LN`].
    fn clamp(&self, x: &mut [f64]) {
        for (v, t) in x.iter_mut().zip(&self.free) {
            let floor = if t.may_vanish() {
                VANISH_LN
            } else {
                WHITE_FLOOR_LN
            };
            *v = v.max(floor);
        }
    }

    /// The maximum of `evaluate` over the `moving` factors from `x0`, the
    /// others held: the point, its value and the evaluations spent.
    fn search(
        &self,
        evaluate: &dyn Fn(&[f64]) -> Result<f64, CalibError>,
        x0: &[f64],
        moving: &[bool],
    ) -> Result<(Vec<f64>, f64, usize), CalibError> {
        let embed = |y: &[f64]| {
            let mut x = x0.to_vec();
            let slots = x.iter_mut().zip(moving).filter(|(_, m)| **m);
            for ((v, _), value) in slots.zip(y) {
                *v = *value;
            }
            self.clamp(&mut x);
            x
        };
        let y0: Vec<f64> = x0
            .iter()
            .zip(moving)
            .filter(|(_, m)| **m)
            .map(|(v, _)| *v)
            .collect();
        let (y, value, n) = nelder_mead(|y: &[f64]| evaluate(&embed(y)), &y0)?;
        Ok((embed(&y), value, n))
    }
}

/// The maximum of `f` over R^n by Nelder–Mead from `origin`: a simplex
/// of steps [`SIMPLEX_STEP`] down each axis, reflected, expanded and
/// contracted until its values agree within [`VALUE_TOLERANCE`] or its size
/// falls below [`SIZE_TOLERANCE`], or [`MAX_EVALUATIONS`] are spent. It
/// follows the ridges that correlated terms make (a gyro's white noise and
/// the fast end of its flicker bank), where a coordinate search zigzags.
/// Returns the best point, its value and the evaluations spent.
fn nelder_mead(
    mut f: impl FnMut(&[f64]) -> Result<f64, CalibError>,
    origin: &[f64],
) -> Result<(Vec<f64>, f64, usize), CalibError> {
    let n = origin.len();
    let mut pts: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    pts.push((origin.to_vec(), f(origin)?));
    for i in 0..n {
        let mut x = origin.to_vec();
        x[i] -= SIMPLEX_STEP;
        pts.push((x.clone(), f(&x)?));
    }
    let mut evaluations = n + 1;
    let towards = |a: &[f64], b: &[f64], t: f64| -> Vec<f64> {
        a.iter().zip(b).map(|(a, b)| a + t * (b - a)).collect()
    };
    while evaluations < MAX_EVALUATIONS {
        pts.sort_by(|a, b| b.1.total_cmp(&a.1));
        let (best, worst) = (pts[0].1, pts[n].1);
        let size = pts
            .iter()
            .skip(1)
            .map(|(x, _)| {
                x.iter()
                    .zip(&pts[0].0)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        if best - worst < VALUE_TOLERANCE || size < SIZE_TOLERANCE {
            break;
        }
        let centroid: Vec<f64> = (0..n)
            .map(|j| pts[..n].iter().map(|(x, _)| x[j]).sum::<f64>() / n as f64)
            .collect();
        let reflected = towards(&centroid, &pts[n].0, -1.0);
        let fr = f(&reflected)?;
        evaluations += 1;
        if fr > best {
            let expanded = towards(&centroid, &pts[n].0, -2.0);
            let fe = f(&expanded)?;
            evaluations += 1;
            pts[n] = if fe > fr {
                (expanded, fe)
            } else {
                (reflected, fr)
            };
        } else if fr > pts[n - 1].1 {
            pts[n] = (reflected, fr);
        } else {
            let (base, fb) = if fr > worst {
                (reflected, fr)
            } else {
                (pts[n].0.clone(), worst)
            };
            let contracted = towards(&centroid, &base, 0.5);
            let fc = f(&contracted)?;
            evaluations += 1;
            if fc > fb {
                pts[n] = (contracted, fc);
            } else {
                // Shrink towards the best.
                for k in 1..=n {
                    let x = towards(&pts[0].0, &pts[k].0, 0.5);
                    pts[k] = (x.clone(), f(&x)?);
                    evaluations += 1;
                }
            }
        }
    }
    pts.sort_by(|a, b| b.1.total_cmp(&a.1));
    let (x, value) = pts.swap_remove(0);
    Ok((x, value, evaluations))
}

#[cfg(test)]
mod tests {
    use super::{carry_unresolved_wander, keep_joint_wander_ln_l, FreeTerm, NoiseFit};
    use crate::estimation::noise_model::NoiseModel;
    use crate::model::Grade;

    /// Below navigation grade the wander a fit left at zero is carried at
    /// the grade's typical size, and named so in the result; a term the
    /// fit kept stays as fitted; at navigation grade nothing is added.
    #[test]
    fn unresolved_wander_is_carried_below_navigation_grade_only() {
        let mut fitted = NoiseModel::white(1e-5, 1e-3);
        fitted.accel.instability = [2e-4; 3];
        let mut nav = fitted;
        assert!(
            carry_unresolved_wander(Grade::Navigation, &FreeTerm::SETTLED, &mut nav).is_empty()
        );
        assert_eq!(nav, fitted);
        let mut mems = fitted;
        let assumed = carry_unresolved_wander(Grade::Consumer, &FreeTerm::SETTLED, &mut mems);
        assert_eq!(
            assumed,
            [
                FreeTerm::GyroInstability,
                FreeTerm::GyroRandomWalk,
                FreeTerm::AccelRandomWalk
            ]
        );
        assert_eq!(mems.accel.instability, fitted.accel.instability);
        assert_eq!(mems.gyro.white, fitted.gyro.white);
        let deg_h = std::f64::consts::PI / 180.0 / 3600.0;
        assert!((mems.gyro.instability[2] / (5.0 * deg_h) - 1.0).abs() < 1e-12);
        let fit = NoiseFit {
            model: mems,
            evaluations: 0,
            assumed,
            reference: None,
        };
        let w = fit.warnings(Grade::Consumer);
        assert!(
            w[0].contains("gyro bias instability") && w[0].contains("consumer unit's 5 deg/h"),
            "{}",
            w[0]
        );
        assert!(
            w[2].contains("accelerometer bias random walk") && w[2].contains("100 µg/√h"),
            "{}",
            w[2]
        );
    }

    /// ln Γ(a) for a a positive multiple of ½.
    fn ln_gamma_half(a: f64) -> f64 {
        let (mut x, mut acc) = (a, 0.0f64);
        while x > 1.0 + 1e-9 {
            x -= 1.0;
            acc += x.ln();
        }
        // Γ(1) = 1, Γ(½) = √π.
        if (x - 0.5).abs() < 1e-9 {
            acc + 0.5 * std::f64::consts::PI.ln()
        } else {
            acc
        }
    }

    /// P(χ²_ν > x) = Q(ν/2, x/2), by the series of the lower function
    /// (enough terms for any x met here).
    fn chi2_tail(nu: usize, x: f64) -> f64 {
        let (a, h) = (nu as f64 / 2.0, x / 2.0);
        let (mut term, mut sum, mut n) = (1.0 / a, 1.0 / a, a);
        for _ in 0..400 {
            n += 1.0;
            term *= h / n;
            sum += term;
        }
        1.0 - sum * (-h + a * h.ln() - ln_gamma_half(a)).exp()
    }

    /// The boundary test's levels are the 1 % points of the χ̄² mixture
    /// Σⱼ C(k, j) 2⁻ᵏ χ²ⱼ of 2 ΔlnL.
    #[test]
    fn joint_wander_levels_are_the_mixture_s_one_percent_points() {
        for k in 1..=4usize {
            let tail = |x: f64| -> f64 {
                (1..=k)
                    .map(|j| {
                        let c = (1..=j).fold(1.0, |c, i| c * (k + 1 - i) as f64 / i as f64);
                        c / 2f64.powi(k as i32) * chi2_tail(j, x)
                    })
                    .sum()
            };
            let level = tail(2.0 * keep_joint_wander_ln_l(k));
            assert!((level - 0.01).abs() < 2e-4, "k = {k}: level {level}");
        }
        assert!((chi2_tail(2, 2.0 * 2.0_f64.ln()) - 0.5).abs() < 1e-12);
    }
}
