//! The overlapping Allan variance, accumulated while the records stream
//! past.
//!
//! For cluster size m (τ = m τ0) over a stretch of n records with
//! increments u_k (angle or velocity) over intervals Δt_k, the cumulative
//! sums x_0 = 0, x_j = Σ_{k≤j} u_k at the times t_j = Σ_{k≤j} Δt_k give the
//! mean rate of each cluster, (x_{j+m} − x_j)/(t_{j+m} − t_j), and the
//! textbook estimator (IEEE Std 1293 Annex, NIST SP 1065 eq. 14)
//!
//! ```text
//! σ²(τ) = Σ_j (ȳ_{j+m,j+2m} − ȳ_{j,j+m})² / (2 (n + 1 − 2m)),
//! ```
//!
//! the variance of the difference of adjacent τ-averages of the rate,
//! taken at every start j (fully overlapping). With evenly stamped records
//! it is Σ_j (x_{j+2m} − 2 x_{j+m} + x_j)² / (2 τ² (n + 1 − 2m)). Each
//! cluster's rate is its increments over its own length (SPEC §2a: a
//! record's increments cover its own interval): with jittered stamps the
//! nominal length would leak the constant rate (gravity, Earth rate) times
//! the jitter into every difference, 0.1 % of g per 1 % of jitter at one
//! record, far above a navigation-grade accelerometer's noise.
//!
//! Each new x_j closes one term for every m with 2m ≤ j, so keeping the
//! last 2·m_max + 1 cumulative sums (and a block) is enough: memory grows
//! with the longest τ, never with the run. The terms are taken a block of
//! records at a time, one cluster size after another: each size then
//! reads the ring along two runs and keeps its sums in registers, where
//! taking every size at every record read ~90 scattered places of a ring
//! of megabytes (a 600 s dwell at 100 Hz). Each size's terms are added in
//! the same order either way. Several stretches (the dwells) add their
//! own terms to the same sums; a term never spans two of them, so the turns
//! between dwells are left out, and each stretch's constant part (Earth
//! rate, gravity, bias) cancels in the difference of adjacent rates.

/// Channels: the three gyro axes (angle increments), then the three
/// accelerometer axes (velocity increments).
pub const CHANNELS: usize = 6;

/// Records whose terms are taken together.
const BLOCK: usize = 64;

/// Cluster sizes (records per cluster) from 1 to at most `m_max`,
/// log-spaced at `per_decade` to a decade (rounded, repeats dropped).
pub fn cluster_sizes(m_max: usize, per_decade: usize) -> Vec<usize> {
    let mut out: Vec<usize> = Vec::new();
    for k in 0.. {
        let m = 10f64.powf(k as f64 / per_decade.max(1) as f64).round() as usize;
        if m > m_max {
            break;
        }
        if out.last() != Some(&m) {
            out.push(m);
        }
    }
    out
}

/// The overlapping Allan sums of every channel at a fixed set of cluster
/// sizes, over any number of stretches fed one after another.
///
/// ```
/// use sinscal_core::noise::allan::{cluster_sizes, OverlappingAllan};
/// let mut acc = OverlappingAllan::new(cluster_sizes(200, 10));
/// for k in 0..1000 {
///     // Δt of this record, then its increments Δθ x y z, Δv x y z.
///     let u = [1e-7 * (k % 3) as f64, 0.0, 0.0, 0.0, 0.0, 0.0981];
///     acc.push(0.01, &u);
/// }
/// acc.end_stretch();
/// let avar = acc.variance(0).unwrap(); // σ² at m = 1, (rad/s)² and (m/s²)²
/// assert!(avar[5] < 1e-20);
/// ```
pub struct OverlappingAllan {
    sizes: Vec<usize>,
    /// The last cumulative sums and their times, (x_j, t_j) at `j & mask`;
    /// a power-of-two length above 2·m_max.
    ring: Vec<([f64; CHANNELS], f64)>,
    mask: usize,
    /// Index of the latest cumulative sum in the open stretch (0: none
    /// pushed yet).
    j: usize,
    /// The latest index whose terms are taken.
    taken: usize,
    open: bool,
    /// The open stretch's first rate, whose share of each interval is
    /// subtracted from every increment: a constant rate leaves the
    /// differences unchanged, and without it the cumulative sums would grow
    /// with gravity or Earth rate times the dwell and bury the noise under
    /// rounding.
    reference: [f64; CHANNELS],
    x: [f64; CHANNELS],
    t: f64,
    /// Σ (difference of adjacent cluster rates)² per cluster size and
    /// channel, in rate units squared.
    sums: Vec<[f64; CHANNELS]>,
    terms: Vec<u64>,
    /// Records in each closed stretch, for the degrees of freedom.
    stretches: Vec<u64>,
}

