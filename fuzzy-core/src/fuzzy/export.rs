//! Export a fuzzy system as a MATLAB/Octave `.fis` file or as IEC 61131-7
//! FCL, so the exact controller can be opened in MATLAB's Fuzzy Logic
//! Toolbox, Octave's fuzzy-logic-toolkit, fuzzylite or jFuzzyLogic.
//!
//! Both writers take any [`core::fmt::Write`], so they need no allocation
//! (a firmware could stream its controller over a serial link).
//!
//! Numbers are written as the exact decimal value of their Q16.16 bits
//! (`0.05` in a definition is stored as 3277/65536 and exported as
//! `0.0500030517578125`), so the other tool evaluates exactly our
//! parameters, not their decimal approximations.
//!
//! Limits of the formats:
//! - `.fis` has no "default output"; MATLAB returns the middle of the output
//!   range when no rule fires (ours returns [`SystemDef::default_output`]).
//!   MATLAB also does not clamp inputs to their range (ours does): compare
//!   inside the universe.
//! - IEC 61131-7 defines only piecewise-linear terms and singletons. Gaussian
//!   and generalised-bell terms are written in fuzzylite's extension syntax
//!   (`Gaussian mean sigma`, `Bell center width slope`), and the FCL is laid
//!   out as fuzzylite 6 reads it unchanged: no comment outside a
//!   declaration, `ACCU` in the `DEFUZZIFY` block, rule keywords in lower
//!   case (fuzzylite drops upper-case rules without a word). jFuzzyLogic
//!   names the two curves `gauss`/`gbell` and wants `ACCU` in the
//!   `RULEBLOCK`. A shoulder whose foot
//!   equals its peak (`a = b`) is written from its peak, so left of it FCL
//!   extends 1 where MATLAB gives 0; inside the universe they agree when
//!   shoulders sit at the universe's ends (as in all our controllers).
//!   A zero-order Sugeno output becomes singletons with `METHOD : COGS`
//!   (weighted average; FCL has no weighted sum).

use core::fmt::{self, Write};

use super::membership::MembershipFn;
use super::rule::{Antecedent, Connective};
use super::system::{
    AndMethod, Implication, Inference, OrMethod, SugenoOutput, SystemDef, Variable,
};
use crate::units::Fx;

/// Write the exact decimal value of a Q16.16 number (no exponent, trailing
/// zeros trimmed).
pub fn write_exact(w: &mut impl Write, v: Fx) -> fmt::Result {
    let bits = v.to_bits() as i64;
    let mag = bits.unsigned_abs();
    if bits < 0 {
        w.write_char('-')?;
    }
    write!(w, "{}", mag >> 16)?;
    let mut frac = mag & 0xFFFF;
    if frac != 0 {
        w.write_char('.')?;
        while frac != 0 {
            frac *= 10;
            let digit = (frac >> 16) as u8;
            w.write_char((b'0' + digit) as char)?;
            frac &= 0xFFFF;
        }
    }
    Ok(())
}

struct Exact(Fx);

impl fmt::Display for Exact {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write_exact(f, self.0)
    }
}

fn and_name(m: AndMethod) -> &'static str {
    match m {
        AndMethod::Min => "min",
        AndMethod::Product => "prod",
    }
}

fn or_name(m: OrMethod) -> &'static str {
    match m {
        OrMethod::Max => "max",
        OrMethod::ProbOr => "probor",
    }
}

/// Write `def` as a MATLAB/Octave `.fis` file (format version 2.0).
pub fn write_fis<const NI: usize>(w: &mut impl Write, def: &SystemDef<'_, NI>) -> fmt::Result {
    let (kind, imp, agg, defuzz) = match def.inference {
        Inference::Mamdani { implication } => (
            "mamdani",
            match implication {
                Implication::Min => "min",
                Implication::Product => "prod",
            },
            "max",
            "centroid",
        ),
        Inference::Sugeno { output } => (
            "sugeno",
            "prod",
            "sum",
            match output {
                SugenoOutput::WeightedAverage => "wtaver",
                SugenoOutput::WeightedSum => "wtsum",
            },
        ),
    };
    writeln!(w, "[System]")?;
    writeln!(w, "Name='{}'", def.name)?;
    writeln!(w, "Type='{kind}'")?;
    writeln!(w, "Version=2.0")?;
    writeln!(w, "NumInputs={NI}")?;
    writeln!(w, "NumOutputs=1")?;
    writeln!(w, "NumRules={}", def.rules.len())?;
    writeln!(w, "AndMethod='{}'", and_name(def.and))?;
    writeln!(w, "OrMethod='{}'", or_name(def.or))?;
    writeln!(w, "ImpMethod='{imp}'")?;
    writeln!(w, "AggMethod='{agg}'")?;
    writeln!(w, "DefuzzMethod='{defuzz}'")?;
    for (i, v) in def.inputs.iter().enumerate() {
        writeln!(w, "\n[Input{}]", i + 1)?;
        write_fis_variable(w, v)?;
    }
    writeln!(w, "\n[Output1]")?;
    write_fis_variable(w, &def.output)?;
    writeln!(w, "\n[Rules]")?;
    for rule in def.rules {
        let mut first = true;
        for a in rule.when.iter() {
            if !first {
                w.write_char(' ')?;
            }
            first = false;
            match *a {
                Antecedent::Any => w.write_char('0')?,
                Antecedent::Is(t) => write!(w, "{}", t as i32 + 1)?,
                Antecedent::IsNot(t) => write!(w, "-{}", t as i32 + 1)?,
            }
        }
        let conn = match rule.connective {
            Connective::And => 1,
            Connective::Or => 2,
        };
        writeln!(
            w,
            ", {} ({}) : {}",
            rule.then as i32 + 1,
            Exact(rule.weight),
            conn
        )?;
    }
    Ok(())
}

