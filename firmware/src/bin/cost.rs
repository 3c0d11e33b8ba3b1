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
//!   the next setpoint from the ring to the step output, i.e. the tick's
//!   step plan queued to the engine), mean and worst; the application
//!   adds RTIC's entry and exit;
//! - `plan`: the step plan alone (`StepQueue::update`: setpoint to
//!   per-axis crossing count, direction, first time, interval, queued),
//!   per tick (mean, worst);
//! - `step_batch`: the step engine per timer interrupt (`StepEngine::done`
//!   then `due`: one batch of edges taken, the next computed), mean and
//!   worst, the engine run over each tick's window in virtual time right
//!   after the tick; `step_per_step`: the engine's instructions per step
//!   emitted (all its batches, falling edges and window changes included);
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
//! The step figures use the firmware's step settings
//! (`controller::settings::STEP_CONFIG`); a last run, `steps3x`, drives
//! three axes at 150, 120 and 105 kHz (1600, 2000.25 and 3200 steps/mm,
//! 250 ticks ramped up and down) through a planner and engine of their
//! own, and `cost steps3x …` reports the engine's share of the core at
//! that rate (instructions per second over 168 M).
//!
//! Output: plain text on semihosting stdout (no defmt: this binary logs
//! nothing else), one `cost <run> …` line per run (with a `cost steps
//! <run> …` line of step figures), then `cost all …` (the shapes, with
//! and without events), `cost load …`, `cost steps3x …` and
//! `cost stack_bytes=…`.
#![no_std]
#![no_main]

use controller::planning::Setpoint;
use controller::replay::{self, Clock, Replay, Report, Stat};
use controller::ring::Ring;
use controller::settings::{
    Plan, MOTION_CONFIG, SCHED_CONFIG, SETPOINT_RING, STEP_CONFIG, STEP_TIMER_HZ, TICK_HZ,
};
use controller::stepper::{first_window, StepOutput, StepPins, StepQueue};
use controller::steps::{
    PlanQueue, Planner, StepConfig, StepEngine, StepReport, StepShared, StepsPerMm, Timing,
};
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
    steps: StepStats,
}

/// The step generator's figures of a run.
#[derive(Clone, Copy, Default)]
struct StepStats {
    plan: Stat,
    batch: Stat,
    /// The batches that changed windows and took no plan (also in
    /// `batch`).
    window: Stat,
    /// The batches that took a plan and changed no window.
    pull: Stat,
    /// The batches that did both.
    both: Stat,
    steps: u64,
}

impl StepStats {
    fn merge(&mut self, o: &StepStats) {
        self.plan.merge(&o.plan);
        self.batch.merge(&o.batch);
        self.window.merge(&o.window);
        self.pull.merge(&o.pull);
        self.both.merge(&o.both);
        self.steps += o.steps;
    }

    fn per_step(&self) -> u64 {
        qemu_instructions(self.batch.total) / self.steps.max(1)
    }
}

/// The step output with its plan timed.
struct Timed<'a> {
    queue: StepQueue<'a>,
    plan: Stat,
}

impl StepOutput for Timed<'_> {
    fn update(&mut self, pos: Point3Mm) {
        let t0 = cycles();
        self.queue.update(pos);
        self.plan.add(cycles_since(t0));
    }
    fn hold(&mut self) {
        let t0 = cycles();
        self.queue.hold();
        self.plan.add(cycles_since(t0));
    }
    fn report(&self) -> StepReport {
        self.queue.report()
    }
}

