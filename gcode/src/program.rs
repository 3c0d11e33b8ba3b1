//! A program's lines and the structure of its O-words: which `sub` ends
//! where, each `if`'s branches, each loop's two ends, and the loop each
//! `break`/`continue` leaves (LinuxCNC's `interp_o_word.cc` finds these by
//! searching the file at run time; we find them once, before running, so a
//! mismatched or unclosed structure is an error naming its line even in a
//! branch that never runs).

use std::collections::HashMap;
use std::path::PathBuf;

use anyhow::{bail, Result};

use super::parse::{self, Keyword, Label, Line, Stmt};

/// Where a control line jumps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum Jump {
    /// `sub`: its `endsub`.
    SubEnd(usize),
    /// `if`/`elseif`: the next branch (`elseif`, `else` or `endif`) and the
    /// `endif`.
    Branch { next: usize, end: usize },
    /// `else`: the `endif`.
    Else { end: usize },
    /// Opening `while`, `do`, `repeat`: the closing line.
    LoopStart { end: usize },
    /// `endwhile`, the `while` closing a `do`, `endrepeat`: the opening line.
    LoopEnd { start: usize },
    /// `break`/`continue`: the opening line of its loop.
    InLoop { start: usize },
}

/// One file of a program.
#[derive(Debug)]
pub struct File {
    /// For error messages.
    pub path: Option<PathBuf>,
    /// Parsed lines.
    pub lines: Vec<Line>,
    /// Control lines by index.
    pub jumps: HashMap<usize, Jump>,
    /// Subroutines defined here: label → index of the `sub` line.
    pub subs: HashMap<Label, usize>,
}

impl File {
    /// Parse `src` and find its structure.
    pub fn parse(src: &str, path: Option<PathBuf>) -> Result<Self> {
        let mut lines = Vec::new();
        for (i, text) in src.lines().enumerate() {
            let number = u32::try_from(i + 1).unwrap_or(u32::MAX);
            lines.push(parse::line(text, number)?);
        }
        let (jumps, subs) = structure(&lines)?;
        Ok(File {
            path,
            lines,
            jumps,
            subs,
        })
    }

    /// The label and keyword of line `i`, if it is an O-word.
    pub fn oword(&self, i: usize) -> Option<(&Label, Keyword)> {
        match &self.lines.get(i)?.stmt {
            Stmt::OWord { label, keyword, .. } => Some((label, *keyword)),
            _ => None,
        }
    }
}

type Structure = (HashMap<usize, Jump>, HashMap<Label, usize>);

