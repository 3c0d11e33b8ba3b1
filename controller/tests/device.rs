//! The controller on the host (`controller::sim::VirtualDevice`, the
//! firmware's own code) driven over its link by the host client
//! (`link::client::Client`): the session's sequence and credit rules, bad
//! frames, a lossy link, the feeding policy, hold/resume/override and
//! underrun, all without QEMU.

use controller::settings::{CMD_CREDIT, CREDIT_BATCH, SCHED_CAP};
use controller::sim::VirtualDevice;
use fuzzy_core::planner::MotionState;
use fuzzy_core::units::{FeedMmPerMin, Point3Mm};
use link::client::Client;
use link::{DeviceMsg, ErrorCode, FrameReader, HostMsg, Motion, PlanEvent, Status, FRAME_MAX};

/// The scheduler's latency, points: a point is released once this many
/// later points arrived (`2 + (WS − 1) + AVG/2`).
const LATENCY: usize = 35;

/// A device, a host session and everything the device said.
struct Bench {
    dev: VirtualDevice,
    client: Client,
    reader: FrameReader,
    inbox: Vec<DeviceMsg>,
    /// Frames the host lets through: `drop_out(k)` drops the k-th frame
    /// sent, `drop_in(k)` the k-th received (a lossy wire).
    drop_out: fn(u64) -> bool,
    drop_in: fn(u64) -> bool,
    sent: u64,
    received: u64,
    /// Bytes the host sent, status queries aside.
    bytes_out: usize,
}

fn never(_: u64) -> bool {
    false
}

fn frame(m: &HostMsg) -> Vec<u8> {
    let mut out = [0u8; FRAME_MAX];
    let n = link::encode(m, &mut out).unwrap();
    out[..n].to_vec()
}

impl Bench {
    fn new() -> Bench {
        let mut b = Bench {
            dev: VirtualDevice::new().unwrap(),
            client: Client::new(),
            reader: FrameReader::new(),
            inbox: Vec::new(),
            drop_out: never,
            drop_in: never,
            sent: 0,
            received: 0,
            bytes_out: 0,
        };
        b.deliver();
        assert!(b.client.hello().is_some(), "hello at reset");
        b
    }

    /// The device's transmit buffer to the host.
    fn deliver(&mut self) {
        for byte in self.dev.transmit() {
            if let Some(m) = self.reader.push::<DeviceMsg>(byte) {
                let m = m.expect("the device's frames decode");
                self.received += 1;
                if (self.drop_in)(self.received) {
                    continue;
                }
                self.client.on_message(&m);
                self.inbox.push(m);
            }
        }
    }

    /// One frame to the device, now.
    fn send(&mut self, m: &HostMsg) {
        self.sent += 1;
        let f = frame(m);
        if !matches!(m, HostMsg::StatusQuery) {
            self.bytes_out += f.len();
        }
        if !(self.drop_out)(self.sent) {
            self.dev.receive(&f);
        }
    }

    /// Queued commands within the credit to the device.
    fn transmit(&mut self) {
        while let Some(m) = self.client.poll_transmit() {
            self.send(&m);
        }
    }

    /// Ask for the status; the reply.
    fn status(&mut self) -> Status {
        self.dev.receive(&frame(&HostMsg::StatusQuery));
        self.deliver();
        match self.inbox.last() {
            Some(DeviceMsg::Status(s)) => *s,
            other => panic!("no status: {other:?}"),
        }
    }

    /// `ticks` tick periods, streaming meanwhile; after a silence of 100
    /// ticks with commands unacknowledged, a status and go-back.
    fn run(&mut self, ticks: u32) {
        let mut quiet = 0;
        for _ in 0..ticks {
            self.transmit();
            self.dev.run_tick();
            let before = self.inbox.len();
            self.deliver();
            if self.inbox.len() > before {
                quiet = 0;
            } else if !self.client.all_acked() {
                quiet += 1;
                if quiet > 100 {
                    let s = self.status();
                    self.client.on_silence(&s);
                    quiet = 0;
                }
            }
        }
    }

