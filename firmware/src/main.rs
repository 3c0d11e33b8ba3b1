//! The motion controller: an RTIC 1.x application.
//!
//! | task | runs on | priority | does |
//! |---|---|---|---|
//! | `tick` | SysTick (default 1 kHz) | 3 (highest) | next setpoint from the ring to the step/dir outputs |
//! | `link_rx` | USART1 receive | 2 | frames → commands (credit-checked), hold/resume/override requests, force samples, status |
//! | `idle` | background | 0 | force loop (Njiri et al.: a force sample → feed override), scheduler (lookahead, fuzzy feed), velocity planner, ticks generated ahead into the ring, transmit, stack probe |
//!
//! Queues (`ring`, lock-free): commands link → idle (its free room
//! is the host's credit), setpoints idle → tick (the planner runs up to
//! `SETPOINT_RING − 1` ticks ahead). The transmit buffer is a shared
//! resource (link and idle write replies, idle sends them).
#![no_std]
#![no_main]

use fuzzy_firmware as _;

#[rtic::app(device = stm32f4::stm32f405, peripherals = true)]
mod app {
    use core::mem::MaybeUninit;

    use fuzzy_core::planner::MotionState;
    use fuzzy_core::units::Point3Mm;
    use fuzzy_firmware::board::{self, Pin, UsartRx, UsartTx};
    use fuzzy_firmware::config::{
        CMD_CREDIT, CMD_QUEUE, CREDIT_BATCH, FEED_MAX_MM_PER_MIN, PLANNER_POINTS, SETPOINT_RING,
        STEPS_PER_MM, TICK_HZ, TX_BUFFER,
    };
    use fuzzy_firmware::measure::{self, StackProbe};
    use fuzzy_firmware::motion::{
        config_from_link, force_from_link, new_plan, point_from_link, Cmd, Controls, Executor,
        Feeder, ForceLoop, Output, Plan, PlanInput, Planner, Setpoint,
    };
    use fuzzy_firmware::ring::{Consumer, Producer, Ring};
    use fuzzy_firmware::stepper::Axes;
    use heapless::Deque;
    use link::{DeviceMsg, ErrorCode, FrameReader, HostMsg, Motion, Status};
    use rtic::Mutex;

    /// What idle publishes for status replies.
    #[derive(Clone, Copy, Default, PartialEq, Eq)]
    pub struct IdleInfo {
        /// Points in the scheduler's lookahead.
        points_held: u16,
        /// Points in the planner.
        planned: u16,
        /// The planner's path index.
        point: u32,
        underruns: u32,
        override_percent: u16,
        /// Stack high-water mark, bytes.
        stack: u32,
        /// Setpoints generated since boot.
        generated: u32,
        /// Checksum of their positions.
        checksum: u32,
    }

    /// Link sequence state (written by `link_rx`, read by idle).
    ///
    /// The credit needs no queue length: every accepted command holds a
    /// slot until idle takes it, so the host may send up to
    /// `taken + capacity` (exclusive).
    #[derive(Clone, Copy, Default)]
    pub struct LinkState {
        next_seq: u32,
        /// Commands idle took from the queue.
        taken: u32,
        bad_frames: u32,
        tx_dropped: u32,
    }

    #[shared]
    struct Shared {
        tx: Deque<u8, TX_BUFFER>,
        controls: Controls,
        /// The tick's state and counters (read for status replies).
        exec: Executor,
        link_state: LinkState,
        idle_info: IdleInfo,
    }

    #[local]
    struct Local {
        sp_rx: Consumer<'static, Setpoint, SETPOINT_RING>,
        axes: Axes<Pin, Pin>,
        rx: UsartRx,
        reader: FrameReader,
        cmd_tx: Producer<'static, Cmd, CMD_QUEUE>,
        tx_port: UsartTx,
        cmd_rx: Consumer<'static, Cmd, CMD_QUEUE>,
        sp_tx: Producer<'static, Setpoint, SETPOINT_RING>,
        feeder: Feeder,
        planner: Planner,
    }

