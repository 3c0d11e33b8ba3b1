//! A program's lines and the structure of its O-words: which `sub` ends
//! where, each `if`'s branches, each loop's two ends, and the loop each
//! `break`/`continue` leaves (LinuxCNC's `interp_o_word.cc` finds these by
//! searching the file at run time; we find them once, before running, so a
//! mismatched or unclosed structure is an error naming its line even in a
//! branch that never runs).
//!
//! Where the program ends, reading stops being strict. After a closing `%`
//! nothing is read (LinuxCNC ignores the rest of the file). After an M2 or
//! M30 outside any O-word structure, lines are still read, because Fanuc and
//! Mach3 programs define their subprograms there; but a line that does not
//! parse is kept as an empty block whose error is raised only if the line
//! runs ([`File::unparsed`]), since rs274ngc never reads it otherwise.

use std::collections::HashMap;
use std::path::PathBuf;

use anyhow::{bail, Result};

use super::parse::{self, Keyword, Label, Line, Stmt};
use super::text;

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
    /// Lines after the program's end that do not parse: line number → the
    /// error, raised when the line runs (it is an empty block in `lines`).
    pub unparsed: HashMap<u32, String>,
}

impl File {
    /// Parse `src` and find its structure.
    pub fn parse(src: &str, path: Option<PathBuf>) -> Result<Self> {
        let mut lines = Vec::new();
        let mut unparsed = HashMap::new();
        let mut end = EndOfProgram::default();
        for (i, text) in text::lines(text::strip_bom(src)).enumerate() {
            let number = u32::try_from(i + 1).unwrap_or(u32::MAX);
            let line = match parse::line(text, number) {
                Ok(l) => l,
                Err(e) if end.passed => {
                    unparsed.insert(number, format!("{e:#}"));
                    Line {
                        number,
                        block_delete: false,
                        stmt: Stmt::Block {
                            words: Vec::new(),
                            assigns: Vec::new(),
                            abort: None,
                        },
                    }
                }
                Err(e) => return Err(e),
            };
            let closing = end.see(&line);
            lines.push(line);
            if closing {
                break;
            }
        }
        let (jumps, subs) = structure(&lines)?;
        Ok(File {
            path,
            lines,
            jumps,
            subs,
            unparsed,
        })
    }

    /// A file with no lines yet: a live program's, grown by
    /// [`File::append`].
    pub fn empty() -> Self {
        File {
            path: None,
            lines: Vec::new(),
            jumps: HashMap::new(),
            subs: HashMap::new(),
            unparsed: HashMap::new(),
        }
    }

    /// Append `lines`, whose O-word structures are complete in themselves;
    /// the subroutines they define, by their index among `lines`.
    pub fn append(&mut self, lines: Vec<Line>) -> Result<Vec<(Label, usize)>> {
        let (jumps, subs) = structure(&lines)?;
        let base = self.lines.len();
        for (label, &i) in &subs {
            if self.subs.contains_key(label) {
                bail!("line {}: {label} sub is defined twice", lines[i].number);
            }
        }
        let shift = |j: Jump| match j {
            Jump::SubEnd(e) => Jump::SubEnd(base + e),
            Jump::Branch { next, end } => Jump::Branch {
                next: base + next,
                end: base + end,
            },
            Jump::Else { end } => Jump::Else { end: base + end },
            Jump::LoopStart { end } => Jump::LoopStart { end: base + end },
            Jump::LoopEnd { start } => Jump::LoopEnd {
                start: base + start,
            },
            Jump::InLoop { start } => Jump::InLoop {
                start: base + start,
            },
        };
        for (i, j) in jumps {
            self.jumps.insert(base + i, shift(j));
        }
        let added: Vec<(Label, usize)> = subs.into_iter().collect();
        for (label, i) in &added {
            self.subs.insert(label.clone(), base + i);
        }
        self.lines.extend(lines);
        Ok(added)
    }

    /// The label and keyword of line `i`, if it is an O-word.
    pub fn oword(&self, i: usize) -> Option<(&Label, Keyword)> {
        match &self.lines.get(i)?.stmt {
            Stmt::OWord { label, keyword, .. } => Some((label, *keyword)),
            _ => None,
        }
    }
}

/// How deep a stream of lines is inside O-word structures (`sub`, `if`,
/// loops): a live program runs a structure once it is closed.
#[derive(Clone, Debug, Default)]
pub struct Opened {
    open: Vec<(Label, Keyword)>,
}

impl Opened {
    /// Account for one more line.
    pub fn step(&mut self, l: &Line) {
        let Stmt::OWord { label, keyword, .. } = &l.stmt else {
            return;
        };
        let top = |open: &[(Label, Keyword)], k: Keyword| {
            open.last().is_some_and(|(lb, kw)| lb == label && *kw == k)
        };
        match keyword {
            Keyword::Sub | Keyword::If | Keyword::Do | Keyword::Repeat => {
                self.open.push((label.clone(), *keyword))
            }
            Keyword::While if top(&self.open, Keyword::Do) => {
                self.open.pop();
            }
            Keyword::While => self.open.push((label.clone(), Keyword::While)),
            Keyword::EndSub | Keyword::EndIf | Keyword::EndWhile | Keyword::EndRepeat => {
                // A mismatched closer is left to the structure check.
                self.open.pop();
            }
            _ => {}
        }
    }

    /// No structure is open.
    pub fn closed(&self) -> bool {
        self.open.is_empty()
    }
}

