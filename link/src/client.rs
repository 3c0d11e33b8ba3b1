//! The host side of the link (feature `std`): the session that keeps
//! sequence numbers, credit and go-back-N resends ([`Client`], no I/O,
//! time passed in), and a connection that runs it over any byte stream
//! ([`Connection`]: a serial port, a TCP socket to QEMU, a pipe).
//!
//! The rules it keeps are the crate's (sequencing and credit, crate docs):
//! path commands get consecutive sequence numbers as they are queued and
//! go out only within the controller's credit; a refusal with
//! `OutOfSequence` or `NoCredit` sends everything again from the
//! controller's `expected_seq` (go-back-N: the controller keeps only the
//! next one, so nothing after a lost frame was taken); silence with
//! commands unacknowledged asks for a status and goes back to its
//! `next_seq`. Acknowledged commands are forgotten.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::thread;
use std::time::{Duration, Instant};

use crate::batch::{on_grid, BatchPoint, PointBatch};
use crate::{
    AlarmCode, DeviceMsg, ErrorCode, FrameReader, HostMsg, MachineCmd, MachineStatus, Status,
    FRAME_MAX,
};

/// The controller's hello: the settings it runs with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Hello {
    /// Interpolation tick rate, Hz.
    pub tick_hz: u32,
    /// Tangential acceleration limit, mm/s² (rounded up).
    pub accel_mm_per_s2: u32,
    /// Largest feed the motion runs, mm/min.
    pub feed_max_mm_per_min: u32,
    /// Points the velocity planner buffers.
    pub planner_points: u16,
}

/// The fewest points a batch is sent with while the credit, not the path,
/// limits it.
pub const MIN_BATCH: usize = 8;

/// Sequence numbers, credit and resends of the path commands (no I/O).
#[derive(Clone, Debug)]
pub struct Client {
    /// Queued commands not yet acknowledged, from sequence number `base`.
    outbox: VecDeque<HostMsg>,
    base: u32,
    /// Next sequence number to transmit.
    send_next: u32,
    /// The controller's next expected sequence number.
    acked: u32,
    /// The controller's credit limit (exclusive).
    window_end: u32,
    hello: Option<Hello>,
    last_status: Option<Status>,
    resends: u32,
    aborted: Option<DeviceMsg>,
    /// Send runs of points on the grid as `Points` batches.
    batching: bool,
    /// The last alarm reported, with where the tool stopped.
    alarm: Option<(AlarmCode, [i64; 3])>,
    /// The last machine status received.
    machine: Option<MachineStatus>,
    /// The last setting reported (`DeviceMsg::Setting`).
    setting: Option<(u16, i64)>,
}

impl Default for Client {
    fn default() -> Self {
        Client {
            outbox: VecDeque::new(),
            base: 0,
            send_next: 0,
            acked: 0,
            window_end: 0,
            hello: None,
            last_status: None,
            resends: 0,
            aborted: None,
            batching: true,
            alarm: None,
            machine: None,
            setting: None,
        }
    }
}

impl Client {
    /// A session with a controller fresh from reset (sequence numbers from
    /// 0). For one already running, [`Client::resync`] on its status.
    pub fn new() -> Self {
        Self::default()
    }

    /// Continue the sequence where the controller is (`status` just
    /// received), dropping anything queued: after connecting to a
    /// controller that did not just reset.
    pub fn resync(&mut self, status: &Status) {
        self.outbox.clear();
        self.base = status.next_seq;
        self.send_next = status.next_seq;
        self.acked = status.next_seq;
        self.window_end = status.window_end;
        self.last_status = Some(*status);
    }

    /// Queue a path command; `make` builds it with its sequence number.
    /// Returns that number.
    pub fn queue(&mut self, make: impl FnOnce(u32) -> HostMsg) -> u32 {
        let seq = self.base.wrapping_add(self.outbox.len() as u32);
        self.outbox.push_back(make(seq));
        seq
    }

