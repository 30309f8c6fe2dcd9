//! [`SharedSlice`]: a mutable slice that several tasks may write at once, at *different*
//! indices; [`Shared`]: one task's exclusive view of a range of it.
//!
//! Parallel Gauss–Seidel needs it: the sticks of one colour batch never share a particle (see
//! [`colouring`](super::colouring)), and islands never share a particle (see
//! [`islands`](super::islands)), so tasks that split a batch or a set of islands write disjoint
//! positions — but which positions is data, not something the borrow checker can see. So the
//! accessors of [`SharedSlice`] are `unsafe fn`s whose contract is exactly that (no other task
//! accesses the index meanwhile), and each caller states which invariant keeps it: disjoint
//! islands, an independent batch, a split of a particle range. Those invariants hold because
//! the step only uses islands that match the topology they were built from
//! ([`Solver::is_organized`](super::Solver::is_organized), checked by every phase) and claims
//! its job indices itself (see `run_jobs` in `step.rs`). Every access is bounds-checked except
//! `get_unchecked`/`set_unchecked` (the stick loop checks all its indices once before the loop:
//! 14 % faster, measured; the line solve checks a line's indices once per solve, see
//! `LineSolve::check` in [`direct`](super::direct): 28 % fewer instructions, measured).
//!
//! A [`Shared`] is made from a range that one task holds alone ([`SharedSlice::part`], unsafe)
//! or from an exclusive borrow ([`Shared::new`]); it cannot be shared between threads (it is not
//! `Sync`), so its bounds-checked accessors are safe.

use std::cell::Cell;
use std::marker::PhantomData;
use std::ops::Range;

/// A slice shared by tasks that access disjoint indices (see the module docs). Copies share
/// the borrow (and its lifetime): a solve keeps its own copy in a local, where the compiler
/// knows that no store moves the pointer.
#[derive(Clone, Copy)]
pub(crate) struct SharedSlice<'a, T> {
    ptr: *mut T,
    len: usize,
    _borrow: PhantomData<&'a mut [T]>,
}

// SAFETY: every access through a `&SharedSlice` is an `unsafe fn` whose caller guarantees that
// no other task accesses that index meanwhile; `T: Send` values may be written from another
// thread.
unsafe impl<T: Send> Sync for SharedSlice<'_, T> {}
// SAFETY: as above: copies share the exclusive borrow taken for `'a` (nothing outside them
// sees the slice), and every access through any copy is an `unsafe fn` with that contract.
unsafe impl<T: Send> Send for SharedSlice<'_, T> {}

impl<'a, T: Copy> SharedSlice<'a, T> {
    /// Wraps an exclusively borrowed slice for the borrow's lifetime.
    pub(crate) fn new(slice: &'a mut [T]) -> Self {
        Self {
            ptr: slice.as_mut_ptr(),
            len: slice.len(),
            _borrow: PhantomData,
        }
    }

    /// Length of the slice.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Reads element `i` (panics when out of bounds).
    ///
    /// # Safety
    /// No other task writes index `i` while this runs.
    #[inline(always)]
    pub(crate) unsafe fn get(&self, i: usize) -> T {
        assert!(i < self.len, "index {i} out of bounds ({})", self.len);
        // SAFETY: in bounds (checked); no concurrent write (caller).
        unsafe { *self.ptr.add(i) }
    }

    /// Writes element `i` (panics when out of bounds).
    ///
    /// # Safety
    /// No other task reads or writes index `i` while this runs.
    #[inline(always)]
    pub(crate) unsafe fn set(&self, i: usize, value: T) {
        assert!(i < self.len, "index {i} out of bounds ({})", self.len);
        // SAFETY: in bounds (checked); no concurrent access (caller).
        unsafe { *self.ptr.add(i) = value }
    }

    /// Reads element `i` without a bounds check.
    ///
    /// # Safety
    /// `i < self.len()` (hot loops check their indices once, before the loop), and no other
    /// task writes index `i` while this runs.
    #[inline(always)]
    pub(crate) unsafe fn get_unchecked(&self, i: usize) -> T {
        debug_assert!(i < self.len);
        // SAFETY: in bounds, no concurrent write (caller).
        unsafe { *self.ptr.add(i) }
    }

    /// Writes element `i` without a bounds check.
    ///
    /// # Safety
    /// `i < self.len()`, and no other task reads or writes index `i` while this runs.
    #[inline(always)]
    pub(crate) unsafe fn set_unchecked(&self, i: usize, value: T) {
        debug_assert!(i < self.len);
        // SAFETY: in bounds, no concurrent access (caller).
        unsafe { *self.ptr.add(i) = value }
    }

    /// The calling task's exclusive mutable slice of `range` (panics when out of bounds).
    ///
    /// # Safety
    /// While the slice lives, no other task accesses an index in `range`.
    #[allow(clippy::mut_from_ref)] // (the contract above is what makes it exclusive)
    pub(crate) unsafe fn slice_mut(&self, range: Range<usize>) -> &mut [T] {
        assert!(
            range.start <= range.end && range.end <= self.len,
            "range {range:?} out of bounds ({})",
            self.len
        );
        // SAFETY: in bounds (checked); no other task accesses the range meanwhile (caller).
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(range.start), range.len()) }
    }

    /// The calling task's exclusive view of `range` (panics when out of bounds).
    ///
    /// # Safety
    /// While the view lives, no other task accesses an index in `range`.
    pub(crate) unsafe fn part(&self, range: Range<usize>) -> Shared<'_, T> {
        assert!(
            range.start <= range.end && range.end <= self.len,
            "range {range:?} out of bounds ({})",
            self.len
        );
        Shared {
            ptr: self.ptr,
            range,
            _borrow: PhantomData,
            _not_sync: PhantomData,
        }
    }
}

/// One task's exclusive view of a range of a slice (indexed like the whole slice): safe,
/// bounds-checked accessors, and not `Sync`, so it never reaches a second thread.
pub(crate) struct Shared<'a, T> {
    ptr: *mut T,
    range: Range<usize>,
    _borrow: PhantomData<&'a mut [T]>,
    _not_sync: PhantomData<Cell<()>>,
}

impl<'a, T: Copy> Shared<'a, T> {
    /// A view of a whole, exclusively borrowed slice.
    pub(crate) fn new(slice: &'a mut [T]) -> Self {
        Self {
            ptr: slice.as_mut_ptr(),
            range: 0..slice.len(),
            _borrow: PhantomData,
            _not_sync: PhantomData,
        }
    }

    /// Reads element `i` (panics outside the view).
    #[inline(always)]
    pub(crate) fn get(&self, i: usize) -> T {
        assert!(
            self.range.contains(&i),
            "index {i} outside {:?}",
            self.range
        );
        // SAFETY: in the view, which this task alone accesses (`new`'s borrow or `part`'s
        // contract), and the view stays on this thread (not `Sync`).
        unsafe { *self.ptr.add(i) }
    }

    /// Writes element `i` (panics outside the view).
    #[inline(always)]
    pub(crate) fn set(&self, i: usize, value: T) {
        assert!(
            self.range.contains(&i),
            "index {i} outside {:?}",
            self.range
        );
        // SAFETY: as for `get`.
        unsafe { *self.ptr.add(i) = value }
    }
}
