//! A fixed-capacity FIFO of `Copy` values for the scheduler's stages.
//!
//! `heapless::Deque` keeps a front index, a back index and a "full" flag,
//! derives its length from them and reaches its capacity through a storage
//! abstraction: more work per push and pop than the scheduler's hot path
//! needs. This ring keeps a start index and a length (both `u32`), wraps
//! with `% N` (a multiplication for a constant `N`, after which the slot
//! index is provably in bounds), and stores plain values (`T: Copy +
//! Default`, so no `unsafe` for uninitialised slots). Every access is
//! checked (`get`), so nothing here can panic.

/// Up to `N` values, oldest first.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ring<T, const N: usize> {
    slots: [T; N],
    /// Slot of the oldest value.
    start: u32,
    /// Values held.
    len: u32,
}

impl<T: Copy + Default, const N: usize> Default for Ring<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Copy + Default, const N: usize> Ring<T, N> {
    /// An empty ring.
    pub(crate) fn new() -> Self {
        Ring {
            slots: [T::default(); N],
            start: 0,
            len: 0,
        }
    }

    /// Values held.
    #[inline(always)]
    pub(crate) fn len(&self) -> usize {
        self.len as usize
    }

    /// Whether no value is held.
    #[inline(always)]
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Whether `N` values are held.
    #[inline(always)]
    pub(crate) fn is_full(&self) -> bool {
        self.len as usize >= N
    }

    /// Slot of the `i`-th value from the oldest (`i < N`).
    #[inline(always)]
    fn slot(&self, i: u32) -> usize {
        // `checked_rem`: folds to `% N` for the crate's N >= 1, and N = 0 cannot
        // panic.
        (self.start as usize + i as usize)
            .checked_rem(N)
            .unwrap_or(0)
    }

    /// Append `v`; gives it back when full.
    #[inline(always)]
    pub(crate) fn push_back(&mut self, v: T) -> Result<(), T> {
        if self.is_full() {
            return Err(v);
        }
        let s = self.slot(self.len);
        match self.slots.get_mut(s) {
            Some(slot) => {
                *slot = v;
                self.len += 1;
                Ok(())
            }
            None => Err(v),
        }
    }

    /// Append a value written in place (the caller fills the returned slot,
    /// which holds a stale value); `None` when full. For large values: the
    /// caller writes them field by field, where moving one whole is a
    /// `memcpy` call on the target.
    #[inline(always)]
    pub(crate) fn push_slot(&mut self) -> Option<&mut T> {
        if self.is_full() {
            return None;
        }
        let s = self.slot(self.len);
        let slot = self.slots.get_mut(s)?;
        self.len += 1;
        Some(slot)
    }

    /// Remove the oldest value (without copying it out).
    #[inline(always)]
    pub(crate) fn drop_front(&mut self) {
        if self.len > 0 {
            self.start = self.slot(1) as u32;
            self.len -= 1;
        }
    }

    /// Remove and return the oldest value.
    #[inline(always)]
    pub(crate) fn pop_front(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        let v = self.slots.get(self.start as usize).copied();
        self.start = self.slot(1) as u32;
        self.len -= 1;
        v
    }

    /// Keep the `len` oldest values (all of them if fewer are held).
    #[inline(always)]
    pub(crate) fn truncate(&mut self, len: usize) {
        self.len = self.len.min(len.min(N) as u32);
    }

    /// The `i`-th value from the oldest.
    #[inline(always)]
    pub(crate) fn get(&self, i: usize) -> Option<&T> {
        if i >= self.len as usize {
            return None;
        }
        self.slots.get(self.slot(i as u32))
    }

    /// The oldest value.
    #[inline(always)]
    pub(crate) fn front(&self) -> Option<&T> {
        if self.len == 0 {
            return None;
        }
        self.slots.get(self.start as usize)
    }

    /// The newest value.
    #[inline(always)]
    pub(crate) fn back(&self) -> Option<&T> {
        self.get((self.len as usize).wrapping_sub(1))
    }

    /// Drop every value.
    pub(crate) fn clear(&mut self) {
        self.start = 0;
        self.len = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::collections::VecDeque;

    #[test]
    fn a_ring_of_no_slots_refuses_everything() {
        let mut r = Ring::<u8, 0>::new();
        assert_eq!(r.push_back(1), Err(1));
        assert!(r.push_slot().is_none());
        assert_eq!(
            (r.pop_front(), r.front(), r.back(), r.get(0)),
            (None, None, None, None)
        );
        r.drop_front();
        r.truncate(0);
        assert!(r.is_empty() && r.is_full());
    }

    proptest! {
        /// Any sequence of operations behaves like `VecDeque` bounded at N.
        #[test]
        fn behaves_like_a_bounded_vecdeque(ops in proptest::collection::vec((0u8..6, 0usize..7), 0..300)) {
            let mut r = Ring::<u32, 5>::new();
            let mut m = VecDeque::new();
            for (i, (op, keep)) in ops.into_iter().enumerate() {
                let v = i as u32;
                match op {
                    0 | 1 => {
                        let ok = r.push_back(v).is_ok();
                        prop_assert_eq!(ok, m.len() < 5);
                        if ok { m.push_back(v); }
                    }
                    2 => prop_assert_eq!(r.pop_front(), m.pop_front()),
                    3 => { r.truncate(keep); m.truncate(keep); }
                    4 if i % 2 == 0 => {
                        let ok = match r.push_slot() { Some(s) => { *s = v; true } None => false };
                        prop_assert_eq!(ok, m.len() < 5);
                        if ok { m.push_back(v); }
                    }
                    4 => { r.drop_front(); m.pop_front(); }
                    5 => { r.clear(); m.clear(); }
                    _ => {}
                }
                prop_assert_eq!(r.len(), m.len());
                prop_assert_eq!(r.is_full(), m.len() == 5);
                prop_assert_eq!(r.front(), m.front());
                prop_assert_eq!(r.back(), m.back());
                for k in 0..6 {
                    prop_assert_eq!(r.get(k), m.get(k));
                }
            }
        }
    }
}
