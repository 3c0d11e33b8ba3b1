//! The interpreter fed a line at a time against a machine: the same output
//! as the whole file, handed out as each line completes; probing and moves
//! made outside the program.

use std::sync::Arc;

use anyhow::Result;
use gcode_interp::interp::{Interp, Stop};
use gcode_interp::machine::{Collect, Machine, ProbeMove};
use gcode_interp::sink::Item;
use gcode_interp::GcodeSettings;

fn whole(src: &str) -> Collect {
    let mut it = Interp::new(Arc::new(GcodeSettings::default()), None).unwrap();
    it.load_main(src, None).unwrap();
    let mut c = Collect::default();
    assert_eq!(it.run_with(&mut c).unwrap(), Stop::Ended);
    c
}

fn live(src: &str) -> Collect {
    let mut it = Interp::new(Arc::new(GcodeSettings::default()), None).unwrap();
    it.start_live();
    let mut c = Collect::default();
    for l in src.lines() {
        it.push_line(l).unwrap();
        assert_eq!(it.run_with(&mut c).unwrap(), Stop::NeedInput);
    }
    c
}

const PROGRAMS: [&str; 5] = [
    "G21 G90\nG0 X10 Y0\nG1 Y5 F600\nG91 X-2\nG90 G3 X0 Y5 I-4 J0\n",
    "G1 X1 F100\nM3 S1000\nG4 P0.5\nG1 X2\nM8\nG1 X3\nM9 M5\n",
    "#1 = 0\no100 while [#1 LT 5]\nG1 X[#1] Y[#1 * 2] F500\n#1 = [#1 + 1]\no100 endwhile\nG0 Z5\n",
    "o<sq> sub\nG91 G1 X#1 F300\nY#1\nX-#1\nY-#1\nG90\no<sq> endsub\nG0 X1 Y1\no<sq> call [2]\no<sq> call [3]\n",
    "G0 Z5\nG81 X1 Y1 Z-2 R1 F100\nX2\nX3\nG80\nG0 Z10\n",
];

#[test]
fn a_line_at_a_time_gives_what_the_whole_file_gives() {
    for src in PROGRAMS {
        let (a, b) = (whole(src), live(src));
        assert_eq!(a.points, b.points, "{src}");
        assert_eq!(a.caps, b.caps, "{src}");
        assert_eq!(a.lines, b.lines, "{src}");
        assert_eq!(a.events, b.events, "{src}");
    }
}

#[test]
fn each_lines_moves_are_handed_out_when_it_completes() {
    let mut it = Interp::new(Arc::new(GcodeSettings::default()), None).unwrap();
    it.start_live();
    let mut c = Collect::default();
    it.push_line("G1 X1 F100").unwrap();
    it.run_with(&mut c).unwrap();
    assert_eq!(c.points, vec![[0.0; 3], [1.0, 0.0, 0.0]]);
    // An open structure waits for its end, then runs as a whole.
    assert!(!it.push_line("o1 repeat [3]").unwrap());
    assert!(!it.push_line("G91 X1").unwrap());
    it.run_with(&mut c).unwrap();
    assert_eq!(c.points.len(), 2);
    assert!(it.push_line("o1 endrepeat").unwrap());
    it.run_with(&mut c).unwrap();
    assert_eq!(c.points.last(), Some(&[4.0, 0.0, 0.0]));
    assert_eq!(c.points.len(), 5);
}

#[test]
fn a_program_end_resets_the_modes_and_the_next_program_runs() {
    let mut it = Interp::new(Arc::new(GcodeSettings::default()), None).unwrap();
    it.start_live();
    let mut c = Collect::default();
    for l in ["G91 G1 X1 F100", "M3 S100", "M30", "X2"] {
        it.push_line(l).unwrap();
        assert_eq!(it.run_with(&mut c).unwrap(), Stop::NeedInput);
    }
    // After M30: absolute again, motion G1 (Grbl, RS274/NGC), spindle off.
    assert_eq!(c.points.last(), Some(&[2.0, 0.0, 0.0]));
    assert_eq!(c.events.len(), 2, "{:?}", c.events);
}

/// A machine with a flat piece whose top is at `z_mm`.
struct Plate {
    out: Collect,
    z_mm: f64,
    moved: Option<[f64; 3]>,
}

