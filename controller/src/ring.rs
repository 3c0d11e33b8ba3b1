//! A single-producer single-consumer ring of `Copy` values, in safe code:
//! `N` slots holding `N − 1`, indices wrapped by comparison (no division),
//! slots reached with `get`, so no path can panic. Each operation is a short
//! critical section (a few instructions with interrupts masked on the
//! single-core Cortex-M4; `critical-section-single-core`).
//!
//! Not `heapless::spsc`: its 0.9 queue takes its length at run time
//! (`% n()`), which leaves a division-by-zero panic path in an image built
//! for size (`firmware/scripts/check.py panic`).
//!
//! The producer and the consumer may run at different interrupt priorities
//! (the background fills the setpoint ring, the tick interrupt empties it);
//! on the host the tests run them on two threads.

use core::cell::Cell;
use critical_section::Mutex;

/// The ring: `N` slots (at least 2), `N − 1` usable.
pub struct Ring<T: Copy, const N: usize> {
    inner: Mutex<Inner<T, N>>,
}

/// A slot. Tagged 0 when empty (`repr(u8)`), so that an empty ring is all
/// zeros and a `static` one lives in `.bss`, not in flash-initialised
/// `.data` (an `Option<T>` would take its `None` from `T`'s niche).
#[derive(Clone, Copy)]
#[repr(u8)]
enum Slot<T: Copy> {
    Empty = 0,
    Full(T) = 1,
}

struct Inner<T: Copy, const N: usize> {
    slots: [Cell<Slot<T>>; N],
    /// Next slot to read.
    head: Cell<usize>,
    /// Next slot to write.
    tail: Cell<usize>,
}

impl<T: Copy, const N: usize> Default for Ring<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Copy, const N: usize> Inner<T, N> {
    /// The slot after `i` (for `i < N`).
    const fn next(i: usize) -> usize {
        if i + 1 >= N {
            0
        } else {
            i + 1
        }
    }

    fn len(&self) -> usize {
        let (head, tail) = (self.head.get(), self.tail.get());
        if tail >= head {
            tail - head
        } else {
            tail + N - head
        }
    }
}

impl<T: Copy, const N: usize> Ring<T, N> {
    const VALID: () = assert!(N >= 2, "a ring needs at least 2 slots");

    /// An empty ring.
    pub const fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::VALID;
        Ring {
            inner: Mutex::new(Inner {
                slots: [const { Cell::new(Slot::Empty) }; N],
                head: Cell::new(0),
                tail: Cell::new(0),
            }),
        }
    }

    /// The producer and consumer ends.
    pub fn split(&mut self) -> (Producer<'_, T, N>, Consumer<'_, T, N>) {
        let ring: &Self = self;
        (Producer { ring }, Consumer { ring })
    }

    fn with<R>(&self, f: impl FnOnce(&Inner<T, N>) -> R) -> R {
        critical_section::with(|cs| f(self.inner.borrow(cs)))
    }
}

/// The writing end.
pub struct Producer<'a, T: Copy, const N: usize> {
    ring: &'a Ring<T, N>,
}

/// The reading end.
pub struct Consumer<'a, T: Copy, const N: usize> {
    ring: &'a Ring<T, N>,
}

impl<T: Copy, const N: usize> Producer<'_, T, N> {
    /// Values the ring holds when full (`N − 1`).
    pub const fn capacity(&self) -> usize {
        N - 1
    }

    /// Whether there is room for a value.
    pub fn ready(&self) -> bool {
        self.ring.with(|r| r.len() < N - 1)
    }

    /// Append `value`; gives it back when the ring is full.
    pub fn enqueue(&mut self, value: T) -> Result<(), T> {
        self.ring.with(|r| {
            let tail = r.tail.get();
            let next = Inner::<T, N>::next(tail);
            match r.slots.get(tail) {
                Some(slot) if next != r.head.get() => {
                    slot.set(Slot::Full(value));
                    r.tail.set(next);
                    Ok(())
                }
                _ => Err(value),
            }
        })
    }
}

impl<T: Copy, const N: usize> Consumer<'_, T, N> {
    /// Whether a value is waiting.
    pub fn ready(&self) -> bool {
        !self.is_empty()
    }

    /// Values waiting.
    pub fn len(&self) -> usize {
        self.ring.with(|r| r.len())
    }

    /// Whether the ring is empty.
    pub fn is_empty(&self) -> bool {
        self.ring.with(|r| r.head.get() == r.tail.get())
    }

    /// Take the oldest value.
    pub fn dequeue(&mut self) -> Option<T> {
        self.ring.with(|r| {
            let head = r.head.get();
            if head == r.tail.get() {
                return None;
            }
            let value = match r.slots.get(head)?.replace(Slot::Empty) {
                Slot::Full(v) => Some(v),
                Slot::Empty => None,
            };
            r.head.set(Inner::<T, N>::next(head));
            value
        })
    }
}

#[cfg(test)]
mod tests {
    use super::Ring;

    #[test]
    fn holds_n_minus_one_in_order_across_wraps() {
        let mut r: Ring<u32, 5> = Ring::new();
        let (mut tx, mut rx) = r.split();
        assert_eq!(tx.capacity(), 4);
        let mut next_in = 0u32;
        let mut next_out = 0u32;
        for round in 0..50 {
            // Fill to capacity: the fifth is refused and given back.
            while tx.ready() {
                tx.enqueue(next_in).unwrap();
                next_in += 1;
            }
            assert_eq!(rx.len(), 4, "round {round}");
            assert_eq!(tx.enqueue(999), Err(999));
            // Drain a varying number, so the indices wrap at every offset.
            for _ in 0..(1 + round % 4) {
                assert_eq!(rx.dequeue(), Some(next_out));
                next_out += 1;
            }
        }
        while let Some(v) = rx.dequeue() {
            assert_eq!(v, next_out);
            next_out += 1;
        }
        assert_eq!(next_out, next_in);
        assert!(rx.is_empty());
        assert_eq!(rx.dequeue(), None);
    }

    #[test]
    fn two_threads_lose_and_reorder_nothing() {
        let r: &'static mut Ring<u64, 17> = Box::leak(Box::new(Ring::new()));
        let (mut tx, mut rx) = r.split();
        const COUNT: u64 = 200_000;
        std::thread::scope(|s| {
            s.spawn(move || {
                let mut i = 0;
                while i < COUNT {
                    if tx.enqueue(i).is_ok() {
                        i += 1;
                    } else {
                        std::hint::spin_loop();
                    }
                }
            });
            s.spawn(move || {
                let mut expect = 0;
                while expect < COUNT {
                    if let Some(v) = rx.dequeue() {
                        assert_eq!(v, expect);
                        expect += 1;
                    } else {
                        std::hint::spin_loop();
                    }
                }
            });
        });
    }
}
