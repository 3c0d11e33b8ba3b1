//! `.fis` and FCL exports of the controllers.

use fuzzy_core::fuzzy::export::{write_fcl, write_fis};
use fuzzy_core::fuzzy::{Antecedent, MembershipFn};
use fuzzy_core::lin2021::SYSTEM;
use fuzzy_core::units::Fx;

fn fis() -> String {
    let mut s = String::new();
    write_fis(&mut s, &SYSTEM).unwrap();
    s
}

/// `key=value` lines of one `[Section]`.
fn section<'a>(text: &'a str, name: &str) -> Vec<(&'a str, &'a str)> {
    let mut inside = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.starts_with('[') {
            inside = line == format!("[{name}]");
            continue;
        }
        if inside {
            if let Some((k, v)) = line.split_once('=') {
                out.push((k, v));
            }
        }
    }
    out
}

#[test]
fn fis_header_describes_the_paper_s_methods() {
    let text = fis();
    let sys = section(&text, "System");
    for (k, v) in [
        ("Type", "'mamdani'"),
        ("NumInputs", "2"),
        ("NumOutputs", "1"),
        ("NumRules", "30"),
        ("AndMethod", "'min'"),
        ("ImpMethod", "'min'"),
        ("AggMethod", "'max'"),
        ("DefuzzMethod", "'centroid'"),
    ] {
        assert!(sys.contains(&(k, v)), "{k}={v} missing in\n{text}");
    }
}

#[test]
fn every_parameter_round_trips_exactly() {
    let text = fis();
    let vars = [
        ("Input1", &SYSTEM.inputs[0]),
        ("Input2", &SYSTEM.inputs[1]),
        ("Output1", &SYSTEM.output),
    ];
    for (sec, var) in vars {
        let entries = section(&text, sec);
        let mfs: Vec<&str> = entries
            .iter()
            .filter(|(k, _)| k.starts_with("MF"))
            .map(|(_, v)| *v)
            .collect();
        assert_eq!(mfs.len(), var.terms.len());
        for (line, term) in mfs.iter().zip(var.terms) {
            // 'ZO':'trimf',[-0.0500030517578125 0 0.0500030517578125]
            let (name, rest) = line.split_once(':').unwrap();
            assert_eq!(name.trim_matches('\''), term.name);
            let (kind, params) = rest.split_once(',').unwrap();
            assert_eq!(kind.trim_matches('\''), term.mf.matlab_name());
            let got: Vec<Fx> = params
                .trim_matches(|c| c == '[' || c == ']')
                .split(' ')
                .map(|p| p.parse().unwrap())
                .collect();
            let (want, n) = term.mf.params();
            assert_eq!(&got[..], &want[..n], "{sec} {}", term.name);
        }
    }
}

#[test]
fn rules_list_r1_to_r30_in_order() {
    let text = fis();
    let rules: Vec<&str> = text
        .lines()
        .skip_while(|l| *l != "[Rules]")
        .skip(1)
        .filter(|l| !l.is_empty())
        .collect();
    assert_eq!(rules.len(), 30);
    for (line, rule) in rules.iter().zip(SYSTEM.rules) {
        let want: Vec<String> = rule
            .when
            .iter()
            .map(|a| match a {
                Antecedent::Is(t) => (t + 1).to_string(),
                _ => unreachable!(),
            })
            .collect();
        assert_eq!(
            *line,
            format!("{}, {} (1) : 1", want.join(" "), rule.then + 1)
        );
    }
    // R1: ZO, ZO -> TF (7); R25: ZO, VH -> VVLF read as VLF (1).
    assert_eq!(rules[0], "1 1, 7 (1) : 1");
    assert_eq!(rules[24], "1 5, 1 (1) : 1");
}

#[test]
fn fcl_names_every_term_and_rule() {
    let mut text = String::new();
    write_fcl(&mut text, &SYSTEM).unwrap();
    assert!(text.contains("FUNCTION_BLOCK lin2021_feed"));
    assert!(text.contains("METHOD : COG;"));
    // Laid out as fuzzylite 6 reads it: ACCU in DEFUZZIFY, lower-case rule
    // keywords, no comment outside a declaration.
    let defuzzify = &text[text.find("DEFUZZIFY").unwrap()..text.find("END_DEFUZZIFY").unwrap()];
    assert!(defuzzify.contains("ACCU : MAX;"));
    assert_eq!(text.matches("ACCU").count(), 1);
    assert!(!text.lines().any(|l| l.starts_with("(*")));
    assert_eq!(text.matches("    RULE ").count(), 30);
    assert!(text.contains("RULE 1 : if curvature is ZO and variation is ZO then feed is TF;"));
    assert!(text.contains("RULE 25 : if curvature is ZO and variation is VH then feed is VLF;"));
    for t in SYSTEM
        .inputs
        .iter()
        .flat_map(|v| v.terms)
        .chain(SYSTEM.output.terms)
    {
        if let MembershipFn::Triangle { a, b, c } = t.mf {
            let pts = format!(
                "TERM {} := ({}, 0) ({}, 1) ({}, 0);",
                t.name,
                exact(a),
                exact(b),
                exact(c)
            );
            assert!(text.contains(&pts), "{pts}");
        }
    }
    assert_eq!(
        text.lines().filter(|l| l.starts_with("FUZZIFY ")).count(),
        2
    );
}

fn exact(v: Fx) -> String {
    let mut s = String::new();
    fuzzy_core::fuzzy::export::write_exact(&mut s, v).unwrap();
    s
}
