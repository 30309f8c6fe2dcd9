//! Which settings each scene is run with, and the cost measurement: wall time per simulated
//! second (median of repeated runs in this process, interleaved across settings), the solver
//! thread's CPU time likewise (Linux), and constraint projections per simulated second
//! (machine-independent).

use crate::sim::{
    Column, Family, Law, Scene, Setting, TIMESTEP, projections_per_step, run, steps_in,
};
use bevy_verlet_physics::solver::Method;
use std::time::{Duration, Instant};

/// How much to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Plan {
    /// `--quick`: budgets 1, 8, 32, 64 only, 1 iteration per substep, 3 timing rounds instead
    /// of 7.
    pub quick: bool,
}

impl Plan {
    /// Budgets swept along each family (`N` for 1 × N, `S` for S × m).
    pub fn budgets(&self) -> &'static [u32] {
        if self.quick {
            &[1, 8, 32, 64]
        } else {
            &[1, 2, 4, 8, 16, 32, 64]
        }
    }

    /// Iterations per substep of the substep families.
    pub fn iterations(&self) -> &'static [u32] {
        if self.quick { &[1] } else { &[1, 2, 4] }
    }

    /// Timing rounds per setting (the median is reported).
    pub fn repeats(&self) -> usize {
        if self.quick { 3 } else { 7 }
    }

    /// Seed style (1 × N) and every substep family (S × m), rigid, no tethers.
    pub fn rigid(&self) -> Vec<Setting> {
        let mut settings: Vec<Setting> = self.budgets().iter().map(|&n| Setting::seed(n)).collect();
        for &m in self.iterations() {
            settings.extend(self.budgets().iter().map(|&s| Setting::substeps(s, m)));
        }
        settings.extend(self.lines());
        settings.extend(self.hierarchy());
        settings
    }

    /// S × 1, each sweep after the coarse levels of a hierarchy.
    pub fn hierarchy(&self) -> Vec<Setting> {
        self.budgets()
            .iter()
            .map(|&s| Setting::hierarchy(s))
            .collect()
    }

    /// S × 1 solved by lines (S = 1 … 8: lines are exact per substep, more substeps only refine
    /// the time integration).
    pub fn lines(&self) -> Vec<Setting> {
        self.budgets()
            .iter()
            .filter(|&&s| s <= 8)
            .map(|&s| Setting::lines(s))
            .collect()
    }

    /// [`Plan::rigid`] plus 1 × N and S × 1 with tethers.
    pub fn rigid_and_tethers(&self) -> Vec<Setting> {
        let mut settings = self.rigid();
        settings.extend(
            self.budgets()
                .iter()
                .map(|&n| Setting::seed(n).with_tethers()),
        );
        settings.extend(
            self.budgets()
                .iter()
                .map(|&s| Setting::substeps(s, 1).with_tethers()),
        );
        settings
    }

    /// 1 × N and S × 1 only (for scenes where the iteration count cannot matter, or for a
    /// second placement of the same scene).
    pub fn lean(&self) -> Vec<Setting> {
        let mut settings: Vec<Setting> = self.budgets().iter().map(|&n| Setting::seed(n)).collect();
        settings.extend(self.budgets().iter().map(|&s| Setting::substeps(s, 1)));
        settings.extend(self.lines());
        settings.extend(self.hierarchy());
        settings
    }

    /// 1 × N, S × 1 and S × 4 under both laws (compliant materials), and lines under XPBD.
    pub fn laws(&self) -> Vec<Setting> {
        let mut base = self.lean();
        base.extend(self.budgets().iter().map(|&s| Setting::substeps(s, 4)));
        let mut settings = base.clone();
        // (Plain stiffness never accumulates multipliers; lines always do: no plain lines.)
        settings.extend(
            base.iter()
                .filter(|s| s.method == Method::Sweep)
                .map(|s| s.with_law(Law::Plain)),
        );
        settings
    }
}

/// One measured point.
#[derive(Clone, Debug)]
pub struct Record {
    /// The setting.
    pub setting: Setting,
    /// The scene's metrics, in the order of its columns.
    pub values: Vec<f64>,
    /// Median wall time per simulated second, in milliseconds.
    pub ms_per_second: f64,
    /// Median CPU time of the solver thread per simulated second, in milliseconds (`NaN` where
    /// the platform does not report it). Unlike wall time it does not count time the thread
    /// waited for a core, so it is the steadier number on a loaded machine.
    pub cpu_ms_per_second: f64,
    /// Constraint projections per simulated second.
    pub projections_per_second: f64,
}

impl Record {
    /// The plotted error: the absolute value of the first metric.
    pub fn error(&self) -> f64 {
        self.values[0].abs()
    }
}

/// Every record of one scene.
#[derive(Clone, Debug)]
pub struct SceneResult {
    /// The scene's name.
    pub name: String,
    /// Its metrics.
    pub columns: Vec<Column>,
    /// One record per setting, in sweep order.
    pub records: Vec<Record>,
}

impl SceneResult {
    /// The record of `setting`, if it was run.
    pub fn get(&self, setting: &Setting) -> Option<&Record> {
        self.records.iter().find(|r| r.setting == *setting)
    }

    /// The records of one family (with or without tethers, under one law), by budget.
    pub fn series(&self, family: Family, tethers: bool, law: Law) -> Vec<&Record> {
        self.records
            .iter()
            .filter(|r| {
                r.setting.family == family && r.setting.tethers == tethers && r.setting.law == law
            })
            .collect()
    }
}

