//! Speed against error: every solver setting on scenes with known answers.
//!
//! ```text
//! cargo run --release --no-default-features --features report --example speed_vs_error [-- --quick]
//! ```
//!
//! # What is measured
//!
//! Each scene (module [`sim`]) is built on the solver core only
//! (`bevy_verlet_physics::solver`, no ECS) and compared with a reference answer:
//!
//! 1. simple pendulum, rigid stick, 5° and 120°: first-period error against the exact
//!    `T = 2π√(L/g)/AGM(1, cos(θ₀/2))`, energy lost per period — in metres at the origin and in
//!    pixels around (1000, 1000) px;
//! 2. hanging chain pinned at both ends (50 links, span 80 % of the length): sag and shape
//!    against the discrete catenary, max link strain;
//! 3. heavy tip (100 links, tip 1000× a link): stretch at rest; 3b. a soft chain under a load:
//!    XPBD compliance against plain PBD stiffness for seed-tuned materials;
//! 4. cloth 50 × 50 pinned along the top: max and mean strain after settling;
//! 5. springs from compliance (2 Hz, 10 Hz, a seed material): frequency against `√(k/m)`;
//! 6. free fall and projectile against `x₀ + v₀t + ½gt²` (and an `f32` loop for contrast);
//! 7. double pendulum: energy lost over 60 s (and left after 10 s);
//! 8. chains released from horizontal (the heavy tip's, 200 equal links): max link strain.
//!
//! The settings (module [`sweep`]): the seeds' style, 1 substep × N = 1…64 iterations (rigid sticks
//! are the seeds' stiffness 1.0), S = 1…64 substeps × 1, 2 and 4 iterations, tethers on and off,
//! XPBD compliance against plain per-pass stiffness, and S = 1…8 substeps solved by lines
//! (direct solve with SHAKE). Cost is measured three ways: wall time per
//! simulated second (median of repeated runs in this process, interleaved across settings, so
//! only comparable within one report), the solver thread's CPU time likewise (Linux; it does not
//! grow when other processes load the machine), and constraint projections per simulated second
//! (machine-independent; it leaves out the per-substep integration that substeps add, which the
//! times include). A settling check reruns the scenes measured at rest for twice as long.
//!
//! Output: `report/speed_vs_error.md` (tables and a reading) and `report/speed_vs_error.png`
//! (log–log cost against error per scene, one series per setting family, Pareto front marked).

mod analysis;
mod extras;
mod lines;
mod plot;
mod precision;
mod reading;
mod report;
mod settle;
mod sim;
mod sweep;

use sim::catenary::Catenary;
use sim::cloth::Cloth;
use sim::double_pendulum::DoublePendulum;
use sim::heavy_tip::HeavyTip;
use sim::loaded::Loaded;
use sim::pendulum::Pendulum;
use sim::spring::{Spring, Stiff};
use sim::swinging::Swinging;
use sim::{Material, Units};
use std::time::Instant;
use sweep::{Plan, SceneResult, sweep};

/// The Tuts+ ragdoll's torso link: 0.8 per pass, 3 passes per 16 ms step.
pub const TUTS_TORSO: Material = Material {
    name: "Tuts+ torso link k = 0.8, 3 passes / 16 ms",
    stiffness: 0.8,
    iterations: 3,
    timestep: 0.016,
};

/// verlet-js cloth stiffness 0.9 (0.225 of the error per pass, 16 passes per 60 Hz frame).
pub const VERLET_JS_CLOTH: Material = Material {
    name: "verlet-js cloth k = 0.9, i.e. 0.225 × 16 passes / 60 Hz",
    stiffness: 0.225,
    iterations: 16,
    timestep: 1.0 / 60.0,
};

/// The Tuts+ ragdoll's "invisible" head link: 0.02 per pass, 3 passes per 16 ms step.
pub const TUTS_HEAD: Material = Material {
    name: "Tuts+ head link k = 0.02, 3 passes / 16 ms",
    stiffness: 0.02,
    iterations: 3,
    timestep: 0.016,
};

