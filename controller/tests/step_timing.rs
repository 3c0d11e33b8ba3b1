//! Step timing against the ideal trajectory (the setpoints' linear
//! interpolation, from the exact `mm × steps/mm`): the engine under a
//! simulated step timer (`controller::steps::sim`), every pin edge
//! recorded and checked: each step within 2 µs of the time the ideal
//! trajectory crosses its position (steps a minimum held back, i.e. the
//! first step after a reversal closer than pulse + max(pulse, setup) to
//! the step before, are counted apart and bounded), the count at every
//! tick end equal to the commanded position, no pulse or gap shorter
//! than configured, every direction change at least the setup time
//! before the next step.
//!
//! Figures: `cargo test -p controller --release --test step_timing -- --nocapture`
//! prints a `steps <case>` line per case.

use controller::planning::Setpoint;
use controller::replay::{self, NoClock, Replay};
use controller::settings::{Plan, MOTION_CONFIG, SCHED_CONFIG};
use controller::steps::sim::{self, Figures, Model, Trace};
use controller::steps::{StepConfig, StepsPerMm, Timing};
use fuzzy_core::scheduler::SchedulerConfig;
use fuzzy_core::units::{FeedMmPerMin, Point3Mm};
use proptest::prelude::*;

const HZ: u32 = 84_000_000;
/// 2 µs in counts of the 84 MHz step timer.
const TWO_US: f64 = 168.0;

/// The step timer interrupt on a 168 MHz STM32F4, modelled from the
/// engine's instruction counts in QEMU (`firmware/src/bin/cost.rs`,
/// `cost steps3x`; the figures in firmware/README.md) at 1.65 cycles an
/// instruction, 2 cycles a count of the 84 MHz timer: 0.25 µs from the
/// compare match to the pin write (entry, the pending batch's store), the
/// counter read right after, `batch_mean × 1.65 / 2` counts before the
/// next batch is ready, `(window_batch_mean − batch_mean) × 1.65 / 2` more
/// for a window change and `(pull_batch_mean − batch_mean) × 1.65 / 2`
/// more for a plan taken; the tick hands its plan over 0.1 ms into its
/// period.
const LOADED: Model = Model {
    latency: 21,
    read_after: 2,
    busy: 237,
    busy_window: 340,
    busy_pull: 234,
    tick_delay: 8_400,
};

fn timing(c: &StepConfig) -> Timing {
    c.timing(HZ, 1000).unwrap()
}

fn print(name: &str, tr: &Trace, f: &Figures) {
    let us = |c: f64| c * 1e6 / HZ as f64;
    println!(
        "steps {name}: steps={} peak_rate_khz={:.1} worst_late_us={:.3} worst_early_us={:.3} held={} (reversals {}) held_worst_late_us={:.2} min_pulse_us={:.3} min_gap_us={:.3} min_dir_setup_us={:.3} tick_end_mismatches={} lag_ticks={} filtered_pairs={}",
        f.steps,
        f.peak_rate_hz / 1000.0,
        us(f.max_late),
        us(f.max_early),
        f.held,
        f.held_reversals,
        us(f.held_max_late),
        us(f.min_pulse as f64),
        us(f.min_gap as f64),
        us(f.min_setup as f64),
        f.tick_end_mismatches,
        tr.report.lag_ticks,
        f.filtered_pairs,
    );
}

