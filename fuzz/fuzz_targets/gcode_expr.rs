//! Any bytes as the value of a word (`X…`): an expression of any length and
//! depth parses to an error or to a value that evaluates to a number or an
//! error, never a panic, an abort or a stack overflow. The first byte is a
//! repeat count (1 to 256) so that short inputs reach long operator chains
//! and deep nesting: the text `prefix|middle|suffix` becomes the prefix,
//! the middle repeated, the suffix; text without two `|` is repeated whole.
#![no_main]

use anyhow::{bail, Result};
use gcode_interp::expr::Params;
use gcode_interp::parse::{self, Stmt};
use libfuzzer_sys::fuzz_target;

/// Parameters without a program: `#n` reads n, `#<a>` is 2, other names
/// are unset.
struct Fixed;

impl Params for Fixed {
    fn number(&self, n: u32) -> Result<f64> {
        Ok(f64::from(n))
    }
    fn named(&self, name: &str) -> Result<f64> {
        if name == "a" {
            Ok(2.0)
        } else {
            bail!("#<{name}> is not set")
        }
    }
    fn exists(&self, name: &str) -> bool {
        name == "a"
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&reps, body)) = data.split_first() else {
        return;
    };
    let body = String::from_utf8_lossy(body);
    let n = usize::from(reps) + 1;
    let src = match body.splitn(3, '|').collect::<Vec<_>>()[..] {
        [prefix, middle, suffix] => format!("X{prefix}{}{suffix}", middle.repeat(n)),
        _ => format!("X{}", body.repeat(n)),
    };
    if let Ok(l) = parse::line(&src, 1) {
        match l.stmt {
            Stmt::Block { words, assigns, .. } => {
                for w in &words {
                    let _ = w.value.eval(&Fixed);
                }
                for (_, e) in &assigns {
                    let _ = e.eval(&Fixed);
                }
            }
            Stmt::OWord { args, .. } => {
                for a in &args {
                    let _ = a.eval(&Fixed);
                }
            }
            Stmt::Percent | Stmt::Skipped(_) => {}
        }
    }
});