    /// Run until `done` holds for the status (checked every 10 ticks).
    fn run_until(&mut self, max_ticks: u32, mut done: impl FnMut(&Status) -> bool) -> Status {
        let mut t = 0;
        loop {
            let s = self.status();
            if done(&s) {
                return s;
            }
            assert!(t < max_ticks, "not done after {t} ticks: {s:?}");
            self.run(10);
            t += 10;
        }
    }

    fn errors(&self) -> Vec<(ErrorCode, u32)> {
        self.inbox
            .iter()
            .filter_map(|m| match *m {
                DeviceMsg::Error { code, expected_seq } => Some((code, expected_seq)),
                _ => None,
            })
            .collect()
    }

    fn last_ack(&self) -> (u32, u32) {
        self.inbox
            .iter()
            .rev()
            .find_map(|m| match *m {
                DeviceMsg::Ack {
                    next_seq,
                    window_end,
                } => Some((next_seq, window_end)),
                _ => None,
            })
            .expect("an ack")
    }

    /// Scheduled points reported: (seq, index, feed bits).
    fn scheduled(&self) -> Vec<(u32, u32, i64)> {
        self.inbox
            .iter()
            .filter_map(|m| match *m {
                DeviceMsg::Scheduled {
                    seq,
                    index,
                    feed_mm_per_min,
                    ..
                } => Some((seq, index, feed_mm_per_min)),
                _ => None,
            })
            .collect()
    }

    fn events(&self) -> Vec<PlanEvent> {
        self.inbox
            .iter()
            .filter_map(|m| match *m {
                DeviceMsg::Planned { event, .. } => Some(event),
                _ => None,
            })
            .collect()
    }

    /// Queue a path (F_max 3000, F_min 60 mm/min) through `pts`, ended or
    /// not; the points' sequence numbers.
    fn path(&mut self, pts: &[Point3Mm], end: bool) -> Vec<u32> {
        self.client.start_path(3000i64 << 32, 60i64 << 32);
        let seqs = pts
            .iter()
            .map(|p| self.client.point(p.to_bits(), None))
            .collect();
        if end {
            self.client.end_path();
        }
        seqs
    }
}

fn line(n: usize, step_mm: f64, from_x: f64) -> Vec<Point3Mm> {
    (1..=n)
        .map(|i| Point3Mm::from_f64(from_x + i as f64 * step_mm, 0.0, 0.0).unwrap())
        .collect()
}

fn point_msg(seq: u32, x_mm: i64) -> HostMsg {
    HostMsg::Point {
        seq,
        pos_mm: [x_mm << 32, 0, 0],
        feed_cap_mm_per_min: None,
    }
}

fn feed(s: &Status) -> f64 {
    s.feed_mm_per_min as f64 / 4294967296.0
}

#[test]
fn a_gap_is_refused_with_the_expected_seq_and_a_repeat_is_acknowledged_again() {
    let mut b = Bench::new();
    b.send(&HostMsg::StartPath {
        seq: 0,
        f_max_mm_per_min: 3000 << 32,
        f_min_mm_per_min: 60 << 32,
    });
    b.deliver();
    assert_eq!(b.last_ack(), (1, CMD_CREDIT));
    // Seq 1 lost: 2 is refused, saying 1 is expected.
    b.send(&point_msg(2, 5));
    b.deliver();
    assert_eq!(b.errors(), vec![(ErrorCode::OutOfSequence, 1)]);
    // A resend of 0 is acknowledged again and changes nothing.
    b.send(&HostMsg::StartPath {
        seq: 0,
        f_max_mm_per_min: 3000 << 32,
        f_min_mm_per_min: 60 << 32,
    });
    b.deliver();
    assert_eq!(b.last_ack(), (1, CMD_CREDIT));
    b.send(&point_msg(1, 4));
    b.send(&point_msg(2, 5));
    b.deliver();
    assert_eq!(b.last_ack(), (3, CMD_CREDIT));
    let s = b.status();
    assert_eq!((s.next_seq, s.bad_frames), (3, 1));
}

