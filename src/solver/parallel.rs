//! How the solver runs work on several threads without knowing any thread pool.
//!
//! The core hands independent jobs to an [`Executor`]: the Bevy layer passes Bevy's
//! `ComputeTaskPool`, [`Serial`] runs them one after the other. Jobs are independent by
//! construction — islands share no particle, the sticks of one colour batch share no particle —
//! so the result is bit-for-bit the same whatever the executor and thread count.
//!
//! [`Executor`] is a safe trait, so the solver does not trust it: it never relies on the job
//! index an executor passes. Each call claims its jobs from an atomic counter, so a job the
//! executor runs twice (even at the same time) or with a wrong index still runs exactly once,
//! and one that returns without running anything makes the step panic instead of silently
//! skipping work (`tests/soundness.rs`).
//!
//! Work is split only when it is large enough to pay for the hand-off (see the `PARALLEL_*`
//! thresholds): a scene that fits one thread runs exactly the serial code.

/// Runs independent jobs, possibly at the same time.
///
/// ```
/// use bevy_verlet_physics::solver::{Executor, Serial};
/// use std::sync::atomic::{AtomicUsize, Ordering};
/// let sum = AtomicUsize::new(0);
/// Serial.run(4, &|job| {
///     sum.fetch_add(job, Ordering::Relaxed);
/// });
/// assert_eq!(sum.into_inner(), 0 + 1 + 2 + 3);
/// ```
pub trait Executor: Sync {
    /// How many jobs are worth running at once (the thread count; `1` = serial).
    fn threads(&self) -> usize;
    /// Runs `job(0)`, …, `job(count − 1)` and returns when all have finished.
    fn run(&self, count: usize, job: &(dyn Fn(usize) + Sync));
}

/// Runs every job on the calling thread, in order.
#[derive(Clone, Copy, Debug, Default)]
pub struct Serial;

impl Executor for Serial {
    fn threads(&self) -> usize {
        1
    }

    fn run(&self, count: usize, job: &(dyn Fn(usize) + Sync)) {
        (0..count).for_each(job);
    }
}

/// Runs each job on its own scoped OS thread (for tests and tools without a task pool; spawning
/// threads costs tens of microseconds per call, so prefer a pool in a game).
#[derive(Clone, Copy, Debug)]
pub struct ScopedThreads(pub usize);

impl Executor for ScopedThreads {
    fn threads(&self) -> usize {
        self.0.max(1)
    }

    fn run(&self, count: usize, job: &(dyn Fn(usize) + Sync)) {
        std::thread::scope(|scope| {
            for i in 1..count {
                scope.spawn(move || job(i));
            }
            if count > 0 {
                job(0);
            }
        });
    }
}

/// A coloured island is solved on every thread when its sticks × iterations per substep reach
/// this (below it, the hand-off to the pool costs more than it saves; measured on a 2-core VM).
pub const PARALLEL_MIN_STICK_ITERATIONS: usize = 32_768;

/// Sticks per chunk that a thread claims at a time within a colour batch.
pub const PARALLEL_CHUNK_STICKS: usize = 1024;

/// Islands are spread across threads only if each thread gets at least this much work
/// (particles + sticks × iterations).
pub const PARALLEL_MIN_WORK_PER_JOB: usize = 32_768;

/// Particle loops (integration, colliders) are split only if each thread gets this many.
pub const PARALLEL_MIN_PARTICLES_PER_JOB: usize = 65_536;

/// How many jobs to split `work` units into, given at least `min_per_job` per job.
pub(crate) fn job_count(executor: &dyn Executor, work: usize, min_per_job: usize) -> usize {
    executor.threads().min(work / min_per_job.max(1)).max(1)
}

/// The `job`-th of `jobs` near-equal parts of `range`.
pub(crate) fn part(
    range: std::ops::Range<usize>,
    job: usize,
    jobs: usize,
) -> std::ops::Range<usize> {
    let len = range.len();
    range.start + len * job / jobs..range.start + len * (job + 1) / jobs
}

/// Claim and completion counters for [`Solver::relax_substep`](super::Solver::relax_substep)'s
/// parallel islands, kept between steps so a step allocates nothing once they are large enough.
#[derive(Debug, Default)]
pub(crate) struct Counters(pub(crate) Vec<std::sync::atomic::AtomicU32>);

impl Counters {
    /// Makes room for `n` counters.
    pub(crate) fn ensure(&mut self, n: usize) {
        if self.0.len() < n {
            self.0.resize_with(n, Default::default);
        }
    }
}

impl Clone for Counters {
    fn clone(&self) -> Self {
        let mut counters = Self::default();
        counters.ensure(self.0.len());
        counters
    }
}
