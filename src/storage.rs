//! Storage for the particle and grid fields that the kernels stream through:
//! [`FieldVec`], a growable array that places its data at a cache-line offset
//! of its own within a 4 KiB page.
//!
//! **Why.** Particle and grid fields are separate arrays of equal length that
//! the kernels walk in lock step (two dozen particle fields, three nodal
//! arrays). The system allocator hands out large blocks page-aligned (glibc
//! serves them by `mmap`, with a small header) or back to back (heap blocks
//! of equal size), so element `p` of every field lands at the same address
//! modulo 4096. The streams then compete for the same few sets of the 8-way
//! L1 cache, and loads are falsely held behind stores to other fields with
//! the same low 12 address bits ("4K aliasing"). Measured on the comparison
//! scene (262,144 particles), this halved the speed of a step.
//!
//! **How.** A [`FieldVec`] owns its allocation (through [`std::alloc`], 64-byte
//! aligned). When a block holds at least [`STAGGER_MIN`] bytes, its data
//! starts `off` bytes into the block, `off` a multiple of 64 that cycles
//! through the 63 non-zero cache-line offsets of a page (a process-wide
//! counter, stepped by [`STRIDE`] lines), so that consecutive large fields
//! start on different cache sets whatever addresses the system allocator
//! returns. Growing a block keeps its offset (the system `realloc` carries
//! the gap along with the data); a new block (a clone, or a small block
//! growing past the threshold) takes the next offset. Small blocks start at
//! offset 0: they fit in the cache anyway, and a page of padding per small
//! field would be waste.
//!
//! The cost is at most 4032 bytes per large field (under 13 % of the
//! smallest). Results do not depend on addresses, so they are unchanged.
//!
//! This replaces a process-wide allocator that staggered every large block:
//! a library must not install a `#[global_allocator]` (a Rust host with its
//! own could not link it), and the cure belongs to the storage that needs
//! it.

use std::alloc::{self, Layout};
use std::fmt;
use std::marker::PhantomData;
use std::ops::{Deref, DerefMut};
use std::ptr::NonNull;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Blocks of at least this many bytes are staggered (see the module notes).
pub const STAGGER_MIN: usize = 32 * 1024;

/// Cache-line size the offsets are multiples of, and the alignment of every
/// block.
pub const LINE: usize = 64;

/// Number of distinct offsets (`1..=63` lines: all but the page-aligned one).
pub const SLOTS: usize = 63;

/// Step between the offsets of consecutive staggered blocks, in lines;
/// coprime with [`SLOTS`] (so any 63 consecutive blocks get 63 distinct
/// offsets), and far from 1 so that neighbouring blocks sit far apart.
pub const STRIDE: usize = 25;

/// Counter of staggered blocks, process-wide.
static NEXT: AtomicUsize = AtomicUsize::new(0);

/// Offset of the next staggered block: `64 * (1 + (n * STRIDE mod 63))`.
fn next_offset() -> usize {
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    LINE * (1 + (n % SLOTS * STRIDE) % SLOTS)
}

/// The allocation a [`FieldVec`] asked for could not be made (the size
/// overflows, or the system refused it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CapacityError {
    /// Bytes of data requested (saturated at `usize::MAX`).
    pub bytes: usize,
}

impl fmt::Display for CapacityError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "cannot allocate {} bytes", self.bytes)
    }
}

impl std::error::Error for CapacityError {}

/// A growable array of plain values (`Copy`, alignment at most 64) with the
/// API of `Vec` that field storage uses, dereferencing to a slice; its data
/// starts at a cache-line offset of its own within a page when large (see
/// the module notes).
pub struct FieldVec<T: Copy> {
    /// Start of the data (`off` bytes into the block); dangling when
    /// `cap == 0`.
    ptr: NonNull<T>,
    /// Number of values stored.
    len: usize,
    /// Number of values the block holds (0: no block).
    cap: usize,
    /// Bytes between the start of the block and the data (0 or a multiple
    /// of [`LINE`] in `64..=4032`).
    off: usize,
    _own: PhantomData<T>,
}

// SAFETY: a FieldVec owns its values like a Vec<T> does.
unsafe impl<T: Copy + Send> Send for FieldVec<T> {}
// SAFETY: shared access only reads the values, as for Vec<T>.
unsafe impl<T: Copy + Sync> Sync for FieldVec<T> {}

