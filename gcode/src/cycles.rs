//! Canned cycles G73, G74, G81-G89 expanded into moves, as the RS274/NGC
//! report defines them (Kramer et al. 2000, §3.5.16) and LinuxCNC runs them
//! (`interp_cycles.cc`: `convert_cycle_xy` and `convert_cycle_g8x`).
//!
//! In the selected plane's terms (G17: hole position X Y, depth along Z;
//! G18: Z X, along Y; G19: Y Z, along X), with `old` the depth-axis position
//! when the cycle mode began:
//! - G90: `R` and the depth word are positions; G91: `R` is relative to
//!   `old`, the depth relative to `R`, and the plane words are increments
//!   repeated `L` times (each repeat drills the next hole).
//! - The clear level is `R` under G99 and `max(old, R)` under G98. If the
//!   tool starts below `R` it first rises to `R`.
//! - Each hole: the first one at the current level, the later ones at the
//!   clear level, a rapid in the plane to the hole, a rapid down to `R`
//!   (when above it), the cycle's own motion, then back to the clear level.
//!
//! | cycle | motion from R |
//! |---|---|
//! | G81 | feed to the bottom, rapid out |
//! | G82 | feed to the bottom, dwell `P`, rapid out |
//! | G73 | pecks of `Q`, each followed by a rapid back by the clearance, then the bottom, rapid out |
//! | G83 | pecks of `Q`, each followed by a rapid to `R` and a rapid down to the clearance above the last depth, then the bottom, rapid out |
//! | G74, G84 | feed to the bottom, dwell `P`, feed out (the spindle reverses: not simulated) |
//! | G85 | feed to the bottom, feed to `R`, rapid out |
//! | G86 | feed to the bottom, dwell, spindle stop, rapid out |
//! | G87 | back boring: rapid to `(I, J)` off the hole, down to the bottom, over the hole, feed up to `K` and back down, rapid off, out, and over |
//! | G88 | feed to the bottom, dwell, then the operator retracts by hand: refused (needs live machine state) |
//! | G89 | feed to the bottom, dwell `P`, feed out |
//!
//! The peck clearance is the block's `D` word or `gcode.peck_clearance_mm`
//! (LinuxCNC's metric default is 1 mm). Dwells do not move the tool: they
//! become machine events (`MachineEvent::Dwell`, which the sender sends),
//! not simulated time. `R`, the depth, `P`, `Q` and G87's `I J K` stay in
//! force for the following blocks of the same cycle.

use anyhow::{anyhow, bail, Result};

use super::interp::{Blk, Interp, AXES, NEEDS_MACHINE};
use super::text::short;

