//! The `fuzzy-planner` method: it runs on every machine, respects the
//! limits it is meant to respect at least as well as plain `fuzzy`, and the
//! plan host-sim records while streaming equals the plan of a buffer holding
//! the whole path. Run with `--nocapture` for the figures.

use fuzzy_core::planner::Motion;
use host_sim::config::SimConfig;
use host_sim::experiments::dat_phuc2024::fanuc::{FanucConfig, FanucMode};
use host_sim::machine::MachineConfig;
use host_sim::methods::{self, Method};
use host_sim::planner::{self, figures};
use host_sim::shapes::Shape;
use host_sim::simulate::{self, Prepared};

fn machines() -> Vec<(&'static str, SimConfig)> {
    let hi = SimConfig {
        machine: MachineConfig::Fanuc(FanucConfig {
            mode: FanucMode::HighAccuracy,
            ..Default::default()
        }),
        ..Default::default()
    };
    let servo = SimConfig {
        machine: MachineConfig::ServoXy(Default::default()),
        ..Default::default()
    };
    vec![
        ("fanuc-conventional", SimConfig::default()),
        ("fanuc-high-accuracy", hi),
        ("servo-xy", servo),
    ]
}

#[test]
fn planner_method_matches_or_beats_plain_fuzzy_on_the_limits_it_respects() {
    for (machine, config) in machines() {
        let a = config.planner.axis_accel_max_mm_per_s2.map(|a| a as f64);
        let at = config.planner.tangential_accel_mm_per_s2();
        for shape in Shape::ALL {
            let p = Prepared::new(shape.toolpath().unwrap());
            for f_max in [1500.0, 3000.0] {
                let fz = simulate::run(&p, Method::Fuzzy, f_max, &config).unwrap();
                let pl = simulate::run(&p, Method::FuzzyPlanner, f_max, &config).unwrap();
                let (m, n) = (&pl.metrics, &fz.metrics);
                eprintln!(
                    "{machine} {} {f_max}: fuzzy-planner vs fuzzy: time {:.3}/{:.3} s, max error {:.4}/{:.4} mm, acc X {:.0}/{:.0} Y {:.0}/{:.0}, acc tan {:.0}/{:.0} mm/s², jerk tan {:.0}/{:.0} mm/s³",
                    shape.name(),
                    m.cycle_time_s,
                    n.cycle_time_s,
                    m.contour_error_max_mm,
                    n.contour_error_max_mm,
                    m.peak_axis_acc_mm_per_s2[0],
                    n.peak_axis_acc_mm_per_s2[0],
                    m.peak_axis_acc_mm_per_s2[1],
                    n.peak_axis_acc_mm_per_s2[1],
                    m.peak_tangential_acc_mm_per_s2,
                    n.peak_tangential_acc_mm_per_s2,
                    m.peak_tangential_jerk_mm_per_s3,
                    n.peak_tangential_jerk_mm_per_s3
                );
                let ctx = format!("{machine} {} {f_max}", shape.name());
                // "Matches" allows 1 % (at 1500 mm/min on ∞ both are set by
                // the same curve, a few mm/s² apart). Not on the
                // high-accuracy machine: there plain `fuzzy` also passes the
                // control's acc/dec before interpolation (1660/1772/1783),
                // which the planner replaces (`planner::machine`), so the
                // planner runs closer to the fuzzy feeds, with higher peaks
                // but within its limits (checked below).
                let compared = machine != "fanuc-high-accuracy";
                for k in (0..2).filter(|_| compared) {
                    assert!(
                        m.peak_axis_acc_mm_per_s2[k] <= n.peak_axis_acc_mm_per_s2[k] * 1.01,
                        "{ctx}: axis {k} acceleration"
                    );
                }
                assert!(
                    !compared
                        || m.peak_tangential_acc_mm_per_s2
                            <= n.peak_tangential_acc_mm_per_s2 * 1.01,
                    "{ctx}: tangential acceleration"
                );
                assert!(
                    m.peak_tangential_jerk_mm_per_s3 <= n.peak_tangential_jerk_mm_per_s3,
                    "{ctx}: tangential jerk"
                );
                // The FANUC-like machine only filters the stream (a moving
                // average never raises a peak): the planner's limits hold on
                // the actual motion too. The servo adds its own dynamics.
                if machine != "servo-xy" {
                    for (peak, limit) in m.peak_axis_acc_mm_per_s2.iter().zip(a) {
                        assert!(*peak <= limit * (1.0 + 1e-6), "{ctx}: {peak} > {limit}");
                    }
                    assert!(m.peak_tangential_acc_mm_per_s2 <= at * 1.001, "{ctx}");
                }
                // Scheduled feeds are upper bounds (on the servo, whose
                // loop overshoots, of the commanded stream: the actual
                // motion only beats plain fuzzy's overshoot).
                let feed_bound = if machine == "servo-xy" {
                    n.peak_feed_mm_per_min
                } else {
                    f_max * 1.001
                };
                assert!(
                    m.peak_feed_mm_per_min <= feed_bound,
                    "{ctx}: peak feed {} (plain fuzzy {})",
                    m.peak_feed_mm_per_min,
                    n.peak_feed_mm_per_min
                );
                assert!(pl.schedule.feeds_mm_per_min == fz.schedule.feeds_mm_per_min);
            }
        }
    }
}

