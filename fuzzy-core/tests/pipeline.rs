//! The streaming scheduler: against the f64 pipeline, and its invariants
//! (property tests).

use fuzzy_core::lin2021::{Lin2021Controller, CONTROLLER, SYSTEM};
use fuzzy_core::reference;
use fuzzy_core::scheduler::{
    PathPoint, ScheduledPoint, Scheduler, SchedulerConfig, SchedulerError,
};
use fuzzy_core::units::{FeedMmPerMin, Point3Mm, COORD_LIMIT_MM};
use proptest::prelude::*;

const WS: usize = 30;
const AVG: usize = 9;
type Sched = Scheduler<&'static Lin2021Controller, WS, AVG, 40>;

fn config() -> SchedulerConfig {
    SchedulerConfig::new(FeedMmPerMin::from_int(3000), FeedMmPerMin::from_int(150))
}

fn run(points: &[PathPoint]) -> Vec<ScheduledPoint> {
    let mut s = Sched::new(&CONTROLLER, config()).unwrap();
    let mut out = Vec::new();
    s.run(points.iter().copied(), |p| out.push(p)).unwrap();
    out
}

fn pts(xy: impl IntoIterator<Item = (f64, f64)>) -> Vec<PathPoint> {
    xy.into_iter()
        .map(|(x, y)| PathPoint::at(Point3Mm::from_f64(x, y, 0.0).unwrap()))
        .collect()
}

/// Test paths: a lemniscate (∞), circles of several radii, a spiral, a
/// polyline with corners of 30-170°, a zigzag of short segments.
fn paths() -> Vec<(&'static str, Vec<PathPoint>)> {
    let n = 2000;
    let lemniscate = pts((0..n).map(|i| {
        let t = i as f64 / n as f64 * std::f64::consts::TAU;
        let d = 1.0 + t.sin().powi(2);
        (50.0 * t.cos() / d, 50.0 * t.sin() * t.cos() / d)
    }));
    let circles = pts((0..n).map(|i| {
        let r = [1.0, 5.0, 20.0, 0.5][i * 4 / n];
        let a = i as f64 * 0.05;
        (r * a.cos() + (i * 4 / n) as f64 * 60.0, r * a.sin())
    }));
    let spiral = pts((0..n).map(|i| {
        let a = i as f64 * 0.02;
        let r = 0.3 + a * 0.5;
        (r * a.cos(), r * a.sin())
    }));
    let mut corners = Vec::new();
    let (mut x, mut y, mut h) = (0.0f64, 0.0f64, 0.0f64);
    for (k, turn) in [30.0f64, 60.0, 90.0, 120.0, 150.0, 170.0, -90.0, -45.0]
        .iter()
        .enumerate()
    {
        for _ in 0..(40 + 7 * k) {
            x += 0.25 * h.cos();
            y += 0.25 * h.sin();
            corners.push((x, y));
        }
        h += turn.to_radians();
    }
    let zigzag = pts((0..n).map(|i| (i as f64 * 0.05, if i % 2 == 0 { 0.0 } else { 0.02 })));
    vec![
        ("lemniscate", lemniscate),
        ("circles", circles),
        ("spiral", spiral),
        ("corners", pts(corners)),
        ("zigzag", zigzag),
    ]
}

#[test]
fn scheduled_feed_matches_the_f64_pipeline() {
    let cfg = config();
    let f_max = cfg.f_max.to_f64();
    let mut worst_all: f64 = 0.0;
    for (name, path) in paths() {
        let got = run(&path);
        let xyz: Vec<[f64; 3]> = path.iter().map(|p| p.pos.to_f64()).collect();
        let want = reference::schedule(&xyz, &[], &SYSTEM, &cfg, WS, AVG);
        assert_eq!(got.len(), want.len(), "{name}");
        let mut worst: f64 = 0.0;
        for (g, w) in got.iter().zip(&want) {
            let err = (g.feed.to_f64() - w.feed).abs() / f_max;
            worst = worst.max(err);
            let k = g.curvature.to_f64();
            assert!(
                (k - w.curvature).abs() <= 1e-6 * w.curvature.max(1.0) || w.curvature.is_infinite(),
                "{name}: κ {k} vs {}",
                w.curvature
            );
        }
        eprintln!(
            "pipeline {name}: max feed error vs f64 {:.5} % of F_max",
            worst * 100.0
        );
        worst_all = worst_all.max(worst);
    }
    assert!(worst_all <= 0.0025, "{worst_all}");
}

#[test]
fn runs_are_deterministic() {
    for (_, path) in paths() {
        assert_eq!(run(&path), run(&path));
    }
}

