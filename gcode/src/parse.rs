//! The syntax of one line of RS274/NGC as LinuxCNC reads it (its
//! `interp_read.cc`; the NIST RS274NGC v3 report, Kramer et al. 2000, §3.3):
//! comments are dropped (`(…)`, `;…`; an `(abort,…)` comment is kept), then
//! spaces and case no longer matter; a line is an optional block delete `/`,
//! an optional `N` number, then either one O-word statement or words and
//! parameter assignments.
//!
//! A word's value is a *real value*: a number, a bracketed expression, a
//! parameter (`#5`, `##1`, `#[…]`, `#<name>`), a unary function of a bracketed
//! expression (`sin[30]`, `atan[y]/[x]`, `exists[#<name>]`), or a signed real
//! value. Expressions combine real values with binary operators at five
//! precedence levels ([`crate::expr`]). Numbers have no exponent (in
//! rs274ngc `E` is a word letter), so `1e3` is the number 1 then an `E` word.
//!
//! An expression is read into postfix order ([`crate::expr::Op`]): operators
//! wait on a small stack by precedence, so a chain of any length reads in a
//! loop. Only nesting (brackets, signs, `#`, function arguments) recurses,
//! and it is refused beyond a fixed depth (`MAX_DEPTH`) with an error
//! naming the line.
//!
//! Why not a lexing crate: the `gcode` crate (and the others on crates.io at
//! the time of writing) reads words with literal numbers only; none reads
//! rs274ngc's brackets, parameters or O-words, and the evaluator has to see
//! the expression's structure anyway.

use anyhow::{anyhow, bail, Result};

use super::expr::{BinOp, Expr, Func, Op, ParamRef};

/// An O-word's label: `o100` or `o<name>`.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Label {
    /// `o123`.
    Number(u32),
    /// `o<name>` (lower case, spaces removed).
    Name(String),
}

impl std::fmt::Display for Label {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Label::Number(n) => write!(f, "o{n}"),
            Label::Name(s) => write!(f, "o<{s}>"),
        }
    }
}

/// The keyword of an O-word statement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Keyword {
    /// `sub`.
    Sub,
    /// `endsub [value]`.
    EndSub,
    /// `call [arg]…`.
    Call,
    /// `return [value]`.
    Return,
    /// `if [cond]`.
    If,
    /// `elseif [cond]`.
    ElseIf,
    /// `else`.
    Else,
    /// `endif`.
    EndIf,
    /// `while [cond]` (opening a loop, or closing a `do`).
    While,
    /// `endwhile`.
    EndWhile,
    /// `do`.
    Do,
    /// `repeat [count]`.
    Repeat,
    /// `endrepeat`.
    EndRepeat,
    /// `break`.
    Break,
    /// `continue`.
    Continue,
    /// A bare `O1000` (no keyword): a Fanuc-style program number, the start
    /// of a subprogram that `M98 P1000` calls and `M99` ends (LinuxCNC
    /// `interp_read.cc`, `Interp::read_o`: the `O_` type); a no-op where
    /// the program runs into it.
    Program,
}

impl Keyword {
    fn from_word(w: &str) -> Option<Self> {
        Some(match w {
            "sub" => Keyword::Sub,
            "endsub" => Keyword::EndSub,
            "call" => Keyword::Call,
            "return" => Keyword::Return,
            "if" => Keyword::If,
            "elseif" => Keyword::ElseIf,
            "else" => Keyword::Else,
            "endif" => Keyword::EndIf,
            "while" => Keyword::While,
            "endwhile" => Keyword::EndWhile,
            "do" => Keyword::Do,
            "repeat" => Keyword::Repeat,
            "endrepeat" => Keyword::EndRepeat,
            "break" => Keyword::Break,
            "continue" => Keyword::Continue,
            _ => return None,
        })
    }

    /// The keyword as written.
    pub fn name(self) -> &'static str {
        match self {
            Keyword::Sub => "sub",
            Keyword::EndSub => "endsub",
            Keyword::Call => "call",
            Keyword::Return => "return",
            Keyword::If => "if",
            Keyword::ElseIf => "elseif",
            Keyword::Else => "else",
            Keyword::EndIf => "endif",
            Keyword::While => "while",
            Keyword::EndWhile => "endwhile",
            Keyword::Do => "do",
            Keyword::Repeat => "repeat",
            Keyword::EndRepeat => "endrepeat",
            Keyword::Break => "break",
            Keyword::Continue => "continue",
            Keyword::Program => "(program number)",
        }
    }
}

