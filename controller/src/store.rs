//! The settings in a flash sector: a log of records, each with a format
//! version, a sequence number and a CRC; the newest good one is in force.
//!
//! ```text
//! record (RECORD_WORDS little-endian 32-bit words):
//!   MAGIC · VERSION | COUNT << 16 · sequence · values (i64: low word, high word) × COUNT · CRC-32
//! ```
//!
//! NOR flash is erased to ones and programmed word by word towards zeros,
//! so records are appended in erased slots one after another and the
//! sector is erased only when it is full: an erase (hundreds of ms on an
//! STM32F4, with the core stalled on flash reads) once every [`SLOTS`]
//! saves in a 16 KiB sector, the others cost the programming of one record.
//! (The same log-structured scheme as ST's EEPROM emulation, AN3969, and
//! grblHAL's flash storage of its settings, `Src/flash.c`; written here
//! for this record.)
//!
//! Reading at start-up ([`load`]) scans the slots up to the first erased
//! one. The newest record decides:
//! - valid (magic, version, CRC, every value in range and the planner's
//!   settings accepted: [`Config::from_values`]): in force
//!   ([`StoreResult::Loaded`]);
//! - another format version: the defaults ([`StoreResult::OldVersion`]):
//!   a record of another layout is never read as this one;
//! - corrupt (a torn write, a flipped bit): the newest older record that is
//!   valid, or the defaults if there is none ([`StoreResult::Corrupt`]);
//! - nothing written: the defaults ([`StoreResult::Empty`]).
//!
//! So what is in force is always a record that was written whole, or the
//! defaults, never garbage, and anything but a clean load is reported.
//! Saving ([`Store::save`]) reads the record back and reports
//! [`StoreResult::WriteFailed`] if it does not match (QEMU's flash is ROM:
//! writes never land there).

use link::StoreResult;

use crate::config::{Config, COUNT};

/// First word of a record.
pub const MAGIC: u32 = 0x5345_5454;
/// The record's format version (a new layout of [`crate::config`] takes a
/// new one).
pub const VERSION: u16 = 2;
/// Words of a record: magic, version, sequence, the values, CRC.
pub const RECORD_WORDS: usize = 3 + 2 * COUNT + 1;
/// Bytes of the smallest sector the log lives in (the STM32F4's 16 KiB
/// sectors 0-3; sectors 5 and up are 128 KiB).
pub const SECTOR_BYTES: usize = 16 * 1024;
/// Records a 16 KiB sector holds.
pub const SLOTS: usize = SECTOR_BYTES / 4 / RECORD_WORDS;

/// A flash sector, by 32-bit words.
pub trait Flash {
    /// The sector's size, words.
    fn words(&self) -> usize;
    /// The word at `index` (0 .. [`Flash::words`]); an erased word reads
    /// `u32::MAX`.
    fn read(&self, index: usize) -> u32;
    /// Erase the whole sector (every word to `u32::MAX`).
    fn erase(&mut self) -> Result<(), FlashError>;
    /// Program one word (only clears bits: program an erased word).
    fn program(&mut self, index: usize, value: u32) -> Result<(), FlashError>;
}

/// The flash controller reported an error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlashError;

/// Where the next record goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Store {
    /// The next free slot (`SLOTS`: full, erase first).
    next: usize,
    /// The newest record's sequence number.
    seq: u32,
}

/// What a slot holds.
#[allow(clippy::large_enum_variant)] // one at a time, on the stack
enum Slot {
    Erased,
    Valid(u32, Config),
    OtherVersion,
    Corrupt,
}

fn crc(words: &[u32]) -> u32 {
    link::crc32_words(words)
}

/// `c` as a record with sequence number `seq`.
pub fn encode(c: &Config, seq: u32) -> [u32; RECORD_WORDS] {
    let mut r = [0u32; RECORD_WORDS];
    r[0] = MAGIC;
    r[1] = VERSION as u32 | (COUNT as u32) << 16;
    r[2] = seq;
    for (w, v) in r[3..3 + 2 * COUNT].chunks_exact_mut(2).zip(c.values()) {
        w[0] = *v as u32;
        w[1] = (*v >> 32) as u32;
    }
    r[RECORD_WORDS - 1] = crc(&r[..RECORD_WORDS - 1]);
    r
}

/// A record's words.
fn decode(r: &[u32; RECORD_WORDS]) -> Slot {
    if r.iter().all(|&w| w == u32::MAX) {
        return Slot::Erased;
    }
    if r[0] != MAGIC || r[RECORD_WORDS - 1] != crc(&r[..RECORD_WORDS - 1]) {
        return Slot::Corrupt;
    }
    if r[1] != VERSION as u32 | (COUNT as u32) << 16 {
        return Slot::OtherVersion;
    }
    let mut values = [0i64; COUNT];
    for (v, w) in values.iter_mut().zip(r[3..3 + 2 * COUNT].chunks_exact(2)) {
        *v = (w[0] as u64 | (w[1] as u64) << 32) as i64;
    }
    match Config::from_values(values) {
        Some(c) => Slot::Valid(r[2], c),
        None => Slot::Corrupt,
    }
}

