//! Cost benchmark and on-target planner check: the scheduler and the
//! velocity planner over the three recorded shapes and a 100 mm line of
//! 0.05 mm segments, run under QEMU with `-icount shift=0` (one instruction
//! per ns; SysTick at 168 MHz counts 168 per 1000 instructions).
//!
//! Every run is `controller::replay::Replay::run`, the fixed order of
//! pushes and ticks shared with the host test
//! `cost_benchmark_plans_the_same_bits_as_the_host` in
//! `tests/tests/firmware_qemu.rs`, which computes the same checksums of the
//! commanded positions on the host and compares them with the ones printed
//! here. Nothing else runs (no interrupts), so nothing
//! else is counted. Figures (instructions):
//! - `sched`: the scheduler's step (`Feeder::command`/`drain`: curvature,
//!   lookahead, controller, filter); mean per scheduled point, worst call;
//! - `push`: a scheduled point into the planner (`Planning::push_pending`)
//!   per point (mean, worst);
//! - `gen`: one generated tick (`Planning::generate`), per tick (mean,
//!   worst); in the application it runs in the background;
//! - `isr`: what the tick interrupt does per tick (`TickExecutor::tick`:
//!   the next setpoint from the ring to the step/dir outputs), mean and
//!   worst; the application adds RTIC's entry and exit;
//! - `override`: an override change (the planner re-plans its buffer),
//!   worst.
//!
//! Runs, in this order: `line` (100 mm of 0.05 mm segments from the origin,
//! F_max 5000 mm/min), `infinity`, `trident`, `butterfly` (F_max 3000
//! mm/min, the firmware's default), and the shapes again with `+events` (a
//! feed hold, override changes and a starved stretch at fixed ticks:
//! `controller::replay::EVENTS`). Each path starts where the previous one
//! ended, the first at the origin, as in the firmware.
//!
//! Output: plain text on semihosting stdout (no defmt: this binary logs
//! nothing else), one `cost <run> …` line per run, then `cost all …` (the
//! shapes, with and without events), `cost load …` and `cost stack_bytes=…`.
#![no_std]
#![no_main]

use controller::planning::Setpoint;
use controller::replay::{self, Clock, Replay, Report, Stat};
use controller::ring::Ring;
use controller::settings::{Plan, MOTION_CONFIG, SCHED_CONFIG, SETPOINT_RING, STEPS_PER_MM};
use controller::stepper::Axes;
use controller::tick::TickExecutor;
use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use fuzzy_core::scheduler::SchedulerConfig;
use fuzzy_core::units::{FeedMmPerMin, Point3Mm};
use fuzzy_firmware::measure::{self, cycles, cycles_since, qemu_instructions};

static SHAPES: [(&str, &[u8]); 3] = [
    (
        "infinity",
        include_bytes!(concat!(env!("OUT_DIR"), "/infinity.bin")),
    ),
    (
        "trident",
        include_bytes!(concat!(env!("OUT_DIR"), "/trident.bin")),
    ),
    (
        "butterfly",
        include_bytes!(concat!(env!("OUT_DIR"), "/butterfly.bin")),
    ),
];

/// Segments of the 0.05 mm line (100 mm).
const LINE_SEGMENTS: u32 = 2000;

/// SysTick as a free-running cycle counter.
struct SysTick;

impl Clock for SysTick {
    fn now(&mut self) -> u32 {
        cycles()
    }
    fn since(&mut self, start: u32) -> u32 {
        cycles_since(start)
    }
}

fn mean(s: &Stat, per: u32) -> u64 {
    qemu_instructions(s.total) / per.max(1) as u64
}

fn worst(s: &Stat) -> u64 {
    qemu_instructions(s.worst as u64)
}

fn points(data: &'static [u8]) -> impl Iterator<Item = Point3Mm> {
    data.chunks_exact(24).map(|c| {
        let mut w = [0i64; 3];
        for (i, v) in w.iter_mut().enumerate() {
            let mut b = [0u8; 8];
            b.copy_from_slice(&c[i * 8..i * 8 + 8]);
            *v = i64::from_le_bytes(b);
        }
        Point3Mm::from_bits(w[0], w[1], w[2])
    })
}

/// What one run measured, with the tick interrupt's figures.
struct Measured {
    r: Report,
    isr: Stat,
}

fn print(name: &str, events: bool, m: &Measured) {
    let r = &m.r;
    hprintln!(
        "cost {}{} points={} ticks={} moving_ticks={} underruns={} sched_mean={} sched_worst={} push_mean={} push_worst={} gen_mean={} gen_worst={} isr_mean={} isr_worst={} override_worst={} positions={:#018x} feed_sum={}",
        name,
        if events { "+events" } else { "" },
        r.points,
        r.ticks,
        r.moving_ticks,
        r.underruns,
        mean(&r.sched, r.points),
        worst(&r.sched),
        mean(&r.push, r.push.n),
        worst(&r.push),
        mean(&r.gen, r.gen.n),
        worst(&r.gen),
        mean(&m.isr, m.isr.n),
        worst(&m.isr),
        worst(&r.overrides),
        r.positions,
        r.feed_sum
    );
}

