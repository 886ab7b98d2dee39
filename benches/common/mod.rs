//! Helpers the benchmarks share.

/// The bench's own flags (after `--`): `--name value` and `--switch`.
#[allow(dead_code)]
pub struct BenchArgs(Vec<String>);

#[allow(dead_code)]
impl BenchArgs {
    pub fn from_env() -> Self {
        BenchArgs(std::env::args().collect())
    }

    /// The number after `name`, when given and a number.
    pub fn number(&self, name: &str) -> Option<f64> {
        let i = self.0.iter().position(|a| a == name)?;
        self.0.get(i + 1)?.parse().ok()
    }

    pub fn switch(&self, name: &str) -> bool {
        self.0.iter().any(|a| a == name)
    }
}

/// Peak resident set size of this process so far, MB (Linux).
#[allow(dead_code)]
pub fn peak_rss_mb() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// The reference scenario: the paper's 3.2 h `ten-position-9+9` run at
/// 100 Hz, Table 1 truth, navigation-grade noise, a start a few tenths of a
/// degree off nominal.
#[allow(dead_code)]
pub fn reference_run() -> sinscal_core::sim::SimConfig {
    use sinscal_core::model::{Effects, ErrorParameters};
    use sinscal_core::sim::{Noise, Scheme, SimConfig};
    SimConfig {
        site: sinscal_core::nav::Site::REFERENCE,
        sample_rate_hz: 100.0,
        scheme: Scheme::builtin("ten-position-9+9", 600.0).unwrap(),
        params: ErrorParameters::paper(),
        effects: Effects::none(),
        noise: Noise::default_navigation_grade(),
        initial_attitude_error_deg: [0.1, -0.1, 2.0],
        seed: 1,
        thermal: None,
        temperature: None,
    }
}
