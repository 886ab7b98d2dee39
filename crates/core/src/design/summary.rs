//! A design as `sinscal design` prints it.

use super::Design;
use crate::model::PARAMETERS;

impl Design {
    /// The printed summary: duration, σ against target per parameter, the
    /// binding parameters and the built-in schemes on the same target.
    pub fn summary(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let (dwells, turns) = self.scheme.counts();
        let _ = writeln!(
            s,
            "scheme {}: {} dwells, {} turns, {:.0} s ({:.2} h); target {} with margin {}{}",
            self.scheme.name,
            dwells,
            turns,
            self.duration_s,
            self.duration_s / 3600.0,
            self.target,
            self.margin,
            if self.by_hand { ", turned by hand" } else { "" }
        );
        let _ = writeln!(
            s,
            "{:<20} {:>12} {:>12} {:>7}  unit",
            "parameter", "sigma", "target", "ratio"
        );
        for p in PARAMETERS.iter() {
            let q = &self.parameters[p.name];
            let _ = writeln!(
                s,
                "{:<20} {:>12.5} {:>12.5} {:>7.2}  {}",
                p.name, q.sigma, q.target, q.ratio, q.unit
            );
        }
        for d in &self.detect {
            let _ = writeln!(s, "{}", d.describe());
        }
        let _ = writeln!(s, "binding: {}", self.binding.join(", "));
        for c in &self.comparisons {
            match (c.dwell_s, c.duration_s) {
                (Some(d), Some(t)) => {
                    let _ = writeln!(
                        s,
                        "{}: needs {d:.0} s dwells, {t:.0} s ({:.2} h); worst ratio {:.2} at 600 s dwells",
                        c.scheme,
                        t / 3600.0,
                        c.worst_ratio_at_600_s
                    );
                }
                _ => {
                    let _ = writeln!(
                        s,
                        "{}: does not reach the target with the dwells searched; worst ratio {:.2} at 600 s dwells",
                        c.scheme, c.worst_ratio_at_600_s
                    );
                }
            }
        }
        s
    }
}