/// Wall time below which a timing repeat keeps stepping (so tiny scenes are timed over many
/// steps).
const MIN_WALL: Duration = Duration::from_millis(10);

/// CPU time this thread has run, in nanoseconds (POSIX `CLOCK_THREAD_CPUTIME_ID`, Linux only
/// here), or `None` where that is not available.
#[cfg(target_os = "linux")]
fn thread_cpu_ns() -> Option<u64> {
    use std::ffi::{c_int, c_long};
    #[repr(C)]
    struct Timespec {
        seconds: c_long,
        nanoseconds: c_long,
    }
    unsafe extern "C" {
        fn clock_gettime(clock: c_int, time: *mut Timespec) -> c_int;
    }
    const CLOCK_THREAD_CPUTIME_ID: c_int = 3;
    let mut time = Timespec {
        seconds: 0,
        nanoseconds: 0,
    };
    // SAFETY: `clock_gettime` only writes a `struct timespec` (two `long`s on Linux) through the
    // valid pointer it is given.
    let status = unsafe { clock_gettime(CLOCK_THREAD_CPUTIME_ID, &mut time) };
    (status == 0).then(|| time.seconds as u64 * 1_000_000_000 + time.nanoseconds as u64)
}

/// CPU time is only read on Linux.
#[cfg(not(target_os = "linux"))]
fn thread_cpu_ns() -> Option<u64> {
    None
}

/// One timing repeat of `scene` under `setting`: builds it afresh and steps it for at least
/// [`Scene::bench_seconds`] of simulated time and [`MIN_WALL`] of wall time, measuring nothing.
/// Returns wall and CPU milliseconds per simulated second (CPU `NaN` if unavailable).
pub fn time_once(scene: &dyn Scene, setting: &Setting) -> (f64, f64) {
    let (mut solver, config) = scene.build(setting);
    let chunk = if projections_per_step(&solver, setting) < 4096 {
        64
    } else {
        1
    };
    let min_steps = steps_in(scene.bench_seconds()).max(1);
    let mut steps = 0;
    let cpu_start = thread_cpu_ns();
    let start = Instant::now();
    while steps < min_steps || start.elapsed() < MIN_WALL {
        run(&mut solver, setting, &config, chunk);
        steps += chunk;
    }
    let wall = start.elapsed().as_secs_f64();
    let cpu = match (cpu_start, thread_cpu_ns()) {
        (Some(a), Some(b)) => (b - a) as f64 * 1e-9,
        _ => f64::NAN,
    };
    let simulated = steps as f64 * TIMESTEP;
    (wall * 1e3 / simulated, cpu * 1e3 / simulated)
}

/// The median of `samples` (`NaN` if empty or all `NaN`).
fn median(mut samples: Vec<f64>) -> f64 {
    samples.retain(|x| !x.is_nan());
    samples.sort_by(f64::total_cmp);
    samples.get(samples.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Runs `scene` with every setting: measures each distinct run once (printing one line per
/// setting), then times them in interleaved rounds — every setting once per round — so that a
/// change in the machine's load hits all settings alike; the median of the rounds is kept.
pub fn sweep(scene: &dyn Scene, settings: &[Setting], plan: &Plan) -> SceneResult {
    let name = scene.name();
    let columns = scene.columns();
    println!("{name}: {} settings", settings.len());
    let mut records: Vec<Record> = Vec::with_capacity(settings.len());
    // Index of the record each setting shares its run with (1 × 1 belongs to several families).
    let mut owner = Vec::with_capacity(settings.len());
    for setting in settings {
        if let Some(i) = records.iter().position(|r| same_run(&r.setting, setting)) {
            owner.push(i);
            continue;
        }
        let values = scene.measure(setting);
        let (solver, _) = scene.build(setting);
        let projections_per_second = projections_per_step(&solver, setting) as f64 / TIMESTEP;
        println!(
            "  {:<12} {} {:>10}",
            setting.label(),
            columns[0].name,
            crate::report::format_value(values[0], columns[0].unit),
        );
        owner.push(records.len());
        records.push(Record {
            setting: *setting,
            values,
            ms_per_second: f64::NAN,
            cpu_ms_per_second: f64::NAN,
            projections_per_second,
        });
    }
    let started = Instant::now();
    let mut samples = vec![(Vec::new(), Vec::new()); records.len()];
    for _ in 0..plan.repeats() {
        for (record, (wall, cpu)) in records.iter().zip(samples.iter_mut()) {
            let (w, c) = time_once(scene, &record.setting);
            wall.push(w);
            cpu.push(c);
        }
    }
    for (record, (wall, cpu)) in records.iter_mut().zip(samples) {
        record.ms_per_second = median(wall);
        record.cpu_ms_per_second = median(cpu);
    }
    println!(
        "  timed {} runs × {} rounds in {:.1} s",
        records.len(),
        plan.repeats(),
        started.elapsed().as_secs_f64()
    );
    let records = settings
        .iter()
        .zip(owner)
        .map(|(setting, i)| Record {
            setting: *setting,
            ..records[i].clone()
        })
        .collect();
    SceneResult {
        name,
        columns,
        records,
    }
}

/// Whether two settings run the same simulation (they may belong to different families).
pub fn same_run(a: &Setting, b: &Setting) -> bool {
    (a.substeps, a.iterations, a.tethers, a.law, a.method)
        == (b.substeps, b.iterations, b.tethers, b.law, b.method)
}
