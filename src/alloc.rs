//! The process-wide allocator of every program that links Gimlet: the system
//! allocator, with large blocks staggered in the address space.
//!
//! **Why.** Particle and grid fields are separate `Vec<f64>`s of equal length
//! that the kernels stream through in lock step. The system allocator hands
//! out large blocks page-aligned (glibc serves them by `mmap`, with a 16-byte
//! header) or back to back (heap blocks of equal size), so element `p` of
//! every field lands at the same address modulo 4096. The two dozen streams
//! then compete for the same few sets of the 8-way L1 cache, and loads are
//! falsely held behind stores to other fields with the same low 12 address
//! bits ("4K aliasing"). Measured on the comparison scene (262,144
//! particles), this halved the speed of a step.
//!
//! **How.** Blocks of at least [`STAGGER_MIN`] bytes with an alignment of at
//! most 64 bytes (the grid's 32-byte aligned node records among them) are
//! over-allocated by up to 4 KiB from a system block of the same alignment
//! (at least 16), and the returned pointer is moved forward by a multiple
//! of 64 bytes
//! that cycles through the 63 cache-line offsets of a page, so consecutive
//! large blocks start on different cache sets. The offset is kept in the 8
//! bytes just below the returned pointer, so that `dealloc` and `realloc`
//! find the system block again; `realloc` of a large block keeps its offset
//! (the system `realloc` moves the offset gap and the header with the data).
//! Offsets are multiples of 64, so the alignment of the system block is
//! kept. Small blocks, and blocks with a larger alignment, go to the system
//! allocator untouched. Whether a block is staggered depends only on its
//! layout, which Rust passes identically to `alloc`, `realloc` and
//! `dealloc`, so every path agrees.
//!
//! The cost is one word and at most 4 KiB per large block (under 13 % of
//! the smallest), and nothing per small block. Results do not depend on
//! addresses, so they are unchanged.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Blocks of at least this many bytes are staggered.
pub const STAGGER_MIN: usize = 32 * 1024;

/// Largest alignment the system allocator (`malloc`) guarantees on x86-64
/// and aarch64 Linux: the least alignment of a staggered block's system
/// block.
const SYS_ALIGN: usize = 16;

/// Largest alignment of a staggered block (offsets are multiples of it).
const MAX_ALIGN: usize = 64;

/// Cache-line size the offsets are multiples of.
const LINE: usize = 64;

/// Number of distinct offsets (`1..=63` lines: all but the page-aligned one).
const SLOTS: usize = 63;

/// Over-allocation of a staggered block: room for the largest offset.
const PAD: usize = SLOTS * LINE;

/// Step between the offsets of consecutive blocks, in lines; coprime with
/// [`SLOTS`], and far from 1 so that neighbouring blocks sit far apart.
const STRIDE: usize = 25;

/// The staggering allocator (see the module notes).
pub struct Staggered {
    next: AtomicUsize,
}

impl Staggered {
    /// A new allocator.
    pub const fn new() -> Staggered {
        Staggered {
            next: AtomicUsize::new(0),
        }
    }

    /// Offset of the next staggered block: `64 * (1 + (n * STRIDE mod 63))`.
    fn next_offset(&self) -> usize {
        let n = self.next.fetch_add(1, Ordering::Relaxed);
        LINE * (1 + (n % SLOTS * STRIDE) % SLOTS)
    }
}

impl Default for Staggered {
    fn default() -> Self {
        Staggered::new()
    }
}

#[inline]
fn staggered(layout: &Layout) -> bool {
    layout.size() >= STAGGER_MIN && layout.align() <= MAX_ALIGN
}

/// Layout of the system block behind a staggered block of `size` bytes and
/// alignment `align`.
#[inline]
fn outer(size: usize, align: usize) -> Option<Layout> {
    Layout::from_size_align(size.checked_add(PAD)?, align.max(SYS_ALIGN)).ok()
}

/// Reads the offset stored below a staggered block.
///
/// # Safety
/// `ptr` must be a staggered block returned by this allocator.
#[inline]
unsafe fn offset_of(ptr: *mut u8) -> usize {
    // SAFETY: every staggered block has at least 64 bytes of its system
    // block below it, the last 8 of which hold the offset.
    unsafe { (ptr.sub(8) as *const usize).read_unaligned() }
}