#[entry]
fn main() -> ! {
    let Some(mut cp) = cortex_m::Peripherals::take() else {
        fuzzy_firmware::fail()
    };
    let Some(dp) = stm32f4::stm32f405::Peripherals::take() else {
        fuzzy_firmware::fail()
    };
    measure::start_cycle_counter(&mut cp.SYST);
    let board = fuzzy_firmware::board::init(dp);
    let mut axes = Axes::new(board.axes, STEPS_PER_MM, Point3Mm::ORIGIN);
    let Ok(mut plan) = Plan::new(MOTION_CONFIG) else {
        fuzzy_firmware::fail()
    };
    let Ok(mut replay) = Replay::new(&mut plan, Point3Mm::ORIGIN) else {
        fuzzy_firmware::fail()
    };
    let mut exec = TickExecutor::new(Point3Mm::ORIGIN);
    let mut ring: Ring<Setpoint, SETPOINT_RING> = Ring::new();
    let (mut ring_tx, mut ring_rx) = ring.split();

    let mut one = |name: &str,
                   config: SchedulerConfig,
                   path: &mut dyn Iterator<Item = Point3Mm>,
                   events: bool|
     -> Measured {
        let mut isr = Stat::default();
        let mut isr_clock = SysTick;
        let r = replay.run(config, path, events, &mut SysTick, |m, t| {
            // What the background does with a generated tick ...
            let _ = ring_tx.enqueue(Setpoint::of(m, t));
            // ... and what the tick interrupt does with it.
            let t0 = isr_clock.now();
            exec.tick(&mut ring_rx, &mut axes);
            let dt = isr_clock.since(t0);
            exec.worst_cycles = exec.worst_cycles.max(dt);
            isr.add(dt);
        });
        let Ok(r) = r else {
            hprintln!("cost {}: {:?}", name, r.err());
            fuzzy_firmware::fail()
        };
        let m = Measured { r, isr };
        print(name, events, &m);
        m
    };

    let line_config =
        SchedulerConfig::new(FeedMmPerMin::from_int(5000), FeedMmPerMin::from_int(60));
    let line = one("line", line_config, &mut replay::line(LINE_SEGMENTS), false);
    let mut all = [
        line.r.sched,
        line.r.push,
        line.r.gen,
        line.isr,
        line.r.overrides,
    ];
    let mut points_all = line.r.points;
    let mut feed_sum = line.r.feed_sum;
    let runs = SHAPES
        .iter()
        .map(|s| (s, false))
        .chain(SHAPES.iter().map(|s| (s, true)));
    for ((name, data), events) in runs {
        let m = one(name, SCHED_CONFIG, &mut points(data), events);
        for (a, b) in all
            .iter_mut()
            .zip([m.r.sched, m.r.push, m.r.gen, m.isr, m.r.overrides])
        {
            a.merge(&b);
        }
        points_all += m.r.points;
        feed_sum = feed_sum.wrapping_add(m.r.feed_sum);
    }
    let [sched, push, gen, isr, ov] = all;
    hprintln!(
        "cost all sched_mean={} sched_worst={} push_mean={} push_worst={} gen_mean={} gen_worst={} isr_mean={} isr_worst={} override_worst={} feed_sum={}",
        mean(&sched, points_all),
        worst(&sched),
        mean(&push, push.n),
        worst(&push),
        mean(&gen, gen.n),
        worst(&gen),
        mean(&isr, isr.n),
        worst(&isr),
        worst(&ov),
        feed_sum
    );
    // CPU share at 0.05 mm segments and 5000 mm/min: 1667 points/s through
    // scheduler and planner, 1000 ticks/s generated, at 168 M instructions/s
    // (permille; from the line's own figures).
    let l = &line.r;
    let per_point = mean(&l.sched, l.points) + mean(&l.push, l.push.n);
    let per_s = per_point * 1667 + mean(&l.gen, l.gen.n) * 1000;
    let isr_per_s = mean(&line.isr, line.isr.n) * 1000;
    hprintln!(
        "cost load line_per_point={} line_gen_mean={} background_permille={} isr_permille={}",
        per_point,
        mean(&l.gen, l.gen.n),
        per_s / 168_000,
        isr_per_s / 168_000
    );
    let mut probe = measure::StackProbe::new();
    hprintln!("cost stack_bytes={}", probe.full_scan());
    fuzzy_firmware::exit_success()
}
