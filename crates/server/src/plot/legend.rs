//! The legend: a swatch and the name of every series and band, in rows
//! under the plot, so that it never hides data and its height is known
//! before the plot is laid out.

use std::borrow::Cow;

use super::series::{BAND_OPACITY, DASHES, DOTS, ZONE_OPACITY};
use super::svg::{attr, attr_str, escape_into, num, rect_open};
use super::Style;

/// Legend text size, px.
pub(super) const FONT: f64 = 11.0;
/// Height of a row, px.
const ROW: f64 = 16.0;
const SWATCH_W: f64 = 22.0;
const SWATCH_H: f64 = 10.0;
/// Between a swatch and its name, and between items, px.
const GAP_TEXT: f64 = 5.0;
const GAP_ITEM: f64 = 14.0;

/// The width of `chars` characters of sans-serif text: no font metrics
/// are at hand on the server, and 0.6 em per character is above the
/// average of common sans-serif faces, so estimates err on the roomy side.
pub(super) fn text_width(chars: usize, font: f64) -> f64 {
    chars as f64 * 0.6 * font
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Swatch {
    Series(Style),
    Band,
    /// A band off the y range: an outline, since nothing on the plot has
    /// its fill.
    BandOffScale,
}

#[derive(Clone, Debug)]
pub(super) struct Item<'a> {
    pub name: Cow<'a, str>,
    pub colour: &'a str,
    pub swatch: Swatch,
}

#[derive(Clone, Copy, Debug)]
struct Placed {
    x: f64,
    row: usize,
    /// The characters of the name shown: a name too long for a row is cut
    /// and ends in "…".
    chars: usize,
}

pub(super) struct Legend<'a> {
    items: Vec<Item<'a>>,
    placed: Vec<Placed>,
    rows: usize,
}

