//! Every controller's FCL export loaded unchanged by fuzzylite 6 (Debian's
//! `fuzzylite` package, its command-line tool), evaluated on a grid of
//! inputs, and compared with the `.fis` export loaded by the same tool and
//! with our own evaluation.
//!
//! fuzzylite's tool exits 0 even when an import fails (it prints
//! `[syntax error]` or `[factory error]` and carries on with what it has,
//! e.g. no rules), so each import is checked by what it printed: no error
//! and every rule present.
//!
//! Without `fuzzylite` the test is skipped, unless `FUZZY_REQUIRE_FUZZYLITE=1`
//! (set by `./scripts/test.sh`, whose set-up installs the package) makes that
//! a failure.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

use fuzzy_core::fuzzy::SystemDef;
use fuzzy_core::units::Fx;
use host_sim::cli::controller::{export, Format, Which};

fn fuzzylite_available() -> bool {
    let ok = Command::new("fuzzylite")
        .arg("--help")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).contains("fuzzylite"))
        .unwrap_or(false);
    if !ok && std::env::var("FUZZY_REQUIRE_FUZZYLITE").as_deref() == Ok("1") {
        panic!("fuzzylite is required (FUZZY_REQUIRE_FUZZYLITE=1) but not available");
    }
    ok
}

/// Run fuzzylite; fail on any error it printed (its exit code says nothing).
fn fuzzylite(args: &[&str]) -> String {
    let out = Command::new("fuzzylite").args(args).output().unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        !text.contains("error]") && !text.contains("[exception]"),
        "fuzzylite {args:?} reported: {text}"
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Inputs on a grid inside the universes (`n` values per input).
fn grid<const NI: usize>(def: &SystemDef<'_, NI>, n: usize) -> Vec<[f64; NI]> {
    let total = n.pow(NI as u32);
    (0..total)
        .map(|mut k| {
            let mut x = [0.0; NI];
            for (i, v) in def.inputs.iter().enumerate() {
                let (lo, hi): (f64, f64) = (v.min.to_num(), v.max.to_num());
                let j = k % n;
                k /= n;
                // On the Q16.16 grid, so both programs see the same numbers.
                let t = lo + (hi - lo) * j as f64 / (n - 1) as f64;
                x[i] = Fx::from_num(t).to_num();
            }
            x
        })
        .collect()
}

/// Outputs fuzzylite computes for `engine` (imported as `format`) on
/// `inputs`.
fn evaluate(engine: &Path, format: &str, names: &[&str], inputs: &[Vec<f64>]) -> Vec<f64> {
    let dir = engine.parent().unwrap();
    let fld = dir.join(format!("inputs_{format}.fld"));
    let mut text = names.join(" ");
    text.push('\n');
    for x in inputs {
        let row: Vec<String> = x.iter().map(|v| format!("{v:.12}")).collect();
        writeln!(text, "{}", row.join(" ")).unwrap();
    }
    std::fs::write(&fld, text).unwrap();
    let out = fuzzylite(&[
        "-i",
        engine.to_str().unwrap(),
        "-if",
        format,
        "-of",
        "fld",
        "-d",
        fld.to_str().unwrap(),
        "-decimals",
        "9",
        "-dheader",
        "false",
        "-dinputs",
        "false",
    ]);
    let ys: Vec<f64> = out
        .split_whitespace()
        .map(|t| t.parse().unwrap_or(f64::NAN))
        .collect();
    assert_eq!(ys.len(), inputs.len(), "fuzzylite printed: {out}");
    ys
}

fn check<const NI: usize>(
    which: Which,
    def: &SystemDef<'_, NI>,
    ours: impl Fn([Fx; NI]) -> f64,
    n: usize,
    tolerance_of_range: f64,
) {
    let dir =
        std::env::temp_dir().join(format!("fuzzy-fuzzylite-{}-{which:?}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let fcl = dir.join("c.fcl");
    let fis = dir.join("c.fis");
    std::fs::write(&fcl, export(which, Format::Fcl).unwrap()).unwrap();
    std::fs::write(&fis, export(which, Format::Fis).unwrap()).unwrap();
    // Imports: no error printed, every rule loaded.
    for (file, format) in [(&fcl, "fcl"), (&fis, "fis")] {
        let fll = fuzzylite(&["-i", file.to_str().unwrap(), "-if", format, "-of", "fll"]);
        let rules = fll
            .lines()
            .filter(|l| l.trim_start().starts_with("rule:"))
            .count();
        assert_eq!(rules, def.rules.len(), "{which:?} {format}: {fll}");
    }
    let names: Vec<&str> = def.inputs.iter().map(|v| v.name).collect();
    let inputs: Vec<Vec<f64>> = grid(def, n).into_iter().map(|x| x.to_vec()).collect();
    let from_fcl = evaluate(&fcl, "fcl", &names, &inputs);
    let from_fis = evaluate(&fis, "fis", &names, &inputs);
    let range = def.output.max.to_num::<f64>() - def.output.min.to_num::<f64>();
    let (mut worst_formats, mut worst_ours) = (0.0f64, 0.0f64);
    for (k, x) in inputs.iter().enumerate() {
        let (a, b) = (from_fcl[k], from_fis[k]);
        worst_formats = worst_formats.max((a - b).abs());
        let mut q = [Fx::ZERO; NI];
        for i in 0..NI {
            q[i] = Fx::from_num(x[i]);
        }
        worst_ours = worst_ours.max((a - ours(q)).abs() / range);
    }
    eprintln!(
        "{which:?}: {} inputs, |FCL − FIS| in fuzzylite ≤ {worst_formats:.2e}, |fuzzylite − ours| ≤ {worst_ours:.2e} of the range",
        inputs.len()
    );
    assert!(
        worst_formats <= 1e-6,
        "{which:?}: FCL and FIS differ by {worst_formats}"
    );
    assert!(
        worst_ours <= tolerance_of_range,
        "{which:?}: fuzzylite and ours differ by {worst_ours} of the range"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn fuzzylite_loads_every_fcl_export_and_agrees_with_the_fis() {
    if !fuzzylite_available() {
        eprintln!("SKIPPED: fuzzylite not found");
        return;
    }
    // fuzzylite's centroid integrates with 100 slices; ours below is the
    // 101-sample sum of the .fis tools (Mamdani) or exact (Sugeno).
    check(
        Which::Lin2021,
        &fuzzy_core::lin2021::SYSTEM,
        |x| {
            fuzzy_core::lin2021::CONTROLLER
                .evaluate_sampled(x)
                .output
                .to_num()
        },
        21,
        0.01,
    );
    check(
        Which::Njiri,
        &fuzzy_core::njiri::SYSTEM,
        |x| {
            fuzzy_core::njiri::CONTROLLER
                .evaluate_sampled(x)
                .output
                .to_num()
        },
        5,
        0.01,
    );
    check(
        Which::Cho,
        &fuzzy_core::cho::SYSTEM,
        |x| {
            fuzzy_core::cho::CONTROLLER
                .evaluate_sampled(x)
                .output
                .to_num()
        },
        21,
        0.01,
    );
    check(
        Which::NagataLength,
        &fuzzy_core::nagata::FEED_SYSTEM,
        |x| {
            fuzzy_core::nagata::FEED_CONTROLLER
                .evaluate(x)
                .output
                .to_num()
        },
        41,
        1e-3,
    );
    check(
        Which::NagataIncrement,
        &fuzzy_core::nagata::COMPENSATION_SYSTEM,
        |x| {
            fuzzy_core::nagata::COMPENSATION_CONTROLLER
                .evaluate(x)
                .output
                .to_num()
        },
        41,
        1e-3,
    );
}
