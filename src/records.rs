//! The byte layouts of the messages that carry particles and nodal sums
//! between patches and ranks: one writer and one reader per kind of
//! record, so that a layout is written down once and a field is found by
//! its name, never by a word offset.
//!
//! | kind | layout (little-endian) | used by |
//! |---|---|---|
//! | [`Routed`] | destination patch (u64), a packed particle ([`Packed`]) | migration, delivery, level changes, rebalancing |
//! | [`Restart`] | file row, level, patch (u64 each), a packed particle | the checkpoint reader's routing |
//! | [`NewRecord`] | id (u64), `x, y, lpx, lpy, vx, vy, mass` (f64), material (u64) | insertion |
//! | [`CopyColumns`] | count `n` (u64); `n` patches (u32), `n` ids (u64), `n` materials (u32); then per f64 particle field its `n` values | copies between levels |
//! | [`NodalSums`] | destination patch, source patch (u64 each), then f64 values | nodal sums over shared nodes, the ring copies' nodal field |
//! | [`Length`] | a byte count (u64) | the size of a message announced before it |
//!
//! A packed particle itself is written by [`Particles::packed`] and read
//! by [`PackedParticle`]. Records hold no MPI: the layers that send them
//! (`level`, `coupling`, `sim`, `io`) own the exchanges.

use crate::particles::{NewParticle, Packed, PackedParticle, Particles};

/// The little-endian u64 at byte `at` of `b`.
#[inline]
fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes"))
}

/// The little-endian u32 at byte `at` of `b`.
#[inline]
fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}

/// A packed particle addressed to a patch: the patch index (u64), then the
/// particle ([`Packed`]).
pub struct Routed;

impl Routed {
    /// Bytes per record.
    pub const BYTES: usize = 8 + Particles::PACKED_BYTES;

    /// Appends the record of `particle` for patch `patch` to `buf`.
    #[inline]
    pub fn write(buf: &mut Vec<u8>, patch: usize, particle: &Packed) {
        buf.extend_from_slice(&(patch as u64).to_le_bytes());
        buf.extend_from_slice(particle);
    }

    /// The patch and the particle of the record at the start of `rec`.
    ///
    /// # Panics
    /// If `rec` is shorter than [`Routed::BYTES`].
    #[inline]
    pub fn read(rec: &[u8]) -> (usize, PackedParticle<'_>) {
        (u64_at(rec, 0) as usize, PackedParticle::new(&rec[8..]))
    }

    /// The records of `buf` in order (a trailing partial record is ignored).
    pub fn all(buf: &[u8]) -> impl Iterator<Item = (usize, PackedParticle<'_>)> + '_ {
        buf.chunks_exact(Self::BYTES).map(Self::read)
    }
}

/// A particle read from a checkpoint, sent to the rank that owns its
/// patch: its row in the file, its level and patch (u64 each), then the
/// particle ([`Packed`]).
pub struct Restart;

impl Restart {
    /// Bytes per record.
    pub const BYTES: usize = 24 + Particles::PACKED_BYTES;

    /// Appends the record of `particle` (file row `row`, on `level`,
    /// `patch`) to `buf`.
    pub fn write(buf: &mut Vec<u8>, row: u64, level: usize, patch: usize, particle: &Packed) {
        for v in [row, level as u64, patch as u64] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        buf.extend_from_slice(particle);
    }

    /// The file row, level, patch and particle of the record at the start
    /// of `rec`.
    ///
    /// # Panics
    /// If `rec` is shorter than [`Restart::BYTES`].
    pub fn read(rec: &[u8]) -> (u64, usize, usize, PackedParticle<'_>) {
        (
            u64_at(rec, 0),
            u64_at(rec, 8) as usize,
            u64_at(rec, 16) as usize,
            PackedParticle::new(&rec[24..]),
        )
    }
}

/// A new particle on its way to the rank that owns its patch (insertion):
/// the id (u64), `x, y, lpx, lpy, vx, vy, mass` (f64), the material (u64).
pub struct NewRecord;

impl NewRecord {
    /// Bytes per record.
    pub const BYTES: usize = 9 * 8;

    /// Appends the record of `p` to `buf`.
    pub fn write(buf: &mut Vec<u8>, p: &NewParticle) {
        buf.extend_from_slice(&p.id.to_le_bytes());
        for v in [p.x, p.y, p.lpx, p.lpy, p.vx, p.vy, p.mass] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        buf.extend_from_slice(&(p.material as u64).to_le_bytes());
    }

