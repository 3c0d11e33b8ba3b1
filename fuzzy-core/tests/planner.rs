//! The velocity planner (issue 6): limits never exceeded, cycle time against
//! the offline time-optimal reference, short segments held at full feed.
//! Run with `--nocapture` for the figures.

use fuzzy_core::lin2021::{Lin2021Controller, CONTROLLER};
use fuzzy_core::planner::{Motion, MotionConfig, MotionPoint, MotionState};
use fuzzy_core::reference;
use fuzzy_core::scheduler::{PathPoint, Scheduler, SchedulerConfig};
use fuzzy_core::units::{CurvaturePerMm, FeedMmPerMin, Point3Mm};

const TS: f64 = 1e-3;

fn shape(name: &str) -> Vec<[f64; 3]> {
    let path = format!(
        "{}/../tests/data/shapes/{name}.csv",
        env!("CARGO_MANIFEST_DIR")
    );
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with('x'))
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

/// The fuzzy schedule of a path: motion points with feed and curvature.
fn scheduled(xyz: &[[f64; 3]], f_max: i32) -> Vec<MotionPoint> {
    let cfg = SchedulerConfig::new(FeedMmPerMin::from_int(f_max), FeedMmPerMin::from_int(60));
    let mut s: Scheduler<&Lin2021Controller, 30, 9, 40> = Scheduler::new(&CONTROLLER, cfg).unwrap();
    let mut out = Vec::new();
    let pts = xyz
        .iter()
        .map(|p| PathPoint::at(Point3Mm::from_f64(p[0], p[1], p[2]).unwrap()));
    s.run(pts, |p| out.push(MotionPoint::from(&p))).unwrap();
    out
}

/// Constant feed, curvature from the three-point formula.
fn constant(xyz: &[[f64; 3]], feed: i32) -> Vec<MotionPoint> {
    let p: Vec<Point3Mm> = xyz
        .iter()
        .map(|p| Point3Mm::from_f64(p[0], p[1], p[2]).unwrap())
        .collect();
    (0..p.len())
        .map(|i| {
            let k = if i > 0 && i + 1 < p.len() {
                fuzzy_core::curvature::curvature(&p[i - 1], &p[i], &p[i + 1])
                    .unwrap_or(CurvaturePerMm::ZERO)
            } else {
                CurvaturePerMm::ZERO
            };
            MotionPoint {
                pos: p[i],
                feed: FeedMmPerMin::from_int(feed),
                curvature: k,
            }
        })
        .collect()
}

struct Figures {
    time_s: f64,
    ref_s: f64,
    axis_vel: f64,
    axis_acc: f64,
    tang_acc: f64,
    tang_jerk: f64,
    s_jerk: f64,
    over_ceiling_mm_min: f64,
    chord_um: f64,
    min_tick_speed_mm_min: f64,
}