/// Where the program ends, followed line by line while reading: the run
/// loop's rule for `%` (the first one opens the program unless a block came
/// before it; the next ends it) and M2/M30 outside O-word structures.
#[derive(Default)]
struct EndOfProgram {
    percent: bool,
    /// A block or O-word seen (not block-deleted).
    content: bool,
    /// A block-deleted block seen.
    deleted: bool,
    /// Open O-word structures, innermost last.
    open: Vec<Keyword>,
    /// Past an M2 or M30, or a `%` that ends the program when block delete
    /// is off: later lines need not parse.
    passed: bool,
}

impl EndOfProgram {
    /// Follow `line`; `true` when it is a `%` that always ends the program.
    fn see(&mut self, line: &Line) -> bool {
        match &line.stmt {
            Stmt::Skipped(_) => self.content = true,
            Stmt::Percent => {
                if self.percent || self.content {
                    return true;
                }
                // Only block-deleted lines came before: this `%` ends the
                // program unless block delete is on.
                self.passed |= self.deleted;
                self.percent = true;
            }
            Stmt::OWord { keyword, .. } => {
                self.content = true;
                match keyword {
                    Keyword::Sub | Keyword::If | Keyword::Do | Keyword::Repeat => {
                        self.open.push(*keyword)
                    }
                    Keyword::While if self.open.last() != Some(&Keyword::Do) => {
                        self.open.push(*keyword)
                    }
                    Keyword::While
                    | Keyword::EndSub
                    | Keyword::EndIf
                    | Keyword::EndWhile
                    | Keyword::EndRepeat => {
                        self.open.pop();
                    }
                    _ => {}
                }
            }
            Stmt::Block { words, assigns, .. } => {
                if line.block_delete {
                    if !words.is_empty() || !assigns.is_empty() {
                        self.deleted = true;
                    }
                } else {
                    if !words.is_empty() || !assigns.is_empty() {
                        self.content = true;
                    }
                    let stops = words.iter().any(|w| {
                        w.letter == 'M' && matches!(w.value.as_number(), Some(2.0 | 30.0))
                    });
                    if stops && self.open.is_empty() {
                        self.passed = true;
                    }
                }
            }
        }
        false
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

    fn run(src: &str) -> Result<crate::Program> {
        crate::run(src, None, &crate::GcodeSettings::default())
    }

    fn xs(src: &str) -> Vec<f64> {
        run(src).unwrap().points.iter().map(|p| p[0]).collect()
    }

    #[test]
    fn a_byte_order_mark_and_any_line_ends_are_read() {
        assert_eq!(xs("\u{feff}G1 X1 F100\n"), [0.0, 1.0]);
        assert_eq!(xs("G1 X1 F100\rG1 X2\rG1 X3"), [0.0, 1.0, 2.0, 3.0]);
        let p = run("G1 X1 F100\r\nG1 X2\r\rG1 X3\nG1 X4\r").unwrap();
        assert_eq!(p.lines, [0, 1, 2, 4, 5]);
        let e = format!("{:#}", run("G1 X1 F100\r\rG1 X2\rX[1/0]\n").unwrap_err());
        assert!(e.contains("line 4"), "{e}");
    }

    #[test]
    fn nothing_after_a_closing_percent_is_read() {
        let f = File::parse("%\nG1 X1 F100\n%\nnot ((G-code\no1 endif\n", None).unwrap();
        assert_eq!(f.lines.len(), 3);
        assert_eq!(xs("G1 X1 F100\n%\n((\n"), [0.0, 1.0]);
    }

    #[test]
    fn lines_after_m2_or_m30_fail_only_when_they_run() {
        // Never run: no error.
        assert_eq!(xs("G1 X1 F100\nM30\nnot ((G-code\nG1 X[1+]\n"), [0.0, 1.0]);
        assert_eq!(xs("G1 X1 F100\nM2\nO1000\nM99\n"), [0.0, 1.0]);
        // A subprogram after M30 is found and runs; its lines that do not
        // parse fail when they run, naming their line.
        let sub = "o<s> call\nM30\no<s> sub\nG1 X2 F100\no<s> endsub\n";
        assert_eq!(xs(sub), [0.0, 2.0]);
        let bad =
            "o<s> call\nM30\no<s> sub\nG1 X[1+] F100\no<s> endsub\no<t> sub\n((\no<t> endsub\n";
        let e = format!("{:#}", run(bad).unwrap_err());
        assert!(e.contains("line 4"), "{e}");
        assert!(run(&bad.replace("X[1+]", "X2")).is_ok());
    }

    #[test]
    fn an_end_that_may_not_be_reached_keeps_reading_strict() {
        for (src, line) in [
            // M30 in a branch, in a sub, block-deleted.
            ("o1 if [0]\nM30\no1 endif\nX[1+]\n", "line 4"),
            ("o2 sub\nM2\no2 endsub\nX[1+]\n", "line 4"),
            ("/M30\nX[1+]\n", "line 2"),
            // A line before the end is read strictly.
            ("X[1+]\nM30\n", "line 1"),
        ] {
            let e = File::parse(src, None).unwrap_err().to_string();
            assert!(e.contains(line), "{src:?}: {e}");
        }
        // After block-deleted lines only, a `%` ends the program unless
        // block delete is on: the next lines run only with it on.
        let src = "/G1 X1 F100\n%\nX[1+]\n";
        let e = format!("{:#}", run(src).unwrap_err());
        assert!(e.contains("line 3"), "{e}");
        let off = crate::GcodeSettings {
            block_delete: false,
            ..Default::default()
        };
        let p = crate::run(src, None, &off).unwrap();
        assert_eq!(p.points.len(), 2);
    }
}
