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
pub fn parse(text: &str) -> Result<Vec<PathPoint>> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .comment(Some(b'#'))
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let mut out = Vec::new();
    for (i, record) in reader.records().enumerate() {
        let record = record?;
        let line = record.position().map_or(i as u64 + 1, |p| p.line());
        let fields: Vec<&str> = record.iter().collect();
        if i == 0 && fields.iter().all(|f| f.parse::<f64>().is_err()) {
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
                    bail!("line {line}: feed {v} outside [0, 1e6] mm/min");
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
    fn only_a_first_row_of_words_is_a_header() {
        // A typo in the first point is not taken for a header.
        let e = format!("{:#}", parse("1O,0,0\n1,1,1\n").unwrap_err());
        assert!(e.contains("line 1") && e.contains("\"1O\""), "{e}");
        let e = format!("{:#}", parse("0,0,O\n1,1,1\n").unwrap_err());
        assert!(e.contains("line 1"), "{e}");
        // Words only: a header, in any case, with or without the feed.
        assert_eq!(parse("X,Y,Z\n1,2,3\n").unwrap().len(), 1);
        assert_eq!(parse("x, y, z, f\n1,2,3\n").unwrap()[0].tag, 2);
        // A second row of words is not a header.
        let e = format!("{:#}", parse("x,y,z\nx,y,z\n1,2,3\n").unwrap_err());
        assert!(e.contains("line 2"), "{e}");
    }
}
