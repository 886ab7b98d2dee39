//! The noise page's charts: one log-log Allan deviation chart per sensor
//! axis, the measured points with their ±1σ, the fitted model, and each
//! term the fit resolved as its own line (IEEE Std 952's slopes), so an
//! engineer sees which term the curve is read from at each τ.

use maud::{html, Markup, PreEscaped};

use crate::plot::{Chart, Point, Scale, Series, Style, YRange};
use sinscal_core::model::units::{DEG_PER_H, UG};
use sinscal_core::noise::fit::NoiseTerms;
use sinscal_core::noise::{AccelNoise, GyroNoise, NoiseReport, Term, TermStatus};

use super::format;

/// Sized so that three fit side by side in a 1280 px window at their drawn
/// size (`.charts.thirds`): their 11 px text is not scaled down.
const WIDTH: f64 = 390.0;
const HEIGHT: f64 = 400.0;

/// Points of each model line, log-spaced over the measured τ.
const MODEL_POINTS: usize = 60;

/// How far below the measured curve the y axis may reach to follow the
/// term lines: a decade shows where each leaves the curve (a flicker
/// floor just under it, a white-noise slope running on), while a line
/// falling for decades more would squash the curve.
const GUIDE_REACH: f64 = 10.0;

const MEASURED_COLOUR: &str = "#4e79a7";
const FIT_COLOUR: &str = "#333";

/// Q, N, B, K, the order of [`AllanAxis::terms`]: how each is named on
/// the chart, the slope it draws and its colour.
const TERM_LINES: [(&str, &str, &str); 4] = [
    ("Q", "slope −1", "#b07aa1"),
    ("N", "slope −½", "#f28e2b"),
    ("B", "flat at 0.664·B", "#59a14f"),
    ("K", "slope +½", "#e15759"),
];

/// One sensor axis as its chart reads it.
struct AllanAxis<'a> {
    /// "gyro x".
    name: String,
    /// The deviation's unit, and SI per unit of it.
    unit: &'a str,
    si_per_unit: f64,
    tau: &'a [f64],
    adev: &'a [f64],
    /// Equivalent degrees of freedom of each σ̂², for its error bar.
    edf: &'a [f64],
    /// Q, N, B, K as the report gives them, each with its unit's name.
    terms: [(&'a Term, &'a str); 4],
    /// The same terms, SI, as the model draws them (0 when not resolved).
    model: NoiseTerms,
}

/// The gyro axes' charts, then the accelerometers'.
pub fn allan_charts(report: &NoiseReport) -> (Markup, Markup) {
    let c = &report.curves;
    let gyro = report
        .gyro
        .iter()
        .zip(c.gyro.iter())
        .map(|((axis, n), (_, curve))| gyro_axis(axis, n, &c.tau_s, &curve.adev_deg_h, &curve.edf));
    let accel = report
        .accel
        .iter()
        .zip(c.accel.iter())
        .map(|((axis, n), (_, curve))| accel_axis(axis, n, &c.tau_s, &curve.adev_ug, &curve.edf));
    (charts(gyro), charts(accel))
}

fn charts<'a>(axes: impl Iterator<Item = AllanAxis<'a>>) -> Markup {
    let mut svg = String::new();
    for a in axes {
        svg.push_str("<figure>");
        allan_chart(&a).write_svg(&mut svg);
        svg.push_str("</figure>");
    }
    html! { (PreEscaped(svg)) }
}

fn gyro_axis<'a>(
    axis: &str,
    n: &'a GyroNoise,
    tau: &'a [f64],
    adev: &'a [f64],
    edf: &'a [f64],
) -> AllanAxis<'a> {
    AllanAxis {
        name: format!("gyro {axis}"),
        unit: "deg/h",
        si_per_unit: DEG_PER_H,
        tau,
        adev,
        edf,
        terms: [
            (&n.angle_quantization_arcsec, "arcsec"),
            (&n.arw_deg_rt_h, "deg/√h"),
            (&n.bias_instability_deg_h, "deg/h"),
            (&n.rate_random_walk_deg_h_rt_h, "deg/h/√h"),
        ],
        model: n.terms_si(),
    }
}