    /// The particle of the record at the start of `rec`.
    ///
    /// # Panics
    /// If `rec` is shorter than [`NewRecord::BYTES`].
    pub fn read(rec: &[u8]) -> NewParticle {
        let f = |k: usize| f64::from_bits(u64_at(rec, 8 * k));
        NewParticle {
            id: u64_at(rec, 0),
            x: f(1),
            y: f(2),
            lpx: f(3),
            lpy: f(4),
            vx: f(5),
            vy: f(6),
            mass: f(7),
            material: u64_at(rec, 64) as u32,
        }
    }
}

/// Copies of particles for another level's patches, one message per rank,
/// column by column: the number of copies `n` (u64), the `n` destination
/// patches (u32), the `n` ids (u64), the `n` materials (u32), then for each
/// f64 field `k` of [`Particles::F64_NAMES`] in turn its `n` values.
pub struct CopyColumns;

/// The sections of a copies message being written (see
/// [`CopyColumns::write`]).
pub struct CopyColumnsMut<'a> {
    n: usize,
    patches: &'a mut [u8],
    ids: &'a mut [u8],
    materials: &'a mut [u8],
    cols: &'a mut [u8],
}

/// A copies message as read (see [`CopyColumns::read`]).
#[derive(Clone, Copy, Debug)]
pub struct CopyColumnsRef<'a> {
    n: usize,
    msg: &'a [u8],
}

impl CopyColumns {
    /// Bytes per copy: patch (u32), id (u64), material (u32) and the f64
    /// fields.
    pub const BYTES_PER_COPY: usize = 4 + 8 + 4 + 8 * Particles::N_F64;

    /// Bytes of a message of `n` copies.
    pub fn len(n: usize) -> Option<usize> {
        n.checked_mul(Self::BYTES_PER_COPY)?.checked_add(8)
    }

    /// Makes `buf` a message of `n` copies (its count written, every other
    /// byte zero) and returns its sections, for the caller to fill.
    pub fn write(buf: &mut Vec<u8>, n: usize) -> CopyColumnsMut<'_> {
        buf.clear();
        buf.resize(8 + n * Self::BYTES_PER_COPY, 0);
        let (head, body) = buf.split_at_mut(8);
        head.copy_from_slice(&(n as u64).to_le_bytes());
        let (patches, body) = body.split_at_mut(4 * n);
        let (ids, body) = body.split_at_mut(8 * n);
        let (materials, cols) = body.split_at_mut(4 * n);
        CopyColumnsMut {
            n,
            patches,
            ids,
            materials,
            cols,
        }
    }

    /// The length of the message that `bytes` start with (its count's
    /// [`CopyColumns::len`]), when they hold that much.
    pub fn first_len(bytes: &[u8]) -> Option<usize> {
        let n = usize::try_from(u64_at(bytes.get(..8)?, 0)).ok()?;
        Self::len(n).filter(|&l| l <= bytes.len())
    }

    /// The message `msg`, when its length is that of the count it starts
    /// with.
    pub fn read(msg: &[u8]) -> Option<CopyColumnsRef<'_>> {
        let n = usize::try_from(u64_at(msg.get(..8)?, 0)).ok()?;
        (Self::len(n) == Some(msg.len())).then_some(CopyColumnsRef { n, msg })
    }
}

impl CopyColumnsMut<'_> {
    /// Writes the destination patches, one per copy in order.
    pub fn patches(&mut self, v: impl IntoIterator<Item = u32>) {
        for (w, x) in self.patches.chunks_exact_mut(4).zip(v) {
            w.copy_from_slice(&x.to_le_bytes());
        }
    }

    /// Writes the ids, one per copy in order.
    pub fn ids(&mut self, v: impl IntoIterator<Item = u64>) {
        for (w, x) in self.ids.chunks_exact_mut(8).zip(v) {
            w.copy_from_slice(&x.to_le_bytes());
        }
    }

    /// Writes the materials, one per copy in order.
    pub fn materials(&mut self, v: impl IntoIterator<Item = u32>) {
        for (w, x) in self.materials.chunks_exact_mut(4).zip(v) {
            w.copy_from_slice(&x.to_le_bytes());
        }
    }

    /// Writes values of f64 field `k`, for the copies `from, from + 1, ...`
    /// in order (as many as `v` gives, up to the last copy).
    #[inline]
    pub fn column(&mut self, k: usize, from: usize, v: impl IntoIterator<Item = f64>) {
        let n = self.n;
        let col = &mut self.cols[8 * (k * n + from)..8 * (k + 1) * n];
        for (w, x) in col.chunks_exact_mut(8).zip(v) {
            w.copy_from_slice(&x.to_le_bytes());
        }
    }
}