    /// Queue a path start: F_max and F_min in mm/min, I32F32 bits.
    pub fn start_path(&mut self, f_max_mm_per_min: i64, f_min_mm_per_min: i64) -> u32 {
        self.queue(|seq| HostMsg::StartPath {
            seq,
            f_max_mm_per_min,
            f_min_mm_per_min,
        })
    }

    /// Queue a point: mm per axis and an optional feed cap in mm/min, all
    /// I32F32 bits.
    pub fn point(&mut self, pos_mm: [i64; 3], feed_cap_mm_per_min: Option<i64>) -> u32 {
        self.queue(|seq| HostMsg::Point {
            seq,
            pos_mm,
            feed_cap_mm_per_min,
        })
    }

    /// Queue the end of the path.
    pub fn end_path(&mut self) -> u32 {
        self.queue(|seq| HostMsg::EndPath { seq })
    }

    /// Queue a machine command (spindle, coolant): it takes effect when
    /// the motion reaches it, after the points queued before it.
    pub fn machine(&mut self, cmd: MachineCmd) -> u32 {
        self.queue(|seq| HostMsg::Machine { seq, cmd })
    }

    /// Queue a probing move to `target_mm` at `feed_mm_per_min` (I32F32
    /// bits): it runs once the motion queued before it has ended
    /// (`HostMsg::Probe`).
    pub fn probe(
        &mut self,
        target_mm: [i64; 3],
        feed_mm_per_min: i64,
        toward: bool,
        error_if_missed: bool,
    ) -> u32 {
        self.queue(|seq| HostMsg::Probe {
            seq,
            target_mm,
            feed_mm_per_min,
            toward,
            error_if_missed,
        })
    }

    /// Whether runs of points whose coordinates lie on the wire's grid
    /// ([`crate::batch::to_grid`]) go out as `Points` batches (on by
    /// default; off, every point is a `Point` frame).
    pub fn set_batching(&mut self, on: bool) {
        self.batching = on;
    }

    /// The next frame to transmit, if the credit allows one: a path
    /// command, or a batch of consecutive points.
    pub fn poll_transmit(&mut self) -> Option<HostMsg> {
        let room = self.window_end.wrapping_sub(self.send_next) as i32;
        if room <= 0 {
            return None;
        }
        let i = self.send_next.wrapping_sub(self.base) as usize;
        let msg = *self.outbox.get(i)?;
        let mut n = 1;
        let mut out = msg;
        if self.batching {
            let mut batch = PointBatch::new();
            let point = |m: Option<&HostMsg>| match m {
                Some(&HostMsg::Point {
                    pos_mm,
                    feed_cap_mm_per_min,
                    ..
                }) if pos_mm.iter().all(|c| on_grid(*c)) => Some(BatchPoint {
                    pos_mm,
                    feed_cap_mm_per_min,
                }),
                _ => None,
            };
            let mut k = 0;
            let mut cut_by_credit = true;
            while k < room as usize {
                match point(self.outbox.get(i + k)) {
                    Some(p) if batch.push(p) => k += 1,
                    _ => {
                        cut_by_credit = false;
                        break;
                    }
                }
            }
            // A batch cut short by the credit waits for more credit: small
            // frames would waste the wire, and a small credit means the
            // controller's queue is nearly full anyway.
            if k >= 1 && cut_by_credit && k < MIN_BATCH {
                return None;
            }
            if k >= 2 {
                n = k;
                out = HostMsg::Points {
                    seq: self.send_next,
                    batch,
                };
            }
        }
        self.send_next = self.send_next.wrapping_add(n as u32);
        Some(out)
    }