fn read_slot(flash: &impl Flash, slot: usize) -> [u32; RECORD_WORDS] {
    let mut r = [0u32; RECORD_WORDS];
    for (i, w) in r.iter_mut().enumerate() {
        *w = flash.read(slot * RECORD_WORDS + i);
    }
    r
}

/// The settings in force after a reset (module docs), how they were found,
/// and where the next record goes.
pub fn load(flash: &impl Flash) -> (Config, StoreResult, Store) {
    let mut good: Option<(u32, Config)> = None;
    let mut newest = Slot::Erased;
    let slots = flash.words() / RECORD_WORDS;
    let mut next = slots;
    for slot in 0..slots {
        match decode(&read_slot(flash, slot)) {
            Slot::Erased => {
                next = slot;
                break;
            }
            Slot::Valid(seq, c) => {
                good = Some((seq, c));
                newest = Slot::Valid(seq, c);
            }
            other => newest = other,
        }
    }
    let seq = good.map_or(0, |g| g.0);
    let store = Store { next, seq };
    let (config, result) = match newest {
        Slot::Erased => (Config::DEFAULT, StoreResult::Empty),
        Slot::Valid(_, c) => (c, StoreResult::Loaded),
        Slot::OtherVersion => (Config::DEFAULT, StoreResult::OldVersion),
        Slot::Corrupt => (good.map_or(Config::DEFAULT, |g| g.1), StoreResult::Corrupt),
    };
    (config, result, store)
}

impl Store {
    /// Append `c` as the newest record (erasing the sector first when it
    /// is full, or when the slot is not erased); read back.
    pub fn save(&mut self, flash: &mut impl Flash, c: &Config) -> StoreResult {
        let seq = self.seq.wrapping_add(1);
        let record = encode(c, seq);
        let free = self.next < flash.words() / RECORD_WORDS
            && (0..RECORD_WORDS).all(|i| flash.read(self.next * RECORD_WORDS + i) == u32::MAX);
        if !free {
            if flash.erase().is_err() {
                return StoreResult::WriteFailed;
            }
            self.next = 0;
        }
        let at = self.next * RECORD_WORDS;
        for (i, w) in record.iter().enumerate() {
            if flash.program(at + i, *w).is_err() {
                self.next += 1;
                return StoreResult::WriteFailed;
            }
        }
        self.next += 1;
        if read_slot(flash, self.next - 1) != record {
            return StoreResult::WriteFailed;
        }
        self.seq = seq;
        StoreResult::Saved
    }
}

/// A flash sector in RAM (host tests and the virtual device): erases to
/// ones, programming only clears bits, as NOR flash.
#[cfg(any(test, feature = "std"))]
#[derive(Clone, Debug)]
pub struct MemFlash {
    /// The sector's words.
    pub words: Vec<u32>,
    /// Erases so far.
    pub erases: u32,
}

#[cfg(any(test, feature = "std"))]
impl Default for MemFlash {
    fn default() -> Self {
        MemFlash {
            words: vec![u32::MAX; SECTOR_BYTES / 4],
            erases: 0,
        }
    }
}

