//! rs274ngc expressions and their evaluation, as LinuxCNC defines them
//! (`interp_execute.cc`: `execute_binary1/2`, `execute_unary`;
//! `interp_internal.cc`: `precedence`):
//!
//! | level | operators |
//! |---|---|
//! | 5 (first) | `**` |
//! | 4 | `*` `/` `MOD` |
//! | 3 | `+` `-` |
//! | 2 | `EQ` `NE` `GT` `GE` `LT` `LE` |
//! | 1 (last) | `AND` `OR` `XOR` |
//!
//! Operators of one level apply left to right. Comparisons give 1 or 0; `EQ`
//! and `NE` (and the equal case of `LE`, `GE`) compare within 1e-6, as
//! LinuxCNC's `TOLERANCE_EQUAL`. Logical operators take any non-zero value as
//! true. `MOD` is always ≥ 0 (`fmod`, then `+|b|` when negative). Angles are
//! in degrees; `ATAN[y]/[x]` is the four-quadrant arctangent; `FIX` rounds
//! down, `FUP` up, `ROUND` to the nearest (halves away from zero).
//! Division by zero, `LN` of x ≤ 0, `SQRT` of x < 0, `ASIN`/`ACOS` outside
//! [-1, 1] and a negative number to a non-integer power are errors.

use anyhow::{anyhow, bail, Result};

use crate::text::short;

/// A parameter reference (the target of an assignment).
#[derive(Clone, Debug, PartialEq)]
pub enum ParamRef {
    /// `#n`, `##n`, `#[expr]`: the number is a value.
    Number(Expr),
    /// `#<name>` (lower case, spaces removed).
    Named(String),
}

/// Unary functions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Func {
    /// `ABS`.
    Abs,
    /// `ACOS`, degrees.
    Acos,
    /// `ASIN`, degrees.
    Asin,
    /// `ATAN` (always with two arguments: [`Op::Atan2`]).
    Atan,
    /// `COS` of degrees.
    Cos,
    /// `EXISTS` (see [`Op::Exists`]).
    Exists,
    /// `EXP`.
    Exp,
    /// `FIX`: round down.
    Fix,
    /// `FUP`: round up.
    Fup,
    /// `LN`.
    Ln,
    /// `ROUND`: to the nearest.
    Round,
    /// `SIN` of degrees.
    Sin,
    /// `SQRT`.
    Sqrt,
    /// `TAN` of degrees.
    Tan,
}

/// Binary operators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum BinOp {
    Pow,
    Mul,
    Div,
    Mod,
    Add,
    Sub,
    Eq,
    Ne,
    Gt,
    Ge,
    Lt,
    Le,
    And,
    Or,
    Xor,
}

impl BinOp {
    /// Binding strength (higher binds first).
    pub fn precedence(self) -> u8 {
        match self {
            BinOp::Pow => 5,
            BinOp::Mul | BinOp::Div | BinOp::Mod => 4,
            BinOp::Add | BinOp::Sub => 3,
            BinOp::Eq | BinOp::Ne | BinOp::Gt | BinOp::Ge | BinOp::Lt | BinOp::Le => 2,
            BinOp::And | BinOp::Or | BinOp::Xor => 1,
        }
    }
}

/// One step of an expression in postfix order: it pops its operands from
/// the value stack and pushes its result.
#[derive(Clone, Debug, PartialEq)]
pub enum Op {
    /// Push a number.
    Num(f64),
    /// Push `#<name>`.
    Named(String),
    /// Pop a parameter number, push that parameter (`#value`).
    Param,
    /// Push 1 if `#<name>` is defined, else 0 (`EXISTS[#<name>]`).
    Exists(String),
    /// Pop x, push −x.
    Neg,
    /// Pop x, push F(x).
    Call(Func),
    /// Pop x, then y, push `ATAN[y]/[x]`.
    Atan2,
    /// Pop b, then a, push `a op b`.
    Bin(BinOp),
}

