//! Tick labels. A tick's value is held as an integer n and a power of ten
//! k (the value is n × 10^k), so a label is written from its digits, never
//! from a float that is almost the value (no `0.30000000000000004`).

/// n × 10^k written out in full, with the −k decimals of the axis' step
/// so that the labels of one axis line up: "0.0015", "120", "0.50".
/// Zero is "0" whatever the step.
pub(super) fn fixed(n: i64, k: i32) -> String {
    if n == 0 {
        return "0".to_string();
    }
    let digits = n.unsigned_abs().to_string();
    let mut out = String::with_capacity(digits.len() + k.unsigned_abs() as usize + 3);
    if n < 0 {
        out.push('-');
    }
    if k >= 0 {
        out.push_str(&digits);
        zeros(&mut out, k as usize);
    } else {
        let d = k.unsigned_abs() as usize;
        if digits.len() > d {
            let (int, frac) = digits.split_at(digits.len() - d);
            out.push_str(int);
            out.push('.');
            out.push_str(frac);
        } else {
            out.push_str("0.");
            zeros(&mut out, d - digits.len());
            out.push_str(&digits);
        }
    }
    out
}

fn zeros(out: &mut String, n: usize) {
    for _ in 0..n {
        out.push('0');
    }
}

/// n × 10^k in exponent form with the fewest mantissa digits: "2e-5",
/// "1.5e-3", "1e6".
pub(super) fn scientific(n: i64, k: i32) -> String {
    if n == 0 {
        return "0".to_string();
    }
    let all = n.unsigned_abs().to_string();
    let digits = all.trim_end_matches('0');
    let e = k + (all.len() - 1) as i32;
    let mut out = String::with_capacity(digits.len() + 6);
    if n < 0 {
        out.push('-');
    }
    out.push_str(&digits[..1]);
    if digits.len() > 1 {
        out.push('.');
        out.push_str(&digits[1..]);
    }
    out.push('e');
    out.push_str(&e.to_string());
    out
}

/// Fixed labels are kept up to this many characters: "123456", "0.0015",
/// "-12.25"; past it the exponent form is used when it is shorter.
const FIXED_MAX_CHARS: usize = 6;

/// The labels of a linear axis whose ticks are `ns[i]` × 10^k. One form
/// for the whole axis, so that the labels read as one sequence: fixed,
/// unless its longest label passes `FIXED_MAX_CHARS` and the exponent
/// form's longest is shorter ("2e-5" rather than "0.00002", "1e6" rather
/// than "1000000", but "1000" and "0.0015" as they are).
pub(super) fn linear_labels(ns: &[i64], k: i32) -> Vec<String> {
    let fixed_labels: Vec<String> = ns.iter().map(|&n| fixed(n, k)).collect();
    let longest = |v: &[String]| v.iter().map(String::len).max().unwrap_or(0);
    let fixed_len = longest(&fixed_labels);
    if fixed_len <= FIXED_MAX_CHARS {
        return fixed_labels;
    }
    let sci_labels: Vec<String> = ns.iter().map(|&n| scientific(n, k)).collect();
    if longest(&sci_labels) < fixed_len {
        sci_labels
    } else {
        fixed_labels
    }
}

/// The label of m × 10^k on a log axis: the shorter of the two forms,
/// fixed on a tie. Each label stands alone there (the ticks are not evenly
/// spaced values), so the decades read "1e-3", "0.01", "0.1", "1", "10",
/// "100", "1e3".
pub(super) fn log_label(m: i64, k: i32) -> String {
    let f = fixed(m, k);
    let s = scientific(m, k);
    if s.len() < f.len() {
        s
    } else {
        f
    }
}

/// A label for a value that is not on a 1-2-5 grid (an axis whose range
/// no grid fits, such as a span beyond the range of f64): four significant
/// digits, shortest form.
pub(super) fn general(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return "0".to_string();
    }
    let s = format!("{v:.3e}");
    let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
    let mantissa = if mantissa.contains('.') {
        mantissa.trim_end_matches('0').trim_end_matches('.')
    } else {
        mantissa
    };
    let exp: i32 = exp.parse().unwrap_or(0);
    if (-3..6).contains(&exp) {
        let g = format!("{}", (v * 1e4).round() / 1e4);
        if g.len() <= FIXED_MAX_CHARS + 2 {
            return g;
        }
    }
    format!("{mantissa}e{exp}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_writes_the_step_decimals() {
        assert_eq!(fixed(15, -4), "0.0015");
        assert_eq!(fixed(12, 1), "120");
        assert_eq!(fixed(-5, -1), "-0.5");
        assert_eq!(fixed(10, -1), "1.0");
        assert_eq!(fixed(1234, -2), "12.34");
        assert_eq!(fixed(0, -3), "0");
        assert_eq!(fixed(7, 0), "7");
    }

    #[test]
    fn scientific_keeps_only_needed_digits() {
        assert_eq!(scientific(2, -5), "2e-5");
        assert_eq!(scientific(15, -4), "1.5e-3");
        assert_eq!(scientific(10, 5), "1e6");
        assert_eq!(scientific(-12, 5), "-1.2e6");
        assert_eq!(scientific(0, 5), "0");
    }

    #[test]
    fn an_axis_uses_one_form_and_prefers_fixed() {
        assert_eq!(
            linear_labels(&[0, 5, 10, 15], -4),
            ["0", "0.0005", "0.0010", "0.0015"]
        );
        assert_eq!(
            linear_labels(&[0, 1, 2, 3], -5),
            ["0", "1e-5", "2e-5", "3e-5"]
        );
        assert_eq!(linear_labels(&[0, 5, 10], 2), ["0", "500", "1000"]);
        assert_eq!(linear_labels(&[0, 5, 10], 5), ["0", "5e5", "1e6"]);
        // Long but not shortened by the exponent form: fixed stays.
        assert_eq!(linear_labels(&[123450, 123455], -1), ["12345.0", "12345.5"]);
    }

    #[test]
    fn log_labels_are_the_shorter_form() {
        let labels: Vec<String> = (-3..=3).map(|k| log_label(1, k)).collect();
        assert_eq!(labels, ["1e-3", "0.01", "0.1", "1", "10", "100", "1e3"]);
        assert_eq!(log_label(2, -5), "2e-5");
        assert_eq!(log_label(5, 1), "50");
    }

    #[test]
    fn general_labels_are_short() {
        assert_eq!(general(1.23456789e300), "1.235e300");
        assert_eq!(general(-2.5), "-2.5");
        assert_eq!(general(0.0), "0");
        assert_eq!(general(f64::NAN), "0");
        assert_eq!(general(1.0e-7), "1e-7");
    }
}