#[cfg(any(test, feature = "std"))]
impl Flash for MemFlash {
    fn words(&self) -> usize {
        self.words.len()
    }
    fn read(&self, index: usize) -> u32 {
        self.words.get(index).copied().unwrap_or(u32::MAX)
    }
    fn erase(&mut self) -> Result<(), FlashError> {
        self.words.fill(u32::MAX);
        self.erases += 1;
        Ok(())
    }
    fn program(&mut self, index: usize, value: u32) -> Result<(), FlashError> {
        let w = self.words.get_mut(index).ok_or(FlashError)?;
        *w &= value;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Key;

    fn changed(k: u16, v: i64) -> Config {
        let mut c = Config::DEFAULT;
        c.set(k, v).unwrap();
        c
    }

    #[test]
    fn a_saved_record_loads_back_and_the_newest_wins() {
        let mut f = MemFlash::default();
        let (c, r, mut s) = load(&f);
        assert_eq!((c, r), (Config::DEFAULT, StoreResult::Empty));
        let a = changed(100, 80_000);
        assert_eq!(s.save(&mut f, &a), StoreResult::Saved);
        let b = changed(120, 500);
        assert_eq!(s.save(&mut f, &b), StoreResult::Saved);
        let (c, r, s2) = load(&f);
        assert_eq!((c, r), (b, StoreResult::Loaded));
        assert_eq!(s2, s, "the next slot and sequence found again");
        assert_eq!(c.get(Key::AccelX), 500);
        assert_eq!(c.get(Key::StepsPerMmX), 100_000, "the newest record only");
    }

    #[test]
    fn a_full_sector_is_erased_and_the_log_starts_again() {
        let mut f = MemFlash::default();
        let (_, _, mut s) = load(&f);
        for i in 0..SLOTS as i64 + 3 {
            let c = changed(120, 100 + i);
            assert_eq!(s.save(&mut f, &c), StoreResult::Saved);
            assert_eq!(load(&f).0, c);
        }
        assert_eq!(f.erases, 1);
        const { assert!(SLOTS >= 32, "records a sector") };
    }

    #[test]
    fn a_torn_or_flipped_record_falls_back_to_the_last_good_one() {
        let mut f = MemFlash::default();
        let (_, _, mut s) = load(&f);
        let good = changed(110, 7000);
        s.save(&mut f, &good);
        s.save(&mut f, &changed(110, 8000));
        // The second record torn: its last words never written.
        let torn = RECORD_WORDS * 2 - 5;
        f.words[torn..RECORD_WORDS * 2].fill(u32::MAX);
        assert_eq!(load(&f).0, good);
        assert_eq!(load(&f).1, StoreResult::Corrupt);
        // A flipped bit in the only record: the defaults.
        let mut g = MemFlash::default();
        let (_, _, mut s) = load(&g);
        s.save(&mut g, &good);
        g.words[7] ^= 1 << 3;
        assert_eq!(load(&g).0, Config::DEFAULT);
        assert_eq!(load(&g).1, StoreResult::Corrupt);
        // The next save goes after the broken slot; then it loads.
        let (_, _, mut s) = load(&g);
        assert_eq!(s.save(&mut g, &good), StoreResult::Saved);
        assert_eq!(load(&g), (good, StoreResult::Loaded, s));
    }

    #[test]
    fn another_version_or_values_out_of_range_are_never_read() {
        let mut f = MemFlash::default();
        let mut r = encode(&changed(110, 7000), 1);
        r[1] = (VERSION as u32 + 1) | (COUNT as u32) << 16;
        r[RECORD_WORDS - 1] = crc(&r[..RECORD_WORDS - 1]);
        for (i, w) in r.iter().enumerate() {
            f.program(i, *w).unwrap();
        }
        assert_eq!(load(&f).0, Config::DEFAULT);
        assert_eq!(load(&f).1, StoreResult::OldVersion);
        // A well-formed record whose value is out of range (as an older
        // firmware with wider ranges could have written): corrupt.
        let mut f = MemFlash::default();
        let mut r = encode(&Config::DEFAULT, 1);
        let at = 3 + 2 * Key::AccelX as usize;
        r[at] = 0;
        r[at + 1] = 0;
        r[RECORD_WORDS - 1] = crc(&r[..RECORD_WORDS - 1]);
        for (i, w) in r.iter().enumerate() {
            f.program(i, *w).unwrap();
        }
        assert_eq!(load(&f).1, StoreResult::Corrupt);
        assert_eq!(load(&f).0, Config::DEFAULT);
    }

    /// A flash whose writes never land (QEMU's ROM).
    struct Rom;
    impl Flash for Rom {
        fn words(&self) -> usize {
            SECTOR_BYTES / 4
        }
        fn read(&self, _: usize) -> u32 {
            0
        }
        fn erase(&mut self) -> Result<(), FlashError> {
            Ok(())
        }
        fn program(&mut self, _: usize, _: u32) -> Result<(), FlashError> {
            Ok(())
        }
    }

    #[test]
    fn a_write_that_does_not_read_back_is_reported() {
        let (c, r, mut s) = load(&Rom);
        assert_eq!((c, r), (Config::DEFAULT, StoreResult::Corrupt));
        assert_eq!(s.save(&mut Rom, &c), StoreResult::WriteFailed);
    }

    mod props {
        use super::*;
        use proptest::prelude::*;

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(64))]
            /// Any corruption of the stored words loads either a record
            /// that was written or the defaults, and says so unless the
            /// newest record is intact.
            #[test]
            fn corruption_never_loads_garbage(
                accel in proptest::collection::vec(1i64..100_000, 1..5),
                hits in proptest::collection::vec((0usize..RECORD_WORDS * 5, any::<u32>()), 0..4),
            ) {
                let mut f = MemFlash::default();
                let (_, _, mut s) = load(&f);
                let written: Vec<Config> = accel.iter().map(|&a| changed(120, a)).collect();
                for c in &written {
                    s.save(&mut f, c);
                }
                for (at, x) in &hits {
                    f.words[*at] ^= x;
                }
                let (c, r, _) = load(&f);
                prop_assert!(c == Config::DEFAULT || written.contains(&c));
                if r == StoreResult::Loaded {
                    prop_assert!(written.contains(&c));
                }
            }
        }
    }
}