fn write_fis_variable(w: &mut impl Write, v: &Variable<'_>) -> fmt::Result {
    writeln!(w, "Name='{}'", v.name)?;
    writeln!(w, "Range=[{} {}]", Exact(v.min), Exact(v.max))?;
    writeln!(w, "NumMFs={}", v.terms.len())?;
    for (k, t) in v.terms.iter().enumerate() {
        write!(w, "MF{}='{}':'{}',[", k + 1, t.name, t.mf.matlab_name())?;
        let (p, n) = t.mf.params();
        for (j, x) in p.iter().take(n).enumerate() {
            if j > 0 {
                w.write_char(' ')?;
            }
            write_exact(w, *x)?;
        }
        writeln!(w, "]")?;
    }
    Ok(())
}

/// Write `def` as an IEC 61131-7 Fuzzy Control Language function block.
pub fn write_fcl<const NI: usize>(w: &mut impl Write, def: &SystemDef<'_, NI>) -> fmt::Result {
    // No comment line: fuzzylite refuses one outside a declaration.
    writeln!(w, "FUNCTION_BLOCK {}\n", def.name)?;
    writeln!(w, "VAR_INPUT")?;
    for v in def.inputs.iter() {
        writeln!(w, "    {} : REAL; (* {} *)", v.name, unit_or_dash(v.unit))?;
    }
    writeln!(w, "END_VAR\n")?;
    writeln!(w, "VAR_OUTPUT")?;
    writeln!(
        w,
        "    {} : REAL; (* {} *)",
        def.output.name,
        unit_or_dash(def.output.unit)
    )?;
    writeln!(w, "END_VAR\n")?;
    for v in def.inputs.iter() {
        writeln!(w, "FUZZIFY {}", v.name)?;
        for t in v.terms {
            write!(w, "    TERM {} := ", t.name)?;
            write_fcl_term(w, &t.mf)?;
            writeln!(w, ";")?;
        }
        writeln!(w, "    RANGE := ({} .. {});", Exact(v.min), Exact(v.max))?;
        writeln!(w, "END_FUZZIFY\n")?;
    }
    let out = &def.output;
    writeln!(w, "DEFUZZIFY {}", out.name)?;
    for t in out.terms {
        write!(w, "    TERM {} := ", t.name)?;
        write_fcl_term(w, &t.mf)?;
        writeln!(w, ";")?;
    }
    let method = match def.inference {
        Inference::Mamdani { .. } => "COG",
        Inference::Sugeno { .. } => "COGS",
    };
    writeln!(w, "    METHOD : {method};")?;
    // Accumulation here, not in the RULEBLOCK: where fuzzylite reads it.
    // A weighted average (Sugeno) accumulates nothing.
    if let Inference::Mamdani { .. } = def.inference {
        writeln!(w, "    ACCU : MAX;")?;
    }
    writeln!(w, "    DEFAULT := {};", Exact(def.default_output))?;
    writeln!(
        w,
        "    RANGE := ({} .. {});",
        Exact(out.min),
        Exact(out.max)
    )?;
    writeln!(w, "END_DEFUZZIFY\n")?;
    writeln!(w, "RULEBLOCK rules")?;
    let (and, or) = match (def.and, def.or) {
        (AndMethod::Min, _) => (
            "MIN",
            if def.or == OrMethod::Max {
                "MAX"
            } else {
                "ASUM"
            },
        ),
        (AndMethod::Product, _) => (
            "PROD",
            if def.or == OrMethod::Max {
                "MAX"
            } else {
                "ASUM"
            },
        ),
    };
    writeln!(w, "    AND : {and};")?;
    writeln!(w, "    OR : {or};")?;
    match def.inference {
        Inference::Mamdani { implication } => {
            let act = match implication {
                Implication::Min => "MIN",
                Implication::Product => "PROD",
            };
            writeln!(w, "    ACT : {act};")?;
        }
        Inference::Sugeno { .. } => {
            writeln!(w, "    ACT : PROD;")?;
        }
    }
    // Rule keywords in lower case: fuzzylite's rule parser knows no other
    // (it drops upper-case rules without a word).
    for (r, rule) in def.rules.iter().enumerate() {
        write!(w, "    RULE {} : if ", r + 1)?;
        let mut first = true;
        let conn = match rule.connective {
            Connective::And => "and",
            Connective::Or => "or",
        };
        for (a, v) in rule.when.iter().zip(def.inputs.iter()) {
            let (neg, t) = match *a {
                Antecedent::Any => continue,
                Antecedent::Is(t) => (false, t),
                Antecedent::IsNot(t) => (true, t),
            };
            if !first {
                write!(w, " {conn} ")?;
            }
            first = false;
            let name = v.terms.get(t as usize).map_or("?", |t| t.name);
            if neg {
                write!(w, "{} is not {}", v.name, name)?;
            } else {
                write!(w, "{} is {}", v.name, name)?;
            }
        }
        if first {
            // No conditions: always true. FCL has no literal TRUE; use a
            // tautology on the first input.
            if let (Some(v), Some(t)) = (
                def.inputs.first(),
                def.inputs.first().and_then(|v| v.terms.first()),
            ) {
                write!(
                    w,
                    "({} is {} or {} is not {})",
                    v.name, t.name, v.name, t.name
                )?;
            }
        }
        let then = out.terms.get(rule.then as usize).map_or("?", |t| t.name);
        write!(w, " then {} is {}", out.name, then)?;
        if rule.weight != Fx::ONE {
            write!(w, " with {}", Exact(rule.weight))?;
        }
        writeln!(w, ";")?;
    }
    writeln!(w, "END_RULEBLOCK\n")?;
    writeln!(w, "END_FUNCTION_BLOCK")
}