/// Run the cycle `code` (G-code × 10) of block `b`.
pub fn run(it: &mut Interp, b: &Blk, code: u32) -> Result<()> {
    let line = b.line;
    let g = code / 10;
    let (a, bb, n) = it.plane.axes();
    let (la, lb, ln) = (AXES[a], AXES[bb], AXES[n]);
    let u = it.units;
    let depth = b
        .get(ln)
        .or(it.cycle.z)
        .ok_or_else(|| anyhow!("line {line}: G{g} needs its depth {ln}"))?;
    let r_word = b
        .get('R')
        .or(it.cycle.r)
        .ok_or_else(|| anyhow!("line {line}: G{g} needs its retract level R"))?;
    it.cycle.z = Some(depth);
    it.cycle.r = Some(r_word);
    let repeats = match b.get('L') {
        None => 1,
        Some(l) if l >= 0.0 && l.fract() == 0.0 && l <= 1e9 => l as u64,
        Some(l) => bail!(
            "line {line}: L{} is not a whole number of repeats",
            short(l)
        ),
    };
    if repeats as f64 * 8.0 > it.out.room() as f64 {
        it.out
            .check_room(repeats as f64 * 8.0, line, &format!("G{g} with L{repeats}"))?;
    }
    let off = |it: &Interp, k: usize| it.pos[k] - program_pos(it, k);
    let current = program_pos(it, n);
    let old = match it.cycle.initial_level {
        Some(v) => v,
        None => {
            it.cycle.initial_level = Some(current);
            current
        }
    };
    let (mut pa, mut pb) = (program_pos(it, a), program_pos(it, bb));
    let (mut da, mut db) = (0.0, 0.0);
    let (r, bottom) = if it.absolute {
        if let Some(v) = b.get(la) {
            pa = v * u;
        }
        if let Some(v) = b.get(lb) {
            pb = v * u;
        }
        (r_word * u, depth * u)
    } else {
        da = b.get(la).unwrap_or(0.0) * u;
        db = b.get(lb).unwrap_or(0.0) * u;
        let r = old + r_word * u;
        (r, r + depth * u)
    };
    if r < bottom {
        bail!("line {line}: G{g} retract level R is below the hole's bottom");
    }
    // Cycle-specific words.
    if matches!(g, 82 | 86 | 88 | 89 | 74 | 84) {
        let p = b.get('P').or(it.cycle.p);
        if p.is_none() && matches!(g, 82 | 86 | 88 | 89) {
            bail!("line {line}: G{g} needs a dwell P");
        }
        if p.is_some_and(|p| p < 0.0) {
            bail!("line {line}: G{g} dwell P is negative");
        }
        it.cycle.p = p;
    }
    let mut q = 0.0;
    if matches!(g, 73 | 83) {
        q = b
            .get('Q')
            .or(it.cycle.q)
            .ok_or_else(|| anyhow!("line {line}: G{g} needs a peck depth Q"))?;
        if q <= 0.0 {
            bail!("line {line}: G{g} peck depth Q must be positive");
        }
        it.cycle.q = Some(q);
        q *= u;
        if (r - bottom) / q > it.out.room() as f64 {
            it.out
                .check_room((r - bottom) / q * 3.0, line, &format!("G{g} pecks"))?;
        }
    }
    let clearance = b.get('D').map_or(it.s.peck_clearance_mm, |d| d * u);
    let mut ijk = [0.0; 3];
    if g == 87 {
        for (k, l) in ['I', 'J', 'K'].iter().enumerate() {
            let v = b
                .get(*l)
                .or(it.cycle.ijk[k])
                .ok_or_else(|| anyhow!("line {line}: G87 needs I, J and K"))?;
            it.cycle.ijk[k] = Some(v);
            ijk[k] = v * u;
        }
        if !it.absolute {
            ijk[2] += bottom;
        }
    }
    if g == 88 {
        bail!("line {line}: G88 stops for the operator to retract by hand: {NEEDS_MACHINE}");
    }
    // Machine point from program coordinates (mm) in the plane's terms.
    let at = |it: &Interp, va: f64, vb: f64, vn: f64| {
        let mut t = it.pos;
        t[a] = va + off(it, a);
        t[bb] = vb + off(it, bb);
        t[n] = vn + off(it, n);
        t
    };
    let (mut old, mut current) = (old, current);
    if old < r {
        let t = at(it, program_pos(it, a), program_pos(it, bb), r);
        it.move_to(t, None, line)?;
        old = r;
        current = r;
    }
    let clear = if it.retract_r { r } else { old };
    for rep in 0..repeats {
        pa += da;
        pb += db;
        if rep == 0 && current > r {
            let t = at(it, pa, pb, current);
            it.move_to(t, None, line)?;
        } else {
            let t = at(it, pa, pb, clear);
            it.move_to(t, None, line)?;
        }
        if program_pos(it, n) > r {
            let t = at(it, pa, pb, r);
            it.move_to(t, None, line)?;
        }
        let to = |it: &Interp, vn: f64| at(it, pa, pb, vn);
        match g {
            81 | 82 | 86 => {
                let t = to(it, bottom);
                it.feed_to(t, line)?;
                if g != 81 {
                    it.out.dwell(line, it.cycle.p.unwrap_or(0.0));
                }
                let t = to(it, clear);
                it.move_to(t, None, line)?;
            }
            73 | 83 => {
                let mut d = r - q;
                while d > bottom {
                    let t = to(it, d);
                    it.feed_to(t, line)?;
                    if g == 83 {
                        let t = to(it, r);
                        it.move_to(t, None, line)?;
                    }
                    let t = to(it, d + clearance);
                    it.move_to(t, None, line)?;
                    d -= q;
                }
                let t = to(it, bottom);
                it.feed_to(t, line)?;
                let t = to(it, clear);
                it.move_to(t, None, line)?;
            }
            74 | 84 | 89 => {
                let t = to(it, bottom);
                it.feed_to(t, line)?;
                it.out.dwell(line, it.cycle.p.unwrap_or(0.0));
                let t = to(it, clear);
                it.feed_to(t, line)?;
            }
            85 => {
                let t = to(it, bottom);
                it.feed_to(t, line)?;
                let t = to(it, r);
                it.feed_to(t, line)?;
                let t = to(it, clear);
                it.move_to(t, None, line)?;
            }
            87 => {
                let (oa, ob) = (pa + ijk[0], pb + ijk[1]);
                let t = at(it, oa, ob, r);
                it.move_to(t, None, line)?;
                let t = at(it, oa, ob, bottom);
                it.move_to(t, None, line)?;
                let t = to(it, bottom);
                it.move_to(t, None, line)?;
                let t = to(it, ijk[2]);
                it.feed_to(t, line)?;
                let t = to(it, bottom);
                it.feed_to(t, line)?;
                let t = at(it, oa, ob, bottom);
                it.move_to(t, None, line)?;
                let t = at(it, oa, ob, clear);
                it.move_to(t, None, line)?;
                let t = to(it, clear);
                it.move_to(t, None, line)?;
            }
            _ => bail!("line {line}: G{g} is not a canned cycle"),
        }
    }
    Ok(())
}