/// One word: a letter and its value (unevaluated). Besides the letters,
/// LinuxCNC's `$` (spindle number), `@` (polar radius) and `^` (polar angle,
/// degrees) are words.
#[derive(Clone, Debug, PartialEq)]
pub struct Word {
    /// Upper-case letter.
    pub letter: char,
    /// Its value.
    pub value: Expr,
}

/// What a line holds.
#[derive(Clone, Debug, PartialEq)]
pub enum Stmt {
    /// Words and assignments (possibly none: an empty or comment line).
    Block {
        /// Words in line order.
        words: Vec<Word>,
        /// `#… = value` assignments, applied after the line's values are
        /// read (rs274ngc: a parameter set on a line is seen from the next).
        assigns: Vec<(ParamRef, Expr)>,
        /// The text of an `(abort, …)` comment.
        abort: Option<String>,
    },
    /// An O-word statement.
    OWord {
        /// Its label.
        label: Label,
        /// Its keyword.
        keyword: Keyword,
        /// Bracketed arguments: call arguments, a condition, a count or a
        /// return value.
        args: Vec<Expr>,
    },
    /// A `%` line.
    Percent,
    /// A line with no effect, skipped with this warning (a Grbl query:
    /// [`crate::grbl_system`]).
    Skipped(String),
}

/// A parsed source line.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// 1-based source line.
    pub number: u32,
    /// Starts with `/` (skipped when block delete is on).
    pub block_delete: bool,
    /// Its content.
    pub stmt: Stmt,
}

/// Drop comments (keeping an `(abort, …)` text), spaces and case.
fn clean(src: &str, line: u32) -> Result<(String, Option<String>)> {
    let mut out = String::with_capacity(src.len());
    let mut abort = None;
    let mut chars = src.chars();
    while let Some(c) = chars.next() {
        match c {
            '(' => {
                let mut text = String::new();
                loop {
                    match chars.next() {
                        Some(')') => break,
                        Some('(') => bail!("line {line}: nested comment"),
                        Some(c) => text.push(c),
                        None => bail!("line {line}: comment not closed by ')'"),
                    }
                }
                let t = text.trim_start().to_ascii_lowercase();
                if let Some(rest) = t.strip_prefix("abort,") {
                    abort = Some(rest.trim().to_string());
                }
            }
            ';' => break,
            c if c.is_whitespace() => {}
            c => out.push(c.to_ascii_lowercase()),
        }
    }
    Ok((out, abort))
}

/// Parse one source line (without its newline).
pub fn line(src: &str, number: u32) -> Result<Line> {
    let (text, abort) = clean(src, number)?;
    match super::grbl_system::classify(&text) {
        Some(super::grbl_system::SystemLine::Refuse(m)) => bail!("line {number}: {m}"),
        Some(super::grbl_system::SystemLine::Skip(m)) => {
            return Ok(Line {
                number,
                block_delete: false,
                stmt: Stmt::Skipped(m),
            })
        }
        None => {}
    }
    let mut c = Cursor {
        s: text.as_bytes(),
        i: 0,
        line: number,
    };
    let block_delete = c.eat(b'/');
    if text.len() - c.i == 1 && c.peek() == Some(b'%') {
        return Ok(Line {
            number,
            block_delete,
            stmt: Stmt::Percent,
        });
    }
    if c.peek() == Some(b'n') {
        c.i += 1;
        let start = c.i;
        while c.peek().is_some_and(|b| b.is_ascii_digit() || b == b'.') {
            c.i += 1;
        }
        if c.i == start {
            bail!("line {number}: N without a number");
        }
    }
    if c.peek() == Some(b'o') {
        let stmt = c.oword()?;
        return Ok(Line {
            number,
            block_delete,
            stmt,
        });
    }
    let mut words = Vec::new();
    let mut assigns = Vec::new();
    while let Some(b) = c.peek() {
        if b == b'#' {
            c.i += 1;
            let p = c.param_ref()?;
            if !c.eat(b'=') {
                bail!("line {number}: a parameter at the start of a word must be assigned (#… = value)");
            }
            let v = c.real_value()?;
            assigns.push((p, v));
        } else if b.is_ascii_lowercase() || matches!(b, b'$' | b'@' | b'^') {
            c.i += 1;
            let letter = (b as char).to_ascii_uppercase();
            if letter == 'N' {
                bail!("line {number}: N word after the start of the line");
            }
            if letter == 'O' {
                bail!("line {number}: O-word after the start of the line");
            }
            let value = c.real_value()?;
            words.push(Word { letter, value });
        } else {
            bail!(
                "line {number}: unexpected {:?} (a word letter, '#' or a comment expected)",
                b as char
            );
        }
    }
    Ok(Line {
        number,
        block_delete,
        stmt: Stmt::Block {
            words,
            assigns,
            abort,
        },
    })
}

