//! FNV-1a (64-bit) over the commanded positions: what the firmware reports
//! of its motion (`link::Status::positions_checksum`, folded to 32 bits)
//! and what the host recomputes from the same inputs.

use fuzzy_core::units::Point3Mm;

/// FNV-1a over 64-bit words.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Checksum(pub u64);

impl Default for Checksum {
    fn default() -> Self {
        Checksum(0xCBF2_9CE4_8422_2325)
    }
}

impl Checksum {
    /// Fold in one word.
    pub fn add(&mut self, w: u64) {
        self.0 = (self.0 ^ w).wrapping_mul(0x0000_0100_0000_01B3);
    }

    /// Fold in a commanded position (its three I32F32 coordinates).
    pub fn add_pos(&mut self, p: Point3Mm) {
        for c in p.to_bits() {
            self.add(c as u64);
        }
    }

    /// Folded to 32 bits (high ⊕ low), as `link::Status` carries it.
    pub fn folded(&self) -> u32 {
        (self.0 ^ (self.0 >> 32)) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_of_known_words() {
        // FNV-1a 64 of no data is its offset basis; one zero word is one
        // multiplication by the prime.
        let mut c = Checksum::default();
        assert_eq!(c.0, 0xCBF2_9CE4_8422_2325);
        c.add(0);
        assert_eq!(c.0, 0xCBF2_9CE4_8422_2325u64.wrapping_mul(0x100_0000_01B3));
        assert_eq!(c.folded(), ((c.0 >> 32) ^ c.0) as u32);
    }

    #[test]
    fn order_matters() {
        let (a, b) = (Point3Mm::from_bits(1, 2, 3), Point3Mm::from_bits(3, 2, 1));
        let (mut x, mut y) = (Checksum::default(), Checksum::default());
        x.add_pos(a);
        x.add_pos(b);
        y.add_pos(b);
        y.add_pos(a);
        assert_ne!(x, y);
    }
}