    /// A message from the controller.
    pub fn on_message(&mut self, m: &DeviceMsg) {
        match *m {
            DeviceMsg::Hello {
                tick_hz,
                accel_mm_per_s2,
                window_end,
                feed_max_mm_per_min,
                planner_points,
            } => {
                self.hello = Some(Hello {
                    tick_hz,
                    accel_mm_per_s2,
                    feed_max_mm_per_min,
                    planner_points,
                });
                self.credit(self.acked, window_end);
            }
            DeviceMsg::Ack {
                next_seq,
                window_end,
            } => self.credit(next_seq, window_end),
            DeviceMsg::Status(s) => {
                self.credit(s.next_seq, s.window_end);
                self.last_status = Some(s);
            }
            DeviceMsg::Error { code, expected_seq } => {
                if matches!(code, ErrorCode::OutOfSequence | ErrorCode::NoCredit) {
                    self.go_back(expected_seq);
                }
            }
            DeviceMsg::Aborted { .. } => self.aborted = Some(*m),
            DeviceMsg::Alarm {
                code,
                pos_mm,
                next_seq,
            } => {
                // Everything queued was dropped on the controller's side:
                // drop it here too and continue the numbering there.
                self.outbox.clear();
                self.base = next_seq;
                self.send_next = next_seq;
                self.acked = next_seq;
                self.alarm = Some((code, pos_mm));
            }
            DeviceMsg::Machine(ms) => self.machine = Some(ms),
            DeviceMsg::Setting { id, value } => self.setting = Some((id, value)),
            DeviceMsg::Scheduled { .. }
            | DeviceMsg::Planned { .. }
            | DeviceMsg::Applied { .. }
            | DeviceMsg::Homed { .. }
            | DeviceMsg::Stored(_)
            | DeviceMsg::Probed { .. } => {}
        }
    }

    /// The last alarm the controller reported (`DeviceMsg::Alarm`): its
    /// cause and where the tool stopped. Path commands queued before it
    /// were dropped.
    pub fn alarm(&self) -> Option<(AlarmCode, [i64; 3])> {
        self.alarm
    }

    /// The last machine status received.
    pub fn machine_status(&self) -> Option<MachineStatus> {
        self.machine
    }

    /// The last setting reported.
    pub fn last_setting(&self) -> Option<(u16, i64)> {
        self.setting
    }

    /// Abort the path (the message to send now): everything queued or sent
    /// and not yet planned is void, on both sides; commands queued from now
    /// on start a new path with the next sequence number.
    pub fn abort(&mut self) -> HostMsg {
        self.outbox.clear();
        self.base = self.send_next;
        self.acked = self.send_next;
        self.aborted = None;
        HostMsg::Abort {
            next_seq: self.send_next,
        }
    }

    /// The controller's report of the last abort, once it came
    /// (`DeviceMsg::Aborted`).
    pub fn aborted(&self) -> Option<DeviceMsg> {
        self.aborted
    }

    /// No reply for a while with commands unacknowledged: after a status
    /// answered, resend from where the controller is.
    pub fn on_silence(&mut self, status: &Status) {
        self.on_message(&DeviceMsg::Status(*status));
        self.go_back(status.next_seq);
    }

    fn go_back(&mut self, expected: u32) {
        let to = later(expected, self.acked);
        if (to.wrapping_sub(self.send_next) as i32) < 0 {
            self.send_next = to;
            self.resends += 1;
        }
    }

    fn credit(&mut self, next_seq: u32, window_end: u32) {
        self.acked = later(self.acked, next_seq);
        self.window_end = later(self.window_end, window_end);
        // Never resend what is acknowledged.
        self.send_next = later(self.send_next, self.acked);
        while (self.base.wrapping_sub(self.acked) as i32) < 0 && !self.outbox.is_empty() {
            self.outbox.pop_front();
            self.base = self.base.wrapping_add(1);
        }
    }

    /// Whether every queued command was acknowledged.
    pub fn all_acked(&self) -> bool {
        self.outbox.is_empty()
    }

    /// Commands queued and not yet acknowledged.
    pub fn unacked(&self) -> usize {
        self.outbox.len()
    }

    /// The sequence number the next queued command will get.
    pub fn queue_end(&self) -> u32 {
        self.base.wrapping_add(self.outbox.len() as u32)
    }

    /// The next sequence number to transmit.
    pub fn send_next(&self) -> u32 {
        self.send_next
    }

    /// The controller's next expected sequence number.
    pub fn acked(&self) -> u32 {
        self.acked
    }

    /// The controller's credit limit (exclusive).
    pub fn window_end(&self) -> u32 {
        self.window_end
    }

    /// The hello, once received.
    pub fn hello(&self) -> Option<Hello> {
        self.hello
    }