impl OverlappingAllan {
    /// `sizes` ascending and distinct, at least 1.
    pub fn new(sizes: Vec<usize>) -> Self {
        let m_max = sizes.last().copied().unwrap_or(1);
        let len = (2 * m_max + BLOCK + 1).next_power_of_two();
        OverlappingAllan {
            terms: vec![0; sizes.len()],
            sums: vec![[0.0; CHANNELS]; sizes.len()],
            sizes,
            ring: vec![([0.0; CHANNELS], 0.0); len],
            mask: len - 1,
            j: 0,
            taken: 0,
            open: false,
            reference: [0.0; CHANNELS],
            x: [0.0; CHANNELS],
            t: 0.0,
            stretches: Vec::new(),
        }
    }

    /// One record's increments (Δθ x, y, z, then Δv x, y, z) over its own
    /// interval `dt_s` (> 0), at the end of the open stretch (opened by the
    /// first push after a close).
    pub fn push(&mut self, dt_s: f64, inc: &[f64; CHANNELS]) {
        if !self.open {
            self.open = true;
            self.j = 0;
            self.taken = 0;
            self.reference = inc.map(|u| u / dt_s);
            self.x = [0.0; CHANNELS];
            self.t = 0.0;
            self.ring[0] = (self.x, 0.0);
        }
        self.j += 1;
        for (x, (u, r)) in self.x.iter_mut().zip(inc.iter().zip(&self.reference)) {
            *x += u - r * dt_s;
        }
        self.t += dt_s;
        self.ring[self.j & self.mask] = (self.x, self.t);
        if self.j - self.taken == BLOCK {
            self.take_terms();
        }
    }

    /// The terms the cumulative sums after `taken` close, size by size.
    fn take_terms(&mut self) {
        let (from, to) = (self.taken + 1, self.j);
        for (i, &m) in self.sizes.iter().enumerate() {
            let first = from.max(2 * m);
            if first > to {
                // The sizes ascend: no larger one closes a term yet.
                break;
            }
            let mut sums = self.sums[i];
            for j in first..=to {
                let (last, t_last) = &self.ring[j & self.mask];
                let (mid, t_mid) = &self.ring[(j - m) & self.mask];
                let (start, t_start) = &self.ring[(j - 2 * m) & self.mask];
                let (late, early) = (1.0 / (t_last - t_mid), 1.0 / (t_mid - t_start));
                for c in 0..CHANNELS {
                    let d = (last[c] - mid[c]) * late - (mid[c] - start[c]) * early;
                    sums[c] += d * d;
                }
            }
            self.sums[i] = sums;
            self.terms[i] += (to + 1 - first) as u64;
        }
        self.taken = to;
    }

    /// Closes the open stretch, if any: the next record starts another.
    /// The sums are complete once the last stretch is closed.
    pub fn end_stretch(&mut self) {
        if self.open {
            self.take_terms();
            self.stretches.push(self.j as u64);
            self.open = false;
        }
    }

    pub fn sizes(&self) -> &[usize] {
        &self.sizes
    }

    /// Terms (overlapping pairs of adjacent clusters) per cluster size.
    pub fn terms(&self) -> &[u64] {
        &self.terms
    }

    /// Records of each closed stretch.
    pub fn stretches(&self) -> &[u64] {
        &self.stretches
    }