/// Everything the figures must show for a run within the engine's rate.
fn assert_clean(name: &str, tr: &Trace, f: &Figures) {
    let t = &tr.timing;
    let m = &tr.model;
    assert_eq!(f.unmatched, 0, "{name}: steps out of order or missing");
    assert_eq!(f.step_without_dir, 0, "{name}");
    assert_eq!(f.dir_while_active, 0, "{name}");
    assert_eq!(f.tick_end_mismatches, 0, "{name}: tick end counts");
    assert_eq!(tr.report.lag_ticks, 0, "{name}: lag {:?}", tr.report);
    assert_eq!(tr.report.late_windows, 0, "{name}");
    assert_eq!(tr.report.filtered_pairs, f.filtered_pairs, "{name}");
    if f.steps > 0 {
        assert!(
            f.min_pulse >= t.pulse as u64,
            "{name}: pulse {}",
            f.min_pulse
        );
    }
    if f.min_gap != u64::MAX {
        assert!(f.min_gap >= t.low as u64, "{name}: gap {}", f.min_gap);
    }
    if f.min_setup != u64::MAX {
        assert!(
            f.min_setup >= t.setup as u64,
            "{name}: setup {}",
            f.min_setup
        );
    }
    // Late: at most the interrupt's own lateness (and the rounding up to a
    // count), within 2 µs for a perfect timer; early: at most the
    // coalescing window.
    let late = 1.0 + 1e-6 + m.lateness() as f64;
    assert!(f.max_late <= late, "{name}: late {}", f.max_late);
    if m.lateness() == 0 {
        assert!(f.max_late <= TWO_US, "{name}: late {}", f.max_late);
    }
    assert!(
        f.max_early <= t.early as f64,
        "{name}: early {}",
        f.max_early
    );
    // Held steps: with a perfect timer only right after a reversal (a
    // loaded interrupt's late falling edges hold some others), and only by
    // the minimums.
    if m.lateness() == 0 {
        assert_eq!(f.held, f.held_reversals, "{name}: held outside reversals");
    }
    let hold = (t.pulse + t.pulse.max(t.setup)) as f64 + late;
    assert!(f.held_max_late <= hold, "{name}: held {}", f.held_max_late);
    let settled = tr.setpoints.last().copied().unwrap_or(tr.start);
    let b = settled.to_bits();
    for (i, p) in tr.position.iter().enumerate() {
        let want = ((b[i] as i128 * tr.spm[i].0 as i128) >> 48) as i64;
        assert_eq!(*p, want, "{name}: axis {i} ends at {p}, commanded {want}");
    }
}

fn check(name: &str, tr: &Trace) -> Figures {
    let f = sim::check(tr);
    print(name, tr, &f);
    assert_clean(name, tr, &f);
    f
}

/// Setpoints from per-axis positions in steps.
fn setpoints(steps: &[[f64; 3]], spm: &[StepsPerMm; 3]) -> Vec<Point3Mm> {
    steps
        .iter()
        .map(|s| {
            Point3Mm::from_f64(
                s[0] / spm[0].to_f64(),
                s[1] / spm[1].to_f64(),
                s[2] / spm[2].to_f64(),
            )
            .unwrap()
        })
        .collect()
}

/// Constant acceleration from rest to `rates` (steps/s per axis) over
/// `ramp` ticks, then `hold` ticks at that rate, then back to rest.
fn ramp(rates: [f64; 3], ramp: usize, hold: usize) -> Vec<[f64; 3]> {
    let dt = 1e-3;
    let mut v = [0.0f64; 3];
    let mut p = [0.3, 0.6, 0.9f64];
    let mut out = Vec::new();
    for k in 0..(2 * ramp + hold) {
        for i in 0..3 {
            let a = rates[i] / (ramp as f64 * dt);
            let v0 = v[i];
            let v1 = if k < ramp {
                v0 + a * dt
            } else if k < ramp + hold {
                rates[i]
            } else {
                (v0 - a * dt).max(0.0)
            };
            p[i] += 0.5 * (v0 + v1) * dt;
            v[i] = v1;
        }
        out.push(p);
    }
    out
}

fn three_axes(rates: [f64; 3], model: Model, extra: usize, name: &str) -> (Trace, Figures) {
    let spm = [
        StepsPerMm::from_int(1600),
        StepsPerMm::from_milli(2_000_250),
        StepsPerMm::from_int(3200),
    ];
    let mut c = StepConfig::new(spm[0]);
    c.axes[1].steps_per_mm = spm[1];
    c.axes[2].steps_per_mm = spm[2];
    let t = timing(&c);
    assert_eq!(t.max_rate_hz(), 200_000);
    let sps = setpoints(&ramp(rates, 50, 200), &spm);
    let tr = sim::run(t, spm, Point3Mm::ORIGIN, &sps, extra, model);
    let f = sim::check(&tr);
    print(name, &tr, &f);
    (tr, f)
}

