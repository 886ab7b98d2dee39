//! Hand-written SVG plots of a diagnosis: the gap at the nodes (velocity
//! residual per stretch, E/N/U) before and after the named effects, with
//! the ±noise floor band. No dependencies.

use std::fmt::Write;

use super::report::DiagnoseReport;

const W: f64 = 900.0;
const H: f64 = 260.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 20.0;
const TOP: f64 = 28.0;
const BOTTOM: f64 = 32.0;
const COLOURS: [&str; 3] = ["#d62728", "#2ca02c", "#1f77b4"];

fn panel(
    out: &mut String,
    y0: f64,
    title: &str,
    t: &[f64],
    v: &[[f64; 3]],
    scale: f64,
    floor: f64,
) {
    let t_max = t.iter().copied().fold(1e-9, f64::max);
    let px = |x: f64| LEFT + (W - LEFT - RIGHT) * x / t_max;
    let py = |y: f64| y0 + TOP + (H - TOP - BOTTOM) * (0.5 - 0.5 * y / scale);
    let _ = writeln!(
        out,
        r##"<text x="{LEFT}" y="{:.1}" font-size="14" font-family="sans-serif">{title}</text>"##,
        y0 + 18.0
    );
    let _ = writeln!(
        out,
        r##"<rect x="{LEFT}" y="{:.1}" width="{:.1}" height="{:.1}" fill="#eef" stroke="none"/>"##,
        py(floor),
        W - LEFT - RIGHT,
        (py(-floor) - py(floor)).max(0.0)
    );
    let _ = writeln!(
        out,
        r##"<rect x="{LEFT}" y="{:.1}" width="{:.1}" height="{:.1}" fill="none" stroke="#888"/>"##,
        y0 + TOP,
        W - LEFT - RIGHT,
        H - TOP - BOTTOM
    );
    let _ = writeln!(
        out,
        r##"<line x1="{LEFT}" y1="{0:.1}" x2="{1:.1}" y2="{0:.1}" stroke="#bbb"/>"##,
        py(0.0),
        W - RIGHT
    );
    for (label, y) in [(scale, scale), (-scale, -scale)] {
        let _ = writeln!(
            out,
            r##"<text x="{:.1}" y="{:.1}" font-size="10" text-anchor="end" font-family="sans-serif">{label:.1e}</text>"##,
            LEFT - 4.0,
            py(y) + 4.0
        );
    }
    let _ = writeln!(
        out,
        r##"<text x="{:.1}" y="{:.1}" font-size="10" text-anchor="end" font-family="sans-serif">{t_max:.0} s</text>"##,
        W - RIGHT,
        y0 + H - 8.0
    );
    for (axis, colour) in COLOURS.iter().enumerate() {
        let mut path = String::new();
        for (i, (x, y)) in t.iter().zip(v.iter()).enumerate() {
            let _ = write!(
                path,
                "{}{:.1},{:.1} ",
                if i == 0 { "M" } else { "L" },
                px(*x),
                py(y[axis].clamp(-scale, scale))
            );
        }
        let _ = writeln!(
            out,
            r##"<path d="{path}" fill="none" stroke="{colour}" stroke-width="1"/>"##
        );
    }
}

/// Two panels (before, after) of the node gap, on a common scale, E red,
/// N green, U blue; the shaded band is ± the noise floor.
pub fn gap_svg(report: &DiagnoseReport) -> String {
    let s = &report.series;
    let scale = s
        .before
        .iter()
        .chain(s.after.iter())
        .flat_map(|v| v.iter().map(|x| x.abs()))
        .fold(report.noise_floor_rms * 2.0, f64::max)
        .max(1e-12);
    let mut out = String::new();
    let _ = writeln!(
        out,
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{}" viewBox="0 0 {W} {}">"##,
        2.0 * H,
        2.0 * H
    );
    let _ = writeln!(out, r##"<rect width="100%" height="100%" fill="white"/>"##);
    panel(
        &mut out,
        0.0,
        &format!(
            "gap before (base model): RMS {:.2e} m/s, noise floor {:.2e} m/s",
            report.gap_rms_before, report.noise_floor_rms
        ),
        &s.t,
        &s.before,
        scale,
        report.noise_floor_rms,
    );
    let model = if report.named.is_empty() {
        "nothing named".to_string()
    } else {
        format!("+{}", report.named.join(" +"))
    };
    panel(
        &mut out,
        H,
        &format!("gap after ({model}): RMS {:.2e} m/s", report.gap_rms_after),
        &s.t,
        &s.after,
        scale,
        report.noise_floor_rms,
    );
    out.push_str("</svg>\n");
    out
}