fn structure(lines: &[Line]) -> Result<Structure> {
    let mut jumps = HashMap::new();
    let mut subs = HashMap::new();
    // Open structures: (label, keyword, index).
    let mut open: Vec<(Label, Keyword, usize)> = Vec::new();
    // The branch lines of each open `if`, by the `if`'s index.
    let mut branches: HashMap<usize, Vec<usize>> = HashMap::new();
    for (i, l) in lines.iter().enumerate() {
        let Stmt::OWord { label, keyword, .. } = &l.stmt else {
            continue;
        };
        let n = l.number;
        let top_matches = |open: &[(Label, Keyword, usize)], k: &[Keyword]| {
            open.last()
                .is_some_and(|(lb, kw, _)| lb == label && k.contains(kw))
        };
        match keyword {
            Keyword::Sub => {
                if open.iter().any(|(_, k, _)| *k == Keyword::Sub) {
                    bail!("line {n}: {label} sub inside another sub (nested definitions are not allowed)");
                }
                if !open.is_empty() {
                    bail!("line {n}: {label} sub inside an open control structure");
                }
                if subs.contains_key(label) {
                    bail!("line {n}: {label} sub is defined twice");
                }
                subs.insert(label.clone(), i);
                open.push((label.clone(), Keyword::Sub, i));
            }
            Keyword::EndSub => {
                if !top_matches(&open, &[Keyword::Sub]) {
                    bail!("line {n}: {label} endsub without its {label} sub (or with a structure still open)");
                }
                let (_, _, s) = open.pop().unwrap_or_else(|| unreachable!());
                jumps.insert(s, Jump::SubEnd(i));
            }
            Keyword::Return => {
                // LinuxCNC accepts any label on a return inside a sub.
                if !open.iter().any(|(_, k, _)| *k == Keyword::Sub) {
                    bail!("line {n}: {label} return outside a sub");
                }
            }
            Keyword::If => {
                open.push((label.clone(), Keyword::If, i));
                branches.insert(i, Vec::new());
            }
            Keyword::ElseIf | Keyword::Else => {
                if !top_matches(&open, &[Keyword::If]) {
                    bail!(
                        "line {n}: {label} {} without its {label} if",
                        keyword.name()
                    );
                }
                let (_, _, s) = open.last().cloned().unwrap_or_else(|| unreachable!());
                let b = branches.entry(s).or_default();
                if let Some(&last) = b.last() {
                    if matches!(
                        &lines[last].stmt,
                        Stmt::OWord {
                            keyword: Keyword::Else,
                            ..
                        }
                    ) {
                        bail!("line {n}: {label} {} after {label} else", keyword.name());
                    }
                }
                b.push(i);
            }
            Keyword::EndIf => {
                if !top_matches(&open, &[Keyword::If]) {
                    bail!("line {n}: {label} endif without its {label} if");
                }
                let (_, _, s) = open.pop().unwrap_or_else(|| unreachable!());
                let b = branches.remove(&s).unwrap_or_default();
                let mut chain = vec![s];
                chain.extend(b);
                for (k, &at) in chain.iter().enumerate() {
                    let next = chain.get(k + 1).copied().unwrap_or(i);
                    let is_else = matches!(
                        &lines[at].stmt,
                        Stmt::OWord {
                            keyword: Keyword::Else,
                            ..
                        }
                    );
                    jumps.insert(
                        at,
                        if is_else {
                            Jump::Else { end: i }
                        } else {
                            Jump::Branch { next, end: i }
                        },
                    );
                }
            }
            Keyword::Do | Keyword::Repeat => open.push((label.clone(), *keyword, i)),
            Keyword::While => {
                if top_matches(&open, &[Keyword::Do]) {
                    let (_, _, s) = open.pop().unwrap_or_else(|| unreachable!());
                    jumps.insert(s, Jump::LoopStart { end: i });
                    jumps.insert(i, Jump::LoopEnd { start: s });
                } else {
                    open.push((label.clone(), Keyword::While, i));
                }
            }
            Keyword::EndWhile | Keyword::EndRepeat => {
                let want = if *keyword == Keyword::EndWhile {
                    Keyword::While
                } else {
                    Keyword::Repeat
                };
                if !top_matches(&open, &[want]) {
                    bail!(
                        "line {n}: {label} {} without its {label} {}",
                        keyword.name(),
                        want.name()
                    );
                }
                let (_, _, s) = open.pop().unwrap_or_else(|| unreachable!());
                jumps.insert(s, Jump::LoopStart { end: i });
                jumps.insert(i, Jump::LoopEnd { start: s });
            }
            Keyword::Break | Keyword::Continue => {
                let found = open.iter().rev().find(|(lb, k, _)| {
                    lb == label && matches!(k, Keyword::While | Keyword::Do | Keyword::Repeat)
                });
                let Some(&(_, _, s)) = found else {
                    bail!(
                        "line {n}: {label} {} outside a {label} loop",
                        keyword.name()
                    );
                };
                jumps.insert(i, Jump::InLoop { start: s });
            }
            Keyword::Call | Keyword::Program => {}
        }
    }
    if let Some((label, k, i)) = open.last() {
        bail!(
            "line {}: {label} {} is never closed",
            lines[*i].number,
            k.name()
        );
    }
    Ok((jumps, subs))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn structures_are_matched_and_mismatches_named() {
        let f = File::parse(
            "o1 sub\no2 if [1]\no2 elseif [0]\no2 else\no2 endif\no1 endsub\no3 do\no3 break\no3 while [1]\n",
            None,
        )
        .unwrap();
        assert_eq!(f.jumps[&0], Jump::SubEnd(5));
        assert_eq!(f.jumps[&1], Jump::Branch { next: 2, end: 4 });
        assert_eq!(f.jumps[&2], Jump::Branch { next: 3, end: 4 });
        assert_eq!(f.jumps[&3], Jump::Else { end: 4 });
        assert_eq!(f.jumps[&6], Jump::LoopStart { end: 8 });
        assert_eq!(f.jumps[&7], Jump::InLoop { start: 6 });
        for (src, line) in [
            ("o1 if [1]\n", "line 1"),
            ("G0 X1\no1 endif\n", "line 2"),
            ("o1 while [1]\no2 endwhile\n", "line 2"),
            ("o1 sub\no2 sub\n", "line 2"),
            ("o1 break\n", "line 1"),
            ("o1 if [1]\no1 else\no1 elseif [1]\no1 endif\n", "line 3"),
        ] {
            let e = File::parse(src, None).unwrap_err().to_string();
            assert!(e.contains(line), "{src:?}: {e}");
        }
    }
}