impl<T: Copy> FieldVec<T> {
    /// Compile-time check that `T` can be stored: not zero-sized, and an
    /// alignment the 64-byte offsets keep.
    const VALID: () = assert!(
        std::mem::size_of::<T>() > 0 && std::mem::align_of::<T>() <= LINE,
        "FieldVec holds non-zero-sized values aligned to at most 64 bytes"
    );

    /// An empty array (allocates nothing).
    pub const fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::VALID;
        FieldVec {
            ptr: NonNull::dangling(),
            len: 0,
            cap: 0,
            off: 0,
            _own: PhantomData,
        }
    }

    /// An empty array with room for `cap` values.
    pub fn with_capacity(cap: usize) -> Self {
        let mut v = Self::new();
        v.reserve_exact(cap);
        v
    }

    /// `len` copies of `value`.
    pub fn from_elem(value: T, len: usize) -> Self {
        let mut v = Self::with_capacity(len);
        v.resize(len, value);
        v
    }

    /// Number of values stored.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when no value is stored.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Number of values the current block holds.
    #[inline]
    pub fn capacity(&self) -> usize {
        self.cap
    }

    /// The values as a slice.
    #[inline]
    pub fn as_slice(&self) -> &[T] {
        // SAFETY: the first `len` values of the block are initialised (or
        // `len == 0` with a dangling, aligned pointer).
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }

    /// The values as a mutable slice.
    #[inline]
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        // SAFETY: as in `as_slice`, and `self` is borrowed mutably.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.as_ptr(), self.len) }
    }

    /// Pointer to the first value.
    #[inline]
    pub fn as_ptr(&self) -> *const T {
        self.ptr.as_ptr()
    }

    /// Mutable pointer to the first value.
    #[inline]
    pub fn as_mut_ptr(&mut self) -> *mut T {
        self.ptr.as_ptr()
    }

    /// Byte offset of the data from the start of its block (0 for small
    /// blocks; see the module notes).
    pub fn stagger(&self) -> usize {
        self.off
    }

    /// Layout of a block of `cap` values starting `off` bytes in.
    fn layout(cap: usize, off: usize) -> Option<Layout> {
        let bytes = cap.checked_mul(std::mem::size_of::<T>())?;
        Layout::from_size_align(bytes.checked_add(off)?, LINE).ok()
    }

    /// Moves the data to a block of exactly `new_cap >= len` values.
    fn set_capacity(&mut self, new_cap: usize) -> Result<(), CapacityError> {
        debug_assert!(new_cap >= self.len && new_cap > self.cap);
        let bytes = new_cap.saturating_mul(std::mem::size_of::<T>());
        let err = CapacityError { bytes };
        if self.cap > 0 && (self.off > 0 || bytes < STAGGER_MIN) {
            // Same kind of block: grow in place or move with the system
            // realloc, which carries the offset gap and the data along.
            let old = Self::layout(self.cap, self.off).expect("layout was valid at allocation");
            let new = Self::layout(new_cap, self.off).ok_or(err)?;
            // SAFETY: the block was allocated with `old`; `new` has the
            // same alignment and a non-zero size.
            let base = unsafe {
                alloc::realloc(
                    self.ptr.as_ptr().cast::<u8>().sub(self.off),
                    old,
                    new.size(),
                )
            };
            if base.is_null() {
                return Err(err);
            }
            // SAFETY: the block holds `off + new_cap` values' bytes; `off`
            // is a multiple of 64, so the data stays aligned.
            self.ptr = unsafe { NonNull::new_unchecked(base.add(self.off).cast::<T>()) };
        } else {
            // A first block, or a small block growing past the threshold:
            // a new block with its own offset.
            let off = if bytes >= STAGGER_MIN {
                next_offset()
            } else {
                0
            };
            let new = Self::layout(new_cap, off).ok_or(err)?;
            // SAFETY: `new` has a non-zero size (`new_cap > 0`, T not
            // zero-sized).
            let base = unsafe { alloc::alloc(new) };
            if base.is_null() {
                return Err(err);
            }
            // SAFETY: the block holds `off` bytes plus `new_cap` values.
            let ptr = unsafe { base.add(off).cast::<T>() };
            if self.cap > 0 {
                // SAFETY: the old block holds `len <= new_cap` initialised
                // values; the blocks are distinct.
                unsafe {
                    std::ptr::copy_nonoverlapping(self.ptr.as_ptr(), ptr, self.len);
                }
                self.free();
            }
            // SAFETY: `base` is non-null.
            self.ptr = unsafe { NonNull::new_unchecked(ptr) };
            self.off = off;
        }
        self.cap = new_cap;
        Ok(())
    }

    /// Frees the block (the values are `Copy`: nothing to drop) and leaves
    /// `self` without one.
    fn free(&mut self) {
        if self.cap > 0 {
            let layout = Self::layout(self.cap, self.off).expect("layout was valid at allocation");
            // SAFETY: the block starts `off` bytes below the data and was
            // allocated with this layout.
            unsafe { alloc::dealloc(self.ptr.as_ptr().cast::<u8>().sub(self.off), layout) };
        }
        self.ptr = NonNull::dangling();
        self.cap = 0;
        self.off = 0;
    }

    /// Makes room for at least `additional` more values, with room to spare
    /// (amortised doubling, as `Vec::reserve`); an allocation failure is
    /// an error.
    pub fn try_reserve(&mut self, additional: usize) -> Result<(), CapacityError> {
        let need = self.needed(additional)?;
        if need <= self.cap {
            return Ok(());
        }
        let grown = self.cap.saturating_mul(2).max(need).max(4);
        self.set_capacity(grown)
    }

    /// Makes room for exactly `additional` more values (as
    /// `Vec::try_reserve_exact`); an allocation failure is an error.
    pub fn try_reserve_exact(&mut self, additional: usize) -> Result<(), CapacityError> {
        let need = self.needed(additional)?;
        if need <= self.cap {
            return Ok(());
        }
        self.set_capacity(need)
    }

    /// The length after `additional` more values, or an error when it
    /// overflows.
    fn needed(&self, additional: usize) -> Result<usize, CapacityError> {
        self.len
            .checked_add(additional)
            .ok_or(CapacityError { bytes: usize::MAX })
    }

    /// Makes room for at least `additional` more values (as
    /// `Vec::reserve`).
    ///
    /// # Panics
    /// When the allocation fails.
    pub fn reserve(&mut self, additional: usize) {
        if let Err(e) = self.try_reserve(additional) {
            panic!("FieldVec::reserve: {e}");
        }
    }

    /// Makes room for exactly `additional` more values (as
    /// `Vec::reserve_exact`).
    ///
    /// # Panics
    /// When the allocation fails.
    pub fn reserve_exact(&mut self, additional: usize) {
        if let Err(e) = self.try_reserve_exact(additional) {
            panic!("FieldVec::reserve_exact: {e}");
        }
    }

    /// Appends a value.
    #[inline]
    pub fn push(&mut self, value: T) {
        if self.len == self.cap {
            self.reserve(1);
        }
        // SAFETY: `len < cap`: the slot lies inside the block.
        unsafe { self.ptr.as_ptr().add(self.len).write(value) };
        self.len += 1;
    }

    /// Removes and returns the last value.
    pub fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: slot `len` was initialised.
        Some(unsafe { self.ptr.as_ptr().add(self.len).read() })
    }

    /// Appends the values of `s`.
    pub fn extend_from_slice(&mut self, s: &[T]) {
        self.reserve(s.len());
        // SAFETY: the block has room for `len + s.len()` values; `s` cannot
        // overlap the spare capacity (nothing else refers to it).
        unsafe {
            std::ptr::copy_nonoverlapping(s.as_ptr(), self.ptr.as_ptr().add(self.len), s.len());
        }
        self.len += s.len();
    }

    /// Shortens to `len` values (no effect when already shorter); keeps the
    /// block.
    pub fn truncate(&mut self, len: usize) {
        self.len = self.len.min(len);
    }

    /// Removes every value; keeps the block.
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Resizes to `len` values, appending copies of `value` when growing.
    pub fn resize(&mut self, len: usize, value: T) {
        if len <= self.len {
            self.len = len;
            return;
        }
        self.reserve(len - self.len);
        for k in self.len..len {
            // SAFETY: `k < len <= cap`.
            unsafe { self.ptr.as_ptr().add(k).write(value) };
        }
        self.len = len;
    }

    /// Keeps the values for which `keep` is true, in order.
    pub fn retain(&mut self, mut keep: impl FnMut(&T) -> bool) {
        let mut w = 0;
        for r in 0..self.len {
            let v = self[r];
            if keep(&v) {
                self[w] = v;
                w += 1;
            }
        }
        self.len = w;
    }
}