#[test]
fn slows_down_before_a_sharp_point_not_only_at_it() {
    // A straight run into a 160° turn: within WS points before the corner the
    // feed is already well below F_max while the corner's own curvature is
    // still zero at those points.
    let mut xy: Vec<(f64, f64)> = (0..200).map(|i| (i as f64 * 0.2, 0.0)).collect();
    let t = 160f64.to_radians();
    xy.extend((1..200).map(|i| {
        (
            199.0 * 0.2 + i as f64 * 0.2 * t.cos(),
            i as f64 * 0.2 * t.sin(),
        )
    }));
    let out = run(&pts(xy));
    let corner = 199;
    assert!(out[corner].curvature.to_f64() > 3.0);
    for back in 5..WS - 5 {
        let p = &out[corner - back];
        assert_eq!(p.curvature.to_f64(), 0.0);
        assert!(
            p.feed.to_f64() < 0.5 * 3000.0,
            "{back} points before: {:?}",
            p.feed
        );
    }
    // Far from it: full speed.
    assert_eq!(out[corner - WS - AVG].feed, FeedMmPerMin::from_int(3000));
}

/// An arbitrary point: near the origin, far away, or at the limits.
fn any_point() -> impl Strategy<Value = (i64, i64, i64)> {
    let lim = (COORD_LIMIT_MM as i64) << 32;
    let coord = prop_oneof![
        -(1i64 << 40)..(1i64 << 40),
        -lim..=lim,
        Just(lim),
        Just(-lim),
        Just(0i64),
    ];
    (coord.clone(), coord.clone(), coord)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn any_stream_is_scheduled_in_order_within_limits(
        raw in proptest::collection::vec((any_point(), 0u8..4, proptest::option::of(0i32..5000)), 0..150)
    ) {
        // Steps: a new point, or repeats of the previous (duplicates).
        let mut points: Vec<PathPoint> = Vec::new();
        for ((x, y, z), repeat, cap) in raw {
            let mut p = PathPoint { pos: Point3Mm::from_bits(x, y, z), feed_cap: cap.map(FeedMmPerMin::from_int), tag: points.len() as u32 };
            if repeat == 0 {
                if let Some(last) = points.last() {
                    p.pos = last.pos;
                }
            }
            points.push(p);
        }
        let mut s = Sched::new(&CONTROLLER, config()).unwrap();
        let mut out = Vec::new();
        s.run(points.iter().copied(), |p| out.push(p)).unwrap();
        // Duplicates merge into the previous point; everything else comes out
        // once, in order.
        let mut distinct: Vec<&PathPoint> = Vec::new();
        for p in &points {
            if distinct.last().is_none_or(|l| l.pos != p.pos) {
                distinct.push(p);
            }
        }
        prop_assert_eq!(out.len(), distinct.len());
        for (i, (o, p)) in out.iter().zip(&distinct).enumerate() {
            prop_assert_eq!(o.index as usize, i);
            prop_assert_eq!(&o.point, *p);
            let (f, lo, hi) = (o.feed, config().f_min, config().f_max);
            match p.feed_cap {
                Some(c) => prop_assert!(f <= c && (f >= lo || f == c)),
                None => prop_assert!(f >= lo && f <= hi),
            }
            prop_assert!(o.fuzzy_feed >= lo && o.fuzzy_feed <= hi);
            prop_assert!(o.curvature.0 >= 0 && o.variation >= o.curvature);
        }
        prop_assert_eq!(s.held(), 0);
    }

    #[test]
    fn refused_points_leave_no_trace(
        good in proptest::collection::vec((-1000i64..1000, -1000i64..1000), 2..60),
        at in 0usize..60,
        bad in prop_oneof![Just(i64::MAX), Just(i64::MIN), (((COORD_LIMIT_MM as i64) + 1) << 32)..i64::MAX],
    ) {
        let path: Vec<PathPoint> = good.iter().map(|&(x, y)| PathPoint::at(Point3Mm::from_bits(x << 28, y << 28, 0))).collect();
        let clean = run(&path);
        let mut s = Sched::new(&CONTROLLER, config()).unwrap();
        let mut out = Vec::new();
        for (i, p) in path.iter().enumerate() {
            if i == at.min(path.len() - 1) {
                let refused = s.push(PathPoint::at(Point3Mm::from_bits(bad, 0, 0)));
                prop_assert_eq!(refused, Err(SchedulerError::CoordinateOutOfRange));
                let capped = s.push(PathPoint { feed_cap: Some(FeedMmPerMin::from_int(-1)), ..*p });
                prop_assert_eq!(capped, Err(SchedulerError::FeedCapOutOfRange));
            }
            if let Some(o) = s.push(*p).unwrap() {
                out.push(o);
            }
        }
        s.finish();
        while let Some(o) = s.drain() {
            out.push(o);
        }
        prop_assert_eq!(out, clean);
    }
}
