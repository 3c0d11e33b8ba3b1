//! The velocity planner (issue 6): limits never exceeded, cycle time against
//! the offline time-optimal reference, short segments held at full feed,
//! and the controller behaviours around it (feed hold, underrun, override,
//! restart, bad input). Run with `--nocapture` for the figures.
//!
//! Every figure is measured from the commanded positions the executor emits
//! (finite differences), not from the planner's own state.

use fuzzy_core::lin2021::{Lin2021Controller, CONTROLLER};
use fuzzy_core::planner::{
    ConfigError, Motion, MotionConfig, MotionError, MotionPoint, MotionState, PlannedPoint,
};
use fuzzy_core::reference;
use fuzzy_core::reference::topp;
use fuzzy_core::scheduler::{PathPoint, Scheduler, SchedulerConfig};
use fuzzy_core::units::{CurvaturePerMm, FeedMmPerMin, Fx, Point3Mm};
use proptest::prelude::*;

#[path = "planner/monotone.rs"]
mod monotone;

fn data(rel: &str) -> String {
    std::fs::read_to_string(format!(
        "{}/../tests/data/{rel}",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

/// x, y, z (and the programmed feed if the file has a 4th column).
fn csv(rel: &str) -> Vec<([f64; 3], Option<f64>)> {
    data(rel)
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with('x'))
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            let f = |i: usize| v[i].trim().parse::<f64>().unwrap();
            (
                [f(0), f(1), f(2)],
                v.get(3).and_then(|s| s.trim().parse().ok()),
            )
        })
        .collect()
}