#[cfg(test)]
impl<T: Copy> FieldVec<T> {
    /// The values' bytes, for bitwise comparisons in tests (the stored
    /// types have no padding: `f64`, integers, arrays and `Node4`).
    pub(crate) fn bytes(&self) -> &[u8] {
        // SAFETY: the first `len` values are initialised; the types tests
        // compare have no padding bytes.
        unsafe {
            std::slice::from_raw_parts(
                self.as_ptr().cast::<u8>(),
                self.len * std::mem::size_of::<T>(),
            )
        }
    }

    /// Asserts the layout property of the module notes: room for the
    /// values, 64-byte aligned data, and a block of at least
    /// [`STAGGER_MIN`] bytes at a non-zero cache-line offset (small ones
    /// at offset 0).
    pub(crate) fn assert_layout(&self) {
        assert!(self.cap >= self.len);
        if self.cap > 0 {
            assert_eq!(self.as_ptr() as usize % LINE, 0);
            assert_eq!(self.off % LINE, 0);
            if self.cap * std::mem::size_of::<T>() >= STAGGER_MIN {
                assert!(
                    (LINE..=SLOTS * LINE).contains(&self.off),
                    "off {}",
                    self.off
                );
            } else {
                assert_eq!(self.off, 0, "a small block is not padded");
            }
        }
    }
}

