//! The solver core's [`Executor`] on Bevy's `ComputeTaskPool`.

use crate::solver::{Executor, Serial};
use bevy::tasks::{ComputeTaskPool, TaskPool};

/// Runs the solver core's jobs on a Bevy task pool: job 0 on the calling thread (which also
/// helps with the others while it waits), the rest as tasks. The plugin uses it with
/// `ComputeTaskPool`; use it to step a [`Solver`](crate::solver::Solver) of your own in
/// parallel.
///
/// ```
/// use bevy::tasks::{ComputeTaskPool, TaskPool};
/// use bevy_verlet_physics::TaskPoolExecutor;
/// use bevy_verlet_physics::solver::{Solver, StepConfig};
/// let pool = ComputeTaskPool::get_or_init(TaskPool::default);
/// let mut solver = Solver::default();
/// solver.step_with(&StepConfig::default(), &TaskPoolExecutor(pool));
/// ```
pub struct TaskPoolExecutor(pub &'static TaskPool);

impl Executor for TaskPoolExecutor {
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
        Some(pool) if parallel => f(&TaskPoolExecutor(pool)),
        _ => f(&Serial),
    }
}