fn accel_axis<'a>(
    axis: &str,
    n: &'a AccelNoise,
    tau: &'a [f64],
    adev: &'a [f64],
    edf: &'a [f64],
) -> AllanAxis<'a> {
    AllanAxis {
        name: format!("accelerometer {axis}"),
        unit: "µg",
        si_per_unit: UG,
        tau,
        adev,
        edf,
        terms: [
            (&n.velocity_quantization_mm_s, "mm/s"),
            (&n.vrw_ug_rt_hz, "µg/√Hz"),
            (&n.bias_instability_ug, "µg"),
            (&n.acceleration_random_walk_ug_rt_h, "µg/√h"),
        ],
        model: n.terms_si(),
    }
}

/// The chart of one axis. The term lines are guides over the whole τ
/// range; the y axis is set by the measured points and the fit, reaching
/// at most [`GUIDE_REACH`] lower for the lines.
fn allan_chart(a: &AllanAxis) -> Chart {
    let mut c = Chart::new(
        format!("{} Allan deviation", a.name),
        "averaging time τ (s)",
        format!("σ(τ) ({})", a.unit),
    );
    c.x_scale = Scale::Log10;
    c.y_scale = Scale::Log10;
    (c.width, c.height) = (WIDTH, HEIGHT);
    let mut measured = Series::new(
        format!("measured ± 1σ ({})", a.unit),
        Style::MarkersWithErrorBars,
        measured_points(a),
    );
    measured.colour = Some(MEASURED_COLOUR.into());
    c.series.push(measured);
    let taus = log_spaced(a.tau);
    let mut fit = Series::new(
        "fitted model",
        Style::Dashed,
        taus.iter()
            .map(|&t| Point::new(t, a.model.allan_deviation(t) / a.si_per_unit))
            .collect(),
    );
    fit.colour = Some(FIT_COLOUR.into());
    c.series.push(fit);
    let lines: Vec<Series> = (0..4).filter_map(|k| term_line(a, k, &taus)).collect();
    if let Some((lo, hi)) = c.shown_y_range() {
        let lowest = lines
            .iter()
            .flat_map(|s| &s.points)
            .map(|p| p.y)
            .filter(|&y| y > 0.0)
            .fold(lo, f64::min);
        c.y_range = YRange::Fixed {
            lo: lowest.max(lo / GUIDE_REACH),
            hi,
        };
    }
    let shown = c.shown_y_range();
    for mut line in lines {
        if shown.is_some_and(|r| off_scale(&line, r)) {
            line.name.push_str(" (off scale)");
        }
        c.series.push(line);
    }
    c
}

/// A line wholly above or below the range `(lo, hi)`: named so, since the
/// legend would otherwise promise a line the chart does not show.
fn off_scale(s: &Series, (lo, hi): (f64, f64)) -> bool {
    s.points.iter().all(|p| p.y < lo) || s.points.iter().all(|p| p.y > hi)
}

/// Each measured σ̂(τ) with its 1σ, σ̂/√(2ν) for ν degrees of freedom
/// (the χ² spread of σ̂² carried to σ̂ to first order); no bar where ν is
/// unknown.
fn measured_points(a: &AllanAxis) -> Vec<Point> {
    a.tau
        .iter()
        .zip(a.adev)
        .enumerate()
        .map(|(i, (&t, &y))| match a.edf.get(i) {
            Some(&nu) if nu.is_finite() && nu > 0.0 => {
                Point::with_sigma(t, y, y / (2.0 * nu).sqrt())
            }
            _ => Point::new(t, y),
        })
        .collect()
}