/// The engine over one tick's window in virtual time (after the tick at
/// `*now`), each batch timed, its edges written to the pins.
fn run_window(
    engine: &mut StepEngine<'_>,
    pins: &mut impl StepPins,
    now: &mut u32,
    window: u32,
    s: &mut StepStats,
) {
    let end = now.wrapping_add(window).wrapping_sub(1);
    let before = engine.position();
    loop {
        let (w0, p0) = (engine.window_end(), engine.plans_taken());
        let t0 = cycles();
        let d = engine.due();
        if (d.at.wrapping_sub(end) as i32) > 0 {
            break;
        }
        pins.write(d.edges);
        engine.done(d.at);
        let dt = cycles_since(t0);
        s.batch.add(dt);
        match (engine.window_end() != w0, engine.plans_taken() != p0) {
            (true, false) => s.window.add(dt),
            (false, true) => s.pull.add(dt),
            (true, true) => s.both.add(dt),
            (false, false) => {}
        }
    }
    let after = engine.position();
    for (a, b) in after.iter().zip(before) {
        s.steps += a.abs_diff(b);
    }
    *now = end.wrapping_add(1);
}

fn print_steps(name: &str, s: &StepStats) {
    hprintln!(
        "cost steps {} plans={} plan_mean={} plan_worst={} batches={} batch_mean={} batch_worst={} steps={} per_step={}",
        name,
        s.plan.n,
        mean(&s.plan, s.plan.n),
        worst(&s.plan),
        s.batch.n,
        mean(&s.batch, s.batch.n),
        worst(&s.batch),
        s.steps,
        s.per_step()
    );
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
    if events {
        let mut n = heapless_name(name);
        n.push_str("+events");
        print_steps(&n, &m.steps);
    } else {
        print_steps(name, &m.steps);
    }
}

/// A run's name with room for `+events`.
fn heapless_name(name: &str) -> Name {
    let mut n = Name::default();
    n.push_str(name);
    n
}

/// A short string without allocation.
#[derive(Default)]
struct Name {
    buf: [u8; 24],
    len: usize,
}

impl Name {
    fn push_str(&mut self, s: &str) {
        for b in s.bytes() {
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = b;
                self.len += 1;
            }
        }
    }
}

impl core::ops::Deref for Name {
    type Target = str;
    fn deref(&self) -> &str {
        core::str::from_utf8(self.buf.get(..self.len).unwrap_or(&[])).unwrap_or("")
    }
}

