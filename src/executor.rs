//! The solver core's [`Executor`] on Bevy's `ComputeTaskPool`.

use crate::solver::{Executor, Serial};
use bevy::tasks::{ComputeTaskPool, TaskPool};

/// Runs the core's jobs on a Bevy task pool: job 0 on the calling thread (which also helps with
/// the others while it waits), the rest as tasks.
pub(crate) struct PoolExecutor(&'static TaskPool);

impl Executor for PoolExecutor {
    fn threads(&self) -> usize {
        // The scope's caller runs jobs too.
        self.0.thread_num() + 1
    }

    fn run(&self, count: usize, job: &(dyn Fn(usize) + Sync)) {
        self.0.scope(|scope| {
            for i in 1..count {
                scope.spawn(async move { job(i) });
            }
            if count > 0 {
                job(0);
            }
        });
    }
}

/// Calls `f` with the compute pool's executor if `parallel` and the pool exists, else serial.
pub(crate) fn with_executor<R>(parallel: bool, f: impl FnOnce(&dyn Executor) -> R) -> R {
    match ComputeTaskPool::try_get() {
        Some(pool) if parallel => f(&PoolExecutor(pool)),
        _ => f(&Serial),
    }
}