impl Machine for Plate {
    fn emit(&mut self, item: Item) -> Result<()> {
        self.out.emit(item)
    }
    fn moved_to(&mut self) -> Option<[f64; 3]> {
        self.moved.take()
    }
    fn probe(&mut self, p: &ProbeMove) -> Result<Option<[f64; 3]>> {
        let from = *self.out.points.last().unwrap();
        if p.kind.toward() && p.target_mm[2] < self.z_mm && from[2] >= self.z_mm {
            let t = (from[2] - self.z_mm) / (from[2] - p.target_mm[2]);
            let at = [
                from[0] + t * (p.target_mm[0] - from[0]),
                from[1] + t * (p.target_mm[1] - from[1]),
                self.z_mm,
            ];
            self.out.points.push(at);
            return Ok(Some(at));
        }
        self.out.points.push(p.target_mm);
        Ok(None)
    }
}

#[test]
fn a_probe_sets_its_parameters_and_a_touch_off_follows() {
    let mut it = Interp::new(Arc::new(GcodeSettings::default()), None).unwrap();
    it.start_live();
    let mut m = Plate {
        out: Collect::default(),
        z_mm: -3.25,
        moved: None,
    };
    for l in [
        "G0 X5 Y5 Z0",
        "G38.2 Z-10 F100",
        "#100 = #5063",
        "#101 = #5070",
        "G10 L20 P1 Z0",
        "G0 Z1",
    ] {
        it.push_line(l).unwrap();
        it.run_with(&mut m).unwrap();
    }
    // Z1 in the new work system is 1 mm above the plate.
    assert_eq!(m.out.points.last(), Some(&[5.0, 5.0, -2.25]));
    it.push_line("G38.3 Z-20 F100").unwrap();
    it.push_line("G0 Z[#5063 + #5070]").unwrap();
    // It trips on the plate again: #5063 is 0 in the new work system, #5070
    // is 1, so the tool goes back to 1 mm above the plate.
    it.run_with(&mut m).unwrap();
    assert_eq!(m.out.points.last(), Some(&[5.0, 5.0, -2.25]));
    // G38.2 that never trips is an error naming the line; G38.3 is not.
    it.push_line("G0 X50 Z5").unwrap();
    it.run_with(&mut m).unwrap();
    m.z_mm = -100.0;
    it.push_line("G38.2 Z-10 F100").unwrap();
    let e = format!("{:#}", it.run_with(&mut m).unwrap_err());
    assert!(e.contains("did not trip"), "{e}");
}

#[test]
fn a_move_outside_the_program_moves_the_next_start() {
    let mut it = Interp::new(Arc::new(GcodeSettings::default()), None).unwrap();
    it.start_live();
    let mut m = Plate {
        out: Collect::default(),
        z_mm: 0.0,
        moved: None,
    };
    it.push_line("G1 X1 F100").unwrap();
    it.run_with(&mut m).unwrap();
    m.moved = Some([10.0, 20.0, 0.0]); // a jog
    it.push_line("G91 X1").unwrap();
    it.run_with(&mut m).unwrap();
    assert_eq!(m.out.points.last(), Some(&[11.0, 20.0, 0.0]));
    assert_eq!(it.position_mm(), [11.0, 20.0, 0.0]);
}

#[test]
fn a_whole_file_refuses_probing_without_a_machine() {
    let mut it = Interp::new(Arc::new(GcodeSettings::default()), None).unwrap();
    it.load_main("G1 X1 F100\nG38.2 Z-5\n", None).unwrap();
    let e = format!("{:#}", it.run_with(&mut Collect::default()).unwrap_err());
    assert!(
        e.contains("line 2") && e.contains("needs live machine state"),
        "{e}"
    );
}

#[test]
fn work_offsets_are_kept_across_restarts_in_the_var_file() {
    let dir = tempfile::tempdir().unwrap();
    let var = dir.path().join("fuzzy.var");
    let settings = Arc::new(GcodeSettings {
        var_file: Some(var.clone()),
        ..Default::default()
    });
    let mut it = Interp::new(settings.clone(), None).unwrap();
    it.start_live();
    let mut c = Collect::default();
    for l in ["G0 X5 Y6 Z7", "G10 L20 P2 X0 Y0", "G55", "G28.1", "G92 Z0"] {
        it.push_line(l).unwrap();
        it.run_with(&mut c).unwrap();
    }
    let text = std::fs::read_to_string(&var).unwrap();
    assert!(text.contains("5241\t5.000000\n5242\t6.000000\n"), "{text}");
    assert!(text.contains("5220\t2.000000\n"), "{text}");
    // A new session starts in G55 with its offsets, G28's position and G92.
    let mut it = Interp::new(settings, None).unwrap();
    it.start_live();
    let mut c = Collect::default();
    for l in ["G0 X1 Y1 Z1", "G28"] {
        it.push_line(l).unwrap();
        it.run_with(&mut c).unwrap();
    }
    assert_eq!(c.points[1], [6.0, 7.0, 8.0]);
    assert_eq!(c.points.last(), Some(&[5.0, 6.0, 7.0]));
}