/// Term `k` alone (Q, N, B, K), when the fit resolved it or held it: the
/// model with every other term taken out, so its line is the core's own
/// formula, not a second copy of it.
fn term_line(a: &AllanAxis, k: usize, taus: &[f64]) -> Option<Series> {
    let (term, unit) = a.terms[k];
    let value = match term.status {
        TermStatus::Resolved | TermStatus::Fixed => term.value?,
        TermStatus::NotResolved => return None,
    };
    let m = &a.model;
    let alone = match k {
        0 => NoiseTerms {
            quantization: m.quantization,
            ..NoiseTerms::default()
        },
        1 => NoiseTerms {
            white: m.white,
            ..NoiseTerms::default()
        },
        2 => NoiseTerms {
            flicker: m.flicker,
            ..NoiseTerms::default()
        },
        _ => NoiseTerms {
            random_walk: m.random_walk,
            ..NoiseTerms::default()
        },
    };
    let (symbol, slope, colour) = TERM_LINES[k];
    let mut s = Series::new(
        format!("{symbol} {} {unit}, {slope}", format::sig(value, 3)),
        Style::Guide,
        taus.iter()
            .map(|&t| Point::new(t, alone.allan_deviation(t) / a.si_per_unit))
            .collect(),
    );
    s.colour = Some(colour.into());
    Some(s)
}