/// An expression as a flat postfix sequence, evaluated with a value stack.
/// Neither evaluating, cloning, comparing nor dropping it recurses, so an
/// expression as long as a line can be (a chain of a hundred thousand
/// `+1`) needs no more call stack than `[1]`; only bracket nesting recurses,
/// in the parser, and that is bounded there.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Expr {
    ops: Vec<Op>,
}

impl Expr {
    /// The constant `x`.
    pub fn number(x: f64) -> Self {
        Expr {
            ops: vec![Op::Num(x)],
        }
    }

    /// An expression from its postfix steps (see [`Expr::eval`] for what a
    /// malformed sequence gives).
    pub fn from_ops(ops: Vec<Op>) -> Self {
        Expr { ops }
    }

    /// Its postfix steps.
    pub fn ops(&self) -> &[Op] {
        &self.ops
    }

    /// The value when the expression is a literal number.
    pub fn as_number(&self) -> Option<f64> {
        match self.ops.as_slice() {
            [Op::Num(x)] => Some(*x),
            _ => None,
        }
    }

    /// The value, reading parameters from `p`. A sequence that does not
    /// leave exactly one value (the parser never builds one) is an error.
    pub fn eval(&self, p: &dyn Params) -> Result<f64> {
        let mut stack: Vec<f64> = Vec::with_capacity(8);
        let malformed = || anyhow!("malformed expression");
        for op in &self.ops {
            let mut pop = || stack.pop().ok_or_else(malformed);
            let v = match op {
                Op::Num(x) => *x,
                Op::Named(n) => p.named(n)?,
                Op::Exists(n) => truth(p.exists(n)),
                Op::Param => p.number(parameter_number(pop()?)?)?,
                Op::Neg => -pop()?,
                Op::Call(f) => unary(*f, pop()?)?,
                Op::Atan2 => {
                    let x = pop()?;
                    let y = pop()?;
                    y.atan2(x).to_degrees()
                }
                Op::Bin(op) => {
                    let b = pop()?;
                    let a = pop()?;
                    binary(*op, a, b)?
                }
            };
            if v.is_nan() {
                bail!("the expression is not a number");
            }
            stack.push(v);
        }
        match stack.as_slice() {
            [v] => Ok(*v),
            _ => Err(malformed()),
        }
    }
}

/// `F[x]`.
pub fn unary(f: Func, x: f64) -> Result<f64> {
    Ok(match f {
        Func::Abs => x.abs(),
        Func::Acos | Func::Asin => {
            if !(-1.0..=1.0).contains(&x) {
                bail!("{} of {}: outside [-1, 1]", func_name(f), short(x));
            }
            if f == Func::Acos {
                x.acos().to_degrees()
            } else {
                x.asin().to_degrees()
            }
        }
        Func::Atan => x.atan().to_degrees(),
        Func::Cos => x.to_radians().cos(),
        Func::Sin => x.to_radians().sin(),
        Func::Tan => x.to_radians().tan(),
        Func::Exp => x.exp(),
        Func::Fix => x.floor(),
        Func::Fup => x.ceil(),
        Func::Round => x.round(),
        Func::Ln => {
            if x <= 0.0 {
                bail!("LN of {}: not positive", short(x));
            }
            x.ln()
        }
        Func::Sqrt => {
            if x < 0.0 {
                bail!("SQRT of {}: negative", short(x));
            }
            x.sqrt()
        }
        Func::Exists => bail!("EXISTS takes a named parameter"),
    })
}

/// `a op b`.
pub fn binary(op: BinOp, a: f64, b: f64) -> Result<f64> {
    Ok(match op {
        BinOp::Pow => {
            if a < 0.0 && b.floor() != b {
                bail!(
                    "{} ** {}: a negative number to a non-integer power",
                    short(a),
                    short(b)
                );
            }
            a.powf(b)
        }
        BinOp::Mul => a * b,
        BinOp::Div => {
            if b == 0.0 {
                bail!("division by zero");
            }
            a / b
        }
        BinOp::Mod => {
            if b == 0.0 {
                bail!("{} MOD 0", short(a));
            }
            let m = a % b;
            if m < 0.0 {
                m + b.abs()
            } else {
                m
            }
        }
        BinOp::Add => a + b,
        BinOp::Sub => a - b,
        BinOp::Eq => truth((a - b).abs() < EQUAL_TOLERANCE),
        BinOp::Ne => truth((a - b).abs() >= EQUAL_TOLERANCE),
        BinOp::Gt => truth(a > b),
        BinOp::Ge => truth((a - b).abs() < EQUAL_TOLERANCE || a >= b),
        BinOp::Lt => truth(a < b),
        BinOp::Le => truth((a - b).abs() < EQUAL_TOLERANCE || a <= b),
        BinOp::And => truth(a != 0.0 && b != 0.0),
        BinOp::Or => truth(a != 0.0 || b != 0.0),
        BinOp::Xor => truth((a != 0.0) != (b != 0.0)),
    })
}

