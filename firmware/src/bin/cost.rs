//! Cost benchmark: instructions per scheduled point and per interpolator
//! tick, on the three recorded shapes, run under QEMU with `-icount
//! shift=0` (one instruction per ns; SysTick at 168 MHz counts 168 per 1000
//! instructions).
//!
//! It runs the firmware's own code paths ([`motion::Feeder`] and
//! [`motion::tick`]) without interrupts, so nothing else is counted:
//! Means are per scheduled point (total over the shape / its points),
//! worsts per call.
//! - `sched`: `Scheduler::push` / `drain` alone (the fuzzy-core pipeline:
//!   curvature, lookahead, controller, filter); the budget figure;
//! - `point`: the whole feeder step per point (scheduler + segment
//!   preparation for the interpolator);
//! - `tick`: one interpolator tick (segment intake, hold/resume/override,
//!   interpolation, step/dir pulses), the whole shape driven to the end,
//!   with a feed hold, an override change and a starved stretch on the way.
//!
//! Output: one line per shape and a summary, plain text on semihosting
//! stdout (no defmt: this binary logs nothing else), e.g.
//! `cost infinity points=2001 sched_mean=… sched_worst=… point_mean=… tick_worst=…`.
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use fuzzy_core::scheduler::PathPoint;
use fuzzy_core::units::Point3Mm;
use fuzzy_firmware::config::{SEG_QUEUE, STEPS_PER_MM};
use fuzzy_firmware::measure::{self, cycles, cycles_since, qemu_instructions};
use fuzzy_firmware::motion::{self, Cmd, Controls, Feeder, Interp, Output, SegItem, INTERP_CONFIG};
use fuzzy_firmware::stepper::Axes;
use heapless::spsc::Queue;

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

#[derive(Default, Clone, Copy)]
struct Stat {
    total: u64,
    worst: u32,
    n: u32,
}

impl Stat {
    fn add(&mut self, cycles: u32) {
        self.total += cycles as u64;
        self.worst = self.worst.max(cycles);
        self.n += 1;
    }
    /// Mean per scheduled point: the pushes that released nothing and the
    /// drains at the end count towards the points they led to.
    fn mean_instr(&self, points: u32) -> u64 {
        qemu_instructions(self.total) / (points.max(1) as u64)
    }
    fn worst_instr(&self) -> u64 {
        qemu_instructions(self.worst as u64)
    }
}

