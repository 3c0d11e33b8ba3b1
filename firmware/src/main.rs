//! The motion controller: an RTIC 1.x application.
//!
//! | task | runs on | priority | does |
//! |---|---|---|---|
//! | `tick` | SysTick (default 1 kHz) | 3 (highest) | interpolator step, step/dir outputs |
//! | `link_rx` | USART1 receive | 2 | frames → commands (credit-checked), immediate hold/resume/override, status |
//! | `idle` | background | 0 | scheduler (lookahead, fuzzy feed), segment preparation, transmit, stack probe |
//!
//! Queues (`heapless::spsc`, lock-free): commands link → idle (its free room
//! is the host's credit), segments idle → tick. The transmit buffer is a
//! shared resource (link and idle write replies, idle sends them).
#![no_std]
#![no_main]

use fuzzy_firmware as _;

#[rtic::app(device = stm32f4::stm32f405, peripherals = true)]
mod app {
    use fuzzy_core::interpolator::MotionState;
    use fuzzy_core::units::Point3Mm;
    use fuzzy_firmware::board::{self, Pin, UsartRx, UsartTx};
    use fuzzy_firmware::config::{
        CMD_CREDIT, CMD_QUEUE, CREDIT_BATCH, SEG_QUEUE, STEPS_PER_MM, TICK_HZ, TX_BUFFER,
    };
    use fuzzy_firmware::measure::{self, StackProbe};
    use fuzzy_firmware::motion::{
        self, config_from_link, point_from_link, Cmd, Controls, Feeder, Interp, Output, SegItem,
        INTERP_CONFIG,
    };
    use fuzzy_firmware::stepper::Axes;
    use heapless::spsc::{Consumer, Producer, Queue};
    use heapless::Deque;
    use link::{DeviceMsg, ErrorCode, FrameReader, HostMsg, Motion, Status};
    use rtic::Mutex;

    /// What the tick publishes for status replies.
    #[derive(Clone, Copy, Default)]
    pub struct Snapshot {
        pos: [i64; 3],
        feed_bits: i64,
        state: MotionState,
        override_percent: u16,
        queued: u16,
        done: u32,
        underruns: u32,
        ticks: u32,
        worst_tick_cycles: u32,
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
        snapshot: Snapshot,
        link_state: LinkState,
        /// Points in the scheduler's lookahead, stack high-water mark.
        idle_info: (u16, u32),
    }

    #[local]
    struct Local {
        interp: Interp,
        seg_rx: Consumer<'static, SegItem>,
        axes: Axes<Pin, Pin>,
        rx: UsartRx,
        reader: FrameReader,
        cmd_tx: Producer<'static, Cmd>,
        tx_port: UsartTx,
        cmd_rx: Consumer<'static, Cmd>,
        seg_tx: Producer<'static, SegItem>,
        feeder: Feeder,
    }

    #[init(local = [
        cmds: Queue<Cmd, CMD_QUEUE> = Queue::new(),
        segs: Queue<SegItem, SEG_QUEUE> = Queue::new(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local, init::Monotonics) {
        let mut core = cx.core;
        let b = board::init(cx.device);
        let (cmd_tx, cmd_rx) = cx.local.cmds.split();
        if (cmd_tx.capacity() as u32) < CMD_CREDIT {
            defmt::error!("command queue smaller than the credit");
            fuzzy_firmware::fail()
        }
        let (seg_tx, seg_rx) = cx.local.segs.split();
        let Ok(interp) = Interp::new(INTERP_CONFIG, Point3Mm::ORIGIN) else {
            defmt::error!("bad interpolator settings {}", INTERP_CONFIG);
            fuzzy_firmware::fail()
        };
        let Ok(feeder) = Feeder::new(Point3Mm::ORIGIN) else {
            defmt::error!("bad scheduler settings");
            fuzzy_firmware::fail()
        };
        let mut tx = Deque::new();
        let window_end = CMD_CREDIT;
        send(
            &mut tx,
            &DeviceMsg::Hello {
                tick_hz: TICK_HZ,
                accel_mm_per_s2: INTERP_CONFIG.accel_mm_per_s2,
                window_end,
            },
        );
        measure::set_tick_period_us(1_000_000 / TICK_HZ);
        measure::start_tick_timer(&mut core.SYST, TICK_HZ);
        defmt::info!(
            "fuzzy feed controller: tick {=u32} Hz, accel {=u32} mm/s2, credit {=u32}",
            TICK_HZ,
            INTERP_CONFIG.accel_mm_per_s2,
            window_end
        );
        (
            Shared {
                tx,
                controls: Controls::default(),
                snapshot: Snapshot {
                    override_percent: 100,
                    ..Snapshot::default()
                },
                link_state: LinkState::default(),
                idle_info: (0, 0),
            },
            Local {
                interp,
                seg_rx,
                axes: Axes::new(b.axes, STEPS_PER_MM, Point3Mm::ORIGIN),
                rx: b.rx,
                reader: FrameReader::new(),
                cmd_tx,
                tx_port: b.tx,
                cmd_rx,
                seg_tx,
                feeder,
            },
            init::Monotonics(),
        )
    }