/// Moves a system block's start forward by `off` and records `off` below
/// the returned pointer.
///
/// # Safety
/// `base` must be a live system block of at least `off + 8` bytes.
#[inline]
unsafe fn place(base: *mut u8, off: usize) -> *mut u8 {
    // SAFETY: `off >= 64`, and the block holds `off` bytes before `ptr`.
    unsafe {
        let ptr = base.add(off);
        (ptr.sub(8) as *mut usize).write_unaligned(off);
        ptr
    }
}

// SAFETY: every block handed out is either a system block (small or
// over-aligned layouts) or lies inside a system block of `size + PAD` bytes
// at an offset recorded below it; `dealloc`/`realloc` recover the system
// block from the same layout-based decision and that offset. Alignment:
// a system block has the alignment of the layout (at least 16), which is
// at most 64, and offsets are multiples of 64.
unsafe impl GlobalAlloc for Staggered {
    #[inline]
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !staggered(&layout) {
            // SAFETY: forwarded contract.
            return unsafe { System.alloc(layout) };
        }
        let Some(o) = outer(layout.size(), layout.align()) else {
            return std::ptr::null_mut();
        };
        // SAFETY: `o` has a non-zero size.
        let base = unsafe { System.alloc(o) };
        if base.is_null() {
            return base;
        }
        // SAFETY: the block has `size + PAD >= off + 8` bytes.
        unsafe { place(base, self.next_offset()) }
    }

    #[inline]
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !staggered(&layout) {
            // SAFETY: forwarded contract.
            return unsafe { System.alloc_zeroed(layout) };
        }
        let Some(o) = outer(layout.size(), layout.align()) else {
            return std::ptr::null_mut();
        };
        // SAFETY: `o` has a non-zero size. The system's zeroed allocation
        // (calloc) avoids touching fresh pages; only the header is written.
        let base = unsafe { System.alloc_zeroed(o) };
        if base.is_null() {
            return base;
        }
        // SAFETY: as in `alloc`.
        unsafe { place(base, self.next_offset()) }
    }

    #[inline]
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if !staggered(&layout) {
            // SAFETY: forwarded contract.
            return unsafe { System.dealloc(ptr, layout) };
        }
        // SAFETY: `ptr` is a staggered block of this layout (same decision
        // as at allocation); its system block starts `off` bytes below.
        unsafe {
            let off = offset_of(ptr);
            let o = outer(layout.size(), layout.align()).expect("layout was valid at allocation");
            System.dealloc(ptr.sub(off), o);
        }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let Ok(new_layout) = Layout::from_size_align(new_size, layout.align()) else {
            return std::ptr::null_mut();
        };
        match (staggered(&layout), staggered(&new_layout)) {
            // SAFETY: forwarded contract (system block both before and after).
            (false, false) => unsafe { System.realloc(ptr, layout, new_size) },
            (true, true) => {
                // The system realloc carries the offset gap, the header and
                // the data along; the offset stays valid.
                let align = layout.align();
                let (Some(o_old), Some(o_new)) =
                    (outer(layout.size(), align), outer(new_size, align))
                else {
                    return std::ptr::null_mut();
                };
                // SAFETY: `ptr` is staggered with this layout; `base` is its
                // system block, of layout `o_old`.
                unsafe {
                    let off = offset_of(ptr);
                    let base = System.realloc(ptr.sub(off), o_old, o_new.size());
                    if base.is_null() {
                        return base;
                    }
                    base.add(off)
                }
            }
            // Crossing the threshold: new block, copy, free the old one.
            _ => {
                // SAFETY: `new_layout` has a non-zero size (it differs in
                // kind from a valid layout, so one of them is >= STAGGER_MIN;
                // if it is the old one, `new_size` may be small but Rust's
                // realloc contract requires it to be non-zero).
                unsafe {
                    let new = self.alloc(new_layout);
                    if new.is_null() {
                        return new;
                    }
                    std::ptr::copy_nonoverlapping(ptr, new, layout.size().min(new_size));
                    self.dealloc(ptr, layout);
                    new
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_blocks_get_distinct_line_offsets_and_keep_their_data() {
        let a = Staggered::new();
        let n = 1 << 17; // 1 MiB of f64
        let layout = Layout::array::<f64>(n).unwrap();
        let mut ptrs = Vec::new();
        for k in 0..SLOTS {
            // SAFETY: non-zero layout; blocks are freed below.
            let p = unsafe { a.alloc(layout) } as *mut f64;
            assert!(!p.is_null());
            assert_eq!(p as usize % SYS_ALIGN, 0);
            // SAFETY: the block holds n f64.
            unsafe {
                for i in 0..n {
                    p.add(i).write(k as f64 + i as f64);
                }
            }
            ptrs.push(p);
        }
        // 63 consecutive blocks are moved by 63 distinct cache-line offsets
        // (so blocks that the system places at equal addresses modulo 4096
        // end up on 63 different cache sets).
        // SAFETY: the blocks are live staggered blocks.
        let mut offs: Vec<usize> = ptrs
            .iter()
            .map(|&p| unsafe { offset_of(p as *mut u8) })
            .collect();
        assert!(offs
            .iter()
            .all(|&o| o % LINE == 0 && (LINE..=PAD).contains(&o)));
        offs.sort_unstable();
        offs.dedup();
        assert_eq!(offs.len(), SLOTS);
        for (k, &p) in ptrs.iter().enumerate() {
            // grow (large -> large), then shrink across the threshold
            // SAFETY: p is a live block of `layout`.
            let q = unsafe { a.realloc(p as *mut u8, layout, 2 * layout.size()) } as *mut f64;
            assert!(!q.is_null());
            // SAFETY: the first n values were carried over.
            unsafe {
                assert_eq!(q.add(n - 1).read(), k as f64 + (n - 1) as f64);
                assert_eq!(q.read(), k as f64);
                q.add(2 * n - 1).write(-1.0);
            }
            let big = Layout::array::<f64>(2 * n).unwrap();
            // SAFETY: q is a live block of `big`.
            let r = unsafe { a.realloc(q as *mut u8, big, 64) } as *mut f64;
            assert!(!r.is_null());
            // SAFETY: the first 8 values were carried over.
            unsafe {
                assert_eq!(r.add(7).read(), k as f64 + 7.0);
                a.dealloc(r as *mut u8, Layout::from_size_align(64, 8).unwrap());
            }
        }
    }

    #[test]
    fn small_blocks_grow_across_the_threshold() {
        let a = Staggered::new();
        let small = Layout::from_size_align(1024, 8).unwrap();
        // SAFETY: non-zero layout.
        let p = unsafe { a.alloc_zeroed(small) };
        assert!(!p.is_null());
        // SAFETY: p holds 1024 zeroed bytes; the realloc keeps them.
        unsafe {
            assert!((0..1024).all(|i| p.add(i).read() == 0));
            p.add(1023).write(7);
            let q = a.realloc(p, small, 1 << 20);
            assert!(!q.is_null());
            assert_eq!(q.add(1023).read(), 7);
            assert_eq!(offset_of(q) % LINE, 0);
            a.dealloc(q, Layout::from_size_align(1 << 20, 8).unwrap());
        }
        // 32-byte aligned blocks are staggered and keep their alignment
        let a32 = Layout::from_size_align(1 << 20, 32).unwrap();
        // SAFETY: non-zero layouts; the blocks are freed right away.
        unsafe {
            let p = a.alloc(a32);
            let q = a.alloc_zeroed(a32);
            assert_eq!((p as usize % 32, q as usize % 32), (0, 0));
            assert_eq!(offset_of(p) % LINE, 0);
            assert!((0..1 << 20).all(|i| q.add(i).read() == 0));
            p.write(3);
            let r = a.realloc(p, a32, 1 << 21);
            assert_eq!((r as usize % 32, r.read()), (0, 3));
            a.dealloc(r, Layout::from_size_align(1 << 21, 32).unwrap());
            a.dealloc(q, a32);
        }
        // over-aligned blocks are left to the system and keep their alignment
        let big_align = Layout::from_size_align(1 << 20, 4096).unwrap();
        // SAFETY: non-zero layout; freed right away.
        unsafe {
            let p = a.alloc(big_align);
            assert_eq!(p as usize % 4096, 0);
            a.dealloc(p, big_align);
        }
    }
}

/// Every allocation of a program that links Gimlet goes through
/// [`Staggered`] (see the module notes).
#[global_allocator]
static GLOBAL: Staggered = Staggered::new();