impl<T: Copy> Drop for FieldVec<T> {
    fn drop(&mut self) {
        self.free();
    }
}

impl<T: Copy> Default for FieldVec<T> {
    fn default() -> Self {
        Self::new()
    }
}

/// A clone holds exactly the source's values in a block of exactly their
/// number (none when empty), staggered when large (a new offset).
///
/// `clone_from` copies into the block `self` already has when it is big
/// enough (no allocation, no page fault: the snapshot of a step reuses its
/// buffers this way, see [`crate::sim::Simulation::step`]) and otherwise
/// grows it to exactly the source's length, as a clone would size it. The
/// values and length are then those of a clone; the capacity is the larger
/// of the old one and the length, and the layout property holds either way:
/// a block of at least [`STAGGER_MIN`] bytes starts at a non-zero
/// cache-line offset (a large block keeps its offset when it grows or is
/// reused, a small one that grows past the threshold takes a new one).
impl<T: Copy> Clone for FieldVec<T> {
    fn clone(&self) -> Self {
        let mut v = Self::with_capacity(self.len);
        v.extend_from_slice(self);
        v
    }

    fn clone_from(&mut self, src: &Self) {
        self.clear();
        self.reserve_exact(src.len());
        self.extend_from_slice(src);
    }
}

impl<T: Copy> Deref for FieldVec<T> {
    type Target = [T];
    #[inline]
    fn deref(&self) -> &[T] {
        self.as_slice()
    }
}

impl<T: Copy> DerefMut for FieldVec<T> {
    #[inline]
    fn deref_mut(&mut self) -> &mut [T] {
        self.as_mut_slice()
    }
}

impl<T: Copy> AsRef<[T]> for FieldVec<T> {
    fn as_ref(&self) -> &[T] {
        self
    }
}

impl<T: Copy> AsMut<[T]> for FieldVec<T> {
    fn as_mut(&mut self) -> &mut [T] {
        self
    }
}

impl<T: Copy> std::borrow::Borrow<[T]> for FieldVec<T> {
    fn borrow(&self) -> &[T] {
        self
    }
}

impl<T: Copy + fmt::Debug> fmt::Debug for FieldVec<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl<T: Copy + PartialEq> PartialEq for FieldVec<T> {
    fn eq(&self, o: &Self) -> bool {
        self.as_slice() == o.as_slice()
    }
}

impl<T: Copy + Eq> Eq for FieldVec<T> {}

impl<T: Copy + PartialEq> PartialEq<Vec<T>> for FieldVec<T> {
    fn eq(&self, o: &Vec<T>) -> bool {
        self.as_slice() == o.as_slice()
    }
}

impl<T: Copy + PartialEq> PartialEq<FieldVec<T>> for Vec<T> {
    fn eq(&self, o: &FieldVec<T>) -> bool {
        self.as_slice() == o.as_slice()
    }
}

