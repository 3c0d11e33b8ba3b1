//! Small programs written for these tests, each read by the G-code reader
//! and checked against a path worked out by hand from the RS274/NGC rules
//! (not from the reader), plus a property: random G-code, valid or not,
//! never panics the reader and never runs past its bounds.

use host_sim::gcode::{self, GcodeSettings, Limits, ToolEntry};
use proptest::prelude::*;

fn read(src: &str, s: &GcodeSettings) -> host_sim::toolpath::Toolpath {
    match gcode::parse("t", src, s) {
        Ok(t) => t,
        Err(e) => panic!("{src}\n{e:#}"),
    }
}

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    (0..3).all(|k| (a[k] - b[k]).abs() < 1e-9)
}

#[test]
fn drilling_cycle_hole_positions() {
    // A 2 × 2 grid by G91 repeats: G81 at X10 Y10, then two holes 15 mm
    // apart along X (L2), then one 20 mm along Y; holes to Z-3 from R1,
    // G98 back to the start level Z5.
    let src =
        "G21 G90 G0 X0 Y0 Z5\nG98 G81 X10 Y10 Z-3 R1 F120\nG91 X15 L2\nY20\nG90 G80\nG0 Z5\nM2\n";
    let t = read(src, &GcodeSettings::default());
    let bottoms: Vec<[f64; 3]> = t
        .points
        .iter()
        .filter(|p| (p[2] + 3.0).abs() < 1e-12)
        .copied()
        .collect();
    // In G91 the depth is relative to R and R to the start level: the
    // G91 blocks keep the sticky R1 and Z-3, now increments: R at 5+1 = 6,
    // bottom at 6-3 = 3. So only the first hole reaches Z-3.
    assert_eq!(bottoms, vec![[10.0, 10.0, -3.0]]);
    let incremental_bottoms: Vec<[f64; 2]> = t
        .points
        .iter()
        .filter(|p| (p[2] - 3.0).abs() < 1e-12)
        .map(|p| [p[0], p[1]])
        .collect();
    assert_eq!(
        incremental_bottoms,
        vec![[25.0, 10.0], [40.0, 10.0], [40.0, 30.0]]
    );
    // Every hole is fed (cap 120) and left at rapid.
    for (i, p) in t.points.iter().enumerate() {
        if (p[2] + 3.0).abs() < 1e-12 || (p[2] - 3.0).abs() < 1e-12 {
            assert_eq!(t.feed_caps[i], Some(120.0));
            assert_eq!(t.feed_caps[i + 1], Some(48_000.0));
        }
    }
}

#[test]
fn g41_offset_of_a_square() {
    // A 10 mm square traced counter-clockwise with G41 and a 4 mm tool
    // (radius 2): the tool is inside, the corners are sharp at 2 mm from
    // each side: (2,2) (8,2) (8,8) (2,8).
    let s = GcodeSettings {
        tools: vec![ToolEntry {
            number: 3,
            diameter_mm: 4.0,
            length_mm: 0.0,
        }],
        ..Default::default()
    };
    let src = "T3 M6\nG0 X5 Y-5\nG41 D3 G1 X5 Y0 F300\nX10\nY10\nX0\nY0\nX5\nG40 G0 X5 Y-5\n";
    let t = read(src, &s);
    for c in [[8.0, 2.0], [8.0, 8.0], [2.0, 8.0], [2.0, 2.0]] {
        assert!(
            t.points.iter().any(|p| close(*p, [c[0], c[1], 0.0])),
            "{c:?} missing in {:?}",
            t.points
        );
    }
    // After the first corner (an outside corner rolled around the entry
    // point) the tool stays 2 mm inside the square until the exit.
    let inside: Vec<_> = t
        .points
        .iter()
        .zip(&t.lines)
        .filter(|(_, &l)| (5..=8).contains(&l))
        .collect();
    for (p, _) in inside {
        assert!(p[0] >= 2.0 - 1e-9 && p[0] <= 8.0 + 1e-9, "{p:?}");
        assert!(p[1] >= 2.0 - 1e-9 && p[1] <= 8.0 + 1e-9, "{p:?}");
    }
}

#[test]
fn subroutine_called_with_arguments() {
    let src = "o<hole> sub\n  G0 X#1 Y#2\n  G1 Z[-#3] F100\n  G0 Z1\no<hole> endsub\n\
               o<hole> call [1] [2] [3]\no<hole> call [4] [5] [6]\nM2\n";
    let t = read(src, &GcodeSettings::default());
    assert_eq!(
        t.points,
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 2.0, 0.0],
            [1.0, 2.0, -3.0],
            [1.0, 2.0, 1.0],
            [4.0, 5.0, 1.0],
            [4.0, 5.0, -6.0],
            [4.0, 5.0, 1.0],
        ]
    );
    // Lines inside the sub are reported as the sub's lines.
    assert_eq!(t.lines[1], 2);
    // A return value, a loop and #1-#30 restored after the call.
    let src = "o<sq> sub\no<sq> return [#1*#1]\no<sq> endsub\n#1=7\no<sq> call [3]\n\
               G1 X#<_value> Y#1 F100\n#2=0\no10 while [#2 lt 3]\n#2=[#2+1]\nG1 Z#2\no10 endwhile\n";
    let t = read(src, &GcodeSettings::default());
    assert_eq!(
        t.points,
        vec![
            [0.0, 0.0, 0.0],
            [9.0, 7.0, 0.0],
            [9.0, 7.0, 1.0],
            [9.0, 7.0, 2.0],
            [9.0, 7.0, 3.0]
        ]
    );
}

