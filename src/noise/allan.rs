//! The overlapping Allan variance, accumulated while the records stream
//! past.
//!
//! For cluster size m (τ = m τ0) over a stretch of n records with
//! increments u_k (angle or velocity), the cumulative sums x_0 = 0,
//! x_j = Σ_{k≤j} u_k give the textbook estimator (IEEE Std 1293 Annex,
//! NIST SP 1065 eq. 14)
//!
//! ```text
//! σ²(τ) = Σ_j (x_{j+2m} − 2 x_{j+m} + x_j)² / (2 τ² (n + 1 − 2m)),
//! ```
//!
//! which is the variance of the difference of adjacent τ-averages of the
//! rate, taken at every start j (fully overlapping). Each new x_j closes
//! one term for every m with 2m ≤ j, so keeping the last 2·m_max + 1
//! cumulative sums is enough: memory grows with the longest τ, never with
//! the run. Several stretches (the dwells) add their own terms to the same
//! sums; a term never spans two of them, so the turns between dwells are
//! left out, and each stretch's constant part (Earth rate, gravity, bias)
//! cancels in the second difference.

/// Channels: the three gyro axes (angle increments), then the three
/// accelerometer axes (velocity increments).
pub const CHANNELS: usize = 6;

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
pub struct OverlappingAllan {
    sizes: Vec<usize>,
    /// The last cumulative sums, x_j at `j & mask`; a power-of-two length
    /// above 2·m_max.
    ring: Vec<[f64; CHANNELS]>,
    mask: usize,
    /// Index of the latest cumulative sum in the open stretch (0: none
    /// pushed yet).
    j: usize,
    open: bool,
    /// The open stretch's first increment, subtracted from every one: a
    /// constant leaves the second differences unchanged, and without it
    /// the cumulative sums would grow with gravity or Earth rate times the
    /// dwell and bury the noise under rounding.
    reference: [f64; CHANNELS],
    x: [f64; CHANNELS],
    /// Σ (second difference)² per cluster size and channel, in the
    /// increments' units squared.
    sums: Vec<[f64; CHANNELS]>,
    terms: Vec<u64>,
    /// Records in each closed stretch, for the degrees of freedom.
    stretches: Vec<u64>,
}

impl OverlappingAllan {
    /// `sizes` ascending and distinct, at least 1.
    pub fn new(sizes: Vec<usize>) -> Self {
        let m_max = sizes.last().copied().unwrap_or(1);
        let len = (2 * m_max + 1).next_power_of_two();
        OverlappingAllan {
            terms: vec![0; sizes.len()],
            sums: vec![[0.0; CHANNELS]; sizes.len()],
            sizes,
            ring: vec![[0.0; CHANNELS]; len],
            mask: len - 1,
            j: 0,
            open: false,
            reference: [0.0; CHANNELS],
            x: [0.0; CHANNELS],
            stretches: Vec::new(),
        }
    }

    /// One record's increments (Δθ x, y, z, then Δv x, y, z) at the end of
    /// the open stretch (opened by the first push after a close).
    pub fn push(&mut self, inc: &[f64; CHANNELS]) {
        if !self.open {
            self.open = true;
            self.j = 0;
            self.reference = *inc;
            self.x = [0.0; CHANNELS];
            self.ring[0] = self.x;
        }
        self.j += 1;
        for (x, (u, r)) in self.x.iter_mut().zip(inc.iter().zip(&self.reference)) {
            *x += u - r;
        }
        let j = self.j;
        self.ring[j & self.mask] = self.x;
        for (i, &m) in self.sizes.iter().enumerate() {
            if 2 * m > j {
                break;
            }
            let mid = &self.ring[(j - m) & self.mask];
            let first = &self.ring[(j - 2 * m) & self.mask];
            let sums = &mut self.sums[i];
            for c in 0..CHANNELS {
                let d = self.x[c] - 2.0 * mid[c] + first[c];
                sums[c] += d * d;
            }
            self.terms[i] += 1;
        }
    }

    /// Closes the open stretch, if any: the next record starts another.
    pub fn end_stretch(&mut self) {
        if self.open {
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
    /// units per second, squared (rad/s, m/s²), for a record interval
    /// `tau0_s`; `None` where no stretch was long enough for a term.
    pub fn variance(&self, i: usize, tau0_s: f64) -> Option<[f64; CHANNELS]> {
        let n = self.terms[i];
        if n == 0 {
            return None;
        }
        let tau = self.sizes[i] as f64 * tau0_s;
        let scale = 1.0 / (2.0 * tau * tau * n as f64);
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
            s.iter().for_each(|u| acc.push(u));
            acc.end_stretch();
        }
        assert_eq!(
            acc.stretches(),
            lengths.iter().map(|&n| n as u64).collect::<Vec<_>>()
        );
        let mut checked = 0;
        for (i, &m) in acc.sizes().iter().enumerate() {
            let streamed = acc.variance(i, tau0);
            for c in 0..CHANNELS {
                let series: Vec<Vec<f64>> = data
                    .iter()
                    .map(|s| s.iter().map(|u| u[c]).collect())
                    .collect();
                let direct = direct_avar(&series, m, tau0);
                match (streamed, direct) {
                    (Some(s), Some(d)) => {
                        let rel = (s[c] - d).abs() / d;
                        assert!(rel < 1e-12, "m {m} channel {c}: {} vs {d} ({rel:e})", s[c]);
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