    #[init(local = [
        cmds: Ring<Cmd, CMD_QUEUE> = Ring::new(),
        setpoints: Ring<Setpoint, SETPOINT_RING> = Ring::new(),
        plan: MaybeUninit<Plan> = MaybeUninit::uninit(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local, init::Monotonics) {
        let mut core = cx.core;
        let b = board::init(cx.device);
        let (cmd_tx, cmd_rx) = cx.local.cmds.split();
        if (cmd_tx.capacity() as u32) < CMD_CREDIT {
            defmt::error!("command queue smaller than the credit");
            fuzzy_firmware::fail()
        }
        let (mut sp_tx, sp_rx) = cx.local.setpoints.split();
        let plan = match new_plan(cx.local.plan) {
            Ok(p) => p,
            Err(e) => {
                defmt::error!("bad planner settings: {}", e);
                fuzzy_firmware::fail()
            }
        };
        let accel_bits = plan.accel_limit_mm_s2().to_bits();
        let Ok(mut planner) = Planner::new(plan, Point3Mm::ORIGIN) else {
            defmt::error!("planner refused the start point");
            fuzzy_firmware::fail()
        };
        let Ok(feeder) = Feeder::new() else {
            defmt::error!("bad scheduler settings");
            fuzzy_firmware::fail()
        };
        // Setpoints ready before the first tick.
        planner.fill(&mut sp_tx);
        // mm/s², rounded up (the limit, for the host's checks).
        let accel =
            ((accel_bits.max(0) as u64 + u32::MAX as u64) >> 32).min(u32::MAX as u64) as u32;
        let mut tx = Deque::new();
        let window_end = CMD_CREDIT;
        send(
            &mut tx,
            &DeviceMsg::Hello {
                tick_hz: TICK_HZ,
                accel_mm_per_s2: accel,
                window_end,
                feed_max_mm_per_min: FEED_MAX_MM_PER_MIN,
                planner_points: PLANNER_POINTS as u16,
            },
            0,
        );
        measure::set_tick_period_us(1_000_000 / TICK_HZ);
        measure::start_tick_timer(&mut core.SYST, TICK_HZ);
        defmt::info!(
            "fuzzy feed controller: tick {=u32} Hz, accel {=u32} mm/s2, feed max {=u32} mm/min, planner {=usize} points, credit {=u32}",
            TICK_HZ,
            accel,
            FEED_MAX_MM_PER_MIN,
            PLANNER_POINTS,
            window_end
        );
        (
            Shared {
                tx,
                controls: Controls::default(),
                exec: Executor::new(Point3Mm::ORIGIN),
                link_state: LinkState::default(),
                idle_info: IdleInfo {
                    override_percent: 100,
                    ..IdleInfo::default()
                },
            },
            Local {
                sp_rx,
                axes: Axes::new(b.axes, STEPS_PER_MM, Point3Mm::ORIGIN),
                rx: b.rx,
                reader: FrameReader::new(),
                cmd_tx,
                tx_port: b.tx,
                cmd_rx,
                sp_tx,
                feeder,
                planner,
            },
            init::Monotonics(),
        )
    }

    /// Encode `msg` into the transmit buffer, leaving `keep` bytes free;
    /// `false` (nothing queued) if it does not fit.
    fn send(tx: &mut Deque<u8, TX_BUFFER>, msg: &DeviceMsg, keep: usize) -> bool {
        let mut frame = [0u8; link::FRAME_MAX];
        let Ok(n) = link::encode_device(msg, &mut frame) else {
            return false;
        };
        if tx.capacity() - tx.len() < n + keep {
            return false;
        }
        for b in frame.iter().take(n) {
            let _ = tx.push_back(*b);
        }
        true
    }

    /// Transmit room link_rx leaves to idle: idle's reports of what the
    /// planner took (at most two `Planned` or one `Scheduled`, 32 bytes
    /// each at most) must never be dropped, or the host could not replay
    /// the planner's inputs.
    const IDLE_RESERVE: usize = 64;

    /// Send what the planner took (room was checked: [`IDLE_RESERVE`]).
    fn report(sh: &mut idle::SharedResources, input: PlanInput) {
        let msg = input.to_msg();
        if !sh.tx.lock(|tx| send(tx, &msg, 0)) {
            defmt::error!("planner report dropped");
        }
    }

    /// The tick: highest priority, every timer period. Only the next
    /// setpoint (generated ahead by idle) to the outputs.
    #[task(binds = SysTick, priority = 3, local = [sp_rx, axes], shared = [exec])]
    fn tick(mut cx: tick::Context) {
        let t0 = measure::cycles_in_period();
        let local = cx.local;
        // The highest priority: no actual lock.
        cx.shared.exec.lock(|e| {
            e.tick(local.sp_rx, local.axes);
            // From entry to here (the wake-up latency is not the tick's
            // cost, and under QEMU's -icount it depends on host timing).
            let dt = measure::cycles_in_period_since(t0);
            e.worst_cycles = e.worst_cycles.max(dt);
        });
        measure::count_tick();
    }

