//! Several path points in one frame ([`crate::HostMsg::Points`]): the
//! compact, exact wire format for dense toolpaths.
//!
//! Positions travel on a grid of 2^-16 mm (about 15 nm, far below any
//! machine's resolution): the host rounds each coordinate to it
//! ([`to_grid`]), and the controller reconstructs exactly those I32F32
//! bits. A batch's first point is absolute, the others are deltas from the
//! point before them, so a batch decodes on its own (a lost or resent frame
//! never leaves the controller decoding against the wrong base). Feed caps
//! (I32F32 bits, exact) are sent only where they change.
//!
//! ```text
//! point: varint zigzag(Δx) · varint zigzag(Δy) · varint (zigzag(Δz) << 1 | cap changed)
//!        [· varint (cap bits + 1), 0 = no cap]          (only if the cap changed)
//! Δ: in grid units (2^-16 mm), from the previous point of the batch; the
//!    first point's from the origin (absolute), and its cap is "changed"
//!    whenever it has one.
//! varint: little-endian base-128 (LEB128), as postcard's; zigzag: (n << 1) ^ (n >> 63).
//! ```
//!
//! A 2-D move of 0.05-0.5 mm takes 5-7 bytes, a 3-D one 7-10; a 128-byte
//! frame holds about 15 such points with its header, sequence number and
//! CRC.

use core::fmt;

use serde::de::{self, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// The grid, as a shift of the I32F32 bits: positions are multiples of
/// 2^16 bits (2^-16 mm).
pub const GRID_SHIFT: u32 = 16;

/// Bytes of point data a batch holds at most (what a frame leaves after its
/// tag, message variant, sequence number and the data's length).
pub const BATCH_BYTES: usize = 100;

/// I32F32 bits rounded to the nearest grid point (2^-16 mm; halves up),
/// saturating at the top of the range.
pub const fn to_grid(bits: i64) -> i64 {
    (bits.saturating_add(1 << (GRID_SHIFT - 1)) >> GRID_SHIFT) << GRID_SHIFT
}

/// Whether `bits` lie on the grid.
pub const fn on_grid(bits: i64) -> bool {
    bits & ((1i64 << GRID_SHIFT) - 1) == 0
}

/// One decoded point: position (I32F32 bits per axis) and feed cap (I32F32
/// bits, mm/min; `None`: none).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BatchPoint {
    /// Position, mm, I32F32 bits per axis.
    pub pos_mm: [i64; 3],
    /// Feed cap, mm/min, I32F32 bits.
    pub feed_cap_mm_per_min: Option<i64>,
}

/// The points of one `Points` frame, encoded (module docs).
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct PointBatch {
    bytes: [u8; BATCH_BYTES],
    len: u8,
    count: u8,
}

impl fmt::Debug for PointBatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "PointBatch({} points, {} bytes)", self.count, self.len)
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for PointBatch {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(
            f,
            "PointBatch({=u8} points, {=u8} bytes)",
            self.count,
            self.len
        )
    }
}

impl Default for PointBatch {
    fn default() -> Self {
        Self::new()
    }
}

fn zigzag(n: i64) -> u64 {
    ((n << 1) ^ (n >> 63)) as u64
}

fn unzigzag(z: u64) -> i64 {
    ((z >> 1) as i64) ^ -((z & 1) as i64)
}

/// Bytes of the LEB128 encoding of `v`.
fn varint_len(v: u64) -> usize {
    (64 - v.leading_zeros() as usize).max(1).div_ceil(7)
}

impl PointBatch {
    /// Empty.
    pub const fn new() -> Self {
        PointBatch {
            bytes: [0; BATCH_BYTES],
            len: 0,
            count: 0,
        }
    }

    /// Points held.
    pub fn len(&self) -> usize {
        self.count as usize
    }

    /// Whether it holds no point.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Encoded bytes.
    pub fn encoded_len(&self) -> usize {
        self.len as usize
    }

    /// The last point pushed (the base of the next delta).
    fn last(&self) -> Option<BatchPoint> {
        self.points().last().and_then(Result::ok)
    }