/// Program coordinate (mm, offsets removed) of axis `k`.
fn program_pos(it: &Interp, k: usize) -> f64 {
    it.program_mm(k)
}

#[cfg(test)]
mod tests {
    use crate::{parse, GcodeSettings};

    fn holes(src: &str) -> Vec<[f64; 3]> {
        let t = parse("t", src, &GcodeSettings::default()).unwrap();
        // Hole bottoms: points where the path turns from going down to up.
        let p = &t.points;
        (1..p.len() - 1)
            .filter(|&i| p[i][2] < p[i - 1][2] && p[i + 1][2] > p[i][2])
            .map(|i| p[i])
            .collect()
    }

    #[test]
    fn g81_absolute_holes_and_levels() {
        // Independent expectation: three holes at (10,0) (20,0) (20,10),
        // bottom Z-5; G98 returns to the start level Z10 between holes.
        let src = "G0 X0 Y0 Z10\nG98 G81 X10 Y0 Z-5 R2 F100\nX20\nY10\nG80\n";
        let t = parse("t", src, &GcodeSettings::default()).unwrap();
        assert_eq!(
            holes(src),
            vec![[10.0, 0.0, -5.0], [20.0, 0.0, -5.0], [20.0, 10.0, -5.0]]
        );
        let after: Vec<_> = t.points.iter().skip(2).collect();
        assert!(after.iter().all(|p| p[2] <= 10.0 && p[2] >= -5.0));
        // G98: between holes the tool is back at Z10; the R level is 2.
        assert_eq!(t.points[2], [10.0, 0.0, 10.0]);
        assert_eq!(t.points[3], [10.0, 0.0, 2.0]);
        assert_eq!(t.points[4], [10.0, 0.0, -5.0]);
        assert_eq!(t.points[5], [10.0, 0.0, 10.0]);
        assert_eq!(t.feed_caps[4], Some(100.0));
        // G99: back to R only.
        let t = parse(
            "t",
            "G0 X0 Y0 Z10\nG99 G81 X10 Y0 Z-5 R2 F100\nX20\n",
            &GcodeSettings::default(),
        )
        .unwrap();
        assert_eq!(t.points[5], [10.0, 0.0, 2.0]);
        assert_eq!(t.points[6], [20.0, 0.0, 2.0]);
    }

    #[test]
    fn g91_repeats_drill_a_row() {
        // G91 L4: four holes 5 mm apart from X0; R is 3 below the start
        // (Z10 → Z7), the depth 9 below R (Z-2).
        let src = "G0 X0 Y0 Z10\nG91 G99 G81 X5 Z-9 R-3 L4 F200\n";
        assert_eq!(
            holes(src),
            (1..=4)
                .map(|k| [5.0 * k as f64, 0.0, -2.0])
                .collect::<Vec<_>>()
        );
    }

    #[test]
    fn g83_pecks_and_g73_chip_breaks() {
        // G83 from R2 to Z-5 in pecks of 3: feeds to -1, -4, then -5; rapid
        // back to R between pecks, rapid down to 1 mm above the last depth.
        let t = parse(
            "t",
            "G0 X0 Y0 Z10\nG98 G83 X0 Y0 Z-5 R2 Q3 F100\n",
            &GcodeSettings::default(),
        )
        .unwrap();
        let z: Vec<f64> = t.points.iter().map(|p| p[2]).collect();
        assert_eq!(
            z,
            vec![0.0, 10.0, 2.0, -1.0, 2.0, 0.0, -4.0, 2.0, -3.0, -5.0, 10.0]
        );
        let t = parse(
            "t",
            "G0 X0 Y0 Z10\nG99 G73 X0 Y0 Z-5 R2 Q3 F100\n",
            &GcodeSettings::default(),
        )
        .unwrap();
        let z: Vec<f64> = t.points.iter().map(|p| p[2]).collect();
        assert_eq!(z, vec![0.0, 10.0, 2.0, -1.0, 0.0, -4.0, -3.0, -5.0, 2.0]);
    }

    #[test]
    fn missing_words_are_errors_naming_the_line() {
        for (src, want) in [
            ("G0 Z5\nG81 X1 Y1 R2 F100\n", "line 2"),
            ("G0 Z5\nG81 X1 Y1 Z-1 F100\n", "line 2"),
            ("G0 Z5\nG82 X1 Y1 Z-1 R1 F100\n", "line 2"),
            ("G0 Z5\nG83 X1 Y1 Z-1 R1 F100\n", "line 2"),
            ("G0 Z5\nG81 X1 Y1 Z3 R1 F100\n", "line 2"),
            (
                "G0 Z5\nG88 X1 Y1 Z-1 R1 P1 F100\n",
                "needs live machine state",
            ),
        ] {
            let e = format!(
                "{:#}",
                parse("t", src, &GcodeSettings::default()).unwrap_err()
            );
            assert!(e.contains(want), "{src:?}: {e}");
        }
    }
}
