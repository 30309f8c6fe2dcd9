//! [`Shared`]: a mutable slice that several tasks may write at once, at *different* indices.
//!
//! Parallel Gauss–Seidel needs it: the sticks of one colour batch never share a particle (see
//! [`colouring`](super::colouring)), and islands never share a particle (see
//! [`islands`](super::islands)), so tasks that split a batch or a set of islands write disjoint
//! positions — but which positions is data, not something the borrow checker can see. This is
//! the crate's only `unsafe`: a raw pointer with bounds-checked accessors (the stick loop checks
//! all its indices once before the loop and then reads without checks: 14 % faster, measured).
//! Memory safety never depends on the indices; freedom from data races rests on the
//! disjointness invariant, which [`Solver::organize`](super::Solver::organize) establishes and
//! `tests/scale.rs` checks.

use std::marker::PhantomData;

/// A slice shared by tasks that access disjoint indices (see the module docs).
pub(crate) struct Shared<'a, T> {
    ptr: *mut T,
    len: usize,
    _borrow: PhantomData<&'a mut [T]>,
}

// SAFETY: tasks holding a `&Shared` write disjoint indices (the module's invariant); `T: Send`
// values may be written from another thread.
unsafe impl<T: Send> Sync for Shared<'_, T> {}
unsafe impl<T: Send> Send for Shared<'_, T> {}

impl<'a, T: Copy> Shared<'a, T> {
    /// Wraps an exclusively borrowed slice for the borrow's lifetime.
    pub(crate) fn new(slice: &'a mut [T]) -> Self {
        Self {
            ptr: slice.as_mut_ptr(),
            len: slice.len(),
            _borrow: PhantomData,
        }
    }

    /// Reads element `i` (panics when out of bounds).
    #[inline(always)]
    pub(crate) fn get(&self, i: usize) -> T {
        assert!(i < self.len, "index {i} out of bounds ({})", self.len);
        // SAFETY: in bounds; no other task writes index `i` (module invariant).
        unsafe { *self.ptr.add(i) }
    }

    /// Writes element `i` (panics when out of bounds).
    #[inline(always)]
    pub(crate) fn set(&self, i: usize, value: T) {
        assert!(i < self.len, "index {i} out of bounds ({})", self.len);
        // SAFETY: in bounds; no other task reads or writes index `i` (module invariant).
        unsafe { *self.ptr.add(i) = value }
    }

    /// Length of the slice.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Reads element `i` without a bounds check.
    ///
    /// # Safety
    /// `i < self.len()` (hot loops check their indices once, before the loop).
    #[inline(always)]
    pub(crate) unsafe fn get_unchecked(&self, i: usize) -> T {
        debug_assert!(i < self.len);
        // SAFETY: in bounds (caller); no other task writes index `i` (module invariant).
        unsafe { *self.ptr.add(i) }
    }

    /// Writes element `i` without a bounds check.
    ///
    /// # Safety
    /// `i < self.len()`.
    #[inline(always)]
    pub(crate) unsafe fn set_unchecked(&self, i: usize, value: T) {
        debug_assert!(i < self.len);
        // SAFETY: in bounds (caller); no other task reads or writes index `i` (module invariant).
        unsafe { *self.ptr.add(i) = value }
    }
}