#[test]
fn three_axes_at_over_100_khz_each() {
    let (tr, f) = three_axes(
        [150_000.0, 120_000.0, 105_000.0],
        Model::IDEAL,
        4,
        "3x100kHz ideal timer",
    );
    assert_clean("3x100kHz ideal timer", &tr, &f);
    assert!(f.peak_rate_hz >= 150_000.0);
    assert!(f.steps > 3 * 200 * 100);
}

#[test]
fn the_modelled_interrupt_keeps_up_with_three_axes_at_40_khz_and_says_so_above() {
    let (tr, f) = three_axes([45_000.0, 40_000.0, 40_000.0], LOADED, 4, "3x40kHz loaded");
    assert_clean("3x40kHz loaded", &tr, &f);
    // At 3 × 100 kHz the modelled interrupt cannot keep up: the steps are
    // carried, reported, and all emitted in the end; no minimum is broken.
    let (tr, f) = three_axes(
        [150_000.0, 120_000.0, 105_000.0],
        LOADED,
        200,
        "3x100kHz loaded",
    );
    assert!(tr.report.lag_ticks > 0, "{:?}", tr.report);
    assert!(f.min_pulse >= tr.timing.pulse as u64 && f.min_gap >= tr.timing.low as u64);
    assert!(f.min_setup >= tr.timing.setup as u64);
    assert_eq!(tr.report.lag_now_steps, 0, "caught up");
    let b = tr.setpoints.last().unwrap().to_bits();
    for (i, p) in tr.position.iter().enumerate() {
        let want = ((b[i] as i128 * tr.spm[i].0 as i128) >> 48) as i64;
        assert_eq!(*p, want, "axis {i}");
    }
    assert_eq!(f.steps, 93_750, "no step but the commanded ones");
}

#[test]
fn rates_above_the_pulse_limit_lag_and_say_so() {
    // 250 kHz wanted, 200 kHz possible at 2.5 µs: carried, counted, caught
    // up once the axis slows; never lost.
    let spm = [StepsPerMm::from_int(1000); 3];
    let t = timing(&StepConfig::new(spm[0]));
    let path = ramp([250_000.0, 0.0, 0.0], 20, 40);
    let sps = setpoints(&path, &spm);
    let tr = sim::run(t, spm, Point3Mm::ORIGIN, &sps, 40, Model::IDEAL);
    let f = sim::check(&tr);
    print("250kHz over the limit", &tr, &f);
    assert!(tr.report.lag_ticks > 10, "{:?}", tr.report);
    assert!(tr.report.lag_max_steps > 100, "{:?}", tr.report);
    assert!(f.tick_end_mismatches > 10);
    assert!(f.min_pulse >= t.pulse as u64 && f.min_gap >= t.low as u64);
    let want = ((sps.last().unwrap().to_bits()[0] as i128 * spm[0].0 as i128) >> 48) as i64;
    assert_eq!(tr.position[0], want, "all steps emitted in the end");
    assert_eq!(tr.report.lag_now_steps, 0);
}

/// The recorded shapes and a 0.05 mm line through the controller's own
/// scheduler and planner (`controller::replay`), the setpoints of every
/// generated tick.
fn replayed(name: &str) -> Vec<Point3Mm> {
    let mut plan = Box::new(Plan::new(MOTION_CONFIG).unwrap());
    let mut replay = Replay::new(&mut plan, Point3Mm::ORIGIN).unwrap();
    let mut out = Vec::new();
    let mut on_tick = |m: &Plan, t: &fuzzy_core::planner::Tick| out.push(Setpoint::of(m, t).pos);
    if name == "line" {
        let c = SchedulerConfig::new(FeedMmPerMin::from_int(5000), FeedMmPerMin::from_int(60));
        replay
            .run(c, replay::line(2000), false, &mut NoClock, &mut on_tick)
            .unwrap();
    } else {
        let path = format!(
            "{}/../tests/data/shapes/{name}.csv",
            env!("CARGO_MANIFEST_DIR")
        );
        let text = std::fs::read_to_string(path).unwrap();
        let pts: Vec<Point3Mm> = text
            .lines()
            .filter(|l| !l.is_empty() && !l.starts_with('#') && !l.starts_with('x'))
            .map(|l| {
                let v: Vec<f64> = l.split(',').map(|c| c.trim().parse().unwrap()).collect();
                Point3Mm::from_f64(v[0], v[1], v[2]).unwrap()
            })
            .collect();
        replay
            .run(
                SCHED_CONFIG,
                pts.into_iter(),
                true,
                &mut NoClock,
                &mut on_tick,
            )
            .unwrap();
    }
    out
}

