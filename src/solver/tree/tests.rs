//! A tree's Gauss–Newton pass against the dense system, with pins below its root.

use super::{Node, TreeSolve, TreeView};
use crate::solver::shared::SharedSlice;
use crate::solver::{Solver, StickKind, kkt};
use glam::DVec3;

/// A trunk of two links forking into three branches of two links, bent, links stretched and
/// compressed, unequal masses; the first branch's tip and the second branch's middle particle
/// pinned, and (`root_pinned`) the trunk's top.
fn forked(root_pinned: bool) -> (Solver, Vec<f64>) {
    let mut solver = Solver::default();
    let top = solver.add_particle(DVec3::ZERO, 1.0);
    let mut link = |from: u32, to: DVec3, w: f64, rest: f64| {
        let p = solver.add_particle(to, w);
        solver
            .sticks
            .push([from, p], rest, 0.0, StickKind::Equal, f64::INFINITY, 0);
        p
    };
    let a = link(top, DVec3::new(0.02, -0.11, 0.0), 1.0, 0.1);
    let fork = link(a, DVec3::new(0.05, -0.2, 0.01), 2.0, 0.1);
    let mut pinned = vec![];
    for (i, side) in [-1.0, 0.0, 1.0].into_iter().enumerate() {
        let at = DVec3::new(0.05 + 0.07 * side, -0.29, 0.02 * side);
        let b = link(fork, at, 1.0, 0.1);
        let tip = link(b, DVec3::new(0.06 + 0.15 * side, -0.37, -0.01), 0.5, 0.12);
        pinned.push([tip, b, tip][i]);
    }
    pinned.truncate(2);
    // (Organized with every particle movable: the tree is rooted at the top either way; the
    // pins are then made in place, as the Bevy layer adds them.)
    solver.organize();
    let mut inverse_mass = solver.particles.inverse_mass.clone();
    for p in pinned.into_iter().chain(root_pinned.then_some(top)) {
        inverse_mass[p as usize] = 0.0;
    }
    (solver, inverse_mass)
}

/// One Gauss–Newton pass (projection, λ = 0 from the current positions): `Δx` per particle
/// and the multipliers after it.
fn pass(solver: &Solver, inverse_mass: &[f64]) -> (Vec<DVec3>, Vec<f64>) {
    let set = solver.islands.lines().trees.clone();
    assert_eq!(set.trees.len(), 1, "solved as a tree");
    let nodes = set.trees[0].nodes.start as usize..set.trees[0].nodes.end as usize;
    let view = TreeView {
        particle: &set.particle[nodes.clone()],
        stick: &set.stick[nodes.clone()],
        parent: &set.parent[nodes],
        offset: set.trees[0].nodes.start,
    };
    let x = solver.particles.position.clone();
    let (mut position, mut previous) = (x.clone(), x.clone());
    let mut lambda = vec![0.0; solver.sticks.len()];
    let mut s = vec![Node::default(); view.particle.len()];
    {
        let (position, previous) = (
            SharedSlice::new(&mut position),
            SharedSlice::new(&mut previous),
        );
        let lambda = SharedSlice::new(&mut lambda);
        let solve = TreeSolve {
            position: &position,
            previous: &previous,
            mirror: None,
            lambda: &lambda,
            inverse_mass,
            sticks: &solver.sticks,
            inv_h2: 4096.0,
            shake: false,
            first_round: true,
        };
        solve.check(&view);
        // SAFETY: this test alone holds the slices, and `check` passed.
        unsafe {
            solve.forward::<false>(&view, &mut s);
            solve.backward(&view, &mut s);
        }
    }
    let dx = position.iter().zip(&x).map(|(p, x)| p - x).collect();
    (dx, lambda)
}

/// With a pin at the end of a branch and one inside another (their sticks to a movable
/// particle eliminated with it, `Node::eliminate_pinned`), with the root pinned or free: the
/// pass's `Δx` and `Δλ` are the dense system's Gauss–Newton step (`kkt::dense` with λ = 0,
/// where the curvature vanishes).
#[test]
fn a_pass_with_pins_below_the_root_is_the_dense_step() {
    for root_pinned in [true, false] {
        let (solver, inverse_mass) = forked(root_pinned);
        let (dx, lambda) = pass(&solver, &inverse_mass);
        let ends: Vec<[usize; 2]> = solver
            .sticks
            .ends()
            .iter()
            .map(|e| e.map(|p| p as usize))
            .collect();
        let sticks = solver.sticks.len();
        // (A stick between two pinned particles is out of the system.)
        let active: Vec<bool> = ends
            .iter()
            .map(|&[a, b]| inverse_mass[a] + inverse_mass[b] > 0.0)
            .collect();
        let (want_dx, want_dl) = kkt::dense::newton_step(&kkt::dense::System {
            x: &solver.particles.position,
            inverse_mass: &inverse_mass,
            ends: &ends,
            lambda: &vec![0.0; sticks],
            rest: &solver.sticks.rest_length,
            compliance: &solver.sticks.compliance,
            active: &active,
            inv_h2: 4096.0,
        });
        let scale = want_dx.iter().map(|d| d.length()).fold(0.0, f64::max);
        assert!(scale > 1e-3, "the pass has something to do");
        for (j, (got, want)) in dx.iter().zip(&want_dx).enumerate() {
            assert!(
                (*got - *want).length() < 1e-6 * scale,
                "root pinned {root_pinned}, particle {j}: Δx {got} against {want}"
            );
        }
        for (k, (got, want)) in lambda.iter().zip(&want_dl).enumerate() {
            assert!(
                (got - want).abs() < 1e-6 * want.abs().max(1.0),
                "root pinned {root_pinned}, stick {k}: Δλ {got} against {want}"
            );
        }
    }
}