impl<T: Copy + PartialEq> PartialEq<[T]> for FieldVec<T> {
    fn eq(&self, o: &[T]) -> bool {
        self.as_slice() == o
    }
}

impl<T: Copy + PartialEq> PartialEq<&[T]> for FieldVec<T> {
    fn eq(&self, o: &&[T]) -> bool {
        self.as_slice() == *o
    }
}

impl<T: Copy + PartialEq, const N: usize> PartialEq<[T; N]> for FieldVec<T> {
    fn eq(&self, o: &[T; N]) -> bool {
        self.as_slice() == o.as_slice()
    }
}

impl<T: Copy> Extend<T> for FieldVec<T> {
    fn extend<I: IntoIterator<Item = T>>(&mut self, iter: I) {
        let it = iter.into_iter();
        self.reserve(it.size_hint().0);
        for v in it {
            self.push(v);
        }
    }
}

impl<'a, T: Copy + 'a> Extend<&'a T> for FieldVec<T> {
    fn extend<I: IntoIterator<Item = &'a T>>(&mut self, iter: I) {
        self.extend(iter.into_iter().copied());
    }
}

impl<T: Copy> FromIterator<T> for FieldVec<T> {
    fn from_iter<I: IntoIterator<Item = T>>(iter: I) -> Self {
        let mut v = Self::new();
        v.extend(iter);
        v
    }
}

impl<T: Copy> From<&[T]> for FieldVec<T> {
    fn from(s: &[T]) -> Self {
        let mut v = Self::with_capacity(s.len());
        v.extend_from_slice(s);
        v
    }
}

impl<T: Copy> From<Vec<T>> for FieldVec<T> {
    fn from(s: Vec<T>) -> Self {
        Self::from(s.as_slice())
    }
}

impl<T: Copy> From<FieldVec<T>> for Vec<T> {
    fn from(s: FieldVec<T>) -> Self {
        s.to_vec()
    }
}

impl<'a, T: Copy> IntoIterator for &'a FieldVec<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<'a, T: Copy> IntoIterator for &'a mut FieldVec<T> {
    type Item = &'a mut T;
    type IntoIter = std::slice::IterMut<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter_mut()
    }
}

/// Owning iterator of a [`FieldVec`] (values by copy, in order).
pub struct IntoIter<T: Copy> {
    v: FieldVec<T>,
    next: usize,
}

impl<T: Copy> Iterator for IntoIter<T> {
    type Item = T;
    fn next(&mut self) -> Option<T> {
        let x = self.v.get(self.next).copied();
        self.next += x.is_some() as usize;
        x
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = self.v.len() - self.next;
        (n, Some(n))
    }
}

impl<T: Copy> ExactSizeIterator for IntoIter<T> {}

