//! The unit's temperature as a run's `temp_c` column gives it (SPEC §3a,
//! §5), kept beside the records rather than in them: a summary of the run
//! and a history decimated to one point a second.
//!
//! Memory: one point (16 bytes) per second of run, about 0.3 % of a
//! 100 Hz f64le file, and a few accumulators; never the records.
//!
//! The rate of change is taken from means over 60 s windows, not from
//! neighbouring samples: a sensor read to 0.01 °C at 100 Hz would show
//! ±60 °C/min between samples, while consecutive window means of 6 000
//! samples differ by noise of about 2e-4 °C/min. A ramp is linear, so
//! the difference of two window means over the difference of their mean
//! times is its rate exactly, whatever the windows' fill.

use crate::model::thermal::PLAUSIBLE_C;

/// Seconds in one point of the decimated history.
pub const HISTORY_STEP_S: f64 = 1.0;

/// Seconds in one window of the rate estimate.
pub const RATE_WINDOW_S: f64 = 60.0;

/// The last window counts towards the rate only once it spans this much
/// of a window: a window of a few samples would make the rate noisy.
const MIN_LAST_WINDOW_FILL: f64 = 0.5;

/// Whether `temp_c` is a temperature a unit can have, °C.
pub(crate) fn is_plausible(temp_c: f64) -> bool {
    PLAUSIBLE_C.contains(&temp_c)
}

/// What a run's temperature column says about the run.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TemperatureSummary {
    /// Mean over every record, °C.
    pub mean_c: f64,
    pub min_c: f64,
    pub max_c: f64,
    /// Largest |Ṫ| between consecutive 60 s window means, °C/min; `None`
    /// for a run shorter than two windows.
    pub max_rate_c_per_min: Option<f64>,
    /// Records read with a temperature.
    pub samples: u64,
}

/// One point of the decimated history: the mean time and temperature of
/// the records in one second.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TemperaturePoint {
    pub t_s: f64,
    pub temp_c: f64,
}

/// Sums over the samples that fall into one bin of time.
#[derive(Clone, Copy, Debug, Default)]
struct Bin {
    index: i64,
    n: u64,
    sum_t: f64,
    sum_c: f64,
    first_t: f64,
    last_t: f64,
}

impl Bin {
    fn start(index: i64, t: f64, c: f64) -> Self {
        Bin {
            index,
            n: 1,
            sum_t: t,
            sum_c: c,
            first_t: t,
            last_t: t,
        }
    }

    fn add(&mut self, t: f64, c: f64) {
        self.n += 1;
        self.sum_t += t;
        self.sum_c += c;
        self.last_t = t;
    }

    fn mean(&self) -> (f64, f64) {
        (self.sum_t / self.n as f64, self.sum_c / self.n as f64)
    }
}

/// Accumulates the temperature column record by record.
#[derive(Clone, Debug, Default)]
pub(crate) struct TemperatureTrack {
    t0: f64,
    samples: u64,
    sum_c: f64,
    min_c: f64,
    max_c: f64,
    history: Vec<TemperaturePoint>,
    second: Option<Bin>,
    window: Option<Bin>,
    /// (mean t, mean T) of the last finished window.
    last_window: Option<(f64, f64)>,
    max_rate: Option<f64>,
}

fn rate_between(a: (f64, f64), b: (f64, f64)) -> f64 {
    (b.1 - a.1) / ((b.0 - a.0) / 60.0)
}

impl TemperatureTrack {
    /// Takes record time `t` (s, increasing) and its temperature (°C,
    /// already checked).
    pub(crate) fn push(&mut self, t: f64, temp_c: f64) {
        if self.samples == 0 {
            self.t0 = t;
            self.min_c = temp_c;
            self.max_c = temp_c;
        }
        self.samples += 1;
        self.sum_c += temp_c;
        self.min_c = self.min_c.min(temp_c);
        self.max_c = self.max_c.max(temp_c);

        let since = t - self.t0;
        let second = (since / HISTORY_STEP_S).floor() as i64;
        match &mut self.second {
            Some(bin) if bin.index == second => bin.add(t, temp_c),
            slot => {
                if let Some(done) = slot.take() {
                    let (t_s, temp_c) = done.mean();
                    self.history.push(TemperaturePoint { t_s, temp_c });
                }
                *slot = Some(Bin::start(second, t, temp_c));
            }
        }
        let window = (since / RATE_WINDOW_S).floor() as i64;
        match &mut self.window {
            Some(bin) if bin.index == window => bin.add(t, temp_c),
            slot => {
                if let Some(done) = slot.take() {
                    let mean = done.mean();
                    if let Some(previous) = self.last_window {
                        let r = rate_between(previous, mean).abs();
                        self.max_rate = Some(self.max_rate.map_or(r, |m| m.max(r)));
                    }
                    self.last_window = Some(mean);
                }
                *slot = Some(Bin::start(window, t, temp_c));
            }
        }
    }