fn shape(name: &str) -> Vec<[f64; 3]> {
    csv(&format!("shapes/{name}.csv"))
        .into_iter()
        .map(|p| p.0)
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

/// Programmed feeds (mm/min; `None` = `feed`), curvature from three points.
fn programmed(xyz: &[([f64; 3], Option<f64>)], feed: f64) -> Vec<MotionPoint> {
    let p: Vec<Point3Mm> = xyz
        .iter()
        .map(|(p, _)| Point3Mm::from_f64(p[0], p[1], p[2]).unwrap())
        .collect();
    (0..p.len())
        .map(|i| {
            let k = if i > 0 && i + 1 < p.len() {
                fuzzy_core::curvature::curvature(&p[i - 1], &p[i], &p[i + 1])
                    .unwrap_or(CurvaturePerMm::ZERO)
            } else {
                CurvaturePerMm::ZERO
            };
            let f = xyz[i].1.unwrap_or(feed).min(1e6);
            MotionPoint {
                pos: p[i],
                feed: FeedMmPerMin::from_f64(f),
                curvature: k,
            }
        })
        .collect()
}

fn constant(xyz: &[[f64; 3]], feed: i32) -> Vec<MotionPoint> {
    let v: Vec<_> = xyz.iter().map(|p| (*p, None)).collect();
    programmed(&v, feed as f64)
}

/// One tick as recorded: position, arc length, speed (mm/s), acceleration
/// (mm/s²), state, point index.
#[derive(Clone, Copy, Debug)]
struct T {
    pos: [f64; 3],
    s: f64,
    v: f64,
    a: f64,
    state: MotionState,
    point: u32,
}

fn record<const N: usize>(m: &mut Motion<N>, ts: f64, out: &mut Vec<T>) -> MotionState {
    let t = m.tick();
    out.push(T {
        pos: t.pos.to_f64(),
        s: t.s_mm.to_num(),
        v: m.speed_mm_per_min(t.speed).to_f64() / 60.0,
        a: t.accel.to_mm_per_s2_f64(ts),
        state: t.state,
        point: t.point,
    });
    t.state
}

fn ts(cfg: &MotionConfig) -> f64 {
    cfg.tick_us as f64 * 1e-6
}

/// Stream `points` through a `Motion<256>`: push while there is room, tick
/// when full; `event(tick index, motion)` runs before every tick.
fn drive(
    points: &[MotionPoint],
    cfg: MotionConfig,
    event: impl FnMut(usize, &mut Motion<256>),
) -> Vec<T> {
    drive_n(points, cfg, event)
}

/// [`drive`] with a buffer (lookahead) of `N` points.
fn drive_n<const N: usize>(
    points: &[MotionPoint],
    cfg: MotionConfig,
    mut event: impl FnMut(usize, &mut Motion<N>),
) -> Vec<T> {
    let ts = ts(&cfg);
    let mut m: Motion<N> = Motion::new(cfg).unwrap();
    let mut ticks = Vec::new();
    for p in points {
        while m.push(*p) == Err(MotionError::Full) {
            event(ticks.len(), &mut m);
            record(&mut m, ts, &mut ticks);
        }
    }
    m.end_path();
    loop {
        event(ticks.len(), &mut m);
        if record(&mut m, ts, &mut ticks) == MotionState::Done {
            break;
        }
        assert!(ticks.len() < 5_000_000, "never finished");
    }
    ticks
}

/// Peak ratios to the limits, from the commanded positions.
#[derive(Debug, Default)]
struct Peaks {
    axis_vel: f64,
    axis_acc: f64,
    tang_acc: f64,
    tang_jerk: f64,
    /// Tangential jerk from the third difference of the arc length.
    s_jerk: f64,
}

fn peaks(ticks: &[T], cfg: &MotionConfig, accel: f64) -> Peaks {
    let ts = ts(cfg);
    let amax = cfg.axis_accel_max_mm_s2.map(|a| a as f64);
    let vmax = cfg.axis_speed_max.map(|v| v.to_f64() / 60.0);
    let j = cfg.jerk_max_mm_s3 as f64;
    let mut p = Peaks::default();
    for w in ticks.windows(3) {
        for k in 0..3 {
            let v = (w[1].pos[k] - w[0].pos[k]) / ts;
            let a = (w[2].pos[k] - 2.0 * w[1].pos[k] + w[0].pos[k]) / (ts * ts);
            p.axis_vel = p.axis_vel.max(v.abs() / vmax[k]);
            p.axis_acc = p.axis_acc.max(a.abs() / amax[k]);
        }
    }
    for w in ticks.windows(2) {
        p.tang_acc = p.tang_acc.max((w[1].v - w[0].v).abs() / ts / accel);
        p.tang_jerk = p.tang_jerk.max((w[1].a - w[0].a).abs() / ts / j);
    }
    for w in ticks.windows(4) {
        let d3 = w[3].s - 3.0 * w[2].s + 3.0 * w[1].s - w[0].s;
        p.s_jerk = p.s_jerk.max(d3.abs() / (ts * ts * ts) / j);
    }
    p
}

/// Quantisation allowances: the planner rounds its per-tick limits down,
/// but positions are quantised to 2^-32 mm, so a k-th difference is exact to
/// within 2^k quanta. The arc length's third difference also gets the
/// quantisation of the acceleration where a stop's final ramp begins part
/// way through a tick: one quantum of `a` there is |a|/J quanta of speed
/// (at most A/J, both per tick), which the stop sheds in its last tick
/// (planner module docs, "Resolution").
fn tolerances(cfg: &MotionConfig) -> (f64, f64) {
    let ts = ts(cfg);
    let q = 2f64.powi(-32);
    let acc = 4.0 * q / (ts * ts) / cfg.axis_accel_max_mm_s2.iter().min().copied().unwrap() as f64;
    let a_over_j = cfg.axis_accel_max_mm_s2.iter().max().copied().unwrap() as f64
        / cfg.jerk_max_mm_s3 as f64
        / ts;
    let jerk = (8.0 + a_over_j + 1.0) * q / (ts * ts * ts) / cfg.jerk_max_mm_s3 as f64;
    (acc + 1e-9, jerk + 1e-6)
}

fn assert_physical(name: &str, p: &Peaks, cfg: &MotionConfig) {
    let (acc_tol, jerk_tol) = tolerances(cfg);
    assert!(
        p.axis_vel <= 1.0 + 1e-9,
        "{name}: axis velocity {}",
        p.axis_vel
    );
    assert!(
        p.axis_acc <= 1.0 + acc_tol,
        "{name}: axis acceleration {}",
        p.axis_acc
    );
    assert!(
        p.tang_acc <= 1.0 + 1e-6,
        "{name}: tangential acceleration {}",
        p.tang_acc
    );
    assert!(
        p.tang_jerk <= 1.0 + 1e-6,
        "{name}: tangential jerk {}",
        p.tang_jerk
    );
    assert!(
        p.s_jerk <= 1.0 + jerk_tol,
        "{name}: jerk from the arc length {}",
        p.s_jerk
    );
}

/// How far a commanded position may lie from the polyline, mm: on it
/// (rounding), or within the chord tolerance with smoothing.
fn off_path(cfg: &MotionConfig) -> f64 {
    if cfg.smoothing().unwrap_or(1) > 1 {
        cfg.chord_tolerance_mm.to_num::<f64>() + 1e-6
    } else {
        1e-6
    }
}

/// Without smoothing, and with the default (over two ticks).
fn with_and_without_smoothing() -> [MotionConfig; 2] {
    [1, 0].map(|smoothing_ticks| MotionConfig {
        smoothing_ticks,
        ..MotionConfig::default()
    })
}

/// Every commanded position lies on the polyline (within `tol` mm), and
/// they advance along it.
fn assert_on_path(name: &str, ticks: &[T], poly: &[[f64; 3]], tol: f64) {
    let mut seg = 0;
    for (n, t) in ticks.iter().enumerate() {
        let dist = |i: usize| segment_distance(poly[i], poly[(i + 1).min(poly.len() - 1)], t.pos);
        let mut best = dist(seg);
        let mut k = seg;
        while best > tol && k + 1 < poly.len() {
            k += 1;
            let d = dist(k);
            if d <= tol {
                seg = k;
                best = d;
            }
        }
        assert!(
            best <= tol,
            "{name}: tick {n} at {:?} is {best} mm off the path",
            t.pos
        );
    }
    for w in ticks.windows(2) {
        assert!(w[1].s >= w[0].s, "{name}: the tool moved backwards");
    }
}

/// The planned ceilings and caps of the whole path (a buffer holding it all).
fn whole_plan(points: &[MotionPoint], cfg: MotionConfig) -> (Vec<PlannedPoint>, f64) {
    // A 0.9 MB planner, built on the stack before it is boxed: copies of it
    // exceed a test thread's 2 MB in an unoptimised build.
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .stack_size(16 << 20)
            .spawn_scoped(s, || {
                let mut all: Box<Motion<16384>> = Box::new(Motion::new(cfg).unwrap());
                for p in points {
                    all.push(*p).unwrap();
                }
                all.end_path();
                (all.planned().collect(), all.accel_limit_mm_s2().to_num())
            })
            .unwrap()
            .join()
            .unwrap()
    })
}

struct Figures {
    time_s: f64,
    ref_s: f64,
    peaks: Peaks,
    over_ceiling_mm_min: f64,
    chord_um: f64,
}