    /// The last status received.
    pub fn last_status(&self) -> Option<Status> {
        self.last_status
    }

    /// Go-backs (after a refusal or a silence).
    pub fn resends(&self) -> u32 {
        self.resends
    }
}

/// The later of two sequence numbers (wrapping).
fn later(a: u32, b: u32) -> u32 {
    if (b.wrapping_sub(a) as i32) > 0 {
        b
    } else {
        a
    }
}

/// Why the connection failed.
#[derive(Debug)]
pub enum LinkError {
    /// The byte stream closed (the controller or its emulator went away).
    Closed,
    /// Nothing came within the time allowed.
    Timeout,
    /// Writing failed.
    Io(std::io::Error),
}

impl core::fmt::Display for LinkError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LinkError::Closed => f.write_str("the link closed"),
            LinkError::Timeout => f.write_str("no answer from the controller"),
            LinkError::Io(e) => write!(f, "link write failed: {e}"),
        }
    }
}

impl std::error::Error for LinkError {}

/// How long without a reply before [`Connection::flush`] asks for a status.
pub const SILENCE: Duration = Duration::from_millis(500);

/// A [`Client`] over a byte stream: frames out, frames in on a reader
/// thread. Bad frames from the controller are counted and skipped.
pub struct Connection {
    writer: Box<dyn Write + Send>,
    rx: Receiver<Result<DeviceMsg, ErrorCode>>,
    client: Client,
    bad_frames: u32,
    bytes_sent: u64,
    /// Nothing was written yet.
    fresh: bool,
}

impl Connection {
    /// Over `reader`/`writer` (two ends of one stream), for a controller
    /// fresh from reset.
    pub fn new(writer: Box<dyn Write + Send>, mut reader: Box<dyn Read + Send>) -> Self {
        let (tx, rx) = mpsc::channel();
        thread::spawn(move || {
            let mut frames = FrameReader::new();
            let mut buf = [0u8; 4096];
            while let Ok(n) = reader.read(&mut buf) {
                if n == 0 {
                    break;
                }
                for b in &buf[..n] {
                    if let Some(m) = frames.push::<DeviceMsg>(*b) {
                        if tx.send(m).is_err() {
                            return;
                        }
                    }
                }
            }
        });
        Connection {
            writer,
            rx,
            client: Client::new(),
            bad_frames: 0,
            bytes_sent: 0,
            fresh: true,
        }
    }

    /// The session.
    pub fn client(&self) -> &Client {
        &self.client
    }

    /// The session, to queue commands.
    pub fn client_mut(&mut self) -> &mut Client {
        &mut self.client
    }

    /// Frames from the controller that did not decode.
    pub fn bad_frames(&self) -> u32 {
        self.bad_frames
    }

    /// Send one message now (outside the credit: for immediate messages,
    /// or to test the controller).
    pub fn send(&mut self, msg: &HostMsg) -> Result<(), LinkError> {
        let mut f = [0u8; FRAME_MAX];
        let n = crate::encode(msg, &mut f)
            .map_err(|_| LinkError::Io(std::io::Error::other("message too large for a frame")))?;
        self.send_raw(f.get(..n).unwrap_or(&[]))
    }

    /// Bytes sent so far.
    pub fn bytes_sent(&self) -> u64 {
        self.bytes_sent
    }