fn point(c: &[u8], tag: u32) -> PathPoint {
    let mut w = [0i64; 3];
    for (i, v) in w.iter_mut().enumerate() {
        let mut b = [0u8; 8];
        b.copy_from_slice(&c[i * 8..i * 8 + 8]);
        *v = i64::from_le_bytes(b);
    }
    PathPoint {
        pos: Point3Mm::from_bits(w[0], w[1], w[2]),
        feed_cap: None,
        tag,
    }
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
    // Each shape starts where the previous one ended (as on a machine).
    let mut start = Point3Mm::ORIGIN;
    let mut all_points = 0u32;

    // 1. The scheduler alone, per point (push, then drain at the end).
    let (mut all_sched, mut all_point, mut all_tick) =
        (Stat::default(), Stat::default(), Stat::default());
    let mut feed_sum: i64 = 0;
    for (name, data) in SHAPES.iter() {
        let Ok(mut feeder) = Feeder::new(Point3Mm::ORIGIN) else {
            fuzzy_firmware::fail()
        };
        let mut sched = Stat::default();
        let s = feeder.scheduler_mut();
        for (i, c) in data.chunks_exact(24).enumerate() {
            let p = point(c, i as u32);
            let t0 = cycles();
            let r = s.push(p);
            let dt = cycles_since(t0);
            sched.add(dt);
            if let Ok(Some(o)) = r {
                feed_sum = feed_sum.wrapping_add(o.feed.0.to_bits());
            }
        }
        s.finish();
        loop {
            let t0 = cycles();
            let r = s.drain();
            let dt = cycles_since(t0);
            let Some(o) = r else { break };
            sched.add(dt);
            feed_sum = feed_sum.wrapping_add(o.feed.0.to_bits());
        }

        // 2. The feeder (scheduler + segment preparation) and the tick,
        //    interleaved as in the firmware: the feeder fills the segment
        //    queue, the tick empties it.
        let Ok(mut feeder) = Feeder::new(start) else {
            fuzzy_firmware::fail()
        };
        let Ok(mut interp) = Interp::new(INTERP_CONFIG, start) else {
            fuzzy_firmware::fail()
        };
        let mut q: Queue<SegItem, SEG_QUEUE> = Queue::new();
        let (mut seg_tx, mut seg_rx) = q.split();
        let mut controls = Controls::default();
        let (mut pstat, mut tstat) = (Stat::default(), Stat::default());
        let points = data.len() / 24;
        let mut next = 0usize;
        let mut ended = false;
        let mut t = 0u32;
        let mut starve_until = 0u32;
        loop {
            // Events: hold at 1.5 s for 0.5 s, override 150 % then 50 %,
            // and a starved stretch (no new points for 0.4 s) at 4 s.
            match t {
                1500 => controls.hold = Some(true),
                2000 => controls.hold = Some(false),
                2500 => controls.override_percent = Some(150),
                3500 => controls.override_percent = Some(50),
                4000 => starve_until = 4400,
                4500 => controls.override_percent = Some(100),
                _ => {}
            }
            while seg_tx.ready() && t >= starve_until && !ended {
                let t0 = cycles();
                let out = if feeder.is_draining() {
                    feeder.drain()
                } else if next < points {
                    let p = point(&data[next * 24..next * 24 + 24], next as u32);
                    next += 1;
                    feeder.command(Cmd::Point(p)).unwrap_or(Output::Nothing)
                } else {
                    let _ = feeder.command(Cmd::EndPath);
                    Output::Nothing
                };
                let dt = cycles_since(t0);
                match out {
                    Output::Point(_, item) => {
                        pstat.add(dt);
                        let _ = seg_tx.enqueue(item);
                    }
                    Output::PathEnd => {
                        let _ = seg_tx.enqueue(SegItem::EndOfPath);
                        ended = true;
                    }
                    Output::Nothing => {
                        if next < points || feeder.is_draining() {
                            pstat.add(dt);
                        }
                    }
                }
            }
            let t0 = cycles();
            motion::tick(&mut interp, &mut seg_rx, &mut controls, &mut axes);
            tstat.add(cycles_since(t0));
            t += 1;
            if ended && interp.state() == fuzzy_core::interpolator::MotionState::Idle {
                break;
            }
            if t > 10_000_000 {
                fuzzy_firmware::fail()
            }
        }
        start = interp.position();
        let c = interp.counters();
        let n = points as u32;
        all_points += n;
        hprintln!(
            "cost {} points={} sched_mean={} sched_worst={} point_mean={} point_worst={} ticks={} tick_worst={} underruns={} lag={}",
            name,
            n,
            sched.mean_instr(n),
            sched.worst_instr(),
            pstat.mean_instr(n),
            pstat.worst_instr(),
            tstat.n,
            tstat.worst_instr(),
            c.underruns,
            axes.lag_events()
        );
        all_sched.total += sched.total;
        all_sched.n += sched.n;
        all_sched.worst = all_sched.worst.max(sched.worst);
        all_point.total += pstat.total;
        all_point.n += pstat.n;
        all_point.worst = all_point.worst.max(pstat.worst);
        all_tick.worst = all_tick.worst.max(tstat.worst);
        all_tick.total += tstat.total;
        all_tick.n += tstat.n;
    }
    hprintln!(
        "cost all sched_mean={} sched_worst={} point_mean={} point_worst={} tick_mean={} tick_worst={} feed_checksum={}",
        all_sched.mean_instr(all_points),
        all_sched.worst_instr(),
        all_point.mean_instr(all_points),
        all_point.worst_instr(),
        all_tick.mean_instr(all_tick.n),
        all_tick.worst_instr(),
        feed_sum
    );
    let mut probe = measure::StackProbe::new();
    hprintln!("cost stack_bytes={}", probe.full_scan());
    fuzzy_firmware::exit_success()
}
