//! Dat & Phuc's corner compensation on the FANUC-like machine.

use host_sim::experiments::dat_phuc2024::corner_comp::{self, CornerSettings};
use host_sim::experiments::dat_phuc2024::fanuc::{FanucConfig, FanucMode};
use host_sim::machine::MachineConfig;

fn fanuc(mode: FanucMode) -> MachineConfig {
    MachineConfig::Fanuc(FanucConfig {
        mode,
        ..Default::default()
    })
}

/// The paper's 90° corner at 900 mm/min: compensated, the predicted path
/// meets the corner within the tolerance in both modes; uncompensated it
/// does not; the geometry of the commanded path is unchanged.
#[test]
fn the_compensated_corner_meets_the_tolerance_in_both_modes() {
    let pts = corner_comp::corner_path(90.0, 10.0);
    let feeds = vec![900.0; 3];
    let s = CornerSettings::default();
    for mode in [FanucMode::Conventional, FanucMode::HighAccuracy] {
        let m = fanuc(mode);
        let (o, c) = corner_comp::evaluate("c", &pts, &feeds, &m, 0.001, &s).unwrap();
        assert!(o.corner_error_before_mm > 2.0 * s.tolerance_mm, "{o:?}");
        assert!(o.corner_error_after_mm <= 1.05 * s.tolerance_mm, "{o:?}");
        assert!(o.contour_error_after_mm < o.contour_error_before_mm);
        assert_eq!(c.points.len(), 5);
        assert_eq!(o.corners.len(), 1);
        // Inserted points lie on the legs; the corner feed is below 900.
        assert!(c.points[1][1].abs() < 1e-12 && (c.points[3][0] - 10.0).abs() < 1e-12);
        assert!(c.feeds[2] < 900.0 && c.feeds[2] == c.feeds[3]);
        assert_eq!((c.feeds[1], c.feeds[4]), (900.0, 900.0));
    }
}

/// Conventional mode (linear acc/dec after interpolation, τ = 64 ms, a
/// moving average of the commanded positions): the machine model's corner
/// error equals that of an `f64` moving average written here, at two
/// feeds.
#[test]
fn conventional_corner_error_matches_a_moving_average_reference() {
    let tau = 0.064;
    let ts = 0.001;
    for v_mm_min in [300.0, 900.0] {
        let v = v_mm_min / 60.0;
        // Commanded: along +X to (10, 0), then +Y, at constant speed.
        let n = (20.0 / v / ts) as usize + 200;
        let cmd: Vec<[f64; 2]> = (0..n)
            .map(|k| {
                let s = (k as f64 * ts * v).min(20.0);
                if s <= 10.0 {
                    [s, 0.0]
                } else {
                    [10.0, s - 10.0]
                }
            })
            .collect();
        let w = (tau / ts).round() as usize;
        let mut best = f64::INFINITY;
        for k in w..n {
            let (mut x, mut y) = (0.0, 0.0);
            for p in &cmd[k + 1 - w..=k] {
                x += p[0];
                y += p[1];
            }
            best = best.min(((x / w as f64 - 10.0).powi(2) + (y / w as f64).powi(2)).sqrt());
        }
        let m = fanuc(FanucMode::Conventional);
        let pts = corner_comp::corner_path(90.0, 10.0);
        let motion = m.simulate(&pts, &[v_mm_min; 3], ts);
        let got = corner_comp::corner_error(&motion, pts[1], 10.0, 0.3);
        assert!(
            (got - best).abs() < 0.02 * best + 1e-4,
            "{v_mm_min}: {got} vs {best}"
        );
    }
}

/// The paper's fixed 5 mm/min corner feed meets the corner far inside the
/// tolerance, at a higher cost in time than the searched feed.
#[test]
fn a_fixed_corner_feed_is_applied_to_every_sharp_corner() {
    let pts = corner_comp::corner_path(90.0, 10.0);
    let m = fanuc(FanucMode::Conventional);
    let searched = CornerSettings::default();
    let fixed = CornerSettings {
        fixed_feed_mm_per_min: Some(5.0),
        ..Default::default()
    };
    let (a, _) = corner_comp::evaluate("c", &pts, &[900.0; 3], &m, 0.001, &searched).unwrap();
    let (b, c) = corner_comp::evaluate("c", &pts, &[900.0; 3], &m, 0.001, &fixed).unwrap();
    assert_eq!(c.feeds[2], 5.0);
    assert!(
        b.corner_error_after_mm < 0.5 * a.corner_error_after_mm,
        "{b:?}"
    );
    assert!(b.cycle_time_after_s > a.cycle_time_after_s);
}

#[test]
fn refine_keeps_the_geometry_and_feeds() {
    let pts = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.1, 0.0]];
    let (p, f) = corner_comp::refine(&pts, &[0.0, 100.0, 50.0], 0.25);
    assert_eq!(p.len(), 6);
    assert_eq!(f, vec![0.0, 100.0, 100.0, 100.0, 100.0, 50.0]);
    assert_eq!(p[4], [1.0, 0.0, 0.0]);
    assert!((corner_comp::turn_deg(&pts, 1) - 90.0).abs() < 1e-9);
    assert_eq!(corner_comp::turn_deg(&p, 2), 0.0);
}

/// A corner below the tolerance already, and a gentle turn, are left alone.
#[test]
fn gentle_or_slow_corners_are_left_alone() {
    let s = CornerSettings::default();
    let m = fanuc(FanucMode::Conventional);
    let gentle = corner_comp::corner_path(10.0, 10.0);
    let c = corner_comp::compensate(&gentle, &[900.0; 3], &m, 0.001, &s).unwrap();
    assert!(c.corners.is_empty() && c.points.len() == 3);
    let sharp = corner_comp::corner_path(90.0, 10.0);
    let c = corner_comp::compensate(&sharp, &[5.0; 3], &m, 0.001, &s).unwrap();
    assert!(c.corners.is_empty(), "{:?}", c.corners);
}

#[test]
fn the_compensated_gcode_parses_back() {
    let pts = corner_comp::corner_path(90.0, 10.0);
    let m = fanuc(FanucMode::Conventional);
    let c =
        corner_comp::compensate(&pts, &[900.0; 3], &m, 0.001, &CornerSettings::default()).unwrap();
    let g = corner_comp::gcode(&c);
    let t = host_sim::gcode::parse("c", &g, &Default::default()).unwrap();
    let last = t.points.last().unwrap();
    assert!((last[0] - 10.0).abs() < 1e-4 && (last[1] - 10.0).abs() < 1e-4);
    assert!(t.points.len() >= 5);
}