    /// Encode `msg` into the transmit buffer; `false` (nothing queued) if it
    /// does not fit.
    fn send(tx: &mut Deque<u8, TX_BUFFER>, msg: &DeviceMsg) -> bool {
        let mut frame = [0u8; link::FRAME_MAX];
        let Ok(n) = link::encode(msg, &mut frame) else {
            return false;
        };
        if tx.capacity() - tx.len() < n {
            return false;
        }
        for b in frame.iter().take(n) {
            let _ = tx.push_back(*b);
        }
        true
    }

    /// The interpolator: highest priority, every timer period.
    #[task(binds = SysTick, priority = 3, local = [interp, seg_rx, axes, worst: u32 = 0], shared = [controls, snapshot])]
    fn tick(cx: tick::Context) {
        let t0 = measure::cycles_in_period();
        let local = cx.local;
        let (mut controls, mut snapshot) = (cx.shared.controls, cx.shared.snapshot);
        let r = controls.lock(|c| motion::tick(local.interp, local.seg_rx, c, local.axes));
        let ip = &*local.interp;
        let c = ip.counters();
        // From entry to here (the wake-up latency is not the tick's cost,
        // and under QEMU's -icount it depends on host timing).
        let dt = measure::cycles_in_period_since(t0);
        if dt > *local.worst {
            *local.worst = dt;
        }
        let worst = *local.worst;
        snapshot.lock(|s| {
            s.pos = r.position.to_bits();
            s.feed_bits = ip.feed().0.to_bits();
            s.state = ip.state();
            s.override_percent = ip.override_percent();
            s.queued = ip.queued() as u16;
            s.done = c.completed;
            s.underruns = c.underruns;
            s.ticks = c.ticks;
            s.worst_tick_cycles = worst;
        });
        measure::count_tick();
    }

    /// The link receiver: every byte, frames decoded as they complete.
    #[task(binds = USART1, priority = 2, local = [rx, reader, cmd_tx], shared = [tx, controls, snapshot, link_state, idle_info])]
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
            let sent = sh.tx.lock(|tx| send(tx, &reply));
            if !sent {
                sh.link_state
                    .lock(|l| l.tx_dropped = l.tx_dropped.wrapping_add(1));
            }
        }
    }

    /// One decoded message: queue it or act on it; the reply.
    fn handle(
        msg: HostMsg,
        cmd_tx: &mut Producer<'static, Cmd>,
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
                point_from_link(seq, pos_mm, feed_cap_mm_per_min).map(Cmd::Point),
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
        let s = sh.snapshot.lock(|s| *s);
        let l = sh.link_state.lock(|l| *l);
        let (held, stack) = sh.idle_info.lock(|i| *i);
        DeviceMsg::Status(Status {
            motion: match s.state {
                MotionState::Idle => Motion::Idle,
                MotionState::Running => Motion::Running,
                MotionState::Held => Motion::Held,
                MotionState::Starved => Motion::Starved,
            },
            pos_mm: s.pos,
            feed_mm_per_min: s.feed_bits,
            override_percent: s.override_percent,
            next_seq: l.next_seq,
            window_end: window_end(&l),
            segments_queued: s.queued,
            points_held: held,
            segments_done: s.done,
            underruns: s.underruns,
            bad_frames: l.bad_frames,
            worst_tick_cycles: s.worst_tick_cycles,
            stack_used_bytes: stack,
            ticks: s.ticks,
        })
    }

    /// Background: the scheduler, the transmitter, the stack probe.
    #[idle(local = [cmd_rx, seg_tx, tx_port, feeder, probe: StackProbe = StackProbe::new()], shared = [tx, link_state, idle_info])]
    fn idle(cx: idle::Context) -> ! {
        let local = cx.local;
        let mut sh = cx.shared;
        let feeder = local.feeder;
        let mut taken_since_ack = 0u32;
        let mut last_state = (0u16, 0u32);
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

            // 2. One scheduler step, if there is room for its output.
            let room = sh
                .tx
                .lock(|tx| tx.capacity() - tx.len() >= 2 * link::FRAME_MAX);
            if room && local.seg_tx.ready() {
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
                match out {
                    Output::Point(s, item) => {
                        let _ = local.seg_tx.enqueue(item);
                        let report = DeviceMsg::Scheduled {
                            seq: s.point.tag,
                            index: s.index,
                            feed_mm_per_min: s.feed.0.to_bits(),
                        };
                        sh.tx.lock(|tx| send(tx, &report));
                    }
                    Output::PathEnd => {
                        let _ = local.seg_tx.enqueue(SegItem::EndOfPath);
                        defmt::info!("path scheduled");
                    }
                    Output::Nothing => {}
                }
            }

            // 3. Credit: tell the host about freed queue slots.
            if taken_since_ack >= CREDIT_BATCH || (taken_since_ack > 0 && !busy) {
                let msg = sh.link_state.lock(|l| DeviceMsg::Ack {
                    next_seq: l.next_seq,
                    window_end: window_end(l),
                });
                if sh.tx.lock(|tx| send(tx, &msg)) {
                    taken_since_ack = 0;
                }
            }

            // 4. Stack high-water mark, a little at a time.
            let stack = local.probe.step(256);
            let state = (feeder.held() as u16, stack);
            if state != last_state {
                last_state = state;
                sh.idle_info.lock(|i| *i = state);
            }

            if !busy && pending == 0 && !local.cmd_rx.ready() {
                rtic::export::wfi();
            }
        }
    }
}
