//! Writing SVG text: escaping, and numbers written straight into the
//! output, so that a page of charts allocates nothing per point.

/// Appends `s` with XML's five special characters escaped: names and
/// colours come from user data, and must neither close an element or an
/// attribute nor open a tag. Characters XML 1.0 forbids (the C0 controls
/// other than tab, newline and return, U+FFFE, U+FFFF) are dropped, since
/// one of them makes the whole page unreadable to an XML parser.
pub(super) fn escape_into(out: &mut String, s: &str) {
    let mut start = 0;
    for (i, c) in s.char_indices() {
        let rep = match c {
            '&' => "&amp;",
            '<' => "&lt;",
            '>' => "&gt;",
            '"' => "&quot;",
            '\'' => "&apos;",
            '\t' | '\n' | '\r' => continue,
            c if (c as u32) < 0x20 || c == '\u{FFFE}' || c == '\u{FFFF}' => "",
            _ => continue,
        };
        out.push_str(&s[start..i]);
        out.push_str(rep);
        start = i + c.len_utf8();
    }
    out.push_str(&s[start..]);
}

/// The largest coordinate written, in pixels. Every coordinate the charts
/// compute lies on or near the drawing; the bound only guarantees that
/// nothing unreadable ever reaches the text.
const MAX_COORD: f64 = 1e7;

/// Appends `v` to one decimal, without a trailing `.0`: a tenth of a pixel
/// is below what a screen or a printer shows, and the short form keeps a
/// page of charts small. Formatting through `fmt` would cost several times
/// as much for the thousands of numbers a page holds. A non-finite `v` is
/// written as 0 (callers never pass one: this keeps `NaN` out of the text
/// whatever happens).
pub(super) fn num(out: &mut String, v: f64) {
    let v = if v.is_finite() {
        v.clamp(-MAX_COORD, MAX_COORD)
    } else {
        0.0
    };
    let tenths = (v * 10.0).round() as i64;
    if tenths < 0 {
        out.push('-');
    }
    let a = tenths.unsigned_abs();
    push_u64(out, a / 10);
    let f = a % 10;
    if f != 0 {
        out.push('.');
        out.push(char::from(b'0' + f as u8));
    }
}

fn push_u64(out: &mut String, mut n: u64) {
    let mut buf = [0u8; 20];
    let mut i = buf.len();
    loop {
        i -= 1;
        buf[i] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            break;
        }
    }
    for &b in &buf[i..] {
        out.push(char::from(b));
    }
}

/// Appends ` name="v"`.
pub(super) fn attr(out: &mut String, name: &str, v: f64) {
    out.push(' ');
    out.push_str(name);
    out.push_str("=\"");
    num(out, v);
    out.push('"');
}

/// Appends ` name="value"`, escaped.
pub(super) fn attr_str(out: &mut String, name: &str, value: &str) {
    out.push(' ');
    out.push_str(name);
    out.push_str("=\"");
    escape_into(out, value);
    out.push('"');
}

/// Appends `x y` (`sep` between them: ' ' in path data, ',' in
/// `points`).
pub(super) fn pair(out: &mut String, x: f64, y: f64, sep: char) {
    num(out, x);
    out.push(sep);
    num(out, y);
}

/// Appends a `<text>` element at (x, y); `attrs` is written as given (a
/// fixed string starting with a space, or empty), `content` escaped.
pub(super) fn text(out: &mut String, x: f64, y: f64, attrs: &str, content: &str) {
    out.push_str("<text");
    attr(out, "x", x);
    attr(out, "y", y);
    out.push_str(attrs);
    out.push('>');
    escape_into(out, content);
    out.push_str("</text>\n");
}

/// Appends a `<rect>` with the given geometry, left open for its paint:
/// the caller writes the remaining attributes and `/>`.
pub(super) fn rect_open(out: &mut String, x: f64, y: f64, w: f64, h: f64) {
    out.push_str("<rect");
    attr(out, "x", x);
    attr(out, "y", y);
    attr(out, "width", w.max(0.0));
    attr(out, "height", h.max(0.0));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn esc(s: &str) -> String {
        let mut out = String::new();
        escape_into(&mut out, s);
        out
    }

    #[test]
    fn the_five_special_characters_are_escaped() {
        assert_eq!(esc(r#"a&b<c>d"e'f"#), "a&amp;b&lt;c&gt;d&quot;e&apos;f");
        assert_eq!(
            esc("<script>alert(1)</script>"),
            "&lt;script&gt;alert(1)&lt;/script&gt;"
        );
        assert_eq!(esc("µg/g² ±σ"), "µg/g² ±σ");
        assert_eq!(esc(""), "");
    }

    #[test]
    fn characters_xml_forbids_are_dropped() {
        assert_eq!(esc("a\u{0}b\u{1b}c\td\ne"), "abc\td\ne");
        assert_eq!(esc("x\u{FFFF}"), "x");
    }

    #[test]
    fn numbers_are_written_to_a_tenth_without_trailing_zero() {
        let mut out = String::new();
        for v in [
            0.0,
            12.0,
            12.34,
            12.36,
            -3.06,
            -0.04,
            1e12,
            f64::NAN,
            f64::INFINITY,
        ] {
            num(&mut out, v);
            out.push(' ');
        }
        assert_eq!(out, "0 12 12.3 12.4 -3.1 0 10000000 0 0 ");
    }

    #[test]
    fn elements_are_written_whole() {
        let mut out = String::new();
        text(&mut out, 1.0, 2.5, " font-size=\"11\"", "a<b");
        rect_open(&mut out, 0.0, 1.0, 2.0, -3.0);
        attr_str(&mut out, "fill", "\"red");
        out.push_str("/>");
        assert_eq!(
            out,
            "<text x=\"1\" y=\"2.5\" font-size=\"11\">a&lt;b</text>\n\
             <rect x=\"0\" y=\"1\" width=\"2\" height=\"0\" fill=\"&quot;red\"/>"
        );
    }
}
