//! A record of the last hard fault, kept across the reset that follows it
//! in RAM the start-up code does not clear (the firmware's `.uninit`
//! section), so that the next boot can report it ([`AlarmCode::Fault`]:
//! the controller starts in the alarm state and says where the fault was).
//!
//! RAM holds noise after a power-up, so the record carries a magic word
//! and a check word: a record is believed only if both match, and reading
//! it clears it (one report per fault).

use link::AlarmCode;

const MAGIC: u32 = 0xFA17_C0DE;

/// The record (three words of RAM that survive a reset).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FaultRecord {
    magic: u32,
    pc: u32,
    check: u32,
}

impl FaultRecord {
    /// A fault at `pc` (the stacked program counter), as the fault handler
    /// writes it.
    pub const fn at(pc: u32) -> Self {
        FaultRecord {
            magic: MAGIC,
            pc,
            check: !pc ^ MAGIC,
        }
    }

    /// Nothing recorded.
    pub const CLEAR: FaultRecord = FaultRecord {
        magic: 0,
        pc: 0,
        check: 0,
    };

    /// The alarm to start in if the record is a fault's (else `None`:
    /// cleared, or power-up noise).
    pub fn alarm(&self) -> Option<AlarmCode> {
        (self.magic == MAGIC && self.check == !self.pc ^ MAGIC)
            .then_some(AlarmCode::Fault { pc: self.pc })
    }

    /// The record as the three words kept in RAM.
    pub const fn words(&self) -> [u32; 3] {
        [self.magic, self.pc, self.check]
    }

    /// From raw words (RAM as found after a reset).
    pub const fn from_words(w: [u32; 3]) -> Self {
        FaultRecord {
            magic: w[0],
            pc: w[1],
            check: w[2],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_recorded_fault_is_reported_with_its_address() {
        let r = FaultRecord::at(0x0800_1234);
        assert_eq!(r.alarm(), Some(AlarmCode::Fault { pc: 0x0800_1234 }));
        assert_eq!(FaultRecord::CLEAR.alarm(), None);
    }

    #[test]
    fn power_up_noise_is_not_a_fault() {
        // A cheap generator over many words: none passes both checks.
        let mut x = 0x1234_5678u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        for _ in 0..100_000 {
            let w = [next(), next(), next()];
            assert_eq!(FaultRecord::from_words(w).alarm(), None, "{w:x?}");
        }
        // Even with the magic word right by chance.
        for _ in 0..100_000 {
            let (pc, check) = (next(), next());
            if check != !pc ^ MAGIC {
                assert_eq!(FaultRecord::from_words([MAGIC, pc, check]).alarm(), None);
            }
        }
    }
}