#[test]
fn the_credit_bounds_the_queue_and_comes_back_as_the_background_takes_commands() {
    let mut b = Bench::new();
    // The background does not run: the queue fills.
    for seq in 0..CMD_CREDIT + 2 {
        b.send(&point_msg(seq, seq as i64));
        b.deliver();
    }
    assert_eq!(
        b.errors(),
        vec![
            (ErrorCode::NoCredit, CMD_CREDIT),
            (ErrorCode::OutOfSequence, CMD_CREDIT)
        ],
        "past the credit: refused (and what follows is a gap), nothing lost before it"
    );
    assert_eq!(b.status().next_seq, CMD_CREDIT);
    // The background takes them (a point with no StartPath goes to the
    // scheduler with the default settings) and returns the credit.
    b.run(20);
    let (next, window_end) = b.last_ack();
    assert_eq!(next, CMD_CREDIT);
    assert_eq!(window_end, 2 * CMD_CREDIT, "every slot free again");
    let s = b.status();
    assert_eq!(
        s.points_held as usize + b.scheduled().len(),
        CMD_CREDIT as usize,
        "every point taken is in the scheduler or scheduled"
    );
    assert!(s.points_held as usize <= SCHED_CAP);
}

/// With the planner's reports off, the replies to a dense path are an
/// acknowledgement a frame and a credit update every `CREDIT_BATCH`
/// commands taken, not one a command: under 2 bytes a point back, and
/// batches of at least a credit update's worth of points out.
#[test]
fn the_credit_comes_back_in_batches_not_a_command_at_a_time() {
    let mut b = Bench::new();
    b.send(&HostMsg::Reports { planner: false });
    b.deliver();
    let pts: Vec<Point3Mm> = line(2000, 0.05, 0.0)
        .iter()
        .map(|p| {
            let [x, y, z] = p.to_bits().map(link::batch::to_grid);
            Point3Mm::from_bits(x, y, z)
        })
        .collect();
    let goal = pts.last().unwrap().to_bits();
    b.inbox.clear();
    b.path(&pts, true);
    let (frames0, bytes0) = (b.sent, b.bytes_out);
    let s = b.run_until(100_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    assert_eq!(s.underruns, 0);
    let mut out = [0u8; FRAME_MAX];
    let mut reply_bytes = 0;
    let mut acks = 0;
    for m in &b.inbox {
        if !matches!(m, DeviceMsg::Status(_)) {
            reply_bytes += link::encode_device(m, &mut out).unwrap();
        }
        acks += matches!(m, DeviceMsg::Ack { .. }) as u32;
    }
    let frames = (b.sent - frames0) as u32;
    let per_point = reply_bytes as f64 / pts.len() as f64;
    let out_per_point = (b.bytes_out - bytes0) as f64 / pts.len() as f64;
    assert!(
        acks <= frames + pts.len() as u32 / CREDIT_BATCH + 2,
        "{acks} acknowledgements for {frames} frames"
    );
    assert!(per_point < 2.0, "{per_point:.2} bytes a point back");
    assert!(out_per_point < 5.5, "{out_per_point:.2} bytes a point out");
    println!("{out_per_point:.2} bytes a point out, {per_point:.2} back, {acks} acknowledgements");
}

#[test]
fn bad_frames_get_error_replies_and_change_nothing() {
    let mut b = Bench::new();
    let good = frame(&point_msg(0, 1));
    let mut flipped = good.clone();
    flipped[3] ^= 0x40;
    let mut truncated = good.clone();
    let n = truncated.len();
    truncated.drain(n - 5..n - 1);
    let raw = |message: &[u8]| {
        let payload: Vec<u8> = [<HostMsg as link::Message>::TAG]
            .into_iter()
            .chain(message.iter().copied())
            .collect();
        let crc = crc32(&payload);
        let mut body = payload.clone();
        body.extend(crc.to_le_bytes());
        let mut out = vec![0u8; body.len() + 4];
        let n = cobs_encode(&body, &mut out);
        out.truncate(n);
        out.push(0);
        out
    };
    let cases: Vec<(Vec<u8>, ErrorCode)> = vec![
        (flipped, ErrorCode::Crc),
        (truncated, ErrorCode::Crc),
        (vec![0x03, 0x11, 0x22, 0x00], ErrorCode::TooShort),
        (
            vec![0x55; 300].into_iter().chain([0]).collect(),
            ErrorCode::TooLong,
        ),
        (raw(&[42, 1, 2, 3]), ErrorCode::UnknownMessage),
        (raw(&[2]), ErrorCode::Malformed),
        (
            frame(&HostMsg::Point {
                seq: 0,
                pos_mm: [1_000_000i64 << 32, 0, 0],
                feed_cap_mm_per_min: None,
            }),
            ErrorCode::OutOfRange,
        ),
        (
            frame(&HostMsg::Override { percent: 9 }),
            ErrorCode::OutOfRange,
        ),
        (
            frame(&HostMsg::SpindleOverride { percent: 201 }),
            ErrorCode::OutOfRange,
        ),
        (
            frame(&HostMsg::Force {
                fx_n_q16: -1,
                fy_n_q16: 0,
            }),
            ErrorCode::OutOfRange,
        ),
        (
            frame(&HostMsg::StartPath {
                seq: 0,
                f_max_mm_per_min: 0,
                f_min_mm_per_min: 0,
            }),
            ErrorCode::OutOfRange,
        ),
    ];
    for (bytes, _) in &cases {
        b.dev.receive(bytes);
    }
    b.deliver();
    // A flipped bit or a lost tail may also break the COBS chain (framing,
    // not CRC).
    let codes: Vec<ErrorCode> = b
        .errors()
        .iter()
        .enumerate()
        .map(|(i, e)| match (i, e.0) {
            (0 | 1, ErrorCode::Framing) => ErrorCode::Crc,
            (_, c) => c,
        })
        .collect();
    assert_eq!(
        codes,
        cases.iter().map(|c| c.1).collect::<Vec<_>>(),
        "one reply per bad frame, in order"
    );
    assert!(b.errors().iter().all(|e| e.1 == 0), "still expecting seq 0");
    let s = b.status();
    assert_eq!(s.bad_frames as usize, cases.len());
    assert_eq!((s.next_seq, s.override_percent), (0, 100));
    // And the next good frame is taken.
    b.dev.receive(&good);
    b.deliver();
    assert_eq!(b.last_ack().0, 1);
}

fn crc32(data: &[u8]) -> u32 {
    // CRC-32/ISO-HDLC, bitwise (the link's CRC, written out as a check).
    let mut crc = !0u32;
    for &byte in data {
        crc ^= byte as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

fn cobs_encode(data: &[u8], out: &mut [u8]) -> usize {
    // COBS for short payloads (< 254 bytes), written out as a check.
    let (mut code_at, mut n, mut code) = (0usize, 1usize, 1u8);
    for &byte in data {
        if byte == 0 {
            out[code_at] = code;
            code_at = n;
            n += 1;
            code = 1;
        } else {
            out[n] = byte;
            n += 1;
            code += 1;
        }
    }
    out[code_at] = code;
    n
}

/// A pseudo-random sequence (SplitMix64), for reproducible loss patterns.
fn mix(k: u64) -> u64 {
    let mut z = k.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[test]
fn a_lossy_link_loses_no_acknowledged_point_and_the_tool_ends_on_the_path_end() {
    let pts: Vec<Point3Mm> = (0..400)
        .map(|i| {
            let a = i as f64 * 0.02;
            Point3Mm::from_f64(20.0 * a.sin(), 10.0 * (2.0 * a).sin(), 0.0).unwrap()
        })
        .collect();
    let mut b = Bench::new();
    // One frame in 7 lost each way.
    b.drop_out = |k| mix(k) % 7 == 0;
    b.drop_in = |k| mix(k ^ 0xABCD) % 7 == 0;
    let seqs = b.path(&pts, true);
    let goal = pts.last().unwrap().to_bits();
    b.run(2000);
    b.drop_out = never;
    b.drop_in = never;
    let s = b.run_until(100_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    assert!(b.client.all_acked());
    assert!(b.client.resends() > 0, "the loss made the host go back");
    assert!(s.bad_frames > 0, "out-of-sequence frames were refused");
    // Every point entered the planner once, in order (the reports that
    // were lost on the way back are the only gaps).
    let got = b.scheduled();
    assert!(got.windows(2).all(|w| w[0].0 < w[1].0), "in order, once");
    assert!(got.iter().all(|g| seqs.contains(&g.0)));
    assert_eq!(s.point_reached as usize, pts.len(), "every point reached");
    assert_eq!(*b.dev.axes.positions.last().unwrap(), *pts.last().unwrap());
}

#[test]
fn hold_stops_on_the_path_and_resume_continues_to_the_end() {
    let pts = line(300, 0.5, 0.0);
    let mut b = Bench::new();
    b.path(&pts, true);
    let cruise = b.run_until(20_000, |s| feed(s) >= 2997.0);
    b.send(&HostMsg::Hold);
    let held = b.run_until(2_000, |s| {
        s.motion == Motion::Held && s.feed_mm_per_min == 0
    });
    // 50 mm/s at the planner's tangential limit takes at least 50 ms.
    assert!(held.ticks - cruise.ticks >= 50, "{cruise:?} {held:?}");
    assert_eq!(held.underruns, 0, "a hold is not an underrun");
    b.run(300);
    assert_eq!(b.status().pos_mm, held.pos_mm, "held still");
    b.send(&HostMsg::Resume);
    let goal = pts.last().unwrap().to_bits();
    let end = b.run_until(20_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    assert_eq!(end.underruns, 0);
    let ev = b.events();
    assert_eq!(
        ev,
        vec![PlanEvent::Hold, PlanEvent::Resume, PlanEvent::EndPath],
        "the planner's inputs are reported in order"
    );
}

#[test]
fn override_scales_the_feed_within_the_machine_maximum() {
    let pts = line(600, 0.5, 0.0);
    let mut b = Bench::new();
    b.path(&pts, true);
    b.run_until(20_000, |s| feed(s) >= 2997.0);
    b.send(&HostMsg::Override { percent: 50 });
    let s = b.run_until(2_000, |s| (feed(s) - 1500.0).abs() < 1.5);
    assert_eq!(s.override_percent, 50);
    b.send(&HostMsg::Override { percent: 200 });
    let max = b.client.hello().unwrap().feed_max_mm_per_min as f64;
    let s = b.run_until(2_000, |s| (feed(s) - max).abs() < max * 1e-3);
    assert_eq!(s.override_percent, 200, "200 % of 3000 capped at {max}");
    // The same override again is no new input to the planner.
    b.send(&HostMsg::Override { percent: 200 });
    b.run(10);
    let overrides = b
        .events()
        .iter()
        .filter(|e| matches!(e, PlanEvent::Override(_)))
        .count();
    assert_eq!(overrides, 2);
}

#[test]
fn a_path_that_stops_arriving_stops_at_the_last_plannable_point() {
    let pts = line(200, 0.5, 0.0);
    let mut b = Bench::new();
    let sent = 150;
    b.path(&pts[..sent], false);
    let s = b.run_until(20_000, |s| {
        s.motion == Motion::Starved && s.feed_mm_per_min == 0
    });
    let released = b.scheduled().len();
    assert_eq!(released, sent - LATENCY, "points released by the scheduler");
    // The planner stops on the point before the last it holds (a point's
    // corner ceiling needs the direction after it).
    assert_eq!(s.pos_mm, pts[released - 2].to_bits());
    assert_eq!(s.underruns, 1);
    b.run(200);
    assert_eq!(b.status().pos_mm, s.pos_mm, "standing still while starved");
    // The rest arrives: on to the end.
    for p in &pts[sent..] {
        b.client.point(p.to_bits(), None);
    }
    b.client.end_path();
    let goal = pts.last().unwrap().to_bits();
    b.run_until(20_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
}

#[test]
fn a_new_path_waits_for_the_previous_one_and_a_first_point_where_the_tool_is_merges() {
    let first = line(100, 0.5, 0.0);
    let end = *first.last().unwrap();
    let mut second = vec![end];
    second.extend(line(100, -0.4, 50.0));
    let mut b = Bench::new();
    b.path(&first, true);
    let seqs = b.path(&second, true);
    let goal = second.last().unwrap().to_bits();
    let s = b.run_until(50_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    // The second path's first point is where the first ended: merged into
    // its start (reported, not pushed), so the path has its 101 points
    // with that one as index 0.
    assert_eq!(s.point_reached as usize, second.len());
    let got = b.scheduled();
    let merged = got.iter().find(|g| g.0 == seqs[0]).expect("reported");
    assert_eq!(merged.1, 0);
    // The tool came to rest between the paths (the second waited for the
    // first to be done), and never left the line.
    let xs: Vec<i64> = b
        .dev
        .axes
        .positions
        .iter()
        .map(|p| p.to_bits()[0])
        .collect();
    let turn = xs.iter().position(|&x| x == end.to_bits()[0]).unwrap();
    assert!(xs[..turn].windows(2).all(|w| w[1] >= w[0]));
    assert!(xs[turn..].windows(2).all(|w| w[1] <= w[0]));
    assert!(b
        .dev
        .axes
        .positions
        .iter()
        .all(|p| p.to_bits()[1..] == [0, 0]));
    assert_eq!(
        b.events(),
        vec![PlanEvent::EndPath, PlanEvent::EndPath],
        "two paths"
    );
    assert_eq!(
        b.dev.background().planning().motion().at_rest(),
        b.dev.exec().now.state == MotionState::Done
    );
}

#[test]
fn a_point_beyond_the_scheduler_capacity_never_gets_acknowledged_and_lost() {
    // A host that keeps within the credit never sees a refusal.
    let pts = line(2 * SCHED_CAP, 0.25, 0.0);
    let mut b = Bench::new();
    b.path(&pts, true);
    b.run(5_000);
    assert!(b.errors().is_empty(), "{:?}", b.errors());
    assert_eq!(b.scheduled().len(), pts.len());
    let f = FeedMmPerMin(fixed::types::I32F32::from_bits(b.scheduled()[10].2));
    assert!(f.to_f64() > 0.0);
}

#[test]
fn an_abort_stops_under_control_drops_the_path_and_the_next_path_runs() {
    let pts = line(400, 0.5, 0.0);
    let mut b = Bench::new();
    b.path(&pts, true);
    let cruise = b.run_until(20_000, |s| feed(s) >= 2997.0);
    let abort = b.client.abort();
    b.send(&abort);
    // A new path at once, from wherever the tool stops, back to x = −5.
    let back = [Point3Mm::from_f64(-5.0, 0.0, 0.0).unwrap()];
    let seqs = b.path(&back, true);
    let goal = back[0].to_bits();
    let end = b.run_until(50_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    let Some(DeviceMsg::Aborted {
        commands,
        points,
        pos_mm,
    }) = b.client.aborted()
    else {
        panic!("no abort report: {:?}", b.inbox.last())
    };
    let stop_x = pos_mm[0] as f64 / 4294967296.0;
    let cruise_x = cruise.pos_mm[0] as f64 / 4294967296.0;
    // 50 mm/s stopping at the planner's limit takes a few mm, and the
    // ring's 16 ticks at 50 mm/s are 0.8 mm.
    assert!(
        stop_x > cruise_x && stop_x < cruise_x + 10.0,
        "{cruise_x} -> {stop_x}"
    );
    assert!(stop_x < 199.0, "stopped well before the path's end");
    assert!(
        commands + points > 0,
        "something was discarded: {commands} commands, {points} points"
    );
    // Everything after the stop belongs to the new path: the tool never
    // went beyond the stop point.
    let xs: Vec<f64> = b
        .dev
        .axes
        .positions
        .iter()
        .map(|p| p.to_bits()[0] as f64 / 4294967296.0)
        .collect();
    let max = xs.iter().cloned().fold(f64::MIN, f64::max);
    assert!(
        (max - stop_x).abs() < 1e-9,
        "went on to {max} after stopping at {stop_x}"
    );
    assert_eq!(end.pos_mm, goal);
    assert!(b.scheduled().iter().any(|g| g.0 == seqs[0]));
    assert!(b.events().contains(&PlanEvent::Abort));
    assert_eq!(end.underruns, 0);
}

#[test]
fn a_feed_too_low_to_make_progress_is_refused_and_the_slowest_allowed_finishes() {
    let mut b = Bench::new();
    b.send(&HostMsg::StartPath {
        seq: 0,
        f_max_mm_per_min: 1,
        f_min_mm_per_min: 0,
    });
    b.send(&HostMsg::Point {
        seq: 0,
        pos_mm: [1 << 30, 0, 0],
        feed_cap_mm_per_min: Some(1),
    });
    b.deliver();
    assert_eq!(
        b.errors(),
        vec![(ErrorCode::OutOfRange, 0), (ErrorCode::OutOfRange, 0)]
    );
    // 1 mm/min over 0.05 mm: 3 s at full feed; the scheduler's slowest
    // output is a tenth of F_max, so at most 30 s.
    let pts: Vec<Point3Mm> = (1..=40)
        .map(|i| Point3Mm::from_f64(i as f64 * 0.00125, 0.0, 0.0).unwrap())
        .collect();
    b.client.start_path(1 << 32, 0);
    for p in &pts {
        b.client.point(p.to_bits(), Some(1 << 32));
    }
    b.client.end_path();
    let goal = pts.last().unwrap().to_bits();
    let s = b.run_until(40_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
    assert!(s.ticks <= 40_000);
}

#[test]
fn a_message_with_trailing_bytes_is_refused_and_does_nothing() {
    let pts = line(300, 0.5, 0.0);
    let mut b = Bench::new();
    b.path(&pts, true);
    b.run_until(20_000, |s| feed(s) >= 2997.0);
    // `Hold` and one byte more, inside a valid CRC.
    let tag = <HostMsg as link::Message>::TAG;
    let payload = [tag, 4, 0];
    let mut body = payload.to_vec();
    body.extend(crc32(&payload).to_le_bytes());
    let mut out = vec![0u8; body.len() + 2];
    let n = cobs_encode(&body, &mut out);
    out.truncate(n);
    out.push(0);
    b.dev.receive(&out);
    b.run(200);
    let s = b.status();
    assert!(feed(&s) >= 2997.0, "still running: {s:?}");
    assert_eq!(b.errors().last().map(|e| e.0), Some(ErrorCode::Malformed));
}

#[test]
fn a_flood_of_noise_gets_rate_limited_replies_and_status_is_still_answered() {
    let mut b = Bench::new();
    // 2000 frames too short to hold a CRC, in one tick.
    let noise: Vec<u8> = std::iter::repeat_n([0x02u8, 0x11, 0x00], 2000)
        .flatten()
        .collect();
    b.dev.receive(&noise);
    b.dev.receive(&frame(&HostMsg::StatusQuery));
    b.deliver();
    let errors = b.errors().len();
    assert!(
        errors <= controller::session::NOISE_BURST as usize,
        "{errors} noise replies in one burst"
    );
    assert!(
        matches!(b.inbox.last(), Some(DeviceMsg::Status(_))),
        "the status query is answered after the flood"
    );
    let s = b.status();
    assert!(s.bad_frames >= 2000);
    // Over 10 s of flood, replies stay at the rate limit.
    for _ in 0..10_000 {
        b.dev.receive(&[0x02, 0x11, 0x00]);
        b.dev.run_tick();
        b.deliver();
    }
    let replies = b.errors().len() - errors;
    let allowed = 10_000_000 / controller::session::NOISE_REFILL_US as usize + 1;
    assert!(replies <= allowed, "{replies} replies, {allowed} allowed");
    assert!(
        replies >= allowed / 2,
        "{replies}: refused frames are still answered"
    );
}

/// 100 kB of line noise without a delimiter, then a delimiter and a
/// status query: one refusal for the whole run (`TooLong`) and the query
/// answered; a query sent straight after a run (no delimiter) is lost in
/// it with one refusal, and asked again after a delimiter, answered.
#[test]
fn a_long_run_without_a_delimiter_costs_one_refusal_and_the_next_frame_is_answered() {
    let mut b = Bench::new();
    b.deliver();
    b.inbox.clear();
    let run = vec![0x55u8; 100_000];
    let mut query = vec![0u8];
    query.extend(frame(&HostMsg::StatusQuery));
    b.dev.receive(&run);
    b.dev.receive(&query);
    b.deliver();
    assert_eq!(b.errors().len(), 1, "{:?}", b.inbox);
    assert!(matches!(b.inbox.last(), Some(DeviceMsg::Status(_))));
    b.inbox.clear();
    b.dev.receive(&run);
    b.dev.receive(&frame(&HostMsg::StatusQuery));
    b.deliver();
    assert!(
        matches!(
            b.inbox[..],
            [DeviceMsg::Error {
                code: ErrorCode::TooLong,
                ..
            }]
        ),
        "{:?}",
        b.inbox
    );
    b.dev.receive(&query);
    b.deliver();
    assert!(matches!(b.inbox.last(), Some(DeviceMsg::Status(_))));
}

mod random_bytes {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// After any byte stream, a delimiter and a status query bring a
        /// status reply: the receiver resynchronises within those bytes.
        #[test]
        fn never_stop_the_device_answering_a_status_query(
            bytes in proptest::collection::vec(any::<u8>(), 0..3000),
            runs in proptest::collection::vec((any::<u8>(), 1usize..400), 0..4),
        ) {
            let mut b = Bench::new();
            b.dev.receive(&bytes);
            // Long runs of one byte (no delimiter, or only delimiters).
            for (byte, n) in runs {
                b.dev.receive(&vec![byte; n * 100]);
            }
            b.deliver();
            b.inbox.clear();
            let mut tail = vec![0u8];
            tail.extend(frame(&HostMsg::StatusQuery));
            b.dev.receive(&tail);
            b.deliver();
            prop_assert!(
                b.inbox.iter().any(|m| matches!(m, DeviceMsg::Status(_))),
                "no status reply: {:?}", b.inbox
            );
        }
    }
}

/// A lemniscate of 0.05-0.2 mm chords, on the wire's grid.
fn figure_eight(n: usize) -> Vec<Point3Mm> {
    (0..n)
        .map(|i| {
            let t = i as f64 / n as f64 * std::f64::consts::TAU;
            let (x, y) = (20.0 * t.sin(), 10.0 * (2.0 * t).sin());
            let p = Point3Mm::from_f64(x, y, 0.5 * t).unwrap().to_bits();
            let g = p.map(link::batch::to_grid);
            Point3Mm::from_bits(g[0], g[1], g[2])
        })
        .collect()
}

#[test]
fn batched_points_schedule_the_same_bits_in_a_third_of_the_bytes() {
    let pts = figure_eight(1500);
    let run = |batching: bool| {
        let mut b = Bench::new();
        b.client.set_batching(batching);
        b.path(&pts, true);
        let goal = pts.last().unwrap().to_bits();
        let s = b.run_until(100_000, |s| s.motion == Motion::Idle && s.pos_mm == goal);
        (b.scheduled(), s, b.bytes_out)
    };
    let (single, s1, bytes1) = run(false);
    let (batched, s2, bytes2) = run(true);
    assert_eq!(single, batched, "the same points, scheduled alike");
    assert_eq!(s1.pos_mm, s2.pos_mm);
    let per = bytes2 as f64 / pts.len() as f64;
    println!(
        "{} points: {:.1} bytes a point as Point frames, {per:.1} in Points batches",
        pts.len(),
        bytes1 as f64 / pts.len() as f64
    );
    assert!(per <= 12.0, "{per} bytes a point");
    assert!(bytes2 * 3 <= bytes1 + bytes1 / 5, "{bytes2} vs {bytes1}");
}

#[test]
fn an_abort_reports_every_queued_command_it_dropped() {
    let pts = line(600, 0.5, 0.0);
    let mut b = Bench::new();
    b.path(&pts, true);
    b.run_until(20_000, |s| feed(s) >= 2997.0);
    // The planner and the scheduler are full, the queue fills up.
    b.run(50);
    let s = b.status();
    let queued = s.next_seq - (s.window_end - CMD_CREDIT);
    assert!(queued > 50, "{queued} queued: {s:?}");
    let abort = b.client.abort();
    b.send(&abort);
    b.run_until(5_000, |s| s.motion == Motion::Idle);
    b.run(20);
    let Some(DeviceMsg::Aborted { commands, .. }) = b.client.aborted() else {
        panic!("no report")
    };
    assert_eq!(commands, queued, "every queued command counted");
}
