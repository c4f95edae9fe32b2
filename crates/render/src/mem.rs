//! [`HugeSlice`]: an immutable array of plain values in memory that the kernel is asked to
//! back with huge pages (Linux transparent huge pages, `madvise(MADV_HUGEPAGE)`), for the large
//! arrays that rays read at random (BVH nodes, triangle blocks): with 4 KiB pages, tens of
//! megabytes read at random miss the TLB on nearly every access, and each miss is a page walk.
//!
//! [`Stack`]: a fixed-capacity stack whose slots are not cleared before use (a traversal's,
//! made for every ray).
//!
//! Arrays of at least [`HUGE`] bytes are allocated aligned to 2 MiB and advised before they
//! are first written (the pages then come as huge pages if the kernel has them); smaller ones,
//! and every array on other systems, are ordinary allocations. Only the memory changes, never
//! the values.

// Why unsafe code is allowed in this file: the array is allocated with `std::alloc::alloc`
// (with an alignment of our own, so it cannot be a `Vec`), written once (`copy_nonoverlapping`
// from a slice of the same length, or slot by slot as `MaybeUninit`), and only then given its
// length and read as a slice of initialised values
// and freed with the layout it was allocated with; `madvise` (libc, which std links on Linux)
// only gives the kernel advice about pages of that allocation and never changes their contents.
// A `Stack` reads only the slots below its length, each written by `push` before (the slots
// from its length up are never read).
#![allow(unsafe_code)]

use std::alloc::{alloc, dealloc, handle_alloc_error, Layout};
use std::mem::MaybeUninit;
use std::ptr::NonNull;

/// Arrays of at least this many bytes go on huge pages.
pub(crate) const HUGE: usize = 2 << 20;

/// A huge page's size (x86-64 and AArch64 with 4 KiB base pages).
const HUGE_PAGE: usize = 2 << 20;

/// An immutable array of `T` (see the module).
pub(crate) struct HugeSlice<T: Copy> {
    ptr: NonNull<T>,
    len: usize,
    layout: Layout,
}

// SAFETY: a `HugeSlice` owns its values, like a `Box<[T]>`.
unsafe impl<T: Copy + Send> Send for HugeSlice<T> {}
// SAFETY: shared access only reads.
unsafe impl<T: Copy + Sync> Sync for HugeSlice<T> {}

impl<T: Copy> HugeSlice<T> {
    /// A copy of `values`.
    pub(crate) fn new(values: &[T]) -> Self {
        let mut s = Self::uninit(values.len());
        // SAFETY: the allocation holds `values.len()` values of `T` and does not overlap
        // `values`; afterwards every value is initialised.
        unsafe { std::ptr::copy_nonoverlapping(values.as_ptr(), s.ptr.as_ptr(), values.len()) };
        s.len = values.len();
        s
    }

    /// `[f(0), f(1), …, f(len - 1)]`, computed in parallel and written in place (without
    /// a copy).
    pub(crate) fn from_fn_par(len: usize, f: impl Fn(usize) -> T + Sync) -> Self
    where
        T: Send,
    {
        use rayon::prelude::*;
        let mut s = Self::uninit(len);
        // SAFETY: the allocation holds `len` values of `T`, here seen as not yet initialised.
        let slots =
            unsafe { std::slice::from_raw_parts_mut(s.ptr.as_ptr() as *mut MaybeUninit<T>, len) };
        const CHUNK: usize = 4096;
        slots
            .par_chunks_mut(CHUNK)
            .enumerate()
            .for_each(|(c, chunk)| {
                for (j, slot) in chunk.iter_mut().enumerate() {
                    slot.write(f(c * CHUNK + j));
                }
            });
        // Every slot has been written.
        s.len = len;
        s
    }

    /// Room for `len` values (advised, not written); `len` stays 0 until the caller fills it.
    fn uninit(len: usize) -> Self {
        let bytes = std::mem::size_of::<T>()
            .checked_mul(len)
            .expect("an array that fits in memory");
        if bytes == 0 {
            return Self {
                ptr: NonNull::dangling(),
                len: 0,
                layout: Layout::new::<()>(),
            };
        }
        let huge = bytes >= HUGE && cfg!(target_os = "linux");
        let align = if huge {
            HUGE_PAGE.max(std::mem::align_of::<T>())
        } else {
            std::mem::align_of::<T>()
        };
        let layout = Layout::from_size_align(bytes, align).expect("an array that fits in memory");
        // SAFETY: `layout` has a non-zero size.
        let p = unsafe { alloc(layout) };
        let Some(ptr) = NonNull::new(p as *mut T) else {
            handle_alloc_error(layout)
        };
        if huge {
            advise_huge(p, bytes);
        }
        Self {
            ptr,
            len: 0,
            layout,
        }
    }
}