#[test]
fn the_shapes_and_the_line() {
    // Fine resolution so that the shapes (3000 mm/min) and the line (5000)
    // step fast: 80 kHz and 133 kHz at 1600 steps/mm.
    let spm = [
        StepsPerMm::from_int(1600),
        StepsPerMm::from_milli(1_333_333),
        StepsPerMm::from_int(400),
    ];
    let mut c = StepConfig::new(spm[0]);
    for (a, s) in c.axes.iter_mut().zip(spm) {
        a.steps_per_mm = s;
    }
    let t = timing(&c);
    for name in ["line", "infinity", "trident", "butterfly"] {
        let sps = replayed(name);
        for (label, model) in [("ideal timer", Model::IDEAL), ("loaded", LOADED)] {
            let tr = sim::run(t, spm, Point3Mm::ORIGIN, &sps, 4, model);
            check(&format!("{name} ({label})"), &tr);
        }
    }
}

/// A path that hovers on a step boundary and reverses there: the cases
/// where a step and a step back come close together.
fn dither(ticks: usize, amplitude: f64, hz: f64, drift: f64) -> Vec<[f64; 3]> {
    (0..ticks)
        .map(|k| {
            let t = k as f64 * 1e-3;
            let s = amplitude * (2.0 * std::f64::consts::PI * hz * t).sin();
            [10.0 + s + drift * t, 20.0 - s, 5.0 + 0.5 * s]
        })
        .collect()
}

#[test]
fn reversals_without_the_filter_are_held_and_bounded() {
    let spm = [StepsPerMm::from_int(100); 3];
    let t = timing(&StepConfig::new(spm[0]));
    let sps = setpoints(&dither(400, 1.3, 170.0, 3.0), &spm);
    let tr = sim::run(t, spm, Point3Mm::ORIGIN, &sps, 4, Model::IDEAL);
    let f = check("dither, no filter", &tr);
    assert_eq!(f.filtered_pairs, 0);
    assert!(f.steps > 500);
}

#[test]
fn the_reversal_filter_cancels_close_pairs_and_only_them() {
    let spm = [StepsPerMm::from_int(100); 3];
    let c = StepConfig {
        reversal_filter_ns: 750_000,
        ..StepConfig::new(spm[0])
    };
    let t = timing(&c);
    let sps = setpoints(&dither(400, 1.3, 170.0, 3.0), &spm);
    let tr = sim::run(t, spm, Point3Mm::ORIGIN, &sps, 4, Model::IDEAL);
    let f = sim::check(&tr);
    print("dither, 750 µs filter", &tr, &f);
    assert!(f.filtered_pairs > 0, "{f:?}");
    assert_eq!(tr.report.filtered_pairs, f.filtered_pairs);
    // Every other figure as without it; tick ends inside a cancelled pair
    // are one step off, by design, and no other.
    assert_clean("dither, 750 µs filter", &tr, &f);
}

#[derive(Clone, Debug)]
struct Case {
    spm: [u32; 3],
    pulse_ns: u32,
    setup_ns: u32,
    coalesce_ns: u32,
    filter_ns: u32,
    loaded: bool,
    invert: (u8, u8),
    /// Per axis: segments of (ticks, target rate as a share of the limit).
    segments: [Vec<(usize, f64)>; 3],
    /// Per axis: dither amplitude (steps) and frequency (Hz).
    dither: [(f64, f64); 3],
}