/// Three axes at 150, 120 and 105 kHz (module docs): the engine's
/// figures and its share of the core.
fn steps3x(timing_of: impl Fn(&StepConfig) -> Timing) {
    let spm = [
        StepsPerMm::from_int(1600),
        StepsPerMm::from_milli(2_000_250),
        StepsPerMm::from_int(3200),
    ];
    let mut cfg = StepConfig::new(spm[0]);
    for (a, s) in cfg.axes.iter_mut().zip(spm) {
        a.steps_per_mm = s;
    }
    let timing = timing_of(&cfg);
    // Travel per tick at full rate, I32F32 mm: rate / tick rate / steps
    // per mm.
    let per_tick = |hz: u64, s: StepsPerMm| -> i64 {
        (((hz as u128) << 48) / (TICK_HZ as u128 * s.0.max(1) as u128)) as i64
    };
    let v = [
        per_tick(150_000, spm[0]),
        per_tick(120_000, spm[1]),
        per_tick(105_000, spm[2]),
    ];
    let mut ring = PlanQueue::new();
    let shared = StepShared::new();
    let (tx, rx) = ring.split();
    let planner = Planner::new(spm, &timing, Point3Mm::ORIGIN);
    let start = planner.position();
    let mut out = Timed {
        queue: StepQueue::new(planner, tx, &shared),
        plan: Stat::default(),
    };
    let mut engine = StepEngine::new(timing, rx, &shared, start, first_window(0, timing.window));
    let mut pins = fuzzy_firmware::board::StepGpio::new();
    let mut s = StepStats::default();
    let mut now = 0u32;
    let (ramp, hold) = (50i64, 150i64);
    let mut pos = [0i64; 3];
    let ticks = 2 * ramp + hold + 3;
    for k in 0..ticks {
        let share = if k < ramp {
            k + 1
        } else if k < ramp + hold {
            ramp
        } else {
            (2 * ramp + hold - k).max(0)
        };
        for (p, vi) in pos.iter_mut().zip(v) {
            *p += vi * share / ramp;
        }
        out.update(Point3Mm::from_bits(pos[0], pos[1], pos[2]));
        run_window(&mut engine, &mut pins, &mut now, timing.window, &mut s);
    }
    s.plan = out.plan;
    let r = out.report();
    // The engine's share of the core over the run's duration.
    let per_s = qemu_instructions(s.batch.total) * TICK_HZ as u64 / ticks as u64;
    hprintln!(
        "cost steps3x rates_khz=150,120,105 ticks={} steps={} batches={} batch_mean={} batch_worst={} window_batch_mean={} window_batches={} pull_batch_mean={} pull_batches={} both_batch_mean={} both_batches={} per_step={} plan_mean={} plan_worst={} lag_ticks={} engine_permille={}",
        ticks,
        s.steps,
        s.batch.n,
        mean(&s.batch, s.batch.n),
        worst(&s.batch),
        mean(&s.window, s.window.n),
        s.window.n,
        mean(&s.pull, s.pull.n),
        s.pull.n,
        mean(&s.both, s.both.n),
        s.both.n,
        s.per_step(),
        mean(&s.plan, s.plan.n),
        worst(&s.plan),
        r.lag_ticks,
        per_s / 168_000
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
    let timing_of = |c: &StepConfig| match c.timing(STEP_TIMER_HZ, TICK_HZ) {
        Ok(t) => t,
        Err(_) => fuzzy_firmware::fail(),
    };
    let timing = timing_of(&STEP_CONFIG);
    let mut plans = PlanQueue::new();
    let step_shared = StepShared::new();
    let (plan_tx, plan_rx) = plans.split();
    let planner = Planner::new(
        STEP_CONFIG.axes.map(|a| a.steps_per_mm),
        &timing,
        Point3Mm::ORIGIN,
    );
    let start = planner.position();
    let mut out = Timed {
        queue: StepQueue::new(planner, plan_tx, &step_shared),
        plan: Stat::default(),
    };
    let mut engine = StepEngine::new(
        timing,
        plan_rx,
        &step_shared,
        start,
        first_window(0, timing.window),
    );
    let mut pins = board.step_pins;
    let mut vnow = 0u32;
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
        let mut steps = StepStats::default();
        out.plan = Stat::default();
        let r = replay.run(config, path, events, &mut SysTick, |m, t| {
            // What the background does with a generated tick ...
            let _ = ring_tx.enqueue(Setpoint::of(m, t));
            // ... what the tick interrupt does with it ...
            let t0 = isr_clock.now();
            exec.tick(&mut ring_rx, &mut out);
            let dt = isr_clock.since(t0);
            exec.worst_cycles = exec.worst_cycles.max(dt);
            isr.add(dt);
            // ... and what the step timer's interrupts then do.
            run_window(&mut engine, &mut pins, &mut vnow, timing.window, &mut steps);
        });
        steps.plan = out.plan;
        let Ok(r) = r else {
            hprintln!("cost {}: {:?}", name, r.err());
            fuzzy_firmware::fail()
        };
        let m = Measured { r, isr, steps };
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
    let mut steps_all = line.steps;
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
        steps_all.merge(&m.steps);
    }
    let [sched, push, gen, isr, ov] = all;
    let st = &steps_all;
    hprintln!(
        "cost all sched_mean={} sched_worst={} push_mean={} push_worst={} gen_mean={} gen_worst={} isr_mean={} isr_worst={} override_worst={} plan_mean={} plan_worst={} step_batch_mean={} step_batch_worst={} step_per_step={} feed_sum={}",
        mean(&sched, points_all),
        worst(&sched),
        mean(&push, push.n),
        worst(&push),
        mean(&gen, gen.n),
        worst(&gen),
        mean(&isr, isr.n),
        worst(&isr),
        worst(&ov),
        mean(&st.plan, st.plan.n),
        worst(&st.plan),
        mean(&st.batch, st.batch.n),
        worst(&st.batch),
        st.per_step(),
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
    steps3x(timing_of);
    let mut probe = measure::StackProbe::new();
    hprintln!("cost stack_bytes={}", probe.full_scan());
    fuzzy_firmware::exit_success()
}