    /// The link receiver: every byte, frames decoded as they complete.
    #[task(binds = USART1, priority = 2, local = [rx, reader, cmd_tx], shared = [tx, controls, exec, link_state, idle_info])]
    fn link_rx(cx: link_rx::Context) {
        let local = cx.local;
        let mut sh = cx.shared;
        while let Some(byte) = local.rx.read() {
            let Some(frame) = local.reader.push::<HostMsg>(byte) else {
                continue;
            };
            let reply = match frame {
                Ok(msg) => handle(msg, local.cmd_tx, &mut sh),
                Err(code) => Err(code),
            };
            let reply = match reply {
                Ok(r) => r,
                Err(code) => {
                    let expected_seq = sh.link_state.lock(|l| {
                        l.bad_frames = l.bad_frames.wrapping_add(1);
                        l.next_seq
                    });
                    defmt::warn!("frame refused: {}", code);
                    DeviceMsg::Error { code, expected_seq }
                }
            };
            let sent = sh.tx.lock(|tx| send(tx, &reply, IDLE_RESERVE));
            if !sent {
                sh.link_state
                    .lock(|l| l.tx_dropped = l.tx_dropped.wrapping_add(1));
            }
        }
    }

    /// One decoded message: queue it or act on it; the reply.
    fn handle(
        msg: HostMsg,
        cmd_tx: &mut Producer<'static, Cmd, CMD_QUEUE>,
        sh: &mut link_rx::SharedResources,
    ) -> Result<DeviceMsg, ErrorCode> {
        let queued = match msg {
            HostMsg::StatusQuery => return Ok(status(sh)),
            HostMsg::Hold | HostMsg::Resume => {
                let hold = matches!(msg, HostMsg::Hold);
                sh.controls.lock(|c| c.hold = Some(hold));
                defmt::info!("{}", if hold { "feed hold" } else { "resume" });
                return Ok(ack(sh));
            }
            HostMsg::Override { percent } => {
                if !(link::OVERRIDE_MIN_PERCENT..=link::OVERRIDE_MAX_PERCENT).contains(&percent) {
                    return Err(ErrorCode::OutOfRange);
                }
                sh.controls.lock(|c| c.override_percent = Some(percent));
                defmt::info!("feed override {=u16} %", percent);
                return Ok(ack(sh));
            }
            HostMsg::Force { fx_n_q16, fy_n_q16 } => {
                let Some(f) = force_from_link(fx_n_q16, fy_n_q16) else {
                    return Err(ErrorCode::OutOfRange);
                };
                sh.controls.lock(|c| c.force = Some(f));
                return Ok(ack(sh));
            }
            HostMsg::StartPath {
                seq,
                f_max_mm_per_min,
                f_min_mm_per_min,
            } => (
                seq,
                config_from_link(f_max_mm_per_min, f_min_mm_per_min).map(Cmd::StartPath),
            ),
            HostMsg::Point {
                seq,
                pos_mm,
                feed_cap_mm_per_min,
            } => (
                seq,
                point_from_link(seq, pos_mm, feed_cap_mm_per_min).map(Cmd::point),
            ),
            HostMsg::EndPath { seq } => (seq, Some(Cmd::EndPath)),
        };
        let (seq, cmd) = queued;
        let next = sh.link_state.lock(|l| l.next_seq);
        if seq < next {
            // A resend of something we have: acknowledge again.
            return Ok(ack(sh));
        }
        if seq > next {
            return Err(ErrorCode::OutOfSequence);
        }
        let Some(cmd) = cmd else {
            return Err(ErrorCode::OutOfRange);
        };
        if cmd_tx.enqueue(cmd).is_err() {
            return Err(ErrorCode::NoCredit);
        }
        sh.link_state
            .lock(|l| l.next_seq = l.next_seq.wrapping_add(1));
        Ok(ack(sh))
    }

    /// The credit limit (exclusive).
    fn window_end(l: &LinkState) -> u32 {
        l.taken.wrapping_add(CMD_CREDIT)
    }

    fn ack(sh: &mut link_rx::SharedResources) -> DeviceMsg {
        sh.link_state.lock(|l| DeviceMsg::Ack {
            next_seq: l.next_seq,
            window_end: window_end(l),
        })
    }

    fn status(sh: &mut link_rx::SharedResources) -> DeviceMsg {
        let s = sh.exec.lock(|e| *e);
        let l = sh.link_state.lock(|l| *l);
        let i = sh.idle_info.lock(|i| *i);
        DeviceMsg::Status(Status {
            motion: match s.now.state {
                MotionState::Idle | MotionState::Done => Motion::Idle,
                MotionState::Moving => Motion::Running,
                MotionState::Holding => Motion::Held,
                MotionState::Starved => Motion::Starved,
            },
            pos_mm: s.now.pos.to_bits(),
            feed_mm_per_min: s.now.feed().0.to_bits(),
            override_percent: i.override_percent,
            next_seq: l.next_seq,
            window_end: window_end(&l),
            planned_points: i.planned,
            points_held: i.points_held,
            point_reached: i.point,
            underruns: i.underruns,
            bad_frames: l.bad_frames,
            worst_tick_cycles: s.worst_cycles,
            stack_used_bytes: i.stack,
            ticks: s.ticks,
            moving_ticks: s.moving_ticks,
            empty_ticks: s.empty_ticks,
            generated_ticks: i.generated,
            positions_checksum: i.checksum,
        })
    }