fn unit_or_dash(u: &str) -> &str {
    if u.is_empty() {
        "-"
    } else {
        u
    }
}

fn write_fcl_term(w: &mut impl Write, mf: &MembershipFn) -> fmt::Result {
    let pt = |w: &mut dyn Write, x: Fx, y: u8| write!(w, "({}, {})", Exact(x), y);
    match *mf {
        MembershipFn::Triangle { a, b, c } => {
            let mut sep = "";
            if a != b {
                pt(w, a, 0)?;
                sep = " ";
            }
            w.write_str(sep)?;
            pt(w, b, 1)?;
            if c != b {
                w.write_char(' ')?;
                pt(w, c, 0)?;
            }
            Ok(())
        }
        MembershipFn::Trapezoid { a, b, c, d } => {
            if a != b {
                pt(w, a, 0)?;
                w.write_char(' ')?;
            }
            pt(w, b, 1)?;
            if c != b {
                w.write_char(' ')?;
                pt(w, c, 1)?;
            }
            if d != c {
                w.write_char(' ')?;
                pt(w, d, 0)?;
            }
            Ok(())
        }
        MembershipFn::Gaussian { sigma, center } => {
            write!(w, "Gaussian {} {}", Exact(center), Exact(sigma))
        }
        MembershipFn::Bell {
            width,
            slope,
            center,
        } => {
            write!(
                w,
                "Bell {} {} {}",
                Exact(center),
                Exact(width),
                Exact(slope)
            )
        }
        MembershipFn::Constant(v) => write!(w, "{}", Exact(v)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Buf {
        data: [u8; 64],
        len: usize,
    }

    impl Write for Buf {
        fn write_str(&mut self, s: &str) -> fmt::Result {
            let end = self.len + s.len();
            self.data
                .get_mut(self.len..end)
                .ok_or(fmt::Error)?
                .copy_from_slice(s.as_bytes());
            self.len = end;
            Ok(())
        }
    }

    fn exact(v: Fx) -> Buf {
        let mut b = Buf {
            data: [0; 64],
            len: 0,
        };
        write_exact(&mut b, v).unwrap();
        b
    }

    #[test]
    fn exact_decimals_round_trip() {
        for bits in [
            0,
            1,
            -1,
            3277,
            -3277,
            65536,
            75366,
            i32::MIN,
            i32::MAX,
            12345678,
        ] {
            let v = Fx::from_bits(bits);
            let b = exact(v);
            let s = core::str::from_utf8(&b.data[..b.len]).unwrap();
            assert_eq!(s.parse::<Fx>().unwrap(), v, "{s}");
        }
        let b = exact(Fx::lit("0.05"));
        assert_eq!(&b.data[..b.len], b"0.0500030517578125");
        let b = exact(Fx::lit("-2.5"));
        assert_eq!(&b.data[..b.len], b"-2.5");
    }
}