    /// σ²(τ) of each channel at cluster size index `i`, in the increments'
    /// units per second, squared (rad/s, m/s²); `None` where no stretch was
    /// long enough for a term. Read once the last stretch is closed.
    pub fn variance(&self, i: usize) -> Option<[f64; CHANNELS]> {
        let n = self.terms[i];
        if n == 0 {
            return None;
        }
        let scale = 1.0 / (2.0 * n as f64);
        Some(self.sums[i].map(|s| s * scale))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The textbook formula written out over the full series of each
    /// stretch, O(n·m): averages of the rate over adjacent clusters of m
    /// samples starting at every sample, their squared differences pooled
    /// over the stretches, halved.
    fn direct_avar(stretches: &[Vec<f64>], m: usize, tau0: f64) -> Option<f64> {
        let (mut sum, mut count) = (0.0, 0usize);
        for y in stretches {
            let rate: Vec<f64> = y.iter().map(|u| u / tau0).collect();
            if rate.len() < 2 * m {
                continue;
            }
            for k in 0..=rate.len() - 2 * m {
                let first: f64 = rate[k..k + m].iter().sum::<f64>() / m as f64;
                let second: f64 = rate[k + m..k + 2 * m].iter().sum::<f64>() / m as f64;
                sum += (second - first).powi(2);
                count += 1;
            }
        }
        (count > 0).then(|| sum / (2.0 * count as f64))
    }

    /// Random increments: an offset of each stretch's own (the constant a
    /// dwell projects), a slow wander, white noise.
    fn stretch(rng: &mut ChaCha8Rng, n: usize, offset: f64) -> Vec<[f64; CHANNELS]> {
        let mut wander = [0.0; CHANNELS];
        (0..n)
            .map(|_| {
                let mut u = [0.0; CHANNELS];
                for c in 0..CHANNELS {
                    wander[c] += 0.05 * (rng.gen::<f64>() - 0.5);
                    u[c] = offset * (c + 1) as f64 + wander[c] + (rng.gen::<f64>() - 0.5);
                }
                u
            })
            .collect()
    }

    fn compare(lengths: &[usize], m_max: usize) {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let tau0 = 0.01;
        let data: Vec<Vec<[f64; CHANNELS]>> = lengths
            .iter()
            .enumerate()
            .map(|(i, &n)| stretch(&mut rng, n, 3.0 - i as f64))
            .collect();
        let mut acc = OverlappingAllan::new(cluster_sizes(m_max, 10));
        for s in &data {
            s.iter().for_each(|u| acc.push(tau0, u));
            acc.end_stretch();
        }
        assert_eq!(
            acc.stretches(),
            lengths.iter().map(|&n| n as u64).collect::<Vec<_>>()
        );
        let mut checked = 0;
        for (i, &m) in acc.sizes().iter().enumerate() {
            let streamed = acc.variance(i);
            for c in 0..CHANNELS {
                let series: Vec<Vec<f64>> = data
                    .iter()
                    .map(|s| s.iter().map(|u| u[c]).collect())
                    .collect();
                let direct = direct_avar(&series, m, tau0);
                match (streamed, direct) {
                    (Some(s), Some(d)) => {
                        let rel = (s[c] - d).abs() / d;
                        assert!(rel < 1e-11, "m {m} channel {c}: {} vs {d} ({rel:e})", s[c]);
                        checked += 1;
                    }
                    (None, None) => {}
                    (s, d) => panic!("m {m}: streamed {s:?}, direct {d:?}"),
                }
            }
        }
        assert!(checked > 6 * 10, "{checked} comparisons");
    }

    #[test]
    fn streaming_overlapping_adev_equals_the_direct_formula_over_one_stretch() {
        compare(&[5000], 1200);
    }

    /// Stretches of unequal length, one shorter than the longest clusters
    /// (it must add terms only where it holds two clusters), each with its
    /// own offset: the pooled sums equal the direct pooling.
    #[test]
    fn streaming_overlapping_adev_equals_the_direct_formula_across_stretches() {
        compare(&[3000, 700, 4100, 1], 1000);
    }

    /// Records stamped with ±10 % jitter whose increments cover their own
    /// intervals (SPEC §2a): a constant rate as large as gravity leaves
    /// nothing, and white noise on top gives the direct formula's value
    /// over the records' own cluster lengths.
    #[test]
    fn jittered_stamps_leave_a_constant_rate_out() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let tau0 = 0.01;
        let n = 4000;
        let dt: Vec<f64> = (0..n)
            .map(|_| tau0 * (1.0 + 0.2 * (rng.gen::<f64>() - 0.5)))
            .collect();
        let noise: Vec<f64> = (0..n).map(|_| 1e-6 * (rng.gen::<f64>() - 0.5)).collect();
        let mut constant = OverlappingAllan::new(cluster_sizes(400, 10));
        let mut noisy = OverlappingAllan::new(cluster_sizes(400, 10));
        for k in 0..n {
            let u = [9.8 * dt[k]; CHANNELS];
            constant.push(dt[k], &u);
            noisy.push(dt[k], &u.map(|v| v + noise[k]));
        }
        constant.end_stretch();
        noisy.end_stretch();
        let t: Vec<f64> = std::iter::once(0.0)
            .chain(dt.iter().scan(0.0, |s, d| {
                *s += d;
                Some(*s)
            }))
            .collect();
        let x: Vec<f64> = std::iter::once(0.0)
            .chain(noise.iter().scan(0.0, |s, d| {
                *s += d;
                Some(*s)
            }))
            .collect();
        for (i, &m) in constant.sizes().iter().enumerate() {
            assert!(constant.variance(i).unwrap()[5] < 1e-18, "m {m}");
            let rate = |a: usize, b: usize| (x[b] - x[a]) / (t[b] - t[a]);
            let terms = n + 1 - 2 * m;
            let direct = (0..terms)
                .map(|j| (rate(j + m, j + 2 * m) - rate(j, j + m)).powi(2))
                .sum::<f64>()
                / (2.0 * terms as f64);
            let got = noisy.variance(i).unwrap()[0];
            assert!(
                (got / direct - 1.0).abs() < 1e-6,
                "m {m}: {got} vs {direct}"
            );
        }
    }

    #[test]
    fn cluster_sizes_are_log_spaced_and_distinct() {
        let m = cluster_sizes(100, 10);
        assert_eq!(
            m,
            [1, 2, 3, 4, 5, 6, 8, 10, 13, 16, 20, 25, 32, 40, 50, 63, 79, 100]
        );
        assert_eq!(cluster_sizes(0, 10), Vec::<usize>::new());
    }
}
