//! The interpreter's persistent state in LinuxCNC's parameter file format
//! (`.var`): one `number<TAB>value` line per parameter, the numbers
//! LinuxCNC keeps between runs (`rs274ngc_pre.cc`,
//! `_required_parameters`: #5161-5169 the G28 position, #5181-5189 G30,
//! #5210-5219 the G92 offset and whether it is on, #5220 the coordinate
//! system, #5221-5230 … #5381-5390 the offsets and XY rotation of G54 …
//! G59.3). Values are in mm, the interpreter's machine unit (LinuxCNC
//! writes its machine units: a metric machine's files read unchanged).
//! Lines that are not `number value` (comments, blanks) are skipped, as
//! LinuxCNC skips them; numbers outside the persistent set are ignored.

use std::path::Path;

use anyhow::{bail, Context, Result};

/// Is `n` one of the parameters kept between runs?
pub fn persistent(n: u32) -> bool {
    matches!(n, 5161..=5169 | 5181..=5189 | 5210..=5220)
        || (5221..=5390).contains(&n) && (n - 5221) % 20 < 10
}

/// Every persistent parameter number, in order.
pub fn numbers() -> impl Iterator<Item = u32> {
    (5161..=5390).filter(|&n| persistent(n))
}

/// The persistent parameters of a `.var` text.
pub fn parse(text: &str) -> Result<Vec<(u32, f64)>> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let mut f = line.split_whitespace();
        let (Some(n), Some(v)) = (f.next(), f.next()) else {
            continue;
        };
        let Ok(n) = n.parse::<u32>() else {
            continue;
        };
        if !persistent(n) {
            continue;
        }
        let v: f64 = v
            .parse()
            .with_context(|| format!("line {}: #{n}: {v:?} is not a number", i + 1))?;
        if !v.is_finite() || v.abs() > 1e9 {
            bail!("line {}: #{n} = {v} is not a finite offset", i + 1);
        }
        out.push((n, v));
    }
    Ok(out)
}

/// The `.var` text of the persistent parameters, `value(n)` each.
pub fn format(value: impl Fn(u32) -> f64) -> String {
    let mut s = String::new();
    for n in numbers() {
        s.push_str(&format!("{n}\t{:.6}\n", value(n)));
    }
    s
}

/// Write `text` to `path` whole or not at all (a temporary file beside it,
/// renamed over it).
pub fn write_atomically(path: &Path, text: &str) -> Result<()> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("replacing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_persistent_set_is_linuxcncs() {
        assert!(persistent(5161) && persistent(5169) && !persistent(5170));
        assert!(persistent(5220) && persistent(5221) && persistent(5230));
        assert!(!persistent(5231) && persistent(5241) && persistent(5390));
        assert_eq!(numbers().count(), 9 + 9 + 11 + 90);
    }

    #[test]
    fn a_file_reads_back_what_was_written() {
        let text = format(|n| if n == 5223 { -12.5 } else { 0.0 });
        let back = parse(&text).unwrap();
        assert_eq!(back.len(), numbers().count());
        assert!(back.contains(&(5223, -12.5)));
        // LinuxCNC's own files: spaces or tabs, other numbers, comments.
        let got = parse("5221  1.5\n# x\n\n31 7\n5222\t2.000000\n").unwrap();
        assert_eq!(got, vec![(5221, 1.5), (5222, 2.0)]);
        assert!(parse("5221 nan\n").is_err());
        assert!(parse("5221 abc\n").is_err());
    }
}