fn case() -> impl Strategy<Value = Case> {
    let segs = || prop::collection::vec((5usize..60, -1.0f64..1.0), 1..6);
    (
        [
            20u32 << 16..3200 << 16,
            20 << 16..3200 << 16,
            20 << 16..3200 << 16,
        ],
        100u32..=5_000,
        100u32..=20_000,
        0u32..=1_000,
        prop_oneof![Just(0u32), 1u32..=1_000_000],
        any::<bool>(),
        (0u8..8, 0u8..8),
        [segs(), segs(), segs()],
        [
            (0.0f64..2.0, 20.0f64..300.0),
            (0.0f64..2.0, 20.0f64..300.0),
            (0.0f64..2.0, 20.0f64..300.0),
        ],
    )
        .prop_map(
            |(
                spm,
                pulse_ns,
                setup_ns,
                coalesce_ns,
                filter_ns,
                loaded,
                invert,
                segments,
                dither,
            )| Case {
                spm,
                pulse_ns,
                setup_ns,
                coalesce_ns,
                filter_ns,
                loaded,
                invert,
                segments,
                dither,
            },
        )
}

impl Case {
    fn config(&self) -> StepConfig {
        let mut c = StepConfig::new(StepsPerMm(self.spm[0]));
        for (i, a) in c.axes.iter_mut().enumerate() {
            a.steps_per_mm = StepsPerMm(self.spm[i]);
            a.invert_step = self.invert.0 & (1 << i) != 0;
            a.invert_dir = self.invert.1 & (1 << i) != 0;
        }
        c.pulse_ns = self.pulse_ns;
        c.dir_setup_ns = self.setup_ns;
        c.coalesce_ns = self.coalesce_ns;
        c.reversal_filter_ns = self.filter_ns;
        c
    }

    /// Positions in steps, tick by tick: speed ramps linearly to each
    /// segment's target (at most 80 % of the pulse limit, and 150 kHz; 50
    /// kHz under the loaded interrupt, whose time a batch caps the three
    /// axes together near 150 000 steps a second), plus a dither that
    /// reverses the axis around step boundaries.
    fn path(&self, limit_hz: f64) -> Vec<[f64; 3]> {
        let cap = if self.loaded { 50_000.0 } else { 150_000.0 };
        let vmax = (0.8 * limit_hz).min(cap);
        let ticks = self
            .segments
            .iter()
            .map(|s| s.iter().map(|x| x.0).sum::<usize>())
            .max()
            .unwrap_or(0);
        let mut out = vec![[0.0; 3]; ticks];
        for axis in 0..3 {
            let (amp, hz) = self.dither[axis];
            // Keep the dither's own speed within the budget too.
            let amp = amp.min(0.2 * vmax / (2.0 * std::f64::consts::PI * hz));
            let (mut p, mut v) = (0.5 + axis as f64 * 0.25, 0.0f64);
            let mut k = 0;
            for &(n, share) in &self.segments[axis] {
                let target = share * 0.8 * vmax;
                let dv = (target - v) / n as f64;
                for _ in 0..n {
                    let v1 = v + dv;
                    p += 0.5 * (v + v1) * 1e-3;
                    v = v1;
                    let t = k as f64 * 1e-3;
                    out[k][axis] = p + amp * (2.0 * std::f64::consts::PI * hz * t).sin();
                    k += 1;
                }
            }
            for row in out.iter_mut().skip(k) {
                row[axis] = p;
            }
        }
        out
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn random_trajectories_hold_every_figure(c in case()) {
        let cfg = c.config();
        let t = timing(&cfg);
        let spm = cfg.axes.map(|a| a.steps_per_mm);
        let sps = setpoints(&c.path(t.max_rate_hz() as f64), &spm);
        let model = if c.loaded { LOADED } else { Model::IDEAL };
        let tr = sim::run(t, spm, Point3Mm::ORIGIN, &sps, 4, model);
        let f = sim::check(&tr);
        assert_clean(&format!("{c:?}"), &tr, &f);
    }
}
