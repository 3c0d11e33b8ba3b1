//! CSV point lists: `x,y,z` in mm with an optional fourth column, the feed cap
//! in mm/min. A first row of words only (no field a number, as `x,y,z,feed`)
//! is a header and skipped; a first row mixing numbers and other text is a
//! point with a typo (`1O,0,0`), an error naming its line. `#` starts a
//! comment line.

use std::path::Path;

use anyhow::{bail, Context, Result};
use fuzzy_core::scheduler::PathPoint;
use fuzzy_core::units::{FeedMmPerMin, Point3Mm};

/// Read a path; errors name the file and the line.
pub fn read(path: &Path) -> Result<Vec<PathPoint>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse(&text).with_context(|| format!("in {}", path.display()))
}

/// Parse CSV text into path points (tags are 1-based line numbers).
///
/// Lines are split here ([`crate::text::lines`]) and each is read as one
/// CSV record: the csv reader's own record positions do not count the
/// comment and blank lines it skips, so its line numbers drift.
pub fn parse(text: &str) -> Result<Vec<PathPoint>> {
    let mut out = Vec::new();
    let mut first = true;
    for (i, src) in crate::text::lines(crate::text::strip_bom(text)).enumerate() {
        let line = i as u64 + 1;
        let trimmed = src.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let record = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(trimmed.as_bytes())
            .records()
            .next()
            .transpose()
            .with_context(|| format!("line {line}"))?
            .unwrap_or_default();
        let fields: Vec<&str> = record.iter().collect();
        if std::mem::take(&mut first) && fields.iter().all(|f| f.parse::<f64>().is_err()) {
            continue; // header
        }
        if fields.len() < 3 || fields.len() > 4 {
            bail!(
                "line {line}: expected x,y,z[,feed], found {} fields",
                fields.len()
            );
        }
        let num = |k: usize, what: &str| -> Result<f64> {
            let v: f64 = fields[k]
                .parse()
                .with_context(|| format!("line {line}: {what} {:?} is not a number", fields[k]))?;
            if !v.is_finite() {
                bail!("line {line}: {what} is not finite");
            }
            Ok(v)
        };
        let (x, y, z) = (num(0, "x")?, num(1, "y")?, num(2, "z")?);
        let pos = Point3Mm::from_f64(x, y, z)
            .with_context(|| format!("line {line}: coordinate out of range"))?;
        if !pos.within_limits() {
            bail!(
                "line {line}: coordinate beyond ±{} mm",
                fuzzy_core::units::COORD_LIMIT_MM
            );
        }
        let feed_cap = match fields.get(3) {
            Some(f) if !f.is_empty() => {
                let v = num(3, "feed")?;
                let cap = FeedMmPerMin::from_f64(v);
                if !cap.within_limits() {
                    bail!(
                        "line {line}: feed {} outside [0, 1e6] mm/min",
                        crate::text::short(v)
                    );
                }
                Some(cap)
            }
            _ => None,
        };
        out.push(PathPoint {
            pos,
            feed_cap,
            tag: line as u32,
        });
    }
    if out.is_empty() {
        bail!("no points");
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_comments_and_caps() {
        let p = parse("x,y,z,feed\n# a comment\n0,0,0\n1.5, 2, 3, 1200\n").unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!(p[1].pos.to_f64(), [1.5, 2.0, 3.0]);
        assert_eq!(p[1].feed_cap, Some(FeedMmPerMin::from_int(1200)));
        assert_eq!(p[1].tag, 4);
    }

    #[test]
    fn errors_name_the_line() {
        let e = format!("{:#}", parse("0,0,0\n1,x,0\n").unwrap_err());
        assert!(e.contains("line 2"), "{e}");
        let e = format!("{:#}", parse("0,0\n").unwrap_err());
        assert!(e.contains("line 1"), "{e}");
        let e = format!("{:#}", parse("0,0,0\n1e9,0,0\n").unwrap_err());
        assert!(e.contains("line 2"), "{e}");
        assert!(parse("x,y,z\n").is_err());
        let e = format!("{:#}", parse("0,0,0,-5\n").unwrap_err());
        assert!(e.contains("feed"), "{e}");
    }

    #[test]
    fn lines_are_counted_as_an_editor_shows_them() {
        // Comments, blank lines, a byte-order mark, \r\n and lone \r.
        let p = parse("\u{feff}# c\n\nx,y,z\r\n# d\r\r0,0,0\r1,1,1\n").unwrap();
        assert_eq!(p.iter().map(|p| p.tag).collect::<Vec<_>>(), [6, 7]);
        let e = format!("{:#}", parse("0,0,0\n\n# c\n\n1,x,0\n").unwrap_err());
        assert!(e.contains("line 5"), "{e}");
    }

    #[test]
    fn only_a_first_row_of_words_is_a_header() {
        // A typo in the first point is not taken for a header.
        let e = format!("{:#}", parse("1O,0,0\n1,1,1\n").unwrap_err());
        assert!(e.contains("line 1") && e.contains("\"1O\""), "{e}");
        let e = format!("{:#}", parse("# points\n\n0,0,O\n1,1,1\n").unwrap_err());
        assert!(e.contains("line 3"), "{e}");
        // Words only: a header, in any case, with or without the feed.
        assert_eq!(parse("X,Y,Z\n1,2,3\n").unwrap().len(), 1);
        assert_eq!(parse("x, y, z, f\n1,2,3\n").unwrap()[0].tag, 2);
        // A second row of words is not a header.
        let e = format!("{:#}", parse("x,y,z\nx,y,z\n1,2,3\n").unwrap_err());
        assert!(e.contains("line 2"), "{e}");
    }
}