    /// Background: the scheduler, the planner (ticks generated ahead into
    /// the ring), the transmitter, the stack probe.
    #[idle(local = [cmd_rx, sp_tx, tx_port, feeder, planner, probe: StackProbe = StackProbe::new()], shared = [tx, controls, link_state, idle_info])]
    fn idle(cx: idle::Context) -> ! {
        let local = cx.local;
        let mut sh = cx.shared;
        let (feeder, planner) = (local.feeder, local.planner);
        let mut taken_since_ack = 0u32;
        let mut last_info = IdleInfo::default();
        // Njiri et al.'s force loop: small, so on this stack, not static.
        let Ok(mut force_loop) = ForceLoop::new() else {
            defmt::error!("bad force loop settings");
            fuzzy_firmware::fail()
        };
        loop {
            let mut busy = false;

            // 1. Transmit what is waiting (as fast as the USART takes it).
            let pending = sh.tx.lock(|tx| {
                while let Some(&b) = tx.front() {
                    if !local.tx_port.try_write(b) {
                        break;
                    }
                    tx.pop_front();
                }
                tx.len()
            });

            // Room for what the planner takes next (link_rx leaves
            // IDLE_RESERVE bytes to idle, so a report always fits).
            let room = sh.tx.lock(|tx| tx.capacity() - tx.len() >= IDLE_RESERVE);

            // 2. Hold, resume, override, force samples (they reach the
            //    tool after the setpoints already in the ring).
            if room {
                let mut c = sh.controls.lock(core::mem::take);
                force_loop.apply(&mut c);
                if c != Controls::default() {
                    for input in planner.apply(c).into_iter().flatten() {
                        report(&mut sh, input);
                    }
                }
            }

            // 3. Keep the ring full.
            planner.fill(local.sp_tx);

            // 4. A scheduled point into the planner, or one scheduler step.
            if room && planner.waiting() {
                match planner.push_pending() {
                    Ok(Some(input)) => {
                        busy = true;
                        report(&mut sh, input);
                    }
                    Ok(None) => {}
                    Err(e) => defmt::error!("planner refused a point: {}", e),
                }
            } else if room {
                let out = if feeder.is_draining() {
                    busy = true;
                    feeder.drain()
                } else if let Some(cmd) = local.cmd_rx.dequeue() {
                    busy = true;
                    taken_since_ack += 1;
                    sh.link_state.lock(|l| l.taken = l.taken.wrapping_add(1));
                    match feeder.command(cmd) {
                        Ok(o) => o,
                        Err(e) => {
                            // Cannot happen: the link checks every value.
                            defmt::error!("scheduler refused {}: {}", cmd, e);
                            Output::Nothing
                        }
                    }
                } else {
                    Output::Nothing
                };
                if out == Output::PathEnd {
                    defmt::info!("path scheduled");
                }
                match planner.take(out) {
                    Ok(Some(input)) => report(&mut sh, input),
                    Ok(None) => {}
                    Err(e) => defmt::error!("planner refused a point: {}", e),
                }
            }

            // 5. Credit: tell the host about freed queue slots.
            if taken_since_ack >= CREDIT_BATCH || (taken_since_ack > 0 && !busy) {
                let msg = sh.link_state.lock(|l| DeviceMsg::Ack {
                    next_seq: l.next_seq,
                    window_end: window_end(l),
                });
                if sh.tx.lock(|tx| send(tx, &msg, 0)) {
                    taken_since_ack = 0;
                }
            }

            // 6. Stack high-water mark (a little at a time), figures for
            //    the status.
            let info = IdleInfo {
                points_held: feeder.held() as u16,
                planned: planner.planned() as u16,
                point: planner.point_reached(),
                underruns: planner.underruns(),
                override_percent: planner.override_percent(),
                stack: local.probe.step(256),
                generated: planner.generated(),
                checksum: planner.checksum32(),
            };
            if info != last_info {
                last_info = info;
                sh.idle_info.lock(|i| *i = info);
            }

            // Sleep until an interrupt when there is nothing to do (a tick
            // frees a ring slot, a byte brings a command).
            if !busy && pending == 0 && !local.cmd_rx.ready() && !local.sp_tx.ready() {
                rtic::export::wfi();
            }
        }
    }
}