    /// Send raw bytes. The first write starts with a delimiter: whatever
    /// an earlier host left unfinished on the wire (a frame cut short,
    /// line noise without a delimiter) ends there, as one bad frame, and
    /// the first frame of this connection decodes.
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        if core::mem::take(&mut self.fresh) {
            self.bytes_sent += 1;
            self.writer
                .write_all(&[crate::DELIMITER])
                .map_err(LinkError::Io)?;
        }
        self.bytes_sent += bytes.len() as u64;
        self.writer.write_all(bytes).map_err(LinkError::Io)?;
        self.writer.flush().map_err(LinkError::Io)
    }

    /// Send a lone delimiter: whatever the controller's receiver holds
    /// (line noise without a delimiter, a frame cut short) ends there, and
    /// the next frame decodes; between frames it is an empty frame, which
    /// the controller ignores. Sent before a request is asked again, as
    /// the request before it may have been swallowed by such a run.
    pub fn send_delimiter(&mut self) -> Result<(), LinkError> {
        self.send_raw(&[crate::DELIMITER])
    }

    /// Send queued commands as the credit allows; how many went.
    pub fn transmit(&mut self) -> Result<usize, LinkError> {
        let mut n = 0;
        while let Some(m) = self.client.poll_transmit() {
            self.send(&m)?;
            n += 1;
        }
        Ok(n)
    }

    /// The next message from the controller within `timeout` (the session
    /// has seen it); `Ok(None)` if none came.
    pub fn recv(&mut self, timeout: Duration) -> Result<Option<DeviceMsg>, LinkError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.rx.recv_timeout(left) {
                Ok(Ok(m)) => {
                    self.client.on_message(&m);
                    return Ok(Some(m));
                }
                Ok(Err(_)) => self.bad_frames += 1,
                Err(RecvTimeoutError::Timeout) => return Ok(None),
                Err(RecvTimeoutError::Disconnected) => return Err(LinkError::Closed),
            }
        }
    }

    /// Ask for the status until one comes (each try waits 500 ms), every
    /// other message passed to `seen`.
    pub fn status(
        &mut self,
        tries: u32,
        mut seen: impl FnMut(&DeviceMsg),
    ) -> Result<Status, LinkError> {
        for attempt in 0..tries {
            if attempt > 0 {
                self.send_delimiter()?;
            }
            self.send(&HostMsg::StatusQuery)?;
            let deadline = Instant::now() + Duration::from_millis(500);
            while let Some(left) = deadline.checked_duration_since(Instant::now()) {
                match self.recv(left.min(Duration::from_millis(50)))? {
                    Some(DeviceMsg::Status(s)) => {
                        seen(&DeviceMsg::Status(s));
                        return Ok(s);
                    }
                    // The query may have gone down with line noise: ask
                    // again at once.
                    Some(m @ DeviceMsg::Error { code, .. }) if code.is_line_noise() => {
                        seen(&m);
                        break;
                    }
                    Some(m) => seen(&m),
                    None => {}
                }
            }
        }
        Err(LinkError::Timeout)
    }

    /// Send `msg` and wait (each try 500 ms, `tries` times) for the reply
    /// `pick` takes, or a refusal; every other message to `seen`.
    fn ask<T>(
        &mut self,
        msg: &HostMsg,
        tries: u32,
        mut pick: impl FnMut(&DeviceMsg) -> Option<T>,
        mut seen: impl FnMut(&DeviceMsg),
    ) -> Result<Result<T, ErrorCode>, LinkError> {
        for attempt in 0..tries {
            if attempt > 0 {
                self.send_delimiter()?;
            }
            self.send(msg)?;
            let deadline = Instant::now() + Duration::from_millis(500);
            while let Some(left) = deadline.checked_duration_since(Instant::now()) {
                let Some(m) = self.recv(left.min(Duration::from_millis(50)))? else {
                    continue;
                };
                seen(&m);
                if let Some(t) = pick(&m) {
                    return Ok(Ok(t));
                }
                if let DeviceMsg::Error { code, .. } = m {
                    // Line noise is not this request's refusal (it may
                    // have gone down with it): ask again at once.
                    if code.is_line_noise() {
                        break;
                    }
                    if !matches!(code, ErrorCode::OutOfSequence | ErrorCode::NoCredit) {
                        return Ok(Err(code));
                    }
                }
            }
        }
        Err(LinkError::Timeout)
    }

    /// Read setting `id`: its value, or why it was refused.
    pub fn get_setting(
        &mut self,
        id: u16,
        seen: impl FnMut(&DeviceMsg),
    ) -> Result<Result<i64, ErrorCode>, LinkError> {
        let pick = |m: &DeviceMsg| match *m {
            DeviceMsg::Setting { id: i, value } if i == id => Some(value),
            _ => None,
        };
        self.ask(&HostMsg::GetSetting { id }, 20, pick, seen)
    }

    /// Write setting `id` (at rest only): the value now in force, or why
    /// it was refused (then nothing changed).
    pub fn set_setting(
        &mut self,
        id: u16,
        value: i64,
        seen: impl FnMut(&DeviceMsg),
    ) -> Result<Result<i64, ErrorCode>, LinkError> {
        let pick = |m: &DeviceMsg| match *m {
            DeviceMsg::Setting { id: i, value } if i == id => Some(value),
            _ => None,
        };
        // A resend of the same write is harmless: it writes the same value
        // (and is refused the same way).
        self.ask(&HostMsg::SetSetting { id, value }, 20, pick, seen)
    }

    /// The machine status (alarm, homing, spindle, coolant, inputs, store).
    pub fn machine(&mut self, seen: impl FnMut(&DeviceMsg)) -> Result<MachineStatus, LinkError> {
        let pick = |m: &DeviceMsg| match *m {
            DeviceMsg::Machine(s) => Some(s),
            _ => None,
        };
        match self.ask(&HostMsg::MachineQuery, 20, pick, seen)? {
            Ok(s) => Ok(s),
            Err(_) => Err(LinkError::Timeout),
        }
    }

    /// Stream until every queued command is acknowledged, resending what
    /// was refused or went unanswered; every message passed to `seen`.
    pub fn flush(
        &mut self,
        timeout: Duration,
        mut seen: impl FnMut(&DeviceMsg),
    ) -> Result<(), LinkError> {
        let deadline = Instant::now() + timeout;
        let mut quiet_since = Instant::now();
        while !self.client.all_acked() {
            if Instant::now() > deadline {
                return Err(LinkError::Timeout);
            }
            if self.transmit()? > 0 {
                quiet_since = Instant::now();
            }
            if let Some(m) = self.recv(Duration::from_millis(20))? {
                seen(&m);
                quiet_since = Instant::now();
            } else if quiet_since.elapsed() > SILENCE {
                let s = self.status(20, &mut seen)?;
                self.client.on_silence(&s);
                quiet_since = Instant::now();
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ack(next_seq: u32, window_end: u32) -> DeviceMsg {
        DeviceMsg::Ack {
            next_seq,
            window_end,
        }
    }

    /// The sequence numbers a frame carries.
    fn seqs(m: &HostMsg) -> Vec<u32> {
        match *m {
            HostMsg::StartPath { seq, .. }
            | HostMsg::Point { seq, .. }
            | HostMsg::EndPath { seq } => vec![seq],
            HostMsg::Points { seq, batch } => (seq..seq + batch.len() as u32).collect(),
            _ => panic!("not a path command: {m:?}"),
        }
    }

    #[test]
    fn runs_of_points_on_the_grid_go_out_in_batches_within_the_credit() {
        let mut c = Client::new();
        for i in 0..30 {
            c.point([i << 20, 0, 0], None);
        }
        // Off the grid: a frame of its own.
        c.point([1, 0, 0], None);
        c.end_path();
        c.on_message(&ack(0, 20));
        let Some(HostMsg::Points { seq, batch }) = c.poll_transmit() else {
            panic!("a batch")
        };
        assert_eq!((seq, batch.len()), (0, 20), "as far as the credit goes");
        assert_eq!(c.poll_transmit(), None);
        c.on_message(&ack(20, 40));
        let Some(HostMsg::Points { seq, batch }) = c.poll_transmit() else {
            panic!("a batch")
        };
        assert_eq!((seq, batch.len()), (20, 10));
        let p: Vec<i64> = batch.points().map(|p| p.unwrap().pos_mm[0]).collect();
        assert_eq!(p, (20..30).map(|i| i << 20).collect::<Vec<_>>());
        assert!(matches!(
            c.poll_transmit(),
            Some(HostMsg::Point { seq: 30, .. })
        ));
        assert!(matches!(
            c.poll_transmit(),
            Some(HostMsg::EndPath { seq: 31 })
        ));
        // A go-back re-chunks from the expected point.
        c.on_message(&DeviceMsg::Error {
            code: ErrorCode::OutOfSequence,
            expected_seq: 25,
        });
        let Some(HostMsg::Points { seq, batch }) = c.poll_transmit() else {
            panic!("a batch")
        };
        assert_eq!((seq, batch.len()), (25, 5));
    }

    #[test]
    fn an_abort_voids_what_was_queued_and_numbers_on() {
        let mut c = Client::new();
        for i in 0..6 {
            c.point([i, 0, 0], None);
        }
        c.on_message(&ack(0, 4));
        assert_eq!(drain(&mut c), vec![0, 1, 2, 3]);
        let Some(HostMsg::Abort { next_seq }) = Some(c.abort()) else {
            unreachable!()
        };
        assert_eq!(next_seq, 4, "after everything sent");
        assert!(c.all_acked(), "4 and 5 were never sent: dropped");
        // The controller acknowledges the abort with the new numbering.
        c.on_message(&ack(4, 12));
        assert_eq!(c.start_path(3000 << 32, 0), 4);
        assert_eq!(drain(&mut c), vec![4]);
    }

    fn drain(c: &mut Client) -> Vec<u32> {
        std::iter::from_fn(|| c.poll_transmit())
            .flat_map(|m| seqs(&m))
            .collect()
    }

    #[test]
    fn sends_within_the_credit_and_forgets_what_is_acknowledged() {
        let mut c = Client::new();
        for i in 0..10 {
            assert_eq!(c.point([i, 0, 0], None), i as u32);
        }
        assert_eq!(
            drain(&mut c),
            Vec::<u32>::new(),
            "no credit before the hello"
        );
        c.on_message(&DeviceMsg::Hello {
            tick_hz: 1000,
            accel_mm_per_s2: 1000,
            window_end: 4,
            feed_max_mm_per_min: 5000,
            planner_points: 112,
        });
        assert_eq!(drain(&mut c), vec![0, 1, 2, 3]);
        c.on_message(&ack(2, 6));
        assert_eq!(c.unacked(), 8);
        assert_eq!(drain(&mut c), vec![4, 5]);
        // An old ack changes nothing.
        c.on_message(&ack(1, 5));
        assert_eq!((c.acked(), c.window_end()), (2, 6));
        c.on_message(&ack(6, 10));
        assert_eq!(drain(&mut c), vec![6, 7, 8, 9]);
        c.on_message(&ack(10, 14));
        assert!(c.all_acked());
        assert_eq!(drain(&mut c), Vec::<u32>::new());
    }

    #[test]
    fn a_refusal_goes_back_to_the_expected_sequence_number() {
        let mut c = Client::new();
        for i in 0..8 {
            c.point([i, 0, 0], None);
        }
        c.on_message(&ack(0, 8));
        assert_eq!(drain(&mut c), (0..8).collect::<Vec<_>>());
        // Frame 3 was lost: 4.. are refused as out of sequence.
        c.on_message(&ack(3, 8));
        for _ in 4..8 {
            c.on_message(&DeviceMsg::Error {
                code: ErrorCode::OutOfSequence,
                expected_seq: 3,
            });
        }
        assert_eq!(c.resends(), 1, "one go-back, not one per refusal");
        assert_eq!(drain(&mut c), vec![3, 4, 5, 6, 7]);
        // Other refusals do not move the sequence.
        c.on_message(&DeviceMsg::Error {
            code: ErrorCode::Crc,
            expected_seq: 3,
        });
        assert_eq!(drain(&mut c), Vec::<u32>::new());
    }

    #[test]
    fn silence_resends_from_the_status() {
        let mut c = Client::new();
        for i in 0..5 {
            c.point([i, 0, 0], None);
        }
        c.on_message(&ack(0, 5));
        assert_eq!(drain(&mut c).len(), 5);
        let s = Status {
            next_seq: 2,
            window_end: 7,
            ..Status::default()
        };
        c.on_silence(&s);
        assert_eq!(drain(&mut c), vec![2, 3, 4]);
        // A status that is already past everything sent: no resend.
        c.on_silence(&Status {
            next_seq: 5,
            window_end: 9,
            ..Status::default()
        });
        assert!(c.all_acked());
        assert_eq!(c.resends(), 1);
    }

    #[test]
    fn resync_continues_a_running_controllers_sequence() {
        let mut c = Client::new();
        c.point([0; 3], None);
        c.resync(&Status {
            next_seq: 1000,
            window_end: 1012,
            ..Status::default()
        });
        assert!(c.all_acked(), "what was queued before is dropped");
        assert_eq!(c.start_path(3000 << 32, 60 << 32), 1000);
        assert_eq!(c.end_path(), 1001);
        assert_eq!(drain(&mut c), vec![1000, 1001]);
    }

    #[test]
    fn sequence_numbers_wrap() {
        let mut c = Client::new();
        c.resync(&Status {
            next_seq: u32::MAX - 1,
            window_end: 2,
            ..Status::default()
        });
        let seqs: Vec<u32> = (0..4).map(|i| c.point([i, 0, 0], None)).collect();
        assert_eq!(seqs, vec![u32::MAX - 1, u32::MAX, 0, 1]);
        assert_eq!(drain(&mut c), seqs);
        c.on_message(&ack(1, 5));
        assert_eq!(c.unacked(), 1);
        c.on_message(&ack(2, 6));
        assert!(c.all_acked());
    }

    #[test]
    fn a_connection_round_trips_over_a_socket_pair() {
        let (a, b) = std::os::unix::net::UnixStream::pair().unwrap();
        let mut conn = Connection::new(Box::new(a.try_clone().unwrap()), Box::new(a));
        // A fake controller on the other end: acknowledges every point.
        let dev = thread::spawn(move || {
            let mut r = FrameReader::new();
            let mut w = b.try_clone().unwrap();
            let mut out = [0u8; FRAME_MAX];
            let n = crate::encode(&ack(0, 4), &mut out).unwrap();
            w.write_all(&out[..n]).unwrap();
            let mut got: Vec<u32> = Vec::new();
            let mut buf = [0u8; 256];
            let mut rd = b;
            while got.len() < 6 {
                let k = rd.read(&mut buf).unwrap();
                for byte in &buf[..k] {
                    if let Some(Ok(m)) = r.push::<HostMsg>(*byte) {
                        let s = seqs(&m);
                        got.extend(&s);
                        let last = *s.last().unwrap();
                        let n = crate::encode(&ack(last + 1, last + 5), &mut out).unwrap();
                        w.write_all(&out[..n]).unwrap();
                    }
                }
            }
            got
        });
        for i in 0..6 {
            conn.client_mut().point([i, 0, 0], None);
        }
        conn.flush(Duration::from_secs(10), |_| {}).unwrap();
        assert_eq!(dev.join().unwrap(), (0..6).collect::<Vec<_>>());
    }

    #[test]
    fn a_connection_ends_what_an_earlier_host_left_on_the_wire_first() {
        let (a, mut b) = std::os::unix::net::UnixStream::pair().unwrap();
        let end = a.try_clone().unwrap();
        let mut conn = Connection::new(Box::new(a.try_clone().unwrap()), Box::new(a));
        conn.send(&HostMsg::StatusQuery).unwrap();
        conn.send(&HostMsg::StatusQuery).unwrap();
        end.shutdown(std::net::Shutdown::Both).unwrap();
        let mut wire = Vec::new();
        b.read_to_end(&mut wire).unwrap();
        assert_eq!(wire[0], crate::DELIMITER, "{wire:?}");
        assert_eq!(wire.iter().filter(|&&x| x == crate::DELIMITER).count(), 3);
        // Noise without a delimiter before it: one bad frame, then the
        // status query decodes.
        let mut r = FrameReader::new();
        let noisy: Vec<Option<Result<HostMsg, ErrorCode>>> = [0x55u8; 600]
            .iter()
            .chain(&wire)
            .filter_map(|x| r.push::<HostMsg>(*x).map(Some))
            .collect();
        assert_eq!(
            noisy,
            vec![
                Some(Err(ErrorCode::TooLong)),
                Some(Ok(HostMsg::StatusQuery)),
                Some(Ok(HostMsg::StatusQuery))
            ]
        );
    }
}
