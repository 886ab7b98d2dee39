//! A unit's parameter spread over runs: the per-result value blob the
//! repeatability read scans, and the statistics computed from it.
//!
//! Each result row keeps its 24 values as one blob (24 little-endian f64 in
//! the canonical order of SPEC §2), so the read touches one row per run,
//! not one per parameter; the statistics are then a single pass in Rust.

use std::collections::BTreeMap;

use sinscal_core::calib::ParameterEstimate;
use sinscal_core::model::PARAMETERS;

/// Bytes of one result's value blob.
pub const BLOB_LEN: usize = 8 * PARAMETERS.len();

/// The value blob of a result's parameters; a parameter the result lacks is
/// NaN (and is left out of that parameter's statistics).
pub fn encode(parameters: &BTreeMap<String, ParameterEstimate>) -> Vec<u8> {
    PARAMETERS
        .iter()
        .flat_map(|p| {
            parameters
                .get(p.name)
                .map_or(f64::NAN, |e| e.value)
                .to_le_bytes()
        })
        .collect()
}

/// One parameter's spread over a unit's runs.
#[derive(Clone, Debug)]
pub struct ParamSpread {
    pub name: String,
    pub n: i64,
    pub mean: f64,
    /// Σ (v − mean)².
    pub sum_sq: f64,
    pub min: f64,
    pub max: f64,
    /// Largest |v_k − v_{k−1}| between consecutive runs in time order.
    pub max_change: Option<f64>,
}

/// Running statistics of one parameter. Welford's update keeps Σ(v − mean)²
/// exact for values like 500 ppm ± 0.2, where Σv² − n·mean² would cancel.
#[derive(Clone, Copy)]
struct Running {
    n: i64,
    mean: f64,
    m2: f64,
    min: f64,
    max: f64,
    last: f64,
    max_change: Option<f64>,
}

impl Running {
    const EMPTY: Running = Running {
        n: 0,
        mean: 0.0,
        m2: 0.0,
        min: f64::INFINITY,
        max: f64::NEG_INFINITY,
        last: f64::NAN,
        max_change: None,
    };

    fn push(&mut self, v: f64) {
        if self.n > 0 {
            let change = (v - self.last).abs();
            self.max_change = Some(self.max_change.map_or(change, |c| c.max(change)));
        }
        self.n += 1;
        let d = v - self.mean;
        self.mean += d / self.n as f64;
        self.m2 += d * (v - self.mean);
        self.min = self.min.min(v);
        self.max = self.max.max(v);
        self.last = v;
    }
}

/// Accumulates value blobs in run-time order.
pub struct SpreadAccumulator {
    params: [Running; PARAMETERS.len()],
}

impl Default for SpreadAccumulator {
    fn default() -> Self {
        SpreadAccumulator {
            params: [Running::EMPTY; PARAMETERS.len()],
        }
    }
}

impl SpreadAccumulator {
    /// Adds the next run's blob; a blob of the wrong length is skipped (it
    /// cannot come from `encode`).
    pub fn push(&mut self, blob: &[u8]) {
        if blob.len() != BLOB_LEN {
            return;
        }
        for (r, bytes) in self.params.iter_mut().zip(blob.chunks_exact(8)) {
            let v = f64::from_le_bytes(bytes.try_into().expect("8-byte chunk"));
            if v.is_finite() {
                r.push(v);
            }
        }
    }

    /// Per parameter, the sample standard deviation (n − 1) of the values
    /// pushed so far (`None` below two), and the most runs any parameter
    /// has: what a verdict's repeatability bounds read after each run.
    pub fn std_devs(&self) -> ([Option<f64>; PARAMETERS.len()], i64) {
        let sd = self
            .params
            .map(|r| (r.n >= 2).then(|| (r.m2.max(0.0) / (r.n - 1) as f64).sqrt()));
        (sd, self.params.iter().map(|r| r.n).max().unwrap_or(0))
    }

    /// The spread of every parameter seen at least once, canonical order.
    pub fn finish(self) -> Vec<ParamSpread> {
        PARAMETERS
            .iter()
            .zip(self.params)
            .filter(|(_, r)| r.n > 0)
            .map(|(p, r)| ParamSpread {
                name: p.name.to_string(),
                n: r.n,
                mean: r.mean,
                sum_sq: r.m2.max(0.0),
                min: r.min,
                max: r.max,
                max_change: r.max_change,
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blob(k: usize) -> (BTreeMap<String, ParameterEstimate>, Vec<u8>) {
        let m: BTreeMap<String, ParameterEstimate> = PARAMETERS
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let value = 500.0 + i as f64 + [0.1, -0.2, 0.05, 0.3][k % 4];
                let e = ParameterEstimate {
                    value,
                    sigma: 0.1,
                    unit: p.unit.into(),
                };
                (p.name.to_string(), e)
            })
            .collect();
        let b = encode(&m);
        (m, b)
    }

    #[test]
    fn statistics_match_two_pass_formulas() {
        let mut acc = SpreadAccumulator::default();
        let runs: Vec<_> = (0..4).map(blob).collect();
        for (_, b) in &runs {
            acc.push(b);
        }
        let spread = acc.finish();
        assert_eq!(spread.len(), PARAMETERS.len());
        for (i, s) in spread.iter().enumerate() {
            assert_eq!(s.name, PARAMETERS[i].name);
            let v: Vec<f64> = runs.iter().map(|(m, _)| m[&s.name].value).collect();
            let mean = v.iter().sum::<f64>() / 4.0;
            let ss: f64 = v.iter().map(|x| (x - mean).powi(2)).sum();
            assert!((s.mean - mean).abs() < 1e-12);
            assert!((s.sum_sq - ss).abs() < 1e-9, "{} vs {ss}", s.sum_sq);
            assert_eq!(s.n, 4);
            assert!((s.max - s.min - 0.5).abs() < 1e-9);
            // Changes 0.3, 0.25, 0.25: the largest is the first.
            assert!((s.max_change.unwrap() - 0.3).abs() < 1e-9);
        }
    }

    #[test]
    fn missing_parameters_are_left_out() {
        let (mut m, _) = blob(0);
        m.remove(PARAMETERS[3].name);
        let mut acc = SpreadAccumulator::default();
        acc.push(&encode(&m));
        acc.push(&[0u8; 7]);
        let spread = acc.finish();
        assert_eq!(spread.len(), PARAMETERS.len() - 1);
        assert!(spread.iter().all(|s| s.n == 1 && s.max_change.is_none()));
    }
}