#[test]
fn the_streamed_plan_is_the_whole_path_plan() {
    // host-sim records each point's ceiling and cap while streaming through
    // a 256-point buffer; a buffer holding the whole path (as fuzzy-core's
    // integration test builds the time-optimal reference from) plans the
    // same ceilings and caps.
    let config = SimConfig::default();
    for shape in Shape::ALL {
        let path = shape.toolpath().unwrap();
        let sch = methods::schedule(Method::Fuzzy, &path, 5000.0, config.ts_s(), &config.methods)
            .unwrap();
        let pts =
            planner::motion_points(&path, &sch.feeds_mm_per_min, &sch.curvature_per_mm).unwrap();
        let streamed = planner::plan(&pts, &path.lines, &config.planner).unwrap();
        let mut whole: Box<Motion<4096>> =
            Box::new(Motion::new(config.planner.motion_config()).unwrap());
        for p in &pts {
            whole.push(*p).unwrap();
        }
        whole.end_path();
        let planned: Vec<_> = whole.planned().collect();
        assert_eq!(planned.len(), streamed.points.len(), "{shape:?}");
        for (a, b) in planned.iter().zip(&streamed.points) {
            assert_eq!(a.index as usize, b.index);
            assert_eq!(a.s_mm.to_num::<f64>(), b.s_mm);
            assert_eq!(
                a.ceiling.to_f64() / 60.0,
                b.ceiling_mm_per_s,
                "{shape:?} {}",
                b.index
            );
            assert_eq!(
                a.cap.to_f64() / 60.0,
                b.cap_mm_per_s,
                "{shape:?} {}",
                b.index
            );
        }
    }
}

#[test]
fn a_longer_buffer_is_never_slower_and_every_buffer_stays_within_limits() {
    let config = SimConfig::default();
    let path = Shape::Butterfly.toolpath().unwrap();
    let sch =
        methods::schedule(Method::Fuzzy, &path, 5000.0, config.ts_s(), &config.methods).unwrap();
    let pts = planner::motion_points(&path, &sch.feeds_mm_per_min, &sch.curvature_per_mm).unwrap();
    let mut last = f64::INFINITY;
    for buffer in planner::SUPPORTED_BUFFERS {
        let settings = planner::PlannerSettings {
            buffer_points: buffer,
            ..config.planner.clone()
        };
        let run = planner::plan(&pts, &path.lines, &settings).unwrap();
        let f = figures::measure("butterfly", "fuzzy", &run, &settings);
        eprintln!(
            "butterfly, lookahead {buffer:4}: {:.3} s, {:.3} × reference",
            f.cycle_time_s, f.time_ratio
        );
        assert!(f.within_limits(), "{}", figures::text(&f));
        assert!(
            f.cycle_time_s <= last + 1e-9,
            "{buffer}: {}",
            f.cycle_time_s
        );
        last = f.cycle_time_s;
    }
}
