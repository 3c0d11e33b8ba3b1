//! Text input as editors and CAM systems write it: a UTF-8 byte-order mark
//! at the start (Windows editors add one), and lines ended by `\n`, `\r\n`
//! or a lone `\r` (classic Mac OS and some controllers' exports).

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

#[cfg(test)]
mod tests {
    use super::*;

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