impl<'a> CopyColumnsRef<'a> {
    /// The number of copies.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether the message holds no copy.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The destination patches, in order.
    pub fn patches(&self) -> impl Iterator<Item = u32> + 'a {
        let at = 8;
        self.msg[at..at + 4 * self.n]
            .chunks_exact(4)
            .map(|w| u32_at(w, 0))
    }

    /// The ids, in order.
    pub fn ids(&self) -> impl Iterator<Item = u64> + 'a {
        let at = 8 + 4 * self.n;
        self.msg[at..at + 8 * self.n]
            .chunks_exact(8)
            .map(|w| u64_at(w, 0))
    }

    /// The materials, in order.
    pub fn materials(&self) -> impl Iterator<Item = u32> + 'a {
        let at = 8 + 12 * self.n;
        self.msg[at..at + 4 * self.n]
            .chunks_exact(4)
            .map(|w| u32_at(w, 0))
    }

    /// Where the values of copy `p` start in the message: field `k`'s value
    /// of copy `p` is at `value_at(p) + k * stride()` (see
    /// [`CopyColumns::values`]).
    pub fn value_at(&self, p: usize) -> usize {
        8 + 16 * self.n + 8 * p
    }

    /// Bytes from one f64 field's column to the next.
    pub fn stride(&self) -> usize {
        8 * self.n
    }
}

impl CopyColumns {
    /// The `len` values of one field of consecutive copies of a message,
    /// the first at byte `at` of `msg` (an offset from
    /// [`CopyColumnsRef::value_at`] plus a multiple of its stride).
    #[inline]
    pub fn values(msg: &[u8], at: usize, len: usize) -> impl Iterator<Item = f64> + '_ {
        msg[at..at + 8 * len]
            .chunks_exact(8)
            .map(|w| f64::from_bits(u64_at(w, 0)))
    }
}

/// A block of nodal sums for a patch: the destination patch and the
/// source patch (u64 each), then f64 values, as many as the two patches'
/// layout gives (both sides know it).
pub struct NodalSums;

impl NodalSums {
    /// Bytes of a block's header.
    pub const HEADER: usize = 16;

    /// Appends the header of a block from patch `src` to patch `dest`.
    #[inline]
    pub fn begin(buf: &mut Vec<u8>, dest: usize, src: usize) {
        buf.extend_from_slice(&(dest as u64).to_le_bytes());
        buf.extend_from_slice(&(src as u64).to_le_bytes());
    }

    /// Appends one value to the block being written.
    #[inline]
    pub fn push(buf: &mut Vec<u8>, v: f64) {
        buf.extend_from_slice(&v.to_le_bytes());
    }

    /// The destination and source patches of the block starting at byte
    /// `at` of `buf`.
    #[inline]
    pub fn header(buf: &[u8], at: usize) -> (usize, usize) {
        (u64_at(buf, at) as usize, u64_at(buf, at + 8) as usize)
    }

    /// Value `r` of the block whose values start at byte `at` of `buf`
    /// (its header's offset plus [`NodalSums::HEADER`]).
    #[inline]
    pub fn value(buf: &[u8], at: usize, r: usize) -> f64 {
        f64::from_bits(u64_at(buf, at + 8 * r))
    }
}

/// The size in bytes of a message, sent before it (u64).
pub struct Length;

impl Length {
    /// Bytes of the record.
    pub const BYTES: usize = 8;

    /// The record of `len`.
    pub fn write(len: usize) -> [u8; 8] {
        (len as u64).to_le_bytes()
    }