/// Where expressions read parameters.
pub trait Params {
    /// `#n`.
    fn number(&self, n: u32) -> Result<f64>;
    /// `#<name>`.
    fn named(&self, name: &str) -> Result<f64>;
    /// Whether `#<name>` is defined.
    fn exists(&self, name: &str) -> bool;
}

/// Largest numbered parameter (LinuxCNC's `RS274NGC_MAX_PARAMETERS` − 1).
pub const MAX_PARAMETER: u32 = 5601;

/// The parameter number a value names: a whole number in
/// `1..=MAX_PARAMETER` (within 1e-4, as LinuxCNC rounds it).
pub fn parameter_number(v: f64) -> Result<u32> {
    let r = v.round();
    if !v.is_finite() || (v - r).abs() > 1e-4 || r < 1.0 || r > MAX_PARAMETER as f64 {
        bail!(
            "parameter number {} is not a whole number in 1..={MAX_PARAMETER}",
            short(v)
        );
    }
    Ok(r as u32)
}

const EQUAL_TOLERANCE: f64 = 1e-6;

fn truth(b: bool) -> f64 {
    if b {
        1.0
    } else {
        0.0
    }
}

fn func_name(f: Func) -> &'static str {
    match f {
        Func::Acos => "ACOS",
        Func::Asin => "ASIN",
        _ => "function",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parse::{line, Stmt};

    struct P;
    impl Params for P {
        fn number(&self, n: u32) -> Result<f64> {
            Ok(n as f64 * 10.0)
        }
        fn named(&self, name: &str) -> Result<f64> {
            if name == "a" {
                Ok(2.0)
            } else {
                bail!("#<{name}> is not defined")
            }
        }
        fn exists(&self, name: &str) -> bool {
            name == "a"
        }
    }

    fn ev(src: &str) -> Result<f64> {
        let l = line(&format!("X{src}"), 1)?;
        let Stmt::Block { words, .. } = l.stmt else {
            panic!()
        };
        words[0].value.eval(&P)
    }

    #[test]
    fn precedence_and_associativity_as_linuxcnc() {
        // Independent expectations worked by hand from the table above.
        assert_eq!(ev("[1+2*3]").unwrap(), 7.0);
        assert_eq!(ev("[2**3**2]").unwrap(), 64.0); // left to right
        assert_eq!(ev("[10-4-3]").unwrap(), 3.0);
        assert_eq!(ev("[8/4/2]").unwrap(), 1.0);
        assert_eq!(ev("[1+1 EQ 2]").unwrap(), 1.0);
        assert_eq!(ev("[1 LT 2 AND 3 GT 4]").unwrap(), 0.0);
        assert_eq!(ev("[1 OR 0 XOR 1]").unwrap(), 0.0);
        assert_eq!(ev("[-7 MOD 3]").unwrap(), 2.0);
        assert_eq!(ev("[0.1+0.2 EQ 0.3]").unwrap(), 1.0);
        assert_eq!(ev("-[2]").unwrap(), -2.0);
    }

    #[test]
    fn functions_in_degrees_and_parameters() {
        assert!((ev("[sin[30]]").unwrap() - 0.5).abs() < 1e-12);
        assert!((ev("atan[1]/[-1]").unwrap() - 135.0).abs() < 1e-12);
        assert!((ev("acos[0]").unwrap() - 90.0).abs() < 1e-12);
        assert_eq!(ev("fix[-1.5]").unwrap(), -2.0);
        assert_eq!(ev("fup[1.2]").unwrap(), 2.0);
        assert_eq!(ev("round[2.5]").unwrap(), 3.0);
        assert_eq!(ev("round[-2.5]").unwrap(), -3.0);
        assert_eq!(ev("#3").unwrap(), 30.0);
        assert_eq!(ev("##2").unwrap(), 200.0);
        assert_eq!(ev("#[1+1]").unwrap(), 20.0);
        assert_eq!(ev("[#<a>*#<a>]").unwrap(), 4.0);
        assert_eq!(ev("exists[#<a>]").unwrap(), 1.0);
        assert_eq!(ev("exists[#<b>]").unwrap(), 0.0);
    }

    #[test]
    fn domain_errors_are_errors() {
        for bad in [
            "[1/0]",
            "ln[0]",
            "sqrt[-1]",
            "asin[2]",
            "[-8**0.5]",
            "#<nope>",
            "#0",
            "#1.5",
            "#99999",
            "[1 MOD 0]",
        ] {
            assert!(ev(bad).is_err(), "{bad}");
        }
    }

    /// Runs `f` on a thread with a 256 KiB stack: an expression whose
    /// parsing or evaluation recursed once per term would overflow it.
    fn on_small_stack<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
        std::thread::Builder::new()
            .stack_size(256 * 1024)
            .spawn(f)
            .expect("spawn")
            .join()
            .expect("no panic")
    }

    #[test]
    fn long_operator_chains_need_no_deep_stack() {
        // 200 001 terms: 1, then 1 added and taken away 100 000 times.
        let src = format!("G1 X[1{}] F100\n", "+1-1".repeat(100_000));
        let t = on_small_stack(move || {
            crate::parse("t", &src, &crate::GcodeSettings::default()).map(|t| t.points)
        })
        .unwrap();
        assert_eq!(t[1], [1.0, 0.0, 0.0]);
        // One chain per precedence level (each reduces as it goes) and one
        // of rising precedence (each operator waits for the next).
        for (chain, want) in [
            (format!("[2{}]", "**1".repeat(200_000)), 2.0),
            (format!("[1{}]", "*1/1".repeat(100_000)), 1.0),
            (format!("[1{}]", " eq 1".repeat(200_000)), 1.0),
            (format!("[1{}]", " and 1 or 0".repeat(100_000)), 1.0),
            (format!("[0{}]", " or 2 eq 1+1*1**1".repeat(50_000)), 1.0),
        ] {
            let v = on_small_stack(move || ev(&chain).map_err(|e| e.to_string()));
            assert_eq!(v, Ok(want));
        }
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_crash() {
        let n = 100_000;
        for deep in [
            format!("{}1{}", "[".repeat(n), "]".repeat(n)),
            format!("{}1", "-".repeat(n)),
            format!("{}1", "+".repeat(n)),
            format!("{}1", "#".repeat(n)),
            format!("{}1{}", "#[".repeat(n), "]".repeat(n)),
            format!("{}1{}", "sin[".repeat(n), "]".repeat(n)),
            format!("{}1{}", "atan[".repeat(n), "]/[1]".repeat(n)),
            format!("{}1", "[1+".repeat(n)),
        ] {
            let e = on_small_stack(move || ev(&deep).map_err(|e| e.to_string()));
            let e = e.unwrap_err();
            assert!(
                e.contains("nested too deeply") && e.contains("line 1"),
                "{e}"
            );
        }
        // Nesting within the bound is read as usual.
        let ok = format!("{}1{}", "[".repeat(30), "]".repeat(30));
        assert_eq!(on_small_stack(move || ev(&ok).unwrap()), 1.0);
    }

    #[test]
    fn malformed_postfix_is_an_error() {
        for ops in [
            vec![],
            vec![Op::Bin(BinOp::Add)],
            vec![Op::Num(1.0), Op::Num(2.0)],
            vec![Op::Atan2],
            vec![Op::Param],
        ] {
            assert!(Expr::from_ops(ops).eval(&P).is_err());
        }
    }

    mod random {
        use super::*;
        use proptest::prelude::*;

        /// An expression as a tree, to render as text and to evaluate
        /// recursively with the same operations: the reference for the
        /// postfix evaluation.
        #[derive(Clone, Debug)]
        enum T {
            Num(f64),
            Named,
            Neg(Box<T>),
            Call(Func, Box<T>),
            Atan(Box<T>, Box<T>),
            Param(Box<T>),
            /// Operators of one precedence level, applied left to right.
            Chain(Box<T>, Vec<(BinOp, T)>),
        }

        fn text(t: &T) -> String {
            match t {
                T::Num(x) => format!("{x}"),
                T::Named => "#<a>".into(),
                T::Neg(x) => format!("-{}", text(x)),
                T::Call(f, x) => format!("{}[{}]", func_text(*f), text(x)),
                T::Atan(y, x) => format!("atan[{}]/[{}]", text(y), text(x)),
                T::Param(x) => format!("#{}", text(x)),
                T::Chain(a, rest) => {
                    let mut s = format!("[{}", text(a));
                    for (op, x) in rest {
                        s += &format!(" {} {}", op_text(*op), text(x));
                    }
                    s + "]"
                }
            }
        }

        fn func_text(f: Func) -> &'static str {
            match f {
                Func::Abs => "abs",
                Func::Acos => "acos",
                Func::Asin => "asin",
                Func::Cos => "cos",
                Func::Exp => "exp",
                Func::Fix => "fix",
                Func::Fup => "fup",
                Func::Ln => "ln",
                Func::Round => "round",
                Func::Sin => "sin",
                Func::Sqrt => "sqrt",
                Func::Tan => "tan",
                Func::Atan | Func::Exists => unreachable!(),
            }
        }

        fn op_text(op: BinOp) -> &'static str {
            match op {
                BinOp::Pow => "**",
                BinOp::Mul => "*",
                BinOp::Div => "/",
                BinOp::Mod => "mod",
                BinOp::Add => "+",
                BinOp::Sub => "-",
                BinOp::Eq => "eq",
                BinOp::Ne => "ne",
                BinOp::Gt => "gt",
                BinOp::Ge => "ge",
                BinOp::Lt => "lt",
                BinOp::Le => "le",
                BinOp::And => "and",
                BinOp::Or => "or",
                BinOp::Xor => "xor",
            }
        }

        fn reference(t: &T) -> Result<f64> {
            let v = match t {
                T::Num(x) => *x,
                T::Named => P.named("a")?,
                T::Neg(x) => -reference(x)?,
                T::Call(f, x) => unary(*f, reference(x)?)?,
                T::Atan(y, x) => {
                    let y = reference(y)?;
                    y.atan2(reference(x)?).to_degrees()
                }
                T::Param(x) => P.number(parameter_number(reference(x)?)?)?,
                T::Chain(a, rest) => {
                    let mut acc = reference(a)?;
                    for (op, x) in rest {
                        acc = binary(*op, acc, reference(x)?)?;
                        if acc.is_nan() {
                            bail!("not a number");
                        }
                    }
                    acc
                }
            };
            if v.is_nan() {
                bail!("not a number");
            }
            Ok(v)
        }

        const LEVELS: [&[BinOp]; 5] = [
            &[BinOp::Pow],
            &[BinOp::Mul, BinOp::Div, BinOp::Mod],
            &[BinOp::Add, BinOp::Sub],
            &[
                BinOp::Eq,
                BinOp::Ne,
                BinOp::Gt,
                BinOp::Ge,
                BinOp::Lt,
                BinOp::Le,
            ],
            &[BinOp::And, BinOp::Or, BinOp::Xor],
        ];

        const FUNCS: [Func; 12] = [
            Func::Abs,
            Func::Acos,
            Func::Asin,
            Func::Cos,
            Func::Exp,
            Func::Fix,
            Func::Fup,
            Func::Ln,
            Func::Round,
            Func::Sin,
            Func::Sqrt,
            Func::Tan,
        ];

        fn tree() -> impl Strategy<Value = T> {
            let leaf = prop_oneof![
                (0u32..20).prop_map(|n| T::Num(n as f64)),
                (0.0f64..1e3).prop_map(T::Num),
                (0.0f64..f64::MAX).prop_map(T::Num),
                Just(T::Named),
            ];
            leaf.prop_recursive(40, 400, 30, |inner| {
                prop_oneof![
                    inner.clone().prop_map(|x| T::Neg(Box::new(x))),
                    (0..FUNCS.len(), inner.clone())
                        .prop_map(|(f, x)| T::Call(FUNCS[f], Box::new(x))),
                    (inner.clone(), inner.clone())
                        .prop_map(|(y, x)| T::Atan(Box::new(y), Box::new(x))),
                    inner.clone().prop_map(|x| T::Param(Box::new(x))),
                    (
                        0..LEVELS.len(),
                        inner.clone(),
                        proptest::collection::vec((0..6usize, inner), 1..30)
                    )
                        .prop_map(|(level, a, rest)| {
                            let ops = LEVELS[level];
                            T::Chain(
                                Box::new(a),
                                rest.into_iter()
                                    .map(|(k, x)| (ops[k % ops.len()], x))
                                    .collect(),
                            )
                        }),
                ]
            })
        }

        /// Pieces of expressions, valid and not, for token soup.
        const TOKENS: [&str; 24] = [
            "[",
            "]",
            "+",
            "-",
            "*",
            "/",
            "**",
            "mod",
            "eq",
            "and",
            "1",
            "0",
            ".5",
            "2.",
            "#",
            "#<a>",
            "#<b>",
            "sin[",
            "atan[",
            "]/[",
            "exists[#<a>]",
            "ln[",
            "<",
            ".",
        ];

        proptest! {
            /// Well-formed expressions of any shape: the postfix evaluation
            /// agrees with the recursive reference, value for value and
            /// error for error, unless the nesting is refused.
            #[test]
            fn postfix_agrees_with_the_tree(
                t in tree(),
                wraps in proptest::collection::vec(0..4usize, 0..80),
            ) {
                // Wrapped in up to 80 more levels of brackets, signs and
                // functions.
                let t = wraps.iter().fold(t, |x, &k| match k {
                    0 => T::Neg(Box::new(x)),
                    1 => T::Call(Func::Abs, Box::new(x)),
                    2 => T::Chain(Box::new(x), Vec::new()),
                    _ => T::Atan(Box::new(x), Box::new(T::Num(1.0))),
                });
                let src = text(&t);
                match line(&format!("X{src}"), 1) {
                    Err(e) => prop_assert!(e.to_string().contains("nested too deeply"), "{src}: {e}"),
                    Ok(l) => {
                        let Stmt::Block { words, .. } = l.stmt else {
                            return Err(TestCaseError::fail("not a block"));
                        };
                        let got = words[0].value.eval(&P);
                        match (reference(&t), got) {
                            (Ok(a), Ok(b)) => prop_assert!(a == b, "{src}: {a} vs {b}"),
                            (Err(_), Err(_)) => {}
                            (a, b) => prop_assert!(false, "{src}: {a:?} vs {b:?}"),
                        }
                    }
                }
            }

            /// Any sequence of pieces, of any length: parsing and evaluation
            /// return (a value or an error), never panic.
            #[test]
            fn token_soup_never_panics(
                toks in proptest::collection::vec(0..TOKENS.len(), 0..3000)
            ) {
                let src: String = toks.iter().map(|&k| TOKENS[k]).collect();
                if let Ok(l) = line(&format!("X{src}"), 1) {
                    if let Stmt::Block { words, .. } = l.stmt {
                        for w in words {
                            let _ = w.value.eval(&P);
                        }
                    }
                }
            }

            /// Any text after a word letter: never a panic.
            #[test]
            fn any_text_never_panics(src in "[\\[\\]+\\-*/#<>0-9.a-z ]{0,400}") {
                if let Ok(l) = line(&format!("X{src}"), 1) {
                    if let Stmt::Block { words, .. } = l.stmt {
                        for w in words {
                            let _ = w.value.eval(&P);
                        }
                    }
                }
            }
        }
    }
}