/// Everything the report shows.
pub struct Results {
    /// Pendulum 5° and 120°, metres at the origin.
    pub pendulum: [SceneResult; 2],
    /// The same in pixels far from the origin (1 × N and S × 1 only).
    pub pendulum_px: [SceneResult; 2],
    /// Catenary.
    pub catenary: SceneResult,
    /// Heavy tip.
    pub heavy_tip: SceneResult,
    /// Chains released from horizontal: the heavy tip's, and 200 equal links.
    pub swinging: [SceneResult; 2],
    /// Soft loaded chains, one per material.
    pub loaded: Vec<SceneResult>,
    /// Cloth.
    pub cloth: SceneResult,
    /// Springs: 2 Hz, 10 Hz, seed material.
    pub springs: Vec<SceneResult>,
    /// Double pendulum.
    pub double_pendulum: SceneResult,
    /// Units and precision rows.
    pub precision: Vec<precision::Row>,
    /// The seeds' Verlet start, projectile error by substeps.
    pub seed_start: Vec<(u32, f64)>,
    /// Settling check rows.
    pub settling: Vec<settle::Row>,
    /// Whether this was a `--quick` run.
    pub quick: bool,
    /// Wall time of the whole run in seconds.
    pub seconds: f64,
}

/// The 1-minute load average (Linux), or `n/a`.
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "n/a".into())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let quick = std::env::args().any(|a| a == "--quick");
    let plan = Plan { quick };
    let started = Instant::now();
    let load_before = load_average();
    println!(
        "speed_vs_error{}: {} budgets per family, {} timing repeats",
        if quick { " --quick" } else { "" },
        plan.budgets().len(),
        plan.repeats()
    );
    let pendulum = |amplitude_deg, units| Pendulum {
        amplitude_deg,
        units,
    };
    let results = Results {
        pendulum: [5.0, 120.0].map(|a| sweep(&pendulum(a, Units::Metres), &plan.rigid(), &plan)),
        pendulum_px: [5.0, 120.0].map(|a| sweep(&pendulum(a, Units::Pixels), &plan.lean(), &plan)),
        catenary: sweep(&Catenary::default(), &plan.rigid_and_tethers(), &plan),
        heavy_tip: sweep(&HeavyTip::default(), &plan.rigid_and_tethers(), &plan),
        swinging: [Swinging::heavy_tip(), Swinging::two_hundred()]
            .map(|scene| sweep(&scene, &plan.rigid_and_tethers(), &plan)),
        loaded: [TUTS_TORSO, VERLET_JS_CLOTH]
            .iter()
            .map(|&m| sweep(&Loaded::new(m), &plan.laws(), &plan))
            .collect(),
        cloth: sweep(&Cloth::default(), &plan.rigid_and_tethers(), &plan),
        springs: vec![
            sweep(
                &Spring {
                    stiff: Stiff::Frequency(2.0),
                },
                &plan.lean(),
                &plan,
            ),
            sweep(
                &Spring {
                    stiff: Stiff::Frequency(10.0),
                },
                &plan.lean(),
                &plan,
            ),
            sweep(
                &Spring {
                    stiff: Stiff::Seed(TUTS_HEAD),
                },
                &plan.laws(),
                &plan,
            ),
        ],
        double_pendulum: sweep(&DoublePendulum::default(), &plan.rigid(), &plan),
        precision: {
            println!("Units and precision (f64 solver against an f32 loop)");
            precision::measure()
        },
        seed_start: precision::seed_start_errors(),
        settling: {
            println!("Settling check (primary error at the scene's duration and at twice it)");
            settle::check()
        },
        quick,
        seconds: 0.0,
    };
    let results = Results {
        seconds: started.elapsed().as_secs_f64(),
        ..results
    };
    std::fs::create_dir_all("report")?;
    let load = (load_before, load_average());
    let markdown = report::document(&results, &plan, load);
    std::fs::write("report/speed_vs_error.md", markdown)?;
    println!("wrote report/speed_vs_error.md");
    plot::draw(&results, "report/speed_vs_error.png")?;
    println!("wrote report/speed_vs_error.png");
    println!("done in {:.0} s", started.elapsed().as_secs_f64());
    Ok(())
}
