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

use anyhow::{bail, Result};

/// A parameter reference.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamRef {
    /// `#n`, `##n`, `#[expr]`: the number is a value.
    Number(Box<Expr>),
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
    /// `ATAN` (always with two arguments: [`Expr::Atan2`]).
    Atan,
    /// `COS` of degrees.
    Cos,
    /// `EXISTS` (see [`Expr::Exists`]).
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

/// An expression tree.
#[derive(Clone, Debug, PartialEq)]
pub enum Expr {
    /// A number.
    Num(f64),
    /// A parameter's value.
    Param(Box<ParamRef>),
    /// `-value`.
    Neg(Box<Expr>),
    /// `F[value]`.
    Call(Func, Box<Expr>),
    /// `ATAN[y]/[x]`.
    Atan2(Box<Expr>, Box<Expr>),
    /// `EXISTS[#<name>]`: 1 if the named parameter is defined.
    Exists(String),
    /// `a op b`.
    Bin(BinOp, Box<Expr>, Box<Expr>),
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
        bail!("parameter number {v} is not a whole number in 1..={MAX_PARAMETER}");
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

impl Expr {
    /// The value, reading parameters from `p`.
    pub fn eval(&self, p: &dyn Params) -> Result<f64> {
        let v = match self {
            Expr::Num(x) => *x,
            Expr::Param(r) => match &**r {
                ParamRef::Number(e) => p.number(parameter_number(e.eval(p)?)?)?,
                ParamRef::Named(n) => p.named(n)?,
            },
            Expr::Neg(e) => -e.eval(p)?,
            Expr::Exists(n) => truth(p.exists(n)),
            Expr::Atan2(y, x) => y.eval(p)?.atan2(x.eval(p)?).to_degrees(),
            Expr::Call(f, e) => {
                let x = e.eval(p)?;
                match f {
                    Func::Abs => x.abs(),
                    Func::Acos | Func::Asin => {
                        if !(-1.0..=1.0).contains(&x) {
                            bail!("{} of {x}: outside [-1, 1]", func_name(*f));
                        }
                        if *f == Func::Acos {
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
                            bail!("LN of {x}: not positive");
                        }
                        x.ln()
                    }
                    Func::Sqrt => {
                        if x < 0.0 {
                            bail!("SQRT of {x}: negative");
                        }
                        x.sqrt()
                    }
                    Func::Exists => bail!("EXISTS takes a named parameter"),
                }
            }
            Expr::Bin(op, a, b) => {
                let (a, b) = (a.eval(p)?, b.eval(p)?);
                match op {
                    BinOp::Pow => {
                        if a < 0.0 && b.floor() != b {
                            bail!("{a} ** {b}: a negative number to a non-integer power");
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
                            bail!("{a} MOD 0");
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
                }
            }
        };
        if v.is_nan() {
            bail!("the expression is not a number");
        }
        Ok(v)
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
}