    /// Append a point if it fits (positions on the grid: [`to_grid`]);
    /// `false` (nothing changed) if it does not fit or is off the grid.
    pub fn push(&mut self, p: BatchPoint) -> bool {
        if !p.pos_mm.iter().all(|c| on_grid(*c)) || self.count == u8::MAX {
            return false;
        }
        let prev = self.last();
        let base = prev.map_or([0; 3], |q| q.pos_mm);
        let cap_changed = match prev {
            None => p.feed_cap_mm_per_min.is_some(),
            Some(q) => q.feed_cap_mm_per_min != p.feed_cap_mm_per_min,
        };
        let d = |k: usize| (p.pos_mm[k].wrapping_sub(base[k])) >> GRID_SHIFT;
        let words = [
            Some(zigzag(d(0))),
            Some(zigzag(d(1))),
            Some((zigzag(d(2)) << 1) | cap_changed as u64),
            cap_changed.then(|| {
                p.feed_cap_mm_per_min
                    .map_or(0, |c| (c as u64).wrapping_add(1))
            }),
        ];
        let need: usize = words.iter().flatten().map(|w| varint_len(*w)).sum();
        let at = self.len as usize;
        if at + need > BATCH_BYTES {
            return false;
        }
        let mut i = at;
        for w in words.iter().flatten() {
            let mut v = *w;
            loop {
                let byte = (v & 0x7F) as u8;
                v >>= 7;
                if let Some(slot) = self.bytes.get_mut(i) {
                    *slot = if v == 0 { byte } else { byte | 0x80 };
                }
                i += 1;
                if v == 0 {
                    break;
                }
            }
        }
        self.len = i as u8;
        self.count += 1;
        true
    }

    /// The points, in order; an error where the bytes do not decode (a
    /// truncated varint, a delta leaving the coordinate range).
    pub fn points(&self) -> Points<'_> {
        Points {
            bytes: self.bytes.get(..self.len as usize).unwrap_or(&[]),
            at: 0,
            prev: None,
            left: self.count,
        }
    }
}

/// Iterator over a batch's points ([`PointBatch::points`]).
pub struct Points<'a> {
    bytes: &'a [u8],
    at: usize,
    prev: Option<BatchPoint>,
    left: u8,
}

impl Points<'_> {
    fn varint(&mut self) -> Option<u64> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let b = *self.bytes.get(self.at)?;
            self.at += 1;
            v |= ((b & 0x7F) as u64) << shift;
            if b & 0x80 == 0 {
                return Some(v);
            }
        }
        None
    }

    fn next_point(&mut self) -> Option<BatchPoint> {
        let base = self.prev.map_or([0; 3], |q| q.pos_mm);
        let dx = unzigzag(self.varint()?);
        let dy = unzigzag(self.varint()?);
        let wz = self.varint()?;
        let dz = unzigzag(wz >> 1);
        let cap = if wz & 1 == 1 {
            match self.varint()? {
                0 => None,
                c => Some(i64::try_from(c - 1).ok()?),
            }
        } else {
            self.prev.and_then(|q| q.feed_cap_mm_per_min)
        };
        let axis = |b: i64, d: i64| b.checked_add(d.checked_mul(1 << GRID_SHIFT)?);
        Some(BatchPoint {
            pos_mm: [axis(base[0], dx)?, axis(base[1], dy)?, axis(base[2], dz)?],
            feed_cap_mm_per_min: cap,
        })
    }
}

impl Iterator for Points<'_> {
    type Item = Result<BatchPoint, crate::ErrorCode>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.left == 0 {
            // Bytes beyond the last point: malformed, said once.
            let extra = self.at < self.bytes.len();
            self.at = self.bytes.len();
            return extra.then_some(Err(crate::ErrorCode::Malformed));
        }
        self.left -= 1;
        match self.next_point() {
            Some(p) => {
                self.prev = Some(p);
                Some(Ok(p))
            }
            None => {
                self.left = 0;
                self.at = self.bytes.len();
                Some(Err(crate::ErrorCode::Malformed))
            }
        }
    }
}

impl Serialize for PointBatch {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeTuple;
        let mut t = s.serialize_tuple(2)?;
        t.serialize_element(&self.count)?;
        t.serialize_element(&Bytes(self.bytes.get(..self.len as usize).unwrap_or(&[])))?;
        t.end()
    }
}

struct Bytes<'a>(&'a [u8]);

impl Serialize for Bytes<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(self.0)
    }
}

impl<'de> Deserialize<'de> for PointBatch {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct BatchVisitor;
        impl<'de> Visitor<'de> for BatchVisitor {
            type Value = PointBatch;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a point count and at most 100 bytes of points")
            }
            fn visit_seq<A: de::SeqAccess<'de>>(self, mut seq: A) -> Result<PointBatch, A::Error> {
                let count: u8 = seq
                    .next_element()?
                    .ok_or_else(|| de::Error::invalid_length(0, &self))?;
                let bytes: BytesIn = seq
                    .next_element()?
                    .ok_or_else(|| de::Error::invalid_length(1, &self))?;
                Ok(PointBatch {
                    bytes: bytes.0,
                    len: bytes.1,
                    count,
                })
            }
        }
        d.deserialize_tuple(2, BatchVisitor)
    }
}