/// [`MODEL_POINTS`] values log-spaced over the measured τ.
fn log_spaced(tau: &[f64]) -> Vec<f64> {
    let (Some(&lo), Some(&hi)) = (tau.first(), tau.last()) else {
        return Vec::new();
    };
    let (a, b) = (lo.ln(), hi.ln());
    (0..MODEL_POINTS)
        .map(|i| (a + (b - a) * i as f64 / (MODEL_POINTS - 1) as f64).exp())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use sinscal_core::noise::fit::Estimate;
    use sinscal_core::noise::term::Reach;

    fn term(e: Estimate, per_unit: f64, unit: &str) -> Term {
        Term::from_estimate(
            &e,
            (per_unit, unit),
            [0.01, 100.0],
            [0.01, 100.0],
            Reach::Short,
            false,
        )
    }

    /// A gyro whose curve is white noise N = 0.01 deg/√h with a flicker
    /// floor B = 0.02 deg/h and a rate random walk K = 0.001 deg/h/√h
    /// that barely shows, Q not resolved, over τ 0.01 … 1000 s.
    #[test]
    fn term_lines_reach_a_decade_below_the_curve_at_most() {
        use sinscal_core::model::units::DEG_PER_RT_H;
        let model = NoiseTerms {
            quantization: 0.0,
            white: 0.01 * DEG_PER_RT_H,
            flicker: 0.02 * DEG_PER_H,
            random_walk: 0.001 * DEG_PER_H / 60.0,
        };
        let tau: Vec<f64> = (0..=50)
            .map(|i| 10f64.powf(-2.0 + 0.1 * f64::from(i)))
            .collect();
        let adev: Vec<f64> = tau
            .iter()
            .map(|&t| model.allan_deviation(t) / DEG_PER_H)
            .collect();
        let edf: Vec<f64> = tau.iter().map(|&t| 1e5 / t.max(1.0)).collect();
        let (q, n, b, k) = (
            term(Estimate::Bound { upper: 1e-7 }, 4.85e-6, "arcsec"),
            term(
                Estimate::Resolved {
                    value: 0.01 * DEG_PER_RT_H,
                    sigma: 1e-4 * DEG_PER_RT_H,
                },
                DEG_PER_RT_H,
                "deg/sqrt(h)",
            ),
            term(
                Estimate::Resolved {
                    value: 0.02 * DEG_PER_H,
                    sigma: 2e-3 * DEG_PER_H,
                },
                DEG_PER_H,
                "deg/h",
            ),
            term(
                Estimate::Resolved {
                    value: 0.001 * DEG_PER_H / 60.0,
                    sigma: 1e-4 * DEG_PER_H / 60.0,
                },
                DEG_PER_H / 60.0,
                "deg/h/sqrt(h)",
            ),
        );
        let axis = AllanAxis {
            name: "gyro x".into(),
            unit: "deg/h",
            si_per_unit: DEG_PER_H,
            tau: &tau,
            adev: &adev,
            edf: &edf,
            terms: [
                (&q, "arcsec"),
                (&n, "deg/√h"),
                (&b, "deg/h"),
                (&k, "deg/h/√h"),
            ],
            model,
        };
        let chart = allan_chart(&axis);
        // Measured, fit, and the three resolved terms.
        assert_eq!(chart.series.len(), 5);
        let (lo, hi) = chart.shown_y_range().unwrap();
        let (a, z) = adev
            .iter()
            .fold((f64::MAX, 0.0f64), |(a, z), &v| (a.min(v), z.max(v)));
        // K's line falls to 1e-6 deg/h at 0.01 s: it must not pull the
        // axis down more than a decade (and the padding, ×1.4 twice on
        // this span) below the curve.
        assert!(
            (z / a).log10() >= (hi / lo).log10() / 3.0,
            "{a} … {z} on {lo} … {hi}"
        );
        assert!(
            lo > a / 10.0 / 2.0 && lo < a / 9.0,
            "{a} … {z} on {lo} … {hi}"
        );
        let svg = chart.to_svg();
        for legend in [
            "measured ± 1σ (deg/h)",
            "N 0.0100 deg/√h, slope −½",
            "B 0.0200 deg/h, flat at 0.664·B",
            "K 0.00100 deg/h/√h, slope +½ (off scale)",
        ] {
            assert!(
                svg.contains(&format!(">{legend}</text>")),
                "{legend} in {svg}"
            );
        }
        assert!(svg.contains("stroke-dasharray=\"2 3\""), "{svg}");
        // The measured points carry error bars.
        assert!(
            svg.contains("stroke=\"#4e79a7\" stroke-width=\"1\" fill=\"none\""),
            "{svg}"
        );
    }

    #[test]
    fn the_white_term_alone_falls_as_one_over_root_tau() {
        let tau = [1.0, 100.0];
        let adev = [1.0, 0.1];
        let n = term(
            Estimate::Resolved {
                value: DEG_PER_H,
                sigma: 0.0,
            },
            DEG_PER_H,
            "x",
        );
        let none = term(Estimate::Bound { upper: 1.0 }, 1.0, "x");
        let axis = AllanAxis {
            name: "g".into(),
            unit: "deg/h",
            si_per_unit: DEG_PER_H,
            tau: &tau,
            adev: &adev,
            edf: &[],
            terms: [(&none, ""), (&n, ""), (&none, ""), (&none, "")],
            model: NoiseTerms {
                white: DEG_PER_H,
                ..NoiseTerms::default()
            },
        };
        let line = term_line(&axis, 1, &log_spaced(&tau)).unwrap();
        let (first, last) = (line.points[0], line.points[MODEL_POINTS - 1]);
        assert!((first.y - 1.0).abs() < 1e-12 && (last.y - 0.1).abs() < 1e-12);
        assert!(term_line(&axis, 2, &tau).is_none());
    }

    #[test]
    fn a_term_line_below_the_curve_is_named_off_scale() {
        let tau = [1.0, 100.0];
        let adev = [1.0, 0.1];
        let n = term(
            Estimate::Resolved {
                value: DEG_PER_H,
                sigma: 0.0,
            },
            DEG_PER_H,
            "x",
        );
        let k = term(
            Estimate::Resolved {
                value: 1e-9,
                sigma: 0.0,
            },
            1.0,
            "x",
        );
        let none = term(Estimate::Bound { upper: 1.0 }, 1.0, "x");
        let axis = AllanAxis {
            name: "g".into(),
            unit: "deg/h",
            si_per_unit: DEG_PER_H,
            tau: &tau,
            adev: &adev,
            edf: &[],
            terms: [(&none, ""), (&n, "u"), (&none, ""), (&k, "u")],
            model: NoiseTerms {
                white: DEG_PER_H,
                random_walk: 1e-9,
                ..NoiseTerms::default()
            },
        };
        let chart = allan_chart(&axis);
        let names: Vec<&str> = chart.series.iter().map(|s| s.name.as_str()).collect();
        assert!(
            names.contains(&"K 1.00e-9 u, slope +½ (off scale)"),
            "{names:?}"
        );
        assert!(names.contains(&"N 1.00 u, slope −½"), "{names:?}");
    }
}