impl<'a> Legend<'a> {
    /// Items placed left to right, wrapping at `width`.
    pub fn layout(items: Vec<Item<'a>>, width: f64) -> Legend<'a> {
        let per_char = text_width(1, FONT);
        let room = ((width - SWATCH_W - GAP_TEXT) / per_char).floor().max(4.0) as usize;
        let mut placed = Vec::with_capacity(items.len());
        let (mut x, mut row) = (0.0, 0);
        for item in &items {
            let n = item.name.chars().count();
            let chars = if n > room { room - 1 } else { n };
            let shown = chars + usize::from(chars < n);
            let w = SWATCH_W + GAP_TEXT + text_width(shown, FONT);
            if x > 0.0 && x + w > width {
                x = 0.0;
                row += 1;
            }
            placed.push(Placed { x, row, chars });
            x += w + GAP_ITEM;
        }
        let rows = if items.is_empty() { 0 } else { row + 1 };
        Legend {
            items,
            placed,
            rows,
        }
    }

    pub fn height(&self) -> f64 {
        self.rows as f64 * ROW
    }

    /// Appends the legend with its first row's top at (x0, y0).
    pub fn write(&self, out: &mut String, x0: f64, y0: f64) {
        if self.items.is_empty() {
            return;
        }
        out.push_str("<g font-size=\"11\" fill=\"#333\">\n");
        for (item, p) in self.items.iter().zip(&self.placed) {
            let x = x0 + p.x;
            let cy = y0 + (p.row as f64 + 0.5) * ROW;
            swatch(out, item, x, cy);
            out.push_str("<text");
            attr(out, "x", x + SWATCH_W + GAP_TEXT);
            attr(out, "y", cy + 0.35 * FONT);
            out.push('>');
            match item.name.char_indices().nth(p.chars) {
                Some((cut, _)) => {
                    escape_into(out, &item.name[..cut]);
                    out.push('…');
                }
                None => escape_into(out, &item.name),
            }
            out.push_str("</text>\n");
        }
        out.push_str("</g>\n");
    }
}

/// The series' look in small, left end at x, centred on cy.
fn swatch(out: &mut String, item: &Item, x: f64, cy: f64) {
    let mid = x + SWATCH_W / 2.0;
    let bar = |out: &mut String| {
        rect_open(out, x, cy - SWATCH_H / 2.0, SWATCH_W, SWATCH_H);
        attr_str(out, "fill", item.colour);
    };
    let stroke = |out: &mut String, d_end: &str| {
        out.push_str("<path d=\"M");
        num(out, x);
        out.push(' ');
        num(out, cy);
        out.push('h');
        num(out, SWATCH_W);
        out.push('"');
        attr_str(out, "stroke", item.colour);
        out.push_str(" stroke-width=\"2\"");
        out.push_str(d_end);
        out.push_str("/>\n");
    };
    let dot = |out: &mut String| {
        out.push_str("<circle");
        attr(out, "cx", mid);
        attr(out, "cy", cy);
        out.push_str(" r=\"3.5\"");
        attr_str(out, "fill", item.colour);
        out.push_str("/>\n");
    };
    match item.swatch {
        Swatch::Band => {
            bar(out);
            attr_str(out, "fill-opacity", ZONE_OPACITY);
            out.push_str("/>\n");
        }
        Swatch::BandOffScale => {
            rect_open(out, x, cy - SWATCH_H / 2.0, SWATCH_W, SWATCH_H);
            out.push_str(" fill=\"none\"");
            attr_str(out, "stroke", item.colour);
            out.push_str(" stroke-dasharray=\"3 2\"/>\n");
        }
        Swatch::Series(Style::Line) => stroke(out, ""),
        Swatch::Series(Style::Dashed) => {
            stroke(out, &format!(" stroke-dasharray=\"{DASHES}\""));
        }
        Swatch::Series(Style::Guide) => {
            stroke(out, &format!(" stroke-dasharray=\"{DOTS}\""));
        }
        Swatch::Series(Style::LineWithBand) => {
            bar(out);
            attr_str(out, "fill-opacity", BAND_OPACITY);
            out.push_str("/>\n");
            stroke(out, "");
        }
        Swatch::Series(Style::Markers) => dot(out),
        Swatch::Series(Style::MarkersWithErrorBars) => {
            out.push_str("<path d=\"M");
            num(out, mid);
            out.push(' ');
            num(out, cy - SWATCH_H / 2.0);
            out.push('v');
            num(out, SWATCH_H);
            out.push('"');
            attr_str(out, "stroke", item.colour);
            out.push_str(" stroke-width=\"1\"/>\n");
            dot(out);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn item(name: &str) -> Item<'_> {
        Item {
            name: name.into(),
            colour: "#4e79a7",
            swatch: Swatch::Series(Style::Line),
        }
    }

    #[test]
    fn items_wrap_at_the_width() {
        // Each item: 22 + 5 + 10 chars × 6.6 = 93 px, then 14 px apart.
        let items = vec![item("abcdefghij"), item("abcdefghij"), item("abcdefghij")];
        let legend = Legend::layout(items, 220.0);
        let xs: Vec<(f64, usize)> = legend.placed.iter().map(|p| (p.x, p.row)).collect();
        assert_eq!(xs, [(0.0, 0), (107.0, 0), (0.0, 1)]);
        assert_eq!(legend.height(), 32.0);
        assert_eq!(Legend::layout(Vec::new(), 220.0).height(), 0.0);
    }

    #[test]
    fn every_name_is_written_escaped_and_long_ones_cut() {
        let long = "x".repeat(100);
        let items = vec![
            item("gyro <x> & bias"),
            Item {
                name: "±limit".into(),
                colour: "#bab0ac",
                swatch: Swatch::Band,
            },
            item(&long),
        ];
        let legend = Legend::layout(items, 300.0);
        let mut out = String::new();
        legend.write(&mut out, 10.0, 200.0);
        assert!(out.contains(">gyro &lt;x&gt; &amp; bias</text>"), "{out}");
        assert!(out.contains(">±limit</text>"), "{out}");
        // (300 − 27) / 6.6 = 41 characters of room: 40 and the ellipsis.
        assert!(
            out.contains(&format!(">{}…</text>", "x".repeat(40))),
            "{out}"
        );
        assert!(out.contains("fill-opacity=\"0.25\""), "{out}");
    }
}
