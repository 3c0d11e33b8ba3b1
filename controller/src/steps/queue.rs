//! The plan queue from the tick to the step engine: single producer,
//! single consumer, every word an atomic (plain loads and stores on the
//! Cortex-M4), so that neither side masks interrupts or copies through a
//! critical section: the tick writes a slot field by field and publishes
//! it; the engine reads the slot it is told is full.
//!
//! (The controller's `ring` copies whole values inside a short critical
//! section; a [`TickPlan`] is 144 bytes, which would hold the step timer's
//! interrupt off for the copy.)

use core::sync::atomic::{AtomicU32, Ordering};

use super::plan::{AxisPlan, TickPlan};

/// Slots (a power of two, so that a masked index is always in range;
/// holds `SLOTS − 1`: the window running's successor, the one after, and
/// one in hand).
pub const SLOTS: usize = 4;
const _: () = assert!(SLOTS.is_power_of_two());
const MASK: u32 = SLOTS as u32 - 1;
/// Words per axis: start (2), steps and direction (1), first (1),
/// first_short (2), interval (1), interval_rem (2), dq (2).
const AXIS_WORDS: usize = 11;
const PLAN_WORDS: usize = 3 * AXIS_WORDS;

/// The queue's storage.
pub struct PlanQueue {
    words: [[AtomicU32; PLAN_WORDS]; SLOTS],
    /// Next slot to read (the engine's).
    head: AtomicU32,
    /// Next slot to write (the tick's).
    tail: AtomicU32,
}

impl Default for PlanQueue {
    fn default() -> Self {
        Self::new()
    }
}

#[allow(clippy::declare_interior_mutable_const)] // array initialisers only
const ZERO: AtomicU32 = AtomicU32::new(0);
#[allow(clippy::declare_interior_mutable_const)]
const ZERO_SLOT: [AtomicU32; PLAN_WORDS] = [ZERO; PLAN_WORDS];

impl PlanQueue {
    /// Empty (all zero: a `static` one lives in `.bss`).
    pub const fn new() -> Self {
        PlanQueue {
            words: [ZERO_SLOT; SLOTS],
            head: AtomicU32::new(0),
            tail: AtomicU32::new(0),
        }
    }

    /// The writing end (the tick's) and the reading end (the engine's).
    pub fn split(&mut self) -> (PlanTx<'_>, PlanRx<'_>) {
        (PlanTx { q: self }, PlanRx { q: self })
    }
}

/// The writing end.
pub struct PlanTx<'a> {
    q: &'a PlanQueue,
}

/// The reading end.
pub struct PlanRx<'a> {
    q: &'a PlanQueue,
}

fn split64(v: u64) -> (u32, u32) {
    (v as u32, (v >> 32) as u32)
}

impl PlanTx<'_> {
    /// Queue `p`; `false` (nothing written) if the queue is full.
    pub fn push(&mut self, p: &TickPlan) -> bool {
        let tail = self.q.tail.load(Ordering::Relaxed);
        let head = self.q.head.load(Ordering::Acquire);
        let next = tail.wrapping_add(1) & MASK;
        if next == head {
            return false;
        }
        let Some(slot) = self.q.words.get((tail & MASK) as usize) else {
            return false;
        };
        for (w, a) in slot.chunks_exact(AXIS_WORDS).zip(p.axes.iter()) {
            let (s0, s1) = split64(a.start as u64);
            let (r0, r1) = split64(a.first_short);
            let (i0, i1) = split64(a.interval_rem);
            let (d0, d1) = split64(a.dq);
            let steps = (a.steps & 0x7FFF_FFFF) | ((a.forward as u32) << 31);
            for (cell, v) in w
                .iter()
                .zip([s0, s1, steps, a.first, r0, r1, a.interval, i0, i1, d0, d1])
            {
                cell.store(v, Ordering::Relaxed);
            }
        }
        self.q.tail.store(next, Ordering::Release);
        true
    }
}

impl<'a> PlanRx<'a> {
    /// A second handle on this reading end, held by an engine for the
    /// moment it is rebuilt on the first (and then dropped: never two
    /// readers at work).
    pub(crate) fn handle(&self) -> PlanRx<'a> {
        PlanRx { q: self.q }
    }
}

impl PlanRx<'_> {
    /// Whether a plan is waiting.
    #[inline(always)]
    pub fn ready(&self) -> bool {
        self.q.head.load(Ordering::Relaxed) != self.q.tail.load(Ordering::Acquire)
    }

    /// Axis `I` of the oldest plan (call only when [`Self::ready`]).
    #[inline(always)]
    pub fn axis<const I: usize>(&self) -> AxisPlan {
        let head = self.q.head.load(Ordering::Relaxed) & MASK;
        let slot = &self.q.words[head as usize];
        let w = |k: usize| slot[I * AXIS_WORDS + k].load(Ordering::Relaxed);
        let join = |lo: u32, hi: u32| (lo as u64) | ((hi as u64) << 32);
        let steps = w(2);
        AxisPlan {
            start: join(w(0), w(1)) as i64,
            steps: steps & 0x7FFF_FFFF,
            forward: steps >> 31 != 0,
            first: w(3),
            first_short: join(w(4), w(5)),
            interval: w(6),
            interval_rem: join(w(7), w(8)),
            dq: join(w(9), w(10)),
        }
    }

    /// Done with the oldest plan.
    #[inline(always)]
    pub fn pop(&mut self) {
        let head = self.q.head.load(Ordering::Relaxed);
        if head != self.q.tail.load(Ordering::Acquire) {
            self.q
                .head
                .store(head.wrapping_add(1) & MASK, Ordering::Release);
        }
    }

    /// The oldest plan whole, taken off the queue (tests).
    pub fn take(&mut self) -> Option<TickPlan> {
        if !self.ready() {
            return None;
        }
        let p = TickPlan {
            axes: [self.axis::<0>(), self.axis::<1>(), self.axis::<2>()],
        };
        self.pop();
        Some(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(k: u32) -> TickPlan {
        let mut p = TickPlan::default();
        for (i, a) in p.axes.iter_mut().enumerate() {
            *a = AxisPlan {
                start: -(k as i64) * 1_000_000_007 - i as i64,
                steps: k + i as u32,
                forward: (k + i as u32) % 2 == 0,
                first: k * 3,
                first_short: u64::MAX - k as u64,
                interval: 77 + k,
                interval_rem: 1 << 40 | k as u64,
                dq: (1 << 55) + k as u64,
            };
        }
        p
    }

    #[test]
    fn plans_come_out_whole_and_in_order_and_a_full_queue_refuses() {
        let mut q = PlanQueue::new();
        let (mut tx, mut rx) = q.split();
        assert_eq!(rx.take(), None);
        for k in 0..SLOTS as u32 - 1 {
            assert!(tx.push(&plan(k)));
        }
        assert!(!tx.push(&plan(99)), "full");
        for k in 0..10u32 {
            assert_eq!(rx.take(), Some(plan(k)));
            assert!(tx.push(&plan(k + SLOTS as u32 - 1)));
        }
        assert_eq!(
            (rx.take(), rx.take(), rx.take(), rx.take()),
            (Some(plan(10)), Some(plan(11)), Some(plan(12)), None)
        );
    }
}