struct Cursor<'a> {
    s: &'a [u8],
    i: usize,
    line: u32,
}

/// Deepest nesting of brackets and signs in one value: bounds the parser's
/// recursion on hostile input.
const MAX_DEPTH: usize = 64;

impl Cursor<'_> {
    fn peek(&self) -> Option<u8> {
        self.s.get(self.i).copied()
    }

    fn eat(&mut self, b: u8) -> bool {
        if self.peek() == Some(b) {
            self.i += 1;
            true
        } else {
            false
        }
    }

    fn starts_with(&self, w: &str) -> bool {
        self.s[self.i..].starts_with(w.as_bytes())
    }

    fn err(&self, what: &str) -> anyhow::Error {
        let rest = String::from_utf8_lossy(&self.s[self.i.min(self.s.len())..]);
        let rest: String = rest.chars().take(20).collect();
        anyhow!("line {}: {what} (at {rest:?})", self.line)
    }

    fn oword(&mut self) -> Result<Stmt> {
        self.i += 1; // 'o'
        let label = if self.eat(b'<') {
            let start = self.i;
            while self.peek().is_some_and(|b| b != b'>') {
                self.i += 1;
            }
            let name = String::from_utf8_lossy(&self.s[start..self.i]).into_owned();
            if !self.eat(b'>') || name.is_empty() {
                return Err(self.err("O-word name not closed by '>'"));
            }
            Label::Name(name)
        } else {
            let start = self.i;
            while self.peek().is_some_and(|b| b.is_ascii_digit()) {
                self.i += 1;
            }
            let digits = std::str::from_utf8(&self.s[start..self.i]).unwrap_or("");
            Label::Number(
                digits
                    .parse()
                    .map_err(|_| self.err("O-word without a number or <name>"))?,
            )
        };
        let start = self.i;
        while self.peek().is_some_and(|b| b.is_ascii_lowercase()) {
            self.i += 1;
        }
        let word = std::str::from_utf8(&self.s[start..self.i]).unwrap_or("");
        if word.is_empty() && self.i == self.s.len() && matches!(label, Label::Number(_)) {
            return Ok(Stmt::OWord {
                label,
                keyword: Keyword::Program,
                args: Vec::new(),
            });
        }
        let keyword = Keyword::from_word(word).ok_or_else(|| {
            anyhow!(
                "line {}: {label} {word:?} is not an O-word keyword (sub, endsub, call, return, if, elseif, else, endif, while, endwhile, do, repeat, endrepeat, break, continue)",
                self.line
            )
        })?;
        let mut args = Vec::new();
        while self.peek() == Some(b'[') {
            self.i += 1;
            let mut out = Vec::new();
            self.expression(0, &mut out)?;
            args.push(Expr::from_ops(out));
        }
        if self.i < self.s.len() {
            return Err(self.err(&format!("unexpected text after {label} {word}")));
        }
        let want = match keyword {
            Keyword::If | Keyword::ElseIf | Keyword::Repeat => Some(1..=1),
            Keyword::While => Some(0..=1),
            Keyword::Return | Keyword::EndSub => Some(0..=1),
            Keyword::Call => None,
            _ => Some(0..=0),
        };
        if let Some(w) = want {
            if !w.contains(&args.len()) {
                bail!(
                    "line {}: {label} {word} takes {} bracketed value{}",
                    self.line,
                    if w.end() == &0 { "no" } else { "one" },
                    if w.end() == &0 { "s" } else { "" }
                );
            }
        }
        if keyword == Keyword::While && args.is_empty() {
            bail!("line {}: {label} while needs a [condition]", self.line);
        }
        if args.len() > 30 {
            bail!(
                "line {}: {label} call has {} arguments; at most 30",
                self.line,
                args.len()
            );
        }
        Ok(Stmt::OWord {
            label,
            keyword,
            args,
        })
    }

    /// The target of an assignment, after its `#`.
    fn param_ref(&mut self) -> Result<ParamRef> {
        if let Some(name) = self.param_name()? {
            return Ok(ParamRef::Named(name));
        }
        let mut out = Vec::new();
        self.real_value_depth(1, &mut out)?;
        Ok(ParamRef::Number(Expr::from_ops(out)))
    }

    /// `<name>` after a `#`, if there is one.
    fn param_name(&mut self) -> Result<Option<String>> {
        if !self.eat(b'<') {
            return Ok(None);
        }
        let start = self.i;
        while self.peek().is_some_and(|b| b != b'>') {
            self.i += 1;
        }
        let name = String::from_utf8_lossy(&self.s[start..self.i]).into_owned();
        if !self.eat(b'>') || name.is_empty() {
            return Err(self.err("parameter name not closed by '>'"));
        }
        Ok(Some(name))
    }

    /// A parameter's value, after its `#`.
    fn param_value(&mut self, depth: usize, out: &mut Vec<Op>) -> Result<()> {
        if let Some(name) = self.param_name()? {
            out.push(Op::Named(name));
            return Ok(());
        }
        self.real_value_depth(depth + 1, out)?;
        out.push(Op::Param);
        Ok(())
    }

    fn real_value(&mut self) -> Result<Expr> {
        let mut out = Vec::new();
        self.real_value_depth(0, &mut out)?;
        Ok(Expr::from_ops(out))
    }

    /// One real value, its postfix steps appended to `out`. Recurses only
    /// into brackets, signs, `#` and function arguments, at most
    /// [`MAX_DEPTH`] deep.
    fn real_value_depth(&mut self, depth: usize, out: &mut Vec<Op>) -> Result<()> {
        if depth > MAX_DEPTH {
            return Err(self.err("value nested too deeply"));
        }
        match self.peek() {
            Some(b'[') => {
                self.i += 1;
                self.expression(depth + 1, out)
            }
            Some(b'#') => {
                self.i += 1;
                self.param_value(depth + 1, out)
            }
            Some(b'-') => {
                self.i += 1;
                self.real_value_depth(depth + 1, out)?;
                out.push(Op::Neg);
                Ok(())
            }
            Some(b'+') => {
                self.i += 1;
                self.real_value_depth(depth + 1, out)
            }
            Some(b) if b.is_ascii_lowercase() => self.function(depth + 1, out),
            Some(b) if b.is_ascii_digit() || b == b'.' => {
                out.push(Op::Num(self.number()?));
                Ok(())
            }
            Some(b) => Err(self.err(&format!("a value expected, not {:?}", b as char))),
            None => Err(self.err("a value expected at the end of the line")),
        }
    }

    fn number(&mut self) -> Result<f64> {
        let start = self.i;
        let mut dot = false;
        while let Some(b) = self.peek() {
            if b.is_ascii_digit() {
                self.i += 1;
            } else if b == b'.' && !dot {
                dot = true;
                self.i += 1;
            } else {
                break;
            }
        }
        let t = std::str::from_utf8(&self.s[start..self.i]).unwrap_or("");
        if t == "." {
            return Err(self.err("a number expected"));
        }
        t.parse::<f64>().map_err(|_| self.err("a number expected"))
    }

    fn function(&mut self, depth: usize, out: &mut Vec<Op>) -> Result<()> {
        const FUNCS: [(&str, Func); 14] = [
            ("abs", Func::Abs),
            ("acos", Func::Acos),
            ("asin", Func::Asin),
            ("atan", Func::Atan),
            ("cos", Func::Cos),
            ("exists", Func::Exists),
            ("exp", Func::Exp),
            ("fix", Func::Fix),
            ("fup", Func::Fup),
            ("ln", Func::Ln),
            ("round", Func::Round),
            ("sin", Func::Sin),
            ("sqrt", Func::Sqrt),
            ("tan", Func::Tan),
        ];
        let Some(&(name, f)) = FUNCS
            .iter()
            .filter(|(n, _)| self.starts_with(n))
            .max_by_key(|(n, _)| n.len())
        else {
            return Err(self.err("a value expected (number, [expression], #parameter or function)"));
        };
        self.i += name.len();
        if !self.eat(b'[') {
            return Err(self.err(&format!("{name} needs a [bracketed] argument")));
        }
        if f == Func::Exists {
            if !self.eat(b'#') {
                return Err(self.err("exists[] takes a #<named parameter>"));
            }
            let Some(n) = self.param_name()? else {
                return Err(self.err("exists[] takes a #<named parameter>"));
            };
            if !self.eat(b']') {
                return Err(self.err("exists[#<name>] not closed by ']'"));
            }
            out.push(Op::Exists(n));
            return Ok(());
        }
        self.expression(depth, out)?;
        if f == Func::Atan {
            if !self.eat(b'/') || !self.eat(b'[') {
                return Err(self.err("atan needs two arguments: atan[y]/[x]"));
            }
            self.expression(depth, out)?;
            out.push(Op::Atan2);
        } else {
            out.push(Op::Call(f));
        }
        Ok(())
    }

    fn binop(&mut self) -> Option<BinOp> {
        const OPS: [(&str, BinOp); 15] = [
            ("**", BinOp::Pow),
            ("*", BinOp::Mul),
            ("/", BinOp::Div),
            ("mod", BinOp::Mod),
            ("+", BinOp::Add),
            ("-", BinOp::Sub),
            ("eq", BinOp::Eq),
            ("ne", BinOp::Ne),
            ("gt", BinOp::Gt),
            ("ge", BinOp::Ge),
            ("lt", BinOp::Lt),
            ("le", BinOp::Le),
            ("and", BinOp::And),
            ("or", BinOp::Or),
            ("xor", BinOp::Xor),
        ];
        for (s, op) in OPS {
            if self.starts_with(s) {
                self.i += s.len();
                return Some(op);
            }
        }
        None
    }

    /// An expression after its `[`, up to and including its `]`, its
    /// postfix steps appended to `out`: operators are applied by
    /// precedence, left to right within a level (as LinuxCNC's
    /// `read_real_expression`). Operators wait on a stack of rising
    /// precedence, so it never holds more than one per level however long
    /// the expression is.
    fn expression(&mut self, depth: usize, out: &mut Vec<Op>) -> Result<()> {
        if depth > MAX_DEPTH {
            return Err(self.err("expression nested too deeply"));
        }
        self.real_value_depth(depth + 1, out)?;
        let mut ops: Vec<BinOp> = Vec::new();
        loop {
            if self.eat(b']') {
                break;
            }
            let Some(op) = self.binop() else {
                return Err(self.err("an operator or ']' expected"));
            };
            while let Some(&top) = ops.last() {
                if top.precedence() < op.precedence() {
                    break;
                }
                out.push(Op::Bin(top));
                ops.pop();
            }
            ops.push(op);
            self.real_value_depth(depth + 1, out)?;
        }
        while let Some(op) = ops.pop() {
            out.push(Op::Bin(op));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(src: &str) -> Vec<Word> {
        match line(src, 1).unwrap().stmt {
            Stmt::Block { words, .. } => words,
            s => panic!("{s:?}"),
        }
    }

    #[test]
    fn comments_spaces_and_case_do_not_matter() {
        let w = words("n10 g 1 x 1.5 (a comment) Y-2 ; rest");
        assert_eq!(w.len(), 3);
        assert_eq!(w[1].letter, 'X');
        assert_eq!(w[1].value, Expr::number(1.5));
        assert_eq!(w[2].value.ops(), [Op::Num(2.0), Op::Neg]);
        assert!(line("G1 (open", 3)
            .unwrap_err()
            .to_string()
            .contains("line 3"));
    }

    #[test]
    fn oword_statements() {
        let l = line("O<Sub Name> call [1] [2+3]", 1).unwrap();
        let Stmt::OWord {
            label,
            keyword,
            args,
        } = l.stmt
        else {
            panic!()
        };
        assert_eq!(label, Label::Name("subname".into()));
        assert_eq!(keyword, Keyword::Call);
        assert_eq!(args.len(), 2);
        assert!(line("o100 sub", 1).is_ok());
        assert!(line("o100 frobnicate", 1).is_err());
        assert!(line("o100 if", 1).is_err());
    }

    #[test]
    fn assignments_and_precedence_shape() {
        let l = line("#1=[1+2*3] #<a> = #1", 1).unwrap();
        let Stmt::Block { assigns, .. } = l.stmt else {
            panic!()
        };
        assert_eq!(assigns.len(), 2);
        // 1 + (2*3), in postfix.
        assert_eq!(
            assigns[0].1.ops(),
            [
                Op::Num(1.0),
                Op::Num(2.0),
                Op::Num(3.0),
                Op::Bin(BinOp::Mul),
                Op::Bin(BinOp::Add)
            ]
        );
        assert!(line("X[1+]", 1).is_err());
        assert!(line("X[1", 1).is_err());
        assert!(line(
            "X[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[1",
            1
        )
        .is_err());
    }
}