/// Asks the kernel for huge pages under `[p, p + bytes)` (advice only: a refusal changes
/// nothing).
#[cfg(target_os = "linux")]
fn advise_huge(p: *mut u8, bytes: usize) {
    extern "C" {
        fn madvise(
            addr: *mut std::ffi::c_void,
            len: usize,
            advice: std::ffi::c_int,
        ) -> std::ffi::c_int;
    }
    const MADV_HUGEPAGE: std::ffi::c_int = 14;
    // SAFETY: the range is part of one live allocation (`p` is 2 MiB aligned, so page
    // aligned, and the length is rounded down to whole huge pages); the advice moves no data.
    let _ = unsafe { madvise(p.cast(), bytes / HUGE_PAGE * HUGE_PAGE, MADV_HUGEPAGE) };
}

#[cfg(not(target_os = "linux"))]
fn advise_huge(_: *mut u8, _: usize) {}

impl<T: Copy> Drop for HugeSlice<T> {
    fn drop(&mut self) {
        if self.layout.size() != 0 {
            // SAFETY: allocated in `new` with this layout, freed once.
            unsafe { dealloc(self.ptr.as_ptr().cast(), self.layout) };
        }
    }
}

impl<T: Copy> std::ops::Deref for HugeSlice<T> {
    type Target = [T];

    #[inline(always)]
    fn deref(&self) -> &[T] {
        // SAFETY: `len` values, initialised in `new` (or none, at a dangling aligned pointer).
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> Clone for HugeSlice<T> {
    fn clone(&self) -> Self {
        Self::new(self)
    }
}

impl<T: Copy> Default for HugeSlice<T> {
    fn default() -> Self {
        Self::new(&[])
    }
}

impl<T: Copy + std::fmt::Debug> std::fmt::Debug for HugeSlice<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl<T: Copy> From<Vec<T>> for HugeSlice<T> {
    fn from(v: Vec<T>) -> Self {
        Self::new(&v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_large_and_empty_arrays_keep_their_values() {
        for n in [0usize, 1, 1000, HUGE / 8 + 3] {
            let v: Vec<u64> = (0..n as u64).map(|i| i * 7 + 1).collect();
            let h = HugeSlice::new(&v);
            assert_eq!(&h[..], &v[..]);
            let c = h.clone();
            drop(h);
            assert_eq!(&c[..], &v[..]);
            let f = HugeSlice::from_fn_par(n, |i| i as u64 * 7 + 1);
            assert_eq!(&f[..], &v[..]);
            if n * 8 >= HUGE && cfg!(target_os = "linux") {
                assert_eq!(c.as_ptr() as usize % HUGE_PAGE, 0);
            }
        }
        assert!(HugeSlice::<[u8; 3]>::default().is_empty());
    }
}

/// A stack of at most `N` values of `T` whose slots are not initialised when it is made: a
/// BVH traversal makes one for every ray, and clearing its couple of kilobytes would cost
/// more than its first nodes. (A thread-local stack kept across rays cost about fifty
/// instructions a ray to borrow.)
pub(crate) struct Stack<T: Copy, const N: usize> {
    slots: [MaybeUninit<T>; N],
    len: usize,
}

impl<T: Copy, const N: usize> Stack<T, N> {
    /// An empty stack.
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Self {
            slots: [const { MaybeUninit::uninit() }; N],
            len: 0,
        }
    }

    /// Pushes `x`; panics when the stack is full.
    #[inline(always)]
    pub(crate) fn push(&mut self, x: T) {
        self.slots[self.len].write(x);
        self.len += 1;
    }

    /// The top value, removed; `None` when empty.
    #[inline(always)]
    pub(crate) fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: the slots below the length were written by `push`.
        Some(unsafe { self.slots[self.len].assume_init() })
    }

    /// The number of values.
    #[inline(always)]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// The values from position `from` (from the bottom) to the top, top last.
    #[inline(always)]
    pub(crate) fn above_mut(&mut self, from: usize) -> &mut [T] {
        let part = &mut self.slots[from.min(self.len)..self.len];
        // SAFETY: the slots below the length were written by `push`, and `MaybeUninit<T>` has
        // the layout of `T`.
        unsafe { &mut *(part as *mut [MaybeUninit<T>] as *mut [T]) }
    }
}

#[cfg(test)]
mod stack_tests {
    use super::Stack;

    #[test]
    fn a_stack_gives_back_what_was_pushed_last_first() {
        let mut s = Stack::<(u32, f32), 8>::new();
        assert_eq!(s.pop(), None);
        for i in 0..5 {
            s.push((i, i as f32));
        }
        assert_eq!(s.len(), 5);
        assert_eq!(s.above_mut(3), &mut [(3, 3.0), (4, 4.0)]);
        s.above_mut(3).swap(0, 1);
        assert_eq!(s.pop(), Some((3, 3.0)));
        assert_eq!(s.pop(), Some((4, 4.0)));
        assert_eq!(s.above_mut(7), &mut []);
        assert_eq!(s.len(), 3);
        while s.pop().is_some() {}
        assert_eq!(s.len(), 0);
    }

    #[test]
    #[should_panic]
    fn pushing_on_a_full_stack_panics() {
        let mut s = Stack::<u8, 2>::new();
        for i in 0..3 {
            s.push(i);
        }
    }
}