    /// The summary of the records read so far; `None` before the first.
    pub(crate) fn summary(&self) -> Option<TemperatureSummary> {
        if self.samples == 0 {
            return None;
        }
        // The window still open counts once it is half full.
        let mut max_rate = self.max_rate;
        if let (Some(previous), Some(open)) = (self.last_window, &self.window) {
            if open.last_t - open.first_t >= MIN_LAST_WINDOW_FILL * RATE_WINDOW_S {
                let r = rate_between(previous, open.mean()).abs();
                max_rate = Some(max_rate.map_or(r, |m| m.max(r)));
            }
        }
        Some(TemperatureSummary {
            mean_c: self.sum_c / self.samples as f64,
            min_c: self.min_c,
            max_c: self.max_c,
            max_rate_c_per_min: max_rate,
            samples: self.samples,
        })
    }

    /// The 1 s history of the records read so far, the second still open
    /// included.
    pub(crate) fn history(&self) -> Vec<TemperaturePoint> {
        let mut out = Vec::with_capacity(self.history.len() + 1);
        out.extend_from_slice(&self.history);
        if let Some(open) = &self.second {
            let (t_s, temp_c) = open.mean();
            out.push(TemperaturePoint { t_s, temp_c });
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_noisy_ramp_gives_its_rate_and_a_one_hertz_history() {
        let mut track = TemperatureTrack::default();
        // 100 Hz for 10 min, 0.5 °C/min, ±0.02 °C alternating noise.
        for k in 1..=60_000u64 {
            let t = k as f64 * 0.01;
            let noise = if k % 2 == 0 { 0.02 } else { -0.02 };
            track.push(t, 20.0 + 0.5 * t / 60.0 + noise);
        }
        let s = track.summary().unwrap();
        assert_eq!(s.samples, 60_000);
        let rate = s.max_rate_c_per_min.unwrap();
        assert!((rate - 0.5).abs() < 1e-6, "{rate}");
        assert!((s.mean_c - 22.5).abs() < 1e-3, "{}", s.mean_c);
        assert!((s.min_c - (20.0 - 0.02 + 0.5 * 0.01 / 60.0)).abs() < 1e-9);
        let h = track.history();
        assert_eq!(h.len(), 600);
        // The mean of the first second's records: t = 0.01 … 1.00.
        assert!((h[0].t_s - 0.505).abs() < 1e-9, "{}", h[0].t_s);
        assert!((h[0].temp_c - (20.0 + 0.5 * 0.505 / 60.0)).abs() < 1e-9);
    }

    #[test]
    fn a_short_run_has_no_rate_and_a_ramp_then_hold_peaks_at_the_ramp() {
        let mut track = TemperatureTrack::default();
        for k in 0..50 {
            track.push(k as f64, 25.0);
        }
        assert_eq!(track.summary().unwrap().max_rate_c_per_min, None);
        let mut track = TemperatureTrack::default();
        for k in 0..1200 {
            let t = k as f64;
            track.push(t, 20.0 + (t / 60.0).min(5.0));
        }
        let rate = track.summary().unwrap().max_rate_c_per_min.unwrap();
        assert!((rate - 1.0).abs() < 1e-9, "{rate}");
    }

    #[test]
    fn plausible_temperatures() {
        assert!(is_plausible(-40.0) && is_plausible(200.0) && is_plausible(-100.0));
        assert!(!is_plausible(200.5) && !is_plausible(-273.0) && !is_plausible(f64::NAN));
    }
}
