//! Grbl system commands (`$…` lines) found in a G-code file.
//!
//! Grbl takes a line starting with `$` as a command to the controller, not
//! G-code (`grbl/protocol.c`, `protocol_main_loop`: `line[0] == '$'`;
//! `grbl/system.c`, `system_execute_line`). Senders type them in their
//! console; some users save them in files. We tell them apart from
//! LinuxCNC's `$` spindle word (`$1 M3 S1000`) by what follows the `$`:
//! nothing, a letter, `$` or `#`, or a number and `=`.
//!
//! | command | what Grbl does | here |
//! |---|---|---|
//! | `$` `$$` `$#` `$G` `$I` `$N` | print help, settings, offsets, parser state, build info, startup lines | skipped with a warning: they change nothing |
//! | `$H` `$HX` … | homing cycle: moves until the switches trip | refused: the position after it is the machine's |
//! | `$X` | clears the alarm lock | refused: a file must not override a safety lock |
//! | `$C` | check mode: the rest of the program does not move | refused |
//! | `$J=…` | a jog, cancellable, not part of a program | refused |
//! | `$SLP`, `$RST=…`, `$<n>=…`, `$N<n>=…`, `$I=…` | sleep, restore, store settings, startup lines, build info | refused: they change the controller's configuration |
//!
//! Refusals name the line and say to send the command from the sender or
//! its console.

/// What a `$` line is, if it is a Grbl system command.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SystemLine {
    /// A query: skipped, with this warning.
    Skip(String),
    /// Refused with this message (without the line number).
    Refuse(String),
}

/// Classify a line as cleaned by the parser (comments and spaces removed,
/// lower case); `None` if it is not a Grbl system command.
pub fn classify(clean: &str) -> Option<SystemLine> {
    let rest = clean.strip_prefix('$')?;
    let first = rest.chars().next();
    let is_setting = {
        let digits = rest.trim_start_matches(|c: char| c.is_ascii_digit());
        digits.len() < rest.len() && digits.starts_with('=')
    };
    let grbl = match first {
        None => true,
        Some(c) if c.is_ascii_alphabetic() || c == '$' || c == '#' => true,
        _ => is_setting,
    };
    if !grbl {
        return None;
    }
    let shown = format!("${}", rest.to_ascii_uppercase());
    let shown: String = shown.chars().take(24).collect();
    let query = match rest {
        "" => Some("prints Grbl's help"),
        "$" => Some("prints the settings"),
        "#" => Some("prints the offsets"),
        "g" => Some("prints the parser state"),
        "i" => Some("prints the build info"),
        "n" => Some("prints the startup lines"),
        _ => None,
    };
    if let Some(what) = query {
        return Some(SystemLine::Skip(format!(
            "Grbl query `{shown}` ({what}) skipped: it has no effect on the program"
        )));
    }
    let what = if is_setting {
        "stores a setting"
    } else if rest.starts_with('h') {
        "runs the homing cycle"
    } else if rest == "x" {
        "clears the alarm lock"
    } else if rest == "c" {
        "toggles check mode"
    } else if rest.starts_with("j=") {
        "jogs"
    } else if rest == "slp" {
        "puts Grbl to sleep"
    } else if rest.starts_with("rst=") {
        "restores defaults"
    } else if rest.starts_with('n') {
        "stores a startup line"
    } else if rest.starts_with("i=") {
        "stores build info"
    } else {
        "is a controller command"
    };
    Some(SystemLine::Refuse(format!(
        "Grbl system command `{shown}` ({what}) in a program: send it from the sender or its console, not in a file"
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(src: &str) -> anyhow::Result<crate::Program> {
        crate::run(src, None, &crate::GcodeSettings::default())
    }

    #[test]
    fn grbl_commands_are_named_and_queries_skipped() {
        for (src, what) in [
            (
                "G0 X1\n$H\n",
                "line 2: Grbl system command `$H` (runs the homing cycle)",
            ),
            (
                "$X\n",
                "line 1: Grbl system command `$X` (clears the alarm lock)",
            ),
            ("$32=1\n", "`$32=1` (stores a setting)"),
            ("$J=G91 X10 F100\n", "`$J=G91X10F100` (jogs)"),
            ("$C (check)\n", "toggles check mode"),
            ("$RST=*\n", "restores defaults"),
            ("$N0=G20\n", "startup line"),
            ("$SLP\n", "sleep"),
            ("$HZ\n", "homing"),
        ] {
            let e = format!("{:#}", read(src).unwrap_err());
            assert!(e.contains(what), "{src:?}: {e}");
            assert!(e.contains("not in a file"), "{e}");
        }
        let p = read("$G\nG0 X1\n$$\n$#\n$G\n$\n$I\n$N\n").unwrap();
        assert_eq!(p.points.last().unwrap(), &[1.0, 0.0, 0.0]);
        assert_eq!(p.warnings.len(), 7);
        assert_eq!(p.warnings[0].0, 1);
        assert!(p.warnings[0]
            .1
            .contains("`$G` (prints the parser state) skipped"));
    }

    #[test]
    fn linuxcnc_spindle_words_are_not_grbl_commands() {
        assert_eq!(classify("$1m3s1000"), None);
        assert_eq!(classify("$0"), None);
        assert_eq!(classify("g0x1"), None);
        assert!(read("$1 M3 S1000\nG0 X1\n").unwrap().warnings.is_empty());
    }
}