fn run(points: &[MotionPoint], cfg: MotionConfig) -> Figures {
    let (planned, accel) = whole_plan(points, cfg);
    let to_s = |f: FeedMmPerMin| f.to_f64() / 60.0;
    let nodes: Vec<(f64, f64, f64)> = planned
        .iter()
        .map(|p| (p.s_mm.to_num(), to_s(p.ceiling), to_s(p.cap)))
        .collect();
    let ref_s = reference::time_optimal_s(&nodes, accel, 0.002);
    let ticks = drive(points, cfg, |_, _| {});
    // Speed passing each point (interpolated between ticks) vs its ceiling.
    let mut over: f64 = f64::MIN;
    let mut k = 0;
    for p in planned.iter().skip(1).take(planned.len().saturating_sub(2)) {
        let s: f64 = p.s_mm.to_num();
        while k + 1 < ticks.len() && ticks[k + 1].s < s {
            k += 1;
        }
        if k + 1 < ticks.len() {
            let (s0, s1) = (ticks[k].s, ticks[k + 1].s);
            let f = if s1 > s0 {
                ((s - s0) / (s1 - s0)).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let v = ticks[k].v + f * (ticks[k + 1].v - ticks[k].v);
            over = over.max((v - to_s(p.ceiling)) * 60.0);
        }
    }
    // Chord deviation: the straight move between two ticks vs the vertices
    // it cuts. (Averaged positions trail the arc length by half the
    // window: a vertex is measured against the nearest of the moves
    // from the one the arc length crosses it in to `n` ticks later.)
    let lag = cfg.smoothing().unwrap() as usize - 1;
    let mut chord: f64 = 0.0;
    let mut j = 0;
    for (k, w) in ticks.windows(2).enumerate() {
        while j < planned.len() && planned[j].s_mm.to_num::<f64>() <= w[0].s {
            j += 1;
        }
        let mut i = j;
        while i < planned.len() && planned[i].s_mm.to_num::<f64>() < w[1].s {
            let p = planned[i].pos.to_f64();
            let d = (k..=(k + lag).min(ticks.len() - 2))
                .map(|m| segment_distance(ticks[m].pos, ticks[m + 1].pos, p))
                .fold(f64::INFINITY, f64::min);
            chord = chord.max(d);
            i += 1;
        }
    }
    Figures {
        time_s: ticks.len() as f64 * ts(&cfg),
        ref_s,
        peaks: peaks(&ticks, &cfg, accel),
        over_ceiling_mm_min: over,
        chord_um: chord * 1000.0,
    }
}

/// Distance from `p` to the segment from `a` to `b`, mm.
fn segment_distance(a: [f64; 3], b: [f64; 3], p: [f64; 3]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let l2 = ab.iter().map(|x| x * x).sum::<f64>();
    let t = if l2 > 0.0 {
        (ap.iter().zip(&ab).map(|(x, y)| x * y).sum::<f64>() / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (0..3)
        .map(|q| (ap[q] - t * ab[q]).powi(2))
        .sum::<f64>()
        .sqrt()
}

fn report(name: &str, f: &Figures) {
    let p = &f.peaks;
    eprintln!(
        "planner {name:36}: time {:7.3} s, time-optimal (accel-limited) {:7.3} s, ratio {:.3} | per-axis v/V {:.3} a/A {:.3} | tangential a/A {:.3} jerk/J {:.3} (Δ³s {:.3}) | max(v − ceiling) {:+.2} mm/min | chord {:.3} µm",
        f.time_s,
        f.ref_s,
        f.time_s / f.ref_s,
        p.axis_vel,
        p.axis_acc,
        p.tang_acc,
        p.tang_jerk,
        p.s_jerk,
        f.over_ceiling_mm_min,
        f.chord_um
    );
}

fn assert_within_limits(name: &str, f: &Figures, cfg: &MotionConfig) {
    report(name, f);
    assert_physical(name, &f.peaks, cfg);
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
fn real_gcode_within_limits() {
    // Toolpaths of the shared G-code programs as host-sim reads them
    // (tests/data/gcode/README.md), at their programmed feeds (rapids
    // capped by the planner's maximum feed) and with the fuzzy schedule.
    let cfg = MotionConfig::default();
    for file in ["freecad_profile", "linuxcnc_butterfly_g52"] {
        let pts = csv(&format!("gcode/{file}.csv"));
        let f = run(&programmed(&pts, 5000.0), cfg);
        assert_within_limits(&format!("{file}, programmed F"), &f, &cfg);
        assert!(f.time_s / f.ref_s <= 1.15, "{file}: {}", f.time_s / f.ref_s);
        let xyz: Vec<[f64; 3]> = pts.iter().map(|p| p.0).collect();
        let f = run(&scheduled(&xyz, 5000), cfg);
        assert_within_limits(&format!("{file}, fuzzy"), &f, &cfg);
        assert!(f.time_s / f.ref_s <= 1.15, "{file}: {}", f.time_s / f.ref_s);
    }
}

#[test]
fn dense_curves_run_at_the_corner_share_of_the_acceleration() {
    // Circles sampled far finer than a tick of travel: the corner limit
    // weighs each vertex by the second difference's hat function, so the
    // tool runs near what the per-axis box leaves for the turn,
    // v²κ·|n_a| <= A_a − ρ·A·|t_a| on every axis (normal n, tangent t), not
    // a fraction of it, and no axis exceeds its limit.
    // Without smoothing (the window's corner test is another).
    let cfg = MotionConfig {
        smoothing_ticks: 1,
        ..MotionConfig::default()
    };
    for (r, h) in [(2.0f64, 0.005f64), (5.0, 0.02), (20.0, 0.05)] {
        let n = (2.0 * std::f64::consts::PI * r / h) as usize;
        let pts: Vec<[f64; 3]> = (0..=n)
            .map(|i| {
                let a = i as f64 * h / r;
                [r * a.cos(), r * a.sin(), 0.0]
            })
            .collect();
        let points = constant(&pts, 20_000);
        let (plan, accel) = whole_plan(&points, cfg);
        let mid = &plan[plan.len() / 2];
        let ceiling = mid.ceiling.to_f64();
        let [x, y, _] = mid.pos.to_f64();
        let (n, t) = ([x / r, y / r], [-y / r, x / r]);
        let (a, rho) = (2000.0, cfg.tangential_share.to_num::<f64>());
        let centripetal = (0..2)
            .map(|k| ((a - rho * a * t[k].abs()) * r / n[k].abs()).sqrt() * 60.0)
            .fold(f64::INFINITY, f64::min); // mm/min
        let expect = centripetal.min(cfg.feed_max.to_f64());
        eprintln!("circle r {r} mm, chords {h} mm: ceiling {ceiling:.0} mm/min, per-axis box {centripetal:.0}");
        assert!(
            ceiling >= 0.93 * expect && ceiling <= expect + 1.0,
            "r {r}: {ceiling}"
        );
        let ticks = drive(&points, cfg, |_, _| {});
        let p = peaks(&ticks, &cfg, accel);
        assert_physical("dense circle", &p, &cfg);
        assert_on_path("dense circle", &ticks, &pts, 1e-6);
    }
}

/// `tests/data/short_segments.ngc`: its `G1` moves as a polyline from the
/// origin.
fn short_segments() -> Vec<[f64; 3]> {
    let mut p = [0.0; 3];
    let mut out = vec![p];
    for l in data("short_segments.ngc").lines() {
        if !l.starts_with("G1 X") {
            continue;
        }
        for w in l.split_whitespace() {
            let (c, v) = w.split_at(1);
            let k = match c {
                "X" => 0,
                "Y" => 1,
                "Z" => 2,
                _ => continue,
            };
            p[k] = v.parse().unwrap();
        }
        out.push(p);
    }
    out
}

/// The time-optimal traversal under the machine's true limits (per-axis
/// box, no jerk limit, corners blended within the chord tolerance): a
/// lower bound for any planner within the same limits.
fn optimum(points: &[MotionPoint], cfg: &MotionConfig) -> topp::TimeOptimal {
    let pts: Vec<topp::Point> = points
        .iter()
        .map(|p| topp::Point {
            pos: p.pos.to_f64(),
            feed_mm_s: p.feed.to_f64() / 60.0,
        })
        .collect();
    let lim = topp::Limits {
        tick_s: ts(cfg),
        feed_max_mm_s: cfg.feed_max.to_f64() / 60.0,
        axis_speed_mm_s: cfg.axis_speed_max.map(|v| v.to_f64() / 60.0),
        axis_accel_mm_s2: cfg.axis_accel_max_mm_s2.map(|a| a as f64),
        chord_mm: cfg.chord_tolerance_mm.to_num(),
        path_mm: cfg.chord_tolerance_mm.to_num(),
    };
    topp::time_optimal(&pts, &lim, 0.002)
}

#[test]
fn cycle_time_against_the_time_optimum_under_the_true_limits() {
    // The paths of the planner's figures (README "Velocity planner"), at
    // 5000 mm/min and with the fuzzy feeds as ceilings. The optimum is a
    // lower bound: no run within the limits may beat it by more than its
    // discretisation error.
    let cfg = MotionConfig::default();
    let gcode = csv("gcode/freecad_profile.csv");
    let freecad: Vec<[f64; 3]> = gcode.iter().map(|p| p.0).collect();
    let mut paths: Vec<(String, Vec<MotionPoint>)> = Vec::new();
    for name in ["infinity", "trident", "butterfly"] {
        let xyz = shape(name);
        paths.push((format!("{name}, F 5000"), constant(&xyz, 5000)));
        paths.push((format!("{name}, fuzzy"), scheduled(&xyz, 5000)));
    }
    let short = short_segments();
    paths.push(("short_segments.ngc, F 5000".into(), constant(&short, 5000)));
    paths.push(("short_segments.ngc, fuzzy".into(), scheduled(&short, 5000)));
    paths.push((
        "freecad_profile, programmed F".into(),
        programmed(&gcode, 5000.0),
    ));
    paths.push(("freecad_profile, fuzzy".into(), scheduled(&freecad, 5000)));
    let linuxcnc = csv("gcode/linuxcnc_butterfly_g52.csv");
    let linuxcnc_xyz: Vec<[f64; 3]> = linuxcnc.iter().map(|p| p.0).collect();
    paths.push((
        "linuxcnc_butterfly_g52, programmed F".into(),
        programmed(&linuxcnc, 5000.0),
    ));
    paths.push((
        "linuxcnc_butterfly_g52, fuzzy".into(),
        scheduled(&linuxcnc_xyz, 5000),
    ));
    for (name, points) in &paths {
        let o = optimum(points, &cfg);
        let time = |cfg: MotionConfig| drive(points, cfg, |_, _| {}).len() as f64 * ts(&cfg);
        let t = time(cfg);
        let plain = time(MotionConfig {
            smoothing_ticks: 1,
            ..cfg
        });
        eprintln!(
            "{name:32}: planner (defaults, smoothing {}) {t:7.3} s, time-optimal {:7.3} s (±{:.4}), ratio {:.3}; without smoothing {plain:7.3} s, ratio {:.3}",
            cfg.smoothing().unwrap(),
            o.time_half_step_s,
            o.discretisation_s(),
            t / o.time_half_step_s,
            plain / o.time_half_step_s
        );
        assert!(
            o.discretisation_s() <= 0.01 * o.time_half_step_s,
            "{name}: reference not converged"
        );
        for t in [t, plain] {
            assert!(
                t >= o.time_half_step_s - o.discretisation_s(),
                "{name}: {t} s beats the time-optimum {} s",
                o.time_half_step_s
            );
        }
    }
}

#[test]
fn path_tolerances_against_grbl() {
    // Grbl 1.1's figures of the planner issue at 5000 mm/min: junction
    // deviation 0.0002 mm (held near A) butterfly 6.09 s, short segments
    // 12.9 s; 0.01 mm (its default) 4.81 s and 7.18 s. Here at the path
    // tolerances 0.001 and 0.01 mm (G64 P) with the default smoothing for
    // each, every limit held, the deviation within the tolerance.
    let short = short_segments();
    let butterfly = shape("butterfly");
    for (name, xyz) in [("butterfly", &butterfly), ("short_segments.ngc", &short)] {
        let points = constant(xyz, 5000);
        for tol in [0.001, 0.01] {
            let cfg = MotionConfig {
                chord_tolerance_mm: fixed::types::I32F32::from_num(tol),
                ..MotionConfig::default()
            };
            let o = optimum(&points, &cfg);
            let f = run(&points, cfg);
            let name = format!(
                "{name}, F 5000, P {tol}, smoothing {}",
                cfg.smoothing().unwrap()
            );
            report(&name, &f);
            eprintln!(
                "{name}: {:.3} s, time-optimal {:.3} s, ratio {:.3}",
                f.time_s,
                o.time_half_step_s,
                f.time_s / o.time_half_step_s
            );
            assert_within_limits(&name, &f, &cfg);
            let ticks = drive(&points, cfg, |_, _| {});
            assert_on_path(&name, &ticks, xyz, tol + 1e-6);
        }
    }
}

#[test]
fn smoothing_blends_corners_within_the_limits_and_the_tolerance() {
    // The figures' paths with the positions averaged over 2 to 4 ticks:
    // every limit holds on the commanded (averaged) positions, each lies
    // within the chord tolerance of the polyline, and so does every vertex
    // of the straight move between two ticks (the tolerance split between
    // the blend and the chord of a tick). Faster than without smoothing
    // where corners bind.
    let gcode = csv("gcode/freecad_profile.csv");
    let mut paths: Vec<(String, Vec<[f64; 3]>, Vec<MotionPoint>)> = Vec::new();
    for name in ["infinity", "trident", "butterfly"] {
        let xyz = shape(name);
        paths.push((format!("{name}, fuzzy"), xyz.clone(), scheduled(&xyz, 5000)));
        paths.push((format!("{name}, F 5000"), xyz.clone(), constant(&xyz, 5000)));
    }
    let short = short_segments();
    paths.push((
        "short_segments.ngc, F 5000".into(),
        short.clone(),
        constant(&short, 5000),
    ));
    let freecad: Vec<[f64; 3]> = gcode.iter().map(|p| p.0).collect();
    paths.push((
        "freecad_profile, programmed F".into(),
        freecad,
        programmed(&gcode, 5000.0),
    ));
    let plain = MotionConfig {
        smoothing_ticks: 1,
        ..MotionConfig::default()
    };
    let tol_mm = plain.chord_tolerance_mm.to_num::<f64>();
    // Three and four ticks fit the tolerance only at shorter ticks
    // (`ConfigError::Smoothing`).
    for (n, tick_us) in [(2u8, 1000), (3, 500), (4, 250)] {
        let cfg = MotionConfig {
            smoothing_ticks: n,
            tick_us,
            ..plain
        };
        for (name, xyz, points) in &paths {
            let name = format!("{name}, smoothing {n}");
            let f = run(points, cfg);
            report(&name, &f);
            assert_physical(&name, &f.peaks, &cfg);
            assert!(
                f.chord_um <= tol_mm * 1000.0 + 1e-6,
                "{name}: chord {} µm",
                f.chord_um
            );
            let ticks = drive(points, cfg, |_, _| {});
            assert_on_path(&name, &ticks, xyz, tol_mm + 1e-6);
        }
    }
    let butterfly = constant(&shape("butterfly"), 5000);
    let t = |cfg| drive(&butterfly, cfg, |_, _| {}).len();
    assert!(
        t(MotionConfig {
            smoothing_ticks: 2,
            ..plain
        }) < t(plain),
        "smoothing does not pay on the butterfly"
    );
}

#[test]
fn a_larger_jerk_limit_settles_and_is_not_slower_beyond_rounding() {
    // FreeCAD profile at its programmed feeds. A larger jerk limit may not
    // lengthen the cycle by more than 0.2 % (strictly monotone is not met:
    // the executor's search of a tick's acceleration is a bisection, whose
    // rounding differs from one limit to the next), and the F400 lines
    // settle at their feed: speed steps of more than 1 % of it that reverse
    // sign from one tick to the next (chatter) stay rare at every limit.
    let pts = csv("gcode/freecad_profile.csv");
    let points = programmed(&pts, 5000.0);
    let mut last = f64::INFINITY;
    for j in [50_000u32, 1_000_000, 10_000_000] {
        let cfg = MotionConfig {
            jerk_max_mm_s3: j,
            ..MotionConfig::default()
        };
        let ticks = drive(&points, cfg, |_, _| {});
        let t = ticks.len() as f64 * ts(&cfg);
        let p = peaks(
            &ticks,
            &cfg,
            MotionConfig::default().axis_accel_max_mm_s2[0] as f64,
        );
        let dv: Vec<f64> = ticks
            .windows(2)
            .filter(|w| (w[0].v * 60.0 - 400.0).abs() < 60.0)
            .map(|w| (w[1].v - w[0].v) * 60.0)
            .collect();
        let flips = dv
            .windows(2)
            .filter(|d| d[0] * d[1] < 0.0 && d[0].abs() > 4.0 && d[1].abs() > 4.0)
            .count();
        eprintln!(
            "freecad_profile, J {j}: {t:.3} s, {flips} reversals of {} ticks near F400, {p:?}",
            dv.len()
        );
        assert_physical(&format!("J {j}"), &p, &cfg);
        assert!(t <= last * 1.002, "J {j}: {t} s after {last} s");
        last = last.min(t);
        assert!(flips < 20, "J {j}: {flips} speed reversals near 400 mm/min");
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
    // 0.02-0.2 mm segments wandering in 3-D: jerk-limited transitions
    // dominate at the low corner speeds, so the acceleration-only reference
    // is far off here; reported, not asserted.
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
fn a_short_segment_between_sharp_corners_runs_at_two_fifths_of_its_length_per_tick() {
    // Zig-zags of 0.15 mm (shorter than the corner reach, 0.21 mm at
    // 5000 mm/min and 1 kHz) turning by 120° at every point: the corners'
    // own ceilings are far below the 0.06 mm/tick (3600 mm/min) that 2/5
    // of a segment's length allows. Each segment's cap is at least that
    // and at most what its ends allow when it is above it, and the motion
    // keeps every limit.
    // Without smoothing (the window's corner test is another).
    let cfg = MotionConfig {
        smoothing_ticks: 1,
        ..MotionConfig::default()
    };
    let len = 0.15;
    let mut pts = vec![[0.0, 0.0, 0.0]];
    for k in 0..200 {
        let a: f64 = if k % 2 == 0 { 0.0 } else { 120f64.to_radians() };
        let p = *pts.last().unwrap();
        pts.push([p[0] + len * a.cos(), p[1] + len * a.sin(), 0.0]);
    }
    let points = constant(&pts, 5000);
    let (planned, _) = whole_plan(&points, cfg);
    let per_tick = |f: FeedMmPerMin| f.to_f64() / 60.0 * ts(&cfg);
    let floor = 0.4 * len;
    let mut checked = 0;
    for w in planned
        .windows(2)
        .skip(1)
        .take(planned.len().saturating_sub(3))
    {
        let (cap, ends) = (
            per_tick(w[0].cap),
            per_tick(w[0].ceiling).min(per_tick(w[1].ceiling)),
        );
        assert!(ends < floor, "the corners do not bind: {ends} mm/tick");
        assert!(
            cap >= floor * (1.0 - 1e-6) && cap <= floor * (1.0 + 1e-6),
            "segment at {}: cap {cap} mm/tick, 2/5 of its length {floor}",
            w[0].index
        );
        checked += 1;
    }
    assert!(checked > 150);
    let f = run(&points, cfg);
    assert_within_limits("zig-zag of 0.15 mm, 120° corners", &f, &cfg);
}

#[test]
fn short_straight_segments_hold_the_programmed_feed() {
    // Grbl on an 8-bit MCU takes 26 % longer on 0.2 mm than on 0.3 mm
    // segments at 5000 mm/min; here 0.05 mm segments run at full feed with
    // a 256-point buffer (the firmware's buffer size is checked in its own
    // tests).
    let cfg = MotionConfig::default();
    for seg in [0.3, 0.2, 0.1, 0.05] {
        let n = (100.0 / seg) as usize;
        let pts: Vec<[f64; 3]> = (0..=n).map(|i| [i as f64 * seg, 0.0, 0.0]).collect();
        let f = run(&constant(&pts, 5000), cfg);
        assert_within_limits(&format!("straight line, {seg} mm segments"), &f, &cfg);
        // Accelerate at 1000 mm/s² (jerk-limited), cruise, brake.
        let v = 5000.0 / 60.0;
        let cruise = 100.0 / v + v / 1000.0 + 1000.0 / cfg.jerk_max_mm_s3 as f64;
        assert!(
            f.time_s <= cruise * 1.01,
            "{seg} mm: {} s vs {cruise} s",
            f.time_s
        );
    }
}

#[test]
fn feed_hold_stops_on_the_path_and_resumes() {
    for cfg in with_and_without_smoothing() {
        feed_hold_stops_and_resumes(cfg);
    }
}

fn feed_hold_stops_and_resumes(cfg: MotionConfig) {
    let xyz = shape("trident");
    let points = scheduled(&xyz, 5000);
    let (_, accel) = whole_plan(&points, cfg);
    let mut held_at = None;
    let ticks = drive(&points, cfg, |n, m| match n {
        700 => m.set_hold(true),
        1400 => m.set_hold(false),
        _ => {}
    });
    for (n, t) in ticks.iter().enumerate().take(1400).skip(700) {
        if t.state == MotionState::Holding && t.v == 0.0 && held_at.is_none() {
            held_at = Some(n);
        }
    }
    let held_at = held_at.expect("came to rest while held");
    // At rest until the resume, then on to the end.
    assert!(ticks[held_at..1400]
        .iter()
        .all(|t| t.v == 0.0 && t.s == ticks[held_at].s));
    assert_eq!(ticks.last().unwrap().state, MotionState::Done);
    let p = peaks(&ticks, &cfg, accel);
    eprintln!(
        "feed hold: at rest {} ticks after the hold, {p:?}",
        held_at - 700
    );
    assert_physical("feed hold", &p, &cfg);
    assert_on_path("feed hold", &ticks, &xyz, off_path(&cfg));
}

#[test]
fn underrun_ends_in_a_controlled_stop_and_resumes_without_a_jump() {
    for cfg in with_and_without_smoothing() {
        underrun_stops_and_resumes(cfg);
    }
}

fn underrun_stops_and_resumes(cfg: MotionConfig) {
    // Points arrive slower than the tool moves: one 0.5 mm segment every
    // 12 ticks at 5000 mm/min (83 mm/s wants one every 6 ticks).
    let xyz: Vec<[f64; 3]> = (0..=200).map(|i| [i as f64 * 0.5, 0.0, 0.0]).collect();
    let points = constant(&xyz, 5000);
    let ts = ts(&cfg);
    let mut m: Motion<64> = Motion::new(cfg).unwrap();
    let mut ticks = Vec::new();
    for (i, p) in points.iter().enumerate() {
        m.push(*p).unwrap();
        let gap = if (60..80).contains(&i) { 200 } else { 12 };
        for _ in 0..gap {
            record(&mut m, ts, &mut ticks);
        }
    }
    m.end_path();
    while record(&mut m, ts, &mut ticks) != MotionState::Done {}
    let starved = ticks
        .iter()
        .filter(|t| t.state == MotionState::Starved)
        .count();
    assert!(starved > 0, "the gap starves the buffer");
    let accel: f64 = m.accel_limit_mm_s2().to_num();
    let p = peaks(&ticks, &cfg, accel);
    eprintln!("underrun: {starved} ticks starved, {p:?}");
    assert_physical("underrun", &p, &cfg);
    assert_on_path("underrun", &ticks, &xyz, off_path(&cfg));
    assert_eq!(ticks.last().unwrap().point, 200);
}

#[test]
fn override_changes_are_ramped_within_the_physical_limits() {
    for cfg in with_and_without_smoothing() {
        override_ramps_within_the_limits(cfg);
    }
}

fn override_ramps_within_the_limits(cfg: MotionConfig) {
    let xyz = shape("butterfly");
    let points = scheduled(&xyz, 5000);
    let (_, accel) = whole_plan(&points, cfg);
    let plain = drive(&points, cfg, |_, _| {}).len();
    let ticks = drive(&points, cfg, |n, m| match n {
        1000 => m.set_override(40),
        3000 => m.set_override(150),
        6000 => m.set_override(200),
        _ => {}
    });
    let p = peaks(&ticks, &cfg, accel);
    eprintln!(
        "override 100/40/150/200 %: {} ticks (100 %: {plain}), {p:?}",
        ticks.len()
    );
    assert_physical("override", &p, &cfg);
    assert_on_path("override", &ticks, &xyz, off_path(&cfg));
    // Once the ramp to 40 % is over, the tool runs at no more than 40 % of
    // the maximum feed until the override is raised again.
    let slow = ticks[1500..3000].iter().map(|t| t.v).fold(0.0, f64::max) * 60.0;
    assert!(
        slow <= 0.4 * cfg.feed_max.to_f64() + 0.5,
        "{slow} mm/min at 40 %"
    );
    // Never above 200 % of the fastest scheduled feed, nor the maximum feed.
    let vmax = ticks.iter().map(|t| t.v).fold(0.0, f64::max) * 60.0;
    assert!(vmax <= cfg.feed_max.to_f64() + 0.5, "{vmax} mm/min");
}

#[test]
fn restart_continues_from_where_the_tool_is() {
    // Without and with smoothing (the mean must have caught up before a
    // restart is taken, and the next path starts from it).
    for cfg in with_and_without_smoothing() {
        restart_from_where_the_tool_is(cfg);
    }
}

fn restart_from_where_the_tool_is(cfg: MotionConfig) {
    let ts = ts(&cfg);
    let off_path = off_path(&cfg);
    let mut m: Motion<32> = Motion::new(cfg).unwrap();
    let mut ticks = Vec::new();
    let first = constant(&[[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]], 3000);
    for p in &first {
        m.push(*p).unwrap();
    }
    m.end_path();
    // Not while moving.
    record(&mut m, ts, &mut ticks);
    record(&mut m, ts, &mut ticks);
    assert_eq!(m.restart(), Err(MotionError::Moving));
    assert_eq!(m.push(first[0]), Err(MotionError::PathEnded));
    while record(&mut m, ts, &mut ticks) != MotionState::Done {}
    let split = ticks.len();
    m.restart().unwrap();
    // The second path's points start elsewhere: the tool goes there along
    // a straight move from (10, 0, 0), never jumping.
    let second = constant(&[[10.0, 5.0, 0.0], [0.0, 5.0, 0.0]], 3000);
    for p in &second {
        m.push(*p).unwrap();
    }
    m.end_path();
    while record(&mut m, ts, &mut ticks) != MotionState::Done {}
    let last = ticks.last().unwrap();
    assert_eq!(last.pos, [0.0, 5.0, 0.0]);
    assert_eq!(last.point, 2); // the anchor is point 0 of the second path
                               // Arc length restarts at 0 with the new path: check each path alone.
    let accel = m.accel_limit_mm_s2().to_num();
    assert_physical("restart 1", &peaks(&ticks[..split], &cfg, accel), &cfg);
    assert_physical("restart 2", &peaks(&ticks[split..], &cfg, accel), &cfg);
    assert_on_path(
        "restart 1",
        &ticks[..split],
        &[[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]],
        off_path,
    );
    let poly = [[10.0, 0.0, 0.0], [10.0, 5.0, 0.0], [0.0, 5.0, 0.0]];
    assert_on_path("restart 2", &ticks[split..], &poly, off_path);
    assert_eq!(ticks[split - 1].pos, [10.0, 0.0, 0.0], "at rest on the end");
}

#[test]
fn bad_input_is_refused_and_nothing_accepted_is_lost() {
    let cfg = MotionConfig::default();
    let mut m: Motion<9> = Motion::new(cfg).unwrap();
    let ok = |x: f64| MotionPoint {
        pos: Point3Mm::from_f64(x, 0.0, 0.0).unwrap(),
        feed: FeedMmPerMin::from_int(1000),
        curvature: CurvaturePerMm::ZERO,
    };
    m.push(ok(0.0)).unwrap();
    m.push(ok(1.0)).unwrap();
    let far = Point3Mm::from_bits(i64::MAX, 0, 0);
    assert_eq!(
        m.push(MotionPoint {
            pos: far,
            ..ok(0.0)
        }),
        Err(MotionError::BadPoint)
    );
    let neg = FeedMmPerMin(fixed::types::I32F32::from_num(-1));
    assert_eq!(
        m.push(MotionPoint {
            feed: neg,
            ..ok(2.0)
        }),
        Err(MotionError::BadPoint)
    );
    let bent = CurvaturePerMm(fixed::types::I32F32::from_num(-1));
    assert_eq!(
        m.push(MotionPoint {
            curvature: bent,
            ..ok(2.0)
        }),
        Err(MotionError::BadPoint)
    );
    // Duplicates are kept as points (their indices count).
    m.push(ok(1.0)).unwrap();
    m.push(ok(2.0)).unwrap();
    for x in 3..8 {
        m.push(ok(x as f64)).unwrap();
    }
    assert_eq!(m.push(ok(9.0)), Err(MotionError::Full));
    m.end_path();
    let mut last = None;
    for _ in 0..100_000 {
        let t = m.tick();
        last = Some(t);
        if t.state == MotionState::Done {
            break;
        }
    }
    let t = last.unwrap();
    assert_eq!(t.state, MotionState::Done);
    assert_eq!(t.pos, Point3Mm::from_f64(7.0, 0.0, 0.0).unwrap());
    assert_eq!(t.point, 8);
    // Configurations out of range are refused with a reason.
    let c = MotionConfig::default();
    assert_eq!(
        Motion::<8>::new(MotionConfig {
            jerk_max_mm_s3: 1,
            ..c
        })
        .err(),
        Some(ConfigError::Resolution)
    );
    assert_eq!(
        Motion::<8>::new(MotionConfig {
            tangential_share: Fx::ZERO,
            ..c
        })
        .err(),
        Some(ConfigError::Share)
    );
}

/// A random polyline: lengths 1 µm to 5 mm, turns up to ±180°, some
/// duplicates, in 3-D.
fn polyline() -> impl Strategy<Value = Vec<[f64; 3]>> {
    prop::collection::vec((0.001f64..5.0, -3.2f64..3.2, -0.5f64..0.5, 0u8..20), 2..60).prop_map(
        |steps| {
            let mut pts = vec![[0.0, 0.0, 0.0]];
            let mut h = 0.0f64;
            for (len, turn, dz, dup) in steps {
                let p = *pts.last().unwrap();
                if dup == 0 {
                    pts.push(p);
                    continue;
                }
                h += turn;
                pts.push([p[0] + len * h.cos(), p[1] + len * h.sin(), p[2] + dz * len]);
            }
            pts
        },
    )
}

fn config() -> impl Strategy<Value = MotionConfig> {
    (
        prop::sample::select(vec![250u32, 500, 1000, 2000]),
        500i32..20_000,
        100u32..5000,
        5_000u32..200_000,
        1u32..100,
        10i32..90,
        prop::sample::select(vec![0u8, 0, 1, 1, 2, 3, 4, 8]),
        prop::sample::select(vec![false, false, false, true]),
    )
        .prop_map(
            |(tick_us, feed, acc, jerk, chord_um, share, smoothing_ticks, exact_path)| {
                MotionConfig {
                    tick_us,
                    feed_max: FeedMmPerMin::from_int(feed),
                    axis_speed_max: [FeedMmPerMin::from_int(feed.max(1000) * 2); 3],
                    axis_accel_max_mm_s2: [acc, acc * 2, acc],
                    jerk_max_mm_s3: jerk,
                    chord_tolerance_mm: fixed::types::I32F32::from_num(chord_um as f64 * 1e-3),
                    tangential_share: Fx::from_num(share as f64 / 100.0),
                    smoothing_ticks,
                    exact_path,
                }
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Any path, any valid limits, holds toggled at random: the motion ends
    /// at the last point, stays on the path, and never exceeds a limit.
    #[test]
    fn any_path_within_limits(
        pts in polyline(),
        cfg in config(),
        feed in 100i32..30_000,
        holds in prop::collection::vec(0usize..20_000, 0..4),
    ) {
        let Ok(probe) = Motion::<8>::new(cfg) else {
            return Ok(()); // a refused configuration (resolution) is fine
        };
        let accel: f64 = probe.accel_limit_mm_s2().to_num();
        let points = constant(&pts, feed);
        let ticks = drive(&points, cfg, |n, m| {
            for (k, &h) in holds.iter().enumerate() {
                if n == h {
                    m.set_hold(k % 2 == 0);
                }
            }
            if n == 40_000 {
                m.set_hold(false);
            }
        });
        let p = peaks(&ticks, &cfg, accel);
        assert_physical("random", &p, &cfg);
        // Smoothing blends corners within the chord tolerance.
        assert_on_path("random", &ticks, &pts, off_path(&cfg));
        let end = pts.last().unwrap();
        let last = ticks.last().unwrap().pos;
        for k in 0..3 {
            prop_assert!((last[k] - end[k]).abs() < 1e-9);
        }
        prop_assert_eq!(ticks.last().unwrap().point as usize, pts.len() - 1);
    }
}

/// Found by the property test: the tool cruised on a segment's cap equal
/// to the next node's envelope and took a tick of full jerk across that
/// node; the speed's crossing of the envelope at the tick's start is no root
/// of the crossing quadratic, so the node was passed over its envelope (a
/// sharp corner, 1.11 × the axis acceleration).
#[test]
fn a_node_is_not_passed_faster_when_the_speed_starts_on_its_envelope() {
    let pts = vec![
        [0.0, 0.0, 0.0],
        [1.7869440214700834, 2.86234783491147, 0.022856266451491337],
        [-2.1800364698471695, 5.836848677469558, 0.8452949215723251],
        [-2.1800364698471695, 5.836848677469558, 0.8452949215723251],
        [-5.513575950011443, 7.699567373269328, -0.8269202779505735],
        [-5.512899674586872, 7.700304022134202, -0.8269202779505735],
        [-4.76681129447554, 6.909421850248927, -0.8269202779505735],
        [-3.956476742633813, 6.623522528997146, -0.7854809723502575],
        [-4.100134587165791, 6.153340539452908, -0.9988172690315257],
        [-4.101019144324749, 6.153806971262005, -0.9988172690315257],
        [-4.101412448011333, 6.152887562642229, -0.9984820542848387],
        [-4.102403441681457, 6.153021471364023, -0.9980098331723678],
        [-4.103085439768635, 6.153752825320112, -0.9980098331723678],
        [-0.26447556382902215, 8.217555079283, -2.4188965519564825],
        [-0.6159170308057369, 8.853215107724957, -2.5454883565824664],
        [2.0781260009059297, 7.6006730016475395, -1.484002701889094],
    ];
    let cfg = MotionConfig {
        tick_us: 2000,
        feed_max: FeedMmPerMin::from_int(10324),
        axis_speed_max: [FeedMmPerMin::from_int(20648); 3],
        axis_accel_max_mm_s2: [100, 200, 100],
        jerk_max_mm_s3: 67555,
        chord_tolerance_mm: fixed::types::I32F32::from_num(0.001),
        tangential_share: Fx::from_num(0.37),
        smoothing_ticks: 1,
        exact_path: false,
    };
    let probe = Motion::<8>::new(cfg).unwrap();
    let accel: f64 = probe.accel_limit_mm_s2().to_num();
    let ticks = drive(&constant(&pts, 807), cfg, |_, _| {});
    assert_physical("regression", &peaks(&ticks, &cfg, accel), &cfg);
}

/// The trade-off the fixed tangential share `ρ` makes (README, "Velocity
/// planner"): the corner limit gives each axis `A_a − ρ·min A·|t_a|` for
/// the turn, the executor `ρ·min A` along the path, and the default
/// smoothing window is the longest whose margins (`n·ρA` a step) fit the
/// tolerance. Cycle times at F 5000 for `ρ` from 0.2 to 0.8 at the path
/// tolerances 0.001 and 0.01 mm, every limit held. A measurement, not a
/// check of the defaults: `--ignored` to print it.
#[test]
#[ignore]
fn tangential_share_trade_off() {
    let short = short_segments();
    let mut paths: Vec<(&str, Vec<MotionPoint>)> = Vec::new();
    for name in ["infinity", "trident", "butterfly"] {
        paths.push((name, constant(&shape(name), 5000)));
    }
    paths.push(("short_segments.ngc", constant(&short, 5000)));
    for rho in [0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8] {
        for tol in [0.001, 0.01] {
            let cfg = MotionConfig {
                tangential_share: Fx::from_num(rho),
                chord_tolerance_mm: fixed::types::I32F32::from_num(tol),
                ..MotionConfig::default()
            };
            let accel: f64 = Motion::<8>::new(cfg).unwrap().accel_limit_mm_s2().to_num();
            let mut line = format!(
                "ρ {rho:.1}, P {tol}, smoothing {}:",
                cfg.smoothing().unwrap()
            );
            for (name, points) in &paths {
                let ticks = drive(points, cfg, |_, _| {});
                let p = peaks(&ticks, &cfg, accel);
                assert_physical(name, &p, &cfg);
                line += &format!(
                    " {name} {:.3} s (a/A {:.3});",
                    ticks.len() as f64 * ts(&cfg),
                    p.axis_acc
                );
            }
            eprintln!("{line}");
        }
    }
}
