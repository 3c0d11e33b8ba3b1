//! Text in and out. Input as editors and CAM systems write it: a UTF-8
//! byte-order mark at the start (Windows editors add one), and lines ended
//! by `\n`, `\r\n` or a lone `\r` (classic Mac OS and some controllers'
//! exports). Out: numbers in messages, short ([`short`]).

use std::fmt;

/// `src` without a leading byte-order mark.
pub fn strip_bom(src: &str) -> &str {
    src.strip_prefix('\u{feff}').unwrap_or(src)
}

/// The lines of `src`, each without its end. `\n`, `\r\n` and a lone `\r`
/// each end one line, so line numbers count what an editor shows; as with
/// [`str::lines`], a last line without an end is a line and a final end
/// adds no empty line.
pub fn lines(src: &str) -> Lines<'_> {
    Lines { rest: src }
}

/// The iterator of [`lines`].
#[derive(Clone, Debug)]
pub struct Lines<'a> {
    rest: &'a str,
}

impl<'a> Iterator for Lines<'a> {
    type Item = &'a str;

    fn next(&mut self) -> Option<&'a str> {
        if self.rest.is_empty() {
            return None;
        }
        let Some(at) = self.rest.find(['\n', '\r']) else {
            let line = self.rest;
            self.rest = "";
            return Some(line);
        };
        let line = &self.rest[..at];
        let end = if self.rest[at..].starts_with("\r\n") {
            2
        } else {
            1
        };
        self.rest = &self.rest[at + end..];
        Some(line)
    }
}

/// `v` for a message: at most six decimals, trailing zeros dropped, and in
/// exponent form from 1e9 up and below 1e-6, so a value computed as
/// `10**300` prints as `1e300`, not as 301 digits.
pub fn short(v: f64) -> Short {
    Short(v)
}

/// A number displayed by [`short`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Short(pub f64);

impl fmt::Display for Short {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if !v.is_finite() {
            return write!(f, "{v}");
        }
        let a = v.abs();
        if a != 0.0 && !(1e-6..1e9).contains(&a) {
            let s = format!("{v:.6e}");
            let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
            return write!(f, "{}e{exp}", trim_zeros(mantissa));
        }
        let s = format!("{v:.6}");
        match trim_zeros(&s) {
            "-0" => f.write_str("0"),
            t => f.write_str(t),
        }
    }
}

/// `1.500000` → `1.5`, `2.000000` → `2`.
fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_in_messages_are_short() {
        let show = |v: f64| short(v).to_string();
        assert_eq!(show(10f64.powi(300)), "1e300");
        assert_eq!(show(-1.5e300), "-1.5e300");
        assert_eq!(show(1e9), "1e9");
        assert_eq!(show(123_456_789.0), "123456789");
        assert_eq!(show(2.0), "2");
        assert_eq!(show(-0.25), "-0.25");
        assert_eq!(show(0.1 + 0.2), "0.3");
        assert_eq!(show(1.0 / 3.0), "0.333333");
        assert_eq!(show(2e-7), "2e-7");
        assert_eq!(show(1.234_567_89e-300), "1.234568e-300");
        assert_eq!(show(0.0), "0");
        assert_eq!(show(-0.0), "0");
        assert_eq!(show(f64::INFINITY), "inf");
        assert_eq!(show(f64::MAX).len(), "1.797693e308".len());
    }

    #[test]
    fn every_line_end_ends_one_line() {
        let all = |s| lines(s).collect::<Vec<_>>();
        assert_eq!(all("a\nb\r\nc\rd"), ["a", "b", "c", "d"]);
        assert_eq!(all("a\r\rb\n\nc\r\n"), ["a", "", "b", "", "c"]);
        assert_eq!(all("\r\n"), [""]);
        assert_eq!(all(""), Vec::<&str>::new());
        // As str::lines where both apply.
        for s in ["x\ny\n", "x\r\ny", "\n\nx", "x\n\n"] {
            assert_eq!(all(s), s.lines().collect::<Vec<_>>(), "{s:?}");
        }
    }

    #[test]
    fn only_a_leading_mark_is_dropped() {
        assert_eq!(strip_bom("\u{feff}G1"), "G1");
        assert_eq!(strip_bom("G1\u{feff}"), "G1\u{feff}");
        assert_eq!(strip_bom("G1"), "G1");
    }
}
