//! Cho et al.'s closed loop on the X-Y servo model: fuzzy-core's online
//! contour error against host-sim's exact one, and the feed law's behaviour.

use host_sim::contour_error::brute_force_distance;
use host_sim::experiments::cho::feed_control::{self as cho, ChoSettings, Contour};
use host_sim::experiments::cho::servo_xy::ServoXyConfig;

/// Online (variable window) and exact (whole path) contour error agree on
/// the circle except where the tool overshoots the end point (the window
/// sees only the path's end; the whole path continues into its start), and
/// the window stays small.
#[test]
fn online_contour_error_matches_the_exact_one_on_the_circle() {
    let servo = ServoXyConfig::default();
    let pts = Contour::Circle.points();
    let s = ChoSettings::paper(Contour::Circle);
    let run = cho::run_fuzzy(&servo, &pts, &s).unwrap();
    let end = pts[pts.len() - 1];
    for row in &run.trace {
        let p = [row[4], row[5], 0.0];
        let near_end = brute_force_distance(&[end], p) < 0.5;
        if !near_end {
            assert!(
                (row[2].abs() - row[3]).abs() < 1e-6,
                "t {}: online {} exact {}",
                row[0],
                row[2],
                row[3]
            );
        }
        // Never smaller than the exact distance.
        assert!(row[2].abs() >= row[3] - 1e-6);
    }
    assert!(
        run.window_max >= 2 && run.window_max < 40,
        "{}",
        run.window_max
    );
}

/// The feed law holds the circle near its bound: after the start the peak
/// error is within 30 % of the bound, and a tighter bound gives a lower
/// feed and a lower error.
#[test]
fn the_feed_law_tracks_the_bound_on_the_circle() {
    let servo = ServoXyConfig::default();
    let pts = Contour::Circle.points();
    let mut s = ChoSettings::paper(Contour::Circle);
    let wide = cho::run_fuzzy(&servo, &pts, &s).unwrap();
    assert!(
        wide.peak_error_mm > 0.7 * s.bound_mm && wide.peak_error_mm < 1.3 * s.bound_mm,
        "{}",
        wide.peak_error_mm
    );
    s.bound_mm = 0.0025;
    let tight = cho::run_fuzzy(&servo, &pts, &s).unwrap();
    assert!(tight.peak_error_mm < wide.peak_error_mm);
    assert!(tight.mean_feed_mm_per_min < wide.mean_feed_mm_per_min);
    assert!(tight.cycle_time_s > wide.cycle_time_s);
}

/// The constant-feed match: peak error rises with the feed, and the
/// matched feed meets its target.
#[test]
fn the_matched_constant_feed_meets_its_target() {
    let servo = ServoXyConfig::default();
    let pts = Contour::Circle.points();
    let s = ChoSettings::paper(Contour::Circle);
    let (f, run) = cho::match_constant(&servo, &pts, 0.004, &s).unwrap();
    assert!(
        run.peak_error_mm <= 0.004 && run.peak_error_mm > 0.0039,
        "{run:?}"
    );
    let faster = cho::run_constant(&servo, &pts, f * 1.01, &s).unwrap();
    assert!(faster.peak_error_mm > run.peak_error_mm);
}

/// The paper's corner on our servo model: the reactive law reaches f_max
/// on the straight leg (no contour error there) and meets the corner at
/// that feed, so the corner's peak error is set by f_max (see the module
/// docs and README): we pin that finding.
#[test]
fn the_corner_error_is_set_by_the_feed_reached_on_the_leg() {
    let servo = ServoXyConfig::default();
    let pts = Contour::Corner.points();
    let mut s = ChoSettings::paper(Contour::Corner);
    s.f_max_mm_per_min = 300.0;
    let slow = cho::run_fuzzy(&servo, &pts, &s).unwrap();
    s.f_max_mm_per_min = 1000.0;
    let fast = cho::run_fuzzy(&servo, &pts, &s).unwrap();
    assert!(fast.peak_error_mm > 3.0 * slow.peak_error_mm);
    assert!(slow.peak_error_mm > s.bound_mm);
}