#[test]
fn g28_retract_as_fusion_360_writes_it() {
    // Fusion 360's preamble retracts with `G28 G91 Z0`: Z to the G28
    // position (machine Z 50 here) without moving X Y, then G90. With a G54
    // offset of (100, 50, -20) the program point X10 Y10 is machine
    // (110, 60) and Z-1 is machine Z-21.
    let s: GcodeSettings = toml::from_str(
        "[reference_positions]\ng28 = [0, 0, 50]\n[work_offsets]\ng54 = [100, 50, -20]\n",
    )
    .unwrap();
    let src = "%\n(1001)\nG90 G94 G17 G91.1\nG21\nG28 G91 Z0.\nG90\nG54\nG0 X10. Y10.\nG1 Z-1. F500.\nG28 G91 Z0.\nG90\nM30\n%\n";
    let t = read(src, &s);
    assert_eq!(
        t.points,
        vec![
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 50.0],
            [110.0, 60.0, 50.0],
            [110.0, 60.0, -21.0],
            [110.0, 60.0, 50.0],
        ]
    );
    // G92 shifts the program origin; G92.1 clears it.
    let t = read(
        "G0 X10\nG92 X0\nG0 X5\nG92.1\nG0 X5\n",
        &GcodeSettings::default(),
    );
    let xs: Vec<f64> = t.points.iter().map(|p| p[0]).collect();
    assert_eq!(xs, vec![0.0, 10.0, 15.0, 5.0]);
}

#[test]
fn bounds_turn_into_errors() {
    let s = GcodeSettings::default();
    for (src, needle) in [
        ("o1 while [1]\no1 endwhile\n", "max_executed_lines"),
        (
            "o<r> sub\no<r> call\no<r> endsub\no<r> call\n",
            "max_call_depth",
        ),
        ("G0 X1\nG2 X1 Y0 I1000000000000 F100\n", "max_points"),
        ("G0 X10\nG2 X10 Y0 I-10 P1000000 F100\n", "max_points"),
        ("G0 X1\nG2 X1 Y0 I10000000000000000 F100\n", "max_points"),
    ] {
        let e = format!("{:#}", gcode::parse("t", src, &s).unwrap_err());
        assert!(e.contains(needle) && e.contains("line"), "{src:?}: {e}");
    }
    let tiny: Result<host_sim::config::SimConfig, _> =
        host_sim::config::SimConfig::parse("[gcode]\nchord_tolerance_mm = 1e-300\n");
    assert!(tiny.is_err());
}

/// Pieces of G-code, valid and not, for random programs.
const PIECES: &[&str] = &[
    "G0",
    "G1",
    "G2",
    "G3",
    "G5.2",
    "G5.3",
    "G6.2",
    "G17",
    "G18",
    "G19",
    "G20",
    "G21",
    "G28",
    "G30",
    "G40",
    "G41",
    "G42",
    "G43",
    "G54",
    "G59.3",
    "G73",
    "G80",
    "G81",
    "G83",
    "G87",
    "G90",
    "G91",
    "G92",
    "G92.1",
    "G93",
    "G95",
    "G98",
    "G99",
    "M2",
    "M6",
    "T1",
    "D1",
    "H1",
    "X1",
    "Y-2.5",
    "Z-1",
    "I1",
    "J-1",
    "K1",
    "R2",
    "P3",
    "Q0.5",
    "L3",
    "F100",
    "F0",
    "S1000",
    "X1e3",
    "I1000000000",
    "P100000",
    "X[1+2]",
    "Y[#1*2]",
    "#1=5",
    "#<a>=[#1/0]",
    "#<_g>=1",
    "X#<a>",
    "Z[sin[30]]",
    "[",
    "]",
    "(",
    ")",
    "(c)",
    ";",
    "o1 while [#1 lt 3]",
    "o1 endwhile",
    "o1 if [1]",
    "o1 else",
    "o1 endif",
    "o<s> sub",
    "o<s> endsub",
    "o<s> call [1]",
    "o1 do",
    "o1 while [0]",
    "o2 repeat [2]",
    "o2 endrepeat",
    "o1 break",
    "%",
    "/",
    "N10",
    "@2",
    "^45",
    "A1",
    "E1",
    "#",
    "##1",
    "atan[1]/[0]",
    "X-",
    ".",
    "G10 L2 P1 X1",
    "G10 L1 P1 R1",
];

fn program() -> impl Strategy<Value = String> {
    prop::collection::vec(
        prop::collection::vec(prop::sample::select(PIECES), 0..6),
        0..24,
    )
    .prop_map(|lines| {
        lines
            .into_iter()
            .map(|l| l.join(" "))
            .collect::<Vec<_>>()
            .join("\n")
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn random_gcode_never_panics_the_reader(src in program(), bytes in prop::collection::vec(any::<u8>(), 0..200)) {
        let s = GcodeSettings {
            limits: Limits { max_points: 200_000, max_executed_lines: 20_000, max_call_depth: 10 },
            ..Default::default()
        };
        // Valid or not: a toolpath or an error, never a panic.
        let _ = gcode::parse("t", &src, &s);
        let _ = gcode::parse("t", &String::from_utf8_lossy(&bytes), &s);
    }
}