/// Up to [`BATCH_BYTES`] bytes, deserialised into a fixed array.
struct BytesIn([u8; BATCH_BYTES], u8);

impl<'de> Deserialize<'de> for BytesIn {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = BytesIn;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("at most 100 bytes")
            }
            fn visit_bytes<E: de::Error>(self, v: &[u8]) -> Result<BytesIn, E> {
                let mut out = [0u8; BATCH_BYTES];
                let dst = out
                    .get_mut(..v.len())
                    .ok_or_else(|| E::invalid_length(v.len(), &self))?;
                dst.copy_from_slice(v);
                Ok(BytesIn(out, v.len() as u8))
            }
            fn visit_borrowed_bytes<E: de::Error>(self, v: &'de [u8]) -> Result<BytesIn, E> {
                self.visit_bytes(v)
            }
        }
        d.deserialize_bytes(V)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn mm(x: f64) -> i64 {
        to_grid((x * 4294967296.0) as i64)
    }

    #[test]
    fn the_grid_rounds_to_nearest() {
        assert_eq!(to_grid(0), 0);
        assert_eq!(to_grid((1 << 15) - 1), 0);
        assert_eq!(to_grid(1 << 15), 1 << 16);
        assert_eq!(to_grid(-(1 << 15)), 0);
        assert_eq!(to_grid(-(1 << 15) - 1), -(1 << 16));
        assert!(on_grid(to_grid(i64::MAX)) && on_grid(to_grid(i64::MIN)));
    }

    #[test]
    fn short_2d_moves_take_about_five_bytes_a_point() {
        let mut b = PointBatch::new();
        let mut n = 0;
        while b.push(BatchPoint {
            pos_mm: [
                mm(10.0 + 0.05 * n as f64),
                mm(5.0 + 0.03 * n as f64),
                mm(-1.0),
            ],
            feed_cap_mm_per_min: Some(1200i64 << 32),
        }) {
            n += 1;
        }
        let per = b.encoded_len() as f64 / n as f64;
        assert!(n >= 16, "{n} points");
        assert!(per <= 6.5, "{per} bytes a point");
        let got: Vec<BatchPoint> = b.points().map(Result::unwrap).collect();
        assert_eq!(got.len(), n);
        assert_eq!(got[3].pos_mm[0], mm(10.15));
        assert!(got
            .iter()
            .all(|p| p.feed_cap_mm_per_min == Some(1200 << 32)));
    }

    #[test]
    fn off_grid_points_are_not_taken() {
        let mut b = PointBatch::new();
        assert!(!b.push(BatchPoint {
            pos_mm: [1, 0, 0],
            feed_cap_mm_per_min: None
        }));
        assert!(b.is_empty());
    }

    #[test]
    fn garbage_bytes_decode_to_an_error_not_a_panic() {
        let b = PointBatch {
            bytes: [0xFF; BATCH_BYTES],
            len: BATCH_BYTES as u8,
            count: 40,
        };
        assert!(b.points().any(|p| p.is_err()));
        // Fewer points than the bytes hold: the rest is malformed.
        let mut ok = PointBatch::new();
        ok.push(BatchPoint {
            pos_mm: [0; 3],
            feed_cap_mm_per_min: None,
        });
        ok.push(BatchPoint {
            pos_mm: [1 << 16; 3],
            feed_cap_mm_per_min: None,
        });
        ok.count = 1;
        let r: Vec<_> = ok.points().collect();
        assert!(matches!(r[..], [Ok(_), Err(crate::ErrorCode::Malformed)]));
    }

    proptest! {
        /// Any points on the grid within ±100 m and any caps come back
        /// exactly, and a batch never holds more than fits.
        #[test]
        fn points_round_trip_exactly(
            pts in proptest::collection::vec(
                ((-100_000_000_000_000i64..100_000_000_000_000), (-1i64..10), (-5i64..5), proptest::option::of(0i64..(1_000_000i64 << 32))),
                1..60),
        ) {
            let mut b = PointBatch::new();
            let mut want = Vec::new();
            for (x, dy, dz, cap) in pts {
                let p = BatchPoint {
                    pos_mm: [to_grid(x), dy << 20, to_grid(dz << 30)],
                    feed_cap_mm_per_min: cap,
                };
                if !b.push(p) {
                    break;
                }
                want.push(p);
            }
            prop_assert!(b.encoded_len() <= BATCH_BYTES);
            let got: Vec<BatchPoint> = b.points().collect::<Result<_, _>>().unwrap();
            prop_assert_eq!(got, want);
        }
    }
}