impl<T: Copy> IntoIterator for FieldVec<T> {
    type Item = T;
    type IntoIter = IntoIter<T>;
    fn into_iter(self) -> IntoIter<T> {
        IntoIter { v: self, next: 0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn behaves_like_a_vec() {
        let mut v: FieldVec<f64> = FieldVec::new();
        assert!(v.is_empty() && v.capacity() == 0);
        let mut w: Vec<f64> = Vec::new();
        for k in 0..10_000 {
            v.push(k as f64);
            w.push(k as f64);
        }
        assert_eq!(v, w);
        v.extend_from_slice(&[1.0, 2.0]);
        w.extend_from_slice(&[1.0, 2.0]);
        v.truncate(5000);
        w.truncate(5000);
        v.resize(6000, -1.0);
        w.resize(6000, -1.0);
        assert_eq!(v, w);
        v.retain(|&x| x > 10.0);
        w.retain(|&x| x > 10.0);
        assert_eq!(v, w);
        assert_eq!(v.pop(), w.pop());
        let c = v.clone();
        assert_eq!(c, v);
        assert_eq!(c.iter().sum::<f64>(), w.iter().sum::<f64>());
        let e: FieldVec<u32> = (0..5).collect();
        assert_eq!(e, [0, 1, 2, 3, 4]);
        assert_eq!(format!("{e:?}"), "[0, 1, 2, 3, 4]");
        v.clear();
        assert!(v.is_empty() && v.capacity() > 0);
        let z = FieldVec::from_elem(0u64, 3);
        assert_eq!(z.clone().into_iter().len(), 3);
        assert_eq!(Vec::from(z), vec![0, 0, 0]);
    }

    #[test]
    fn large_fields_get_distinct_line_offsets_and_keep_them_when_growing() {
        // 63 fields grown in lock step past the threshold, as particle
        // fields are: distinct offsets (other tests may draw from the
        // counter concurrently, so only alignment and range are certain
        // there; here the draws are consecutive unless interleaved).
        let n = 1 << 14; // 128 KiB of f64
        let mut fields: Vec<FieldVec<f64>> = (0..SLOTS).map(|_| FieldVec::new()).collect();
        for i in 0..n {
            for (k, f) in fields.iter_mut().enumerate() {
                f.push((k * n + i) as f64);
            }
        }
        for (k, f) in fields.iter().enumerate() {
            assert_eq!(f.as_ptr() as usize % LINE, 0);
            assert!(f.stagger() % LINE == 0 && (LINE..=SLOTS * LINE).contains(&f.stagger()));
            assert!(f.iter().enumerate().all(|(i, &x)| x == (k * n + i) as f64));
        }
        let mut offs: Vec<usize> = fields.iter().map(|f| f.stagger()).collect();
        offs.sort_unstable();
        offs.dedup();
        // Concurrent tests may interleave a few draws; most offsets differ.
        assert!(offs.len() > SLOTS / 2, "{} distinct offsets", offs.len());
        // Growing keeps the offset; a clone takes its own.
        let f = &mut fields[0];
        let off = f.stagger();
        f.reserve(10 * n);
        assert_eq!(f.stagger(), off);
        assert_eq!(f[n - 1], (n - 1) as f64);
        let g = f.clone();
        assert_eq!(&g, f);
        assert!(g.stagger() >= LINE);
        // Small fields are not padded.
        let s: FieldVec<f64> = FieldVec::from_elem(1.0, 16);
        assert_eq!(s.stagger(), 0);
    }

    #[test]
    fn clone_from_reuses_the_block_and_sizes_like_clone() {
        let big: FieldVec<f64> = (0..10_000).map(|k| k as f64).collect();
        let small: FieldVec<f64> = (0..100).map(|k| -(k as f64)).collect();
        // Into nothing: exactly a clone (capacity = length, staggered).
        let mut d: FieldVec<f64> = FieldVec::new();
        d.clone_from(&big);
        assert_eq!(
            (d.bytes(), d.len(), d.capacity()),
            (big.bytes(), 10_000, 10_000)
        );
        assert!(d.stagger() >= LINE);
        d.assert_layout();
        // Into a block big enough: the same block, offset kept.
        let (ptr, off) = (d.as_ptr(), d.stagger());
        d.clone_from(&small);
        assert_eq!(d.bytes(), small.bytes());
        assert_eq!((d.as_ptr(), d.stagger(), d.capacity()), (ptr, off, 10_000));
        d.clone_from(&big);
        assert_eq!(d.bytes(), big.bytes());
        assert_eq!(d.as_ptr(), ptr);
        d.assert_layout();
        // A small block grown past the threshold: a staggered block of
        // exactly the length, as a clone.
        let mut s = small.clone();
        assert_eq!(s.stagger(), 0);
        s.clone_from(&big);
        assert_eq!((s.bytes(), s.capacity()), (big.bytes(), 10_000));
        assert!(s.stagger() >= LINE);
        s.assert_layout();
        // Empty source: no values, the block kept.
        s.clone_from(&FieldVec::new());
        assert!(s.is_empty() && s.capacity() == 10_000);
        s.assert_layout();
    }

    #[test]
    fn aligned_records_keep_their_alignment() {
        #[derive(Clone, Copy, Default, PartialEq, Debug)]
        #[repr(C, align(32))]
        struct R([f64; 4]);
        let mut v: FieldVec<R> = FieldVec::new();
        v.try_reserve_exact(1 << 12).unwrap();
        v.resize(1 << 12, R::default());
        assert_eq!(v.as_ptr() as usize % 32, 0);
        v[7].0[3] = 2.0;
        v.resize(1 << 14, R([1.0; 4]));
        assert_eq!((v[7].0[3], v[(1 << 14) - 1].0[0]), (2.0, 1.0));
        assert!(v.try_reserve_exact(usize::MAX / 2).is_err());
    }
}