    /// The length in the record at the start of `rec`.
    ///
    /// # Panics
    /// If `rec` is shorter than [`Length::BYTES`].
    pub fn read(rec: &[u8]) -> usize {
        u64_at(rec, 0) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Particles {
        let mut p = Particles::new();
        for i in 0..3 {
            p.push(
                &NewParticle {
                    id: 40 + i,
                    x: 1.0 + i as f64,
                    y: -2.0,
                    lpx: 0.25,
                    lpy: 0.125,
                    vx: 3.0,
                    vy: 4.0 - i as f64,
                    mass: 9.0,
                    material: 2 + i as u32,
                },
                1.0,
            );
        }
        p
    }

    #[test]
    fn routed_and_restart_records_round_trip() {
        let p = sample();
        let mut buf = Vec::new();
        for i in 0..3 {
            Routed::write(&mut buf, 7 + i, &p.packed(i));
        }
        assert_eq!(buf.len(), 3 * Routed::BYTES);
        let got: Vec<(usize, u64, f64)> =
            Routed::all(&buf).map(|(q, b)| (q, b.id(), b.x())).collect();
        assert_eq!(got, [(7, 40, 1.0), (8, 41, 2.0), (9, 42, 3.0)]);
        let mut r = Vec::new();
        Restart::write(&mut r, 123, 2, 5, &p.packed(1));
        assert_eq!(r.len(), Restart::BYTES);
        let (row, l, k, b) = Restart::read(&r);
        assert_eq!((row, l, k), (123, 2, 5));
        assert_eq!(b.bytes(), &p.packed(1)[..]);
    }

    #[test]
    fn new_particle_records_round_trip() {
        let p = NewParticle {
            id: 7,
            x: 1.5,
            y: -2.0,
            lpx: 0.25,
            lpy: 0.125,
            vx: 3.0,
            vy: 4.0,
            mass: 9.0,
            material: 3,
        };
        let mut b = Vec::new();
        NewRecord::write(&mut b, &p);
        assert_eq!(b.len(), NewRecord::BYTES);
        assert_eq!(NewRecord::read(&b), p);
    }

    #[test]
    fn copy_columns_round_trip_and_reject_a_wrong_length() {
        let n = 3;
        let mut buf = Vec::new();
        let mut w = CopyColumns::write(&mut buf, n);
        w.patches([4, 4, 9]);
        w.ids([10, 11, 3]);
        w.materials([0, 1, 0]);
        for k in 0..Particles::N_F64 {
            w.column(k, 0, (0..n).map(|p| (100 * k + p) as f64));
        }
        // A column written from a later copy leaves the earlier ones.
        w.column(1, 2, [-1.0]);
        assert_eq!(Some(buf.len()), CopyColumns::len(n));
        let m = CopyColumns::read(&buf).expect("a whole message");
        assert_eq!(m.len(), n);
        assert_eq!(m.patches().collect::<Vec<_>>(), [4, 4, 9]);
        assert_eq!(m.ids().collect::<Vec<_>>(), [10, 11, 3]);
        assert_eq!(m.materials().collect::<Vec<_>>(), [0, 1, 0]);
        for k in 0..Particles::N_F64 {
            let got: Vec<f64> =
                CopyColumns::values(&buf, m.value_at(0) + k * m.stride(), n).collect();
            let mut want: Vec<f64> = (0..n).map(|p| (100 * k + p) as f64).collect();
            if k == 1 {
                want[2] = -1.0;
            }
            assert_eq!(got, want, "field {k}");
        }
        assert!(CopyColumns::read(&buf[..buf.len() - 1]).is_none());
        assert!(CopyColumns::read(&buf[..4]).is_none());
        assert!(CopyColumns::read(&[]).is_none());
    }

    #[test]
    fn lengths_round_trip() {
        for n in [0, 1, 280, 1 << 40] {
            assert_eq!(Length::read(&Length::write(n)), n);
        }
    }

    #[test]
    fn two_copy_messages_split_at_the_first_count() {
        let (mut a, mut b) = (Vec::new(), Vec::new());
        let mut m = CopyColumns::write(&mut a, 2);
        m.ids([7, 9]);
        m.column(0, 0, [1.5, -2.5]);
        CopyColumns::write(&mut b, 0);
        let both = [a.clone(), b.clone()].concat();
        let la = CopyColumns::first_len(&both).expect("the first message fits");
        assert_eq!(la, a.len());
        let first = CopyColumns::read(&both[..la]).expect("a whole message");
        assert_eq!(first.ids().collect::<Vec<_>>(), [7, 9]);
        let x: Vec<f64> = CopyColumns::values(&both, first.value_at(0), 2).collect();
        assert_eq!(x, [1.5, -2.5]);
        assert!(CopyColumns::read(&both[la..]).is_some_and(|m| m.is_empty()));
        // A count larger than the bytes, or fewer bytes than a count.
        assert_eq!(CopyColumns::first_len(&both[..la - 1]), None);
        assert_eq!(CopyColumns::first_len(&both[..7]), None);
    }

    #[test]
    fn nodal_sums_blocks_round_trip() {
        let mut buf = Vec::new();
        NodalSums::begin(&mut buf, 3, 1);
        for v in [0.5, -2.0] {
            NodalSums::push(&mut buf, v);
        }
        NodalSums::begin(&mut buf, 0, 8);
        NodalSums::push(&mut buf, 7.0);
        assert_eq!(NodalSums::header(&buf, 0), (3, 1));
        assert_eq!(NodalSums::value(&buf, NodalSums::HEADER, 1), -2.0);
        let second = NodalSums::HEADER + 16;
        assert_eq!(NodalSums::header(&buf, second), (0, 8));
        assert_eq!(NodalSums::value(&buf, second + NodalSums::HEADER, 0), 7.0);
    }
}
