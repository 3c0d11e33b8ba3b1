//! The transmit buffer: replies and reports framed in, bytes out to the
//! wire as fast as it takes them.
//!
//! Two writers share it: the link's receive side (replies to frames) and
//! the background (the planner's reports and credit). The planner's
//! reports (`Scheduled`, `Planned`) must never be dropped, or the host
//! could not replay the planner's inputs, so replies to frames leave the
//! last [`BACKGROUND_RESERVE`] bytes to the background, and the background
//! gives the planner an input only with that much room free
//! ([`TxBuffer::has_reserve`]).

use heapless::Deque;
use link::DeviceMsg;

use crate::settings::TX_BUFFER;

/// Transmit room replies to frames leave to the background: its reports of
/// what the planner took in one pass (at most two `Planned` or one
/// `Scheduled`, 32 bytes each at most).
pub const BACKGROUND_RESERVE: usize = 64;

/// Framed bytes waiting for the wire.
#[derive(Default)]
pub struct TxBuffer {
    bytes: Deque<u8, TX_BUFFER>,
}

impl TxBuffer {
    /// Empty.
    pub const fn new() -> Self {
        TxBuffer {
            bytes: Deque::new(),
        }
    }

    /// Bytes waiting.
    pub fn len(&self) -> usize {
        self.bytes.len()
    }

    /// Whether nothing waits.
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// Free room, bytes.
    pub fn room(&self) -> usize {
        self.bytes.capacity() - self.bytes.len()
    }

    /// Whether the background's reserve is free.
    pub fn has_reserve(&self) -> bool {
        self.room() >= BACKGROUND_RESERVE
    }

    /// Frame `msg` into the buffer, leaving `keep` bytes free; `false`
    /// (nothing queued) if it does not fit.
    pub fn send(&mut self, msg: &DeviceMsg, keep: usize) -> bool {
        let mut frame = [0u8; link::FRAME_MAX];
        let Ok(n) = link::encode_device(msg, &mut frame) else {
            return false;
        };
        if self.room() < n + keep {
            return false;
        }
        for b in frame.iter().take(n) {
            let _ = self.bytes.push_back(*b);
        }
        true
    }

    /// Hand bytes to `write` until it refuses one (`false`: the wire is
    /// busy); returns how many still wait.
    pub fn drain(&mut self, mut write: impl FnMut(u8) -> bool) -> usize {
        while let Some(&b) = self.bytes.front() {
            if !write(b) {
                break;
            }
            self.bytes.pop_front();
        }
        self.bytes.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use link::{FrameReader, Motion, Status};

    fn decode(bytes: &[u8]) -> Vec<DeviceMsg> {
        let mut r = FrameReader::new();
        bytes
            .iter()
            .filter_map(|b| r.push::<DeviceMsg>(*b))
            .map(|m| m.unwrap())
            .collect()
    }

    #[test]
    fn frames_go_out_whole_and_in_order() {
        let mut tx = TxBuffer::new();
        let a = DeviceMsg::Ack {
            next_seq: 3,
            window_end: 15,
        };
        let s = DeviceMsg::Status(Status {
            motion: Motion::Running,
            ..Status::default()
        });
        assert!(tx.send(&a, 0));
        assert!(tx.send(&s, 0));
        let mut wire = Vec::new();
        // A wire that takes 5 bytes at a time.
        loop {
            let mut budget = 5;
            let left = tx.drain(|b| {
                if budget == 0 {
                    return false;
                }
                budget -= 1;
                wire.push(b);
                true
            });
            if left == 0 {
                break;
            }
        }
        assert_eq!(decode(&wire), vec![a, s]);
    }

    #[test]
    fn replies_leave_the_reserve_and_a_full_buffer_refuses_whole_frames() {
        let mut tx = TxBuffer::new();
        let s = DeviceMsg::Status(Status {
            pos_mm: [i64::MIN; 3],
            ..Status::default()
        });
        let mut sent = 0;
        while tx.send(&s, BACKGROUND_RESERVE) {
            sent += 1;
        }
        assert!(sent > 0);
        assert!(tx.has_reserve(), "replies never eat the reserve");
        // The background still fits its reports.
        let report = DeviceMsg::Scheduled {
            seq: u32::MAX,
            index: u32::MAX,
            feed_mm_per_min: i64::MIN,
            tick: u32::MAX,
        };
        let mut reports = 0;
        while tx.send(&report, 0) {
            reports += 1;
        }
        assert!(reports >= 1, "the reserve holds a report");
        assert!(tx.room() < 32, "full");
        // Whatever was refused left nothing half-written.
        let mut wire = Vec::new();
        tx.drain(|b| {
            wire.push(b);
            true
        });
        assert_eq!(decode(&wire).len(), sent + reports);
        assert!(tx.is_empty());
    }
}