fn run(points: &[MotionPoint], cfg: MotionConfig) -> Figures {
    // The planned ceilings and caps of the whole path, for the reference.
    let mut all: Box<Motion<8192>> = Box::new(Motion::new(cfg).unwrap());
    for p in points {
        all.push(*p).unwrap();
    }
    all.end_path();
    let planned: Vec<_> = all.planned().collect();
    let to_s = |f: FeedMmPerMin| f.to_f64() / 60.0;
    let nodes: Vec<(f64, f64, f64)> = planned
        .iter()
        .map(|p| (p.s_mm.to_num(), to_s(p.ceiling), to_s(p.cap)))
        .collect();
    let accel: f64 = all.accel_limit_mm_s2().to_num();
    let ref_s = reference::time_optimal_s(&nodes, accel, 0.002);
    // Streaming execution with a 256-point buffer.
    let mut m: Motion<256> = Motion::new(cfg).unwrap();
    let mut ticks: Vec<([f64; 3], f64, f64, f64)> = Vec::new();
    let record = |m: &mut Motion<256>, ticks: &mut Vec<_>| {
        let t = m.tick();
        ticks.push((
            t.pos.to_f64(),
            t.s_mm.to_num::<f64>(),
            m.speed_mm_per_min(t.speed).to_f64() / 60.0,
            t.accel as f64 / 4294967296.0 / (TS * TS),
        ));
        t.state
    };
    for p in points {
        while m.push(*p) == Err(fuzzy_core::planner::MotionError::Full) {
            record(&mut m, &mut ticks);
        }
    }
    m.end_path();
    let mut guard = 0;
    while record(&mut m, &mut ticks) != MotionState::Done {
        guard += 1;
        assert!(guard < 50_000_000, "never finished");
    }
    // Figures from the commanded positions.
    let amax = cfg.axis_accel_max_mm_s2.map(|a| a as f64);
    let vmax = cfg.axis_speed_max.map(|v| v.to_f64() / 60.0);
    let (mut axis_vel, mut axis_acc): (f64, f64) = (0.0, 0.0);
    for w in ticks.windows(3) {
        for k in 0..3 {
            let v = (w[1].0[k] - w[0].0[k]) / TS;
            let a = (w[2].0[k] - 2.0 * w[1].0[k] + w[0].0[k]) / (TS * TS);
            axis_vel = axis_vel.max(v.abs() / vmax[k]);
            axis_acc = axis_acc.max(a.abs() / amax[k]);
        }
    }
    let (mut tang_acc, mut tang_jerk): (f64, f64) = (0.0, 0.0);
    for w in ticks.windows(2) {
        tang_acc = tang_acc.max((w[1].2 - w[0].2).abs() / TS / accel);
        tang_jerk = tang_jerk.max((w[1].3 - w[0].3).abs() / TS / cfg.jerk_max_mm_s3 as f64);
    }
    // The same from the commanded arc length alone (third difference).
    let mut s_jerk: f64 = 0.0;
    for w in ticks.windows(4) {
        let d3 = w[3].1 - 3.0 * w[2].1 + 3.0 * w[1].1 - w[0].1;
        s_jerk = s_jerk.max(d3.abs() / (TS * TS * TS) / cfg.jerk_max_mm_s3 as f64);
    }
    // Speed passing each point (interpolated between ticks) vs its ceiling.
    let mut over: f64 = f64::MIN;
    let mut k = 0;
    for p in planned.iter().skip(1).take(planned.len().saturating_sub(2)) {
        let s: f64 = p.s_mm.to_num();
        while k + 1 < ticks.len() && ticks[k + 1].1 < s {
            k += 1;
        }
        if k + 1 < ticks.len() {
            let (s0, s1) = (ticks[k].1, ticks[k + 1].1);
            let f = if s1 > s0 {
                ((s - s0) / (s1 - s0)).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let v = ticks[k].2 + f * (ticks[k + 1].2 - ticks[k].2);
            over = over.max((v - to_s(p.ceiling)) * 60.0);
        }
    }
    // Chord deviation: the straight move between two ticks vs the vertices
    // it cuts.
    let mut chord: f64 = 0.0;
    let mut j = 0;
    for w in ticks.windows(2) {
        let (a, b) = (w[0].0, w[1].0);
        while j < planned.len() && planned[j].s_mm.to_num::<f64>() <= w[0].1 {
            j += 1;
        }
        let mut i = j;
        while i < planned.len() && planned[i].s_mm.to_num::<f64>() < w[1].1 {
            let p = planned[i].pos.to_f64();
            let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
            let l2 = ab.iter().map(|x| x * x).sum::<f64>();
            let t = if l2 > 0.0 {
                (ap.iter().zip(&ab).map(|(x, y)| x * y).sum::<f64>() / l2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let d = (0..3)
                .map(|q| (ap[q] - t * ab[q]).powi(2))
                .sum::<f64>()
                .sqrt();
            chord = chord.max(d);
            i += 1;
        }
    }
    let moving: Vec<f64> = ticks.iter().map(|t| t.2).collect();
    Figures {
        time_s: ticks.len() as f64 * TS,
        ref_s,
        axis_vel,
        axis_acc,
        tang_acc,
        tang_jerk,
        s_jerk,
        over_ceiling_mm_min: over,
        chord_um: chord * 1000.0,
        min_tick_speed_mm_min: moving.iter().copied().fold(f64::MAX, f64::min) * 60.0,
    }
}

fn report(name: &str, f: &Figures) {
    eprintln!(
        "planner {name:32}: time {:7.3} s, time-optimal (accel-limited) {:7.3} s, ratio {:.3} | per-axis v/V {:.3} a/A {:.3} | tangential a/A {:.3} jerk/J {:.3} (Δ³s {:.3}) | max(v − ceiling) {:+.2} mm/min | chord {:.3} µm",
        f.time_s,
        f.ref_s,
        f.time_s / f.ref_s,
        f.axis_vel,
        f.axis_acc,
        f.tang_acc,
        f.tang_jerk,
        f.s_jerk,
        f.over_ceiling_mm_min,
        f.chord_um
    );
}

fn assert_within_limits(name: &str, f: &Figures, cfg: &MotionConfig) {
    report(name, f);
    assert!(
        f.axis_vel <= 1.0 + 1e-9,
        "{name}: axis velocity {}",
        f.axis_vel
    );
    assert!(
        f.axis_acc <= 1.0 + 1e-9,
        "{name}: axis acceleration {}",
        f.axis_acc
    );
    assert!(
        f.tang_acc <= 1.0 + 1e-6,
        "{name}: tangential acceleration {}",
        f.tang_acc
    );
    assert!(
        f.tang_jerk <= 1.0 + 1e-6,
        "{name}: tangential jerk {}",
        f.tang_jerk
    );
    // The third difference of positions quantised to 2^-32 mm is exact to
    // within 8 quanta.
    let quanta = 8.0 * 2f64.powi(-32) / (cfg.jerk_max_mm_s3 as f64 * TS * TS * TS);
    assert!(
        f.s_jerk <= 1.0 + quanta,
        "{name}: jerk from the commanded arc length {}",
        f.s_jerk
    );
    assert!(
        f.over_ceiling_mm_min <= 0.5,
        "{name}: speed over a ceiling by {} mm/min",
        f.over_ceiling_mm_min
    );
    assert!(
        f.chord_um <= cfg.chord_tolerance_mm.to_num::<f64>() * 1000.0 + 1e-6,
        "{name}: chord {} µm",
        f.chord_um
    );
}

#[test]
fn paper_shapes_within_limits_and_near_time_optimal() {
    let cfg = MotionConfig::default();
    for name in ["infinity", "trident", "butterfly"] {
        let f = run(&scheduled(&shape(name), 5000), cfg);
        assert_within_limits(name, &f, &cfg);
        assert!(
            f.time_s / f.ref_s <= 1.15,
            "{name}: {} × the time-optimal reference",
            f.time_s / f.ref_s
        );
    }
}

#[test]
fn sharp_corners_and_short_segments() {
    let cfg = MotionConfig::default();
    // A square spiral: 90° corners between long segments.
    let mut pts = vec![[0.0, 0.0, 0.0]];
    let (mut x, mut y, mut l) = (0.0, 0.0, 40.0);
    for k in 0..40 {
        let (dx, dy) = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)][k % 4];
        x += dx * l;
        y += dy * l;
        pts.push([x, y, 0.0]);
        if k % 2 == 1 {
            l -= 2.0;
        }
    }
    let f = run(&constant(&pts, 5000), cfg);
    assert_within_limits("square spiral, 90° corners", &f, &cfg);
    // 0.02-0.2 mm segments wandering in 3-D.
    let mut pts = vec![[0.0, 0.0, 0.0]];
    let (mut h, mut z) = (0.0f64, 0.0f64);
    for i in 0..3000 {
        let len = 0.02 + 0.18 * ((i * 7919) % 101) as f64 / 100.0;
        h += 0.06 * (((i * 104729) % 201) as f64 / 100.0 - 1.0);
        z += 0.01 * (((i * 13) % 7) as f64 - 3.0) / 3.0;
        let p = *pts.last().unwrap();
        pts.push([p[0] + len * h.cos(), p[1] + len * h.sin(), z]);
    }
    let f = run(&constant(&pts, 5000), cfg);
    assert_within_limits("short segments 0.02-0.2 mm, 3-D", &f, &cfg);
}

#[test]
fn short_straight_segments_hold_the_programmed_feed() {
    // Grbl on an 8-bit MCU takes 26 % longer on 0.2 mm than on 0.3 mm
    // segments at 5000 mm/min; here 0.05 mm segments run at full feed.
    let cfg = MotionConfig::default();
    for seg in [0.3, 0.2, 0.1, 0.05] {
        let n = (100.0 / seg) as usize;
        let pts: Vec<[f64; 3]> = (0..=n).map(|i| [i as f64 * seg, 0.0, 0.0]).collect();
        let f = run(&constant(&pts, 5000), cfg);
        assert_within_limits(&format!("straight line, {seg} mm segments"), &f, &cfg);
        // Cruise: accelerate at 1000 mm/s² (jerk-limited), cruise, brake.
        let v = 5000.0 / 60.0;
        let cruise = 100.0 / v + v / 1000.0 + 1000.0 / cfg.jerk_max_mm_s3 as f64;
        assert!(
            f.time_s <= cruise * 1.01,
            "{seg} mm: {} s vs {cruise} s",
            f.time_s
        );
        let _ = f.min_tick_speed_mm_min;
    }
}
