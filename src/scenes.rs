//! The examples' scenes, as library functions, so a game or a headless test can spawn exactly
//! what an example shows.
//!
//! 2D scenes are in pixels with the origin at the centre of a 1280 × 720 window and Y up (use
//! them with [`Gravity::PIXELS`](crate::Gravity::PIXELS)); the 3D scene is in metres.

use crate::builders::{ClothBuilder, Composite, RagdollBuilder, RopeBuilder, StructureBuilder};
use crate::{AngleConstraint, Particle, Pin, Stick, Stiffness, VerletCollider};
use bevy::prelude::*;

/// Half the example window (1280 × 720).
pub const HALF_WINDOW: Vec2 = Vec2::new(640.0, 360.0);

/// Floor of the 2D scenes: 60 px above the window's bottom edge, leaving a strip for the
/// examples' status line.
pub const FLOOR_Y: f32 = -300.0;

/// The window rectangle (down to [`FLOOR_Y`]) as a bounds collider (the seeds'
/// `constrain(stageRect)`).
pub fn window_bounds(restitution: f32, friction: f32) -> VerletCollider {
    VerletCollider::bounds_2d(Vec2::new(-HALF_WINDOW.x, FLOOR_Y), HALF_WINDOW)
        .with_restitution(restitution)
        .with_friction(friction)
}

/// verlet-js stiffness `k` (applied 16 times per 60 Hz frame with `stepCoef = 1/16`, each pass
/// removing `4·k/16` of a stick's error) as a [`Stiffness::Seed`].
pub fn verlet_js_stiffness(k: f32) -> Stiffness {
    Stiffness::Seed {
        stiffness: (k / 4.0).min(1.0),
        iterations: 16,
        timestep: 1.0 / 60.0,
    }
}

/// Columns, rows and spacing of the [`curtain`].
pub const CURTAIN: (usize, usize, f32) = (100, 60, 7.0);

/// The Tuts+ "Curtain": a tearable cloth of [`CURTAIN`] particles (the seed's 61 × 41 at 6 px,
/// larger), top row pinned, tethered so it does not sag, tearing at 150 % strain.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::scenes;
/// let mut world = World::new();
/// let curtain = scenes::curtain(&mut world.commands());
/// assert_eq!(curtain.particles.len(), 6000);
/// ```
pub fn curtain(commands: &mut Commands) -> Composite {
    let (columns, rows, spacing) = CURTAIN;
    let width = (columns - 1) as f32 * spacing;
    ClothBuilder::new(Vec3::new(-width / 2.0, 250.0, 0.0), columns, rows, spacing)
        .pin_top_row(1)
        .tear_strain(1.5)
        .tethers(true)
        .spawn(commands)
}

/// Ragdoll height (feet to shoulders) in the ragdoll scene.
pub const RAGDOLL_HEIGHT: f32 = 110.0;

/// The Tuts+ ragdolls: `count` ragdolls standing across the window, with a floor and walls
/// (friction 0.6). Returns the ragdolls.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::scenes;
/// let mut world = World::new();
/// let dolls = scenes::ragdolls(&mut world.commands(), 3);
/// assert_eq!(dolls.len(), 3);
/// ```
pub fn ragdolls(commands: &mut Commands, count: usize) -> Vec<Composite> {
    commands.spawn((Name::new("Walls"), window_bounds(0.0, 0.6)));
    (0..count)
        .map(|i| {
            let x = -500.0 + 1000.0 * (i as f32 + 0.5) / count.max(1) as f32;
            // Start in the air, slightly leaning, so they fall and tumble.
            spawn_ragdoll(
                commands,
                Vec3::new(x, -100.0 + 40.0 * (i % 3) as f32, 0.0),
                i % 2 == 1,
            )
        })
        .collect()
}

/// One ragdoll of the ragdoll scene with its feet at `feet`.
pub fn spawn_ragdoll(commands: &mut Commands, feet: Vec3, mirrored: bool) -> Composite {
    let builder = RagdollBuilder::new(feet, RAGDOLL_HEIGHT).mirrored(mirrored);
    #[cfg(feature = "gizmos")]
    let builder = builder.color(Color::hsl((feet.x * 0.37).rem_euclid(360.0), 0.7, 0.7));
    builder.spawn(commands)
}

/// Per-pass stiffness of the AS3 structures scene (the seed's sticks are 1; 0.3 makes the
/// iteration count visible).
pub const STRUCTURE_STIFFNESS: f32 = 0.3;

/// The two halves of [`structures`].
#[derive(Clone, Debug)]
pub struct StructuresScene {
    /// Left half: sticks whose stiffness the example re-derives from the iteration count, as in
    /// the AS3 code (see [`per_pass_stiffness`]).
    pub per_pass: Vec<Composite>,
    /// Right half: the same material as one fixed compliance.
    pub compliant: Vec<Composite>,
}

/// The stiffness a stick gets in seed-style code that removes `stiffness` of its error per
/// pass, `iterations` passes per step of `timestep`: stiffer with every extra pass.
pub fn per_pass_stiffness(stiffness: f32, iterations: u32, timestep: f32) -> Stiffness {
    Stiffness::Seed {
        stiffness,
        iterations,
        timestep,
    }
}

/// The AS3 chapter's structures, twice: a triangle, a square that collapses, a square with a
/// diagonal brace, and the hinge (triangle base, arm, weight), kept inside the window with
/// bounce. Both halves start as the same material ([`STRUCTURE_STIFFNESS`] per pass at one
/// pass per 1/64 s step); the `structures` example re-derives the left half's stiffness from
/// the iteration count as the seed would, while the right half keeps its compliance.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::scenes;
/// let mut world = World::new();
/// let scene = scenes::structures(&mut world.commands());
/// assert_eq!((scene.per_pass.len(), scene.compliant.len()), (4, 4));
/// ```
pub fn structures(commands: &mut Commands) -> StructuresScene {
    commands.spawn((Name::new("Window"), window_bounds(0.3, 0.5)));
    let material = per_pass_stiffness(STRUCTURE_STIFFNESS, 1, 1.0 / 64.0);
    StructuresScene {
        per_pass: structure_set(commands, -630.0, material),
        compliant: structure_set(commands, 10.0, material),
    }
}

/// One half of [`structures`], starting at `left` (pixels).
fn structure_set(commands: &mut Commands, left: f32, stiffness: Stiffness) -> Vec<Composite> {
    // The hinge's base is twice as wide as its arm is long (the seed's spans the stage), so
    // the swinging weight cannot tip it over.
    [
        StructureBuilder::triangle(Vec3::new(left + 60.0, 150.0, 0.0), 80.0),
        StructureBuilder::square(Vec3::new(left + 160.0, 180.0, 0.0), 70.0),
        StructureBuilder::braced_square(Vec3::new(left + 260.0, 120.0, 0.0), 70.0),
        StructureBuilder::hinge(Vec3::new(left + 470.0, FLOOR_Y, 0.0), 280.0, 260.0, 130.0),
    ]
    .into_iter()
    .map(|builder| builder.stiffness(stiffness).spawn(commands))
    .collect()
}

/// The verlet-js "shapes" demo: tires of different stiffness, a slack bridge of line segments
/// pinned at both ends, and a tree held by angle constraints. Returns `[tires…, bridge, tree]`.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::scenes;
/// let mut world = World::new();
/// assert_eq!(scenes::shapes(&mut world.commands()).len(), 5);
/// ```
pub fn shapes(commands: &mut Commands) -> Vec<Composite> {
    commands.spawn((Name::new("Window"), window_bounds(0.0, 0.3)));
    let mut shapes = vec![
        // verlet-js: tire(r 50, 30 seg, 0.3, 0.9), (r 70, 7 seg, 0.1, 0.2), (r 70, 3 seg, 1, 1).
        tire(commands, Vec3::new(-420.0, 150.0, 0.0), 50.0, 30, 0.3, 0.9),
        tire(commands, Vec3::new(-220.0, 200.0, 0.0), 70.0, 7, 0.1, 0.2),
        tire(commands, Vec3::new(-30.0, 250.0, 0.0), 70.0, 3, 1.0, 1.0),
    ];
    // A slack bridge of line segments pinned at both ends: 20 rigid links with 10 % slack
    // (verlet-js uses a very soft stiffness, 0.02, for the same sag). It is spawned already
    // slack, as a V of two 10-link arms, so no link starts compressed.
    let (left, span, link) = (Vec2::new(-560.0, -120.0), 480.0_f32, 480.0 / 20.0 * 1.1);
    let depth = ((10.0 * link) * (10.0 * link) - (span / 2.0) * (span / 2.0)).sqrt();
    let bridge = RopeBuilder::along((0..=20).map(|i| {
        let arm = 1.0 - (i as f32 - 10.0).abs() / 10.0; // 0 at the pins, 1 in the middle
        (left + Vec2::new(span * i as f32 / 20.0, -depth * arm)).extend(0.0)
    }))
    .pin_start()
    .pin_end()
    .spawn(commands);
    shapes.push(bridge);
    shapes.push(tree(
        commands,
        Vec3::new(350.0, FLOOR_Y + 45.0, 0.0),
        5,
        105.0,
    ));
    shapes
}

/// Mass of a lantern in [`lanterns`], in link masses.
///
/// ```
/// assert!(bevy_verlet_physics::scenes::LANTERN_MASS > 10.0);
/// ```
pub const LANTERN_MASS: f32 = 100.0;

/// Ropes hung from several posts, with heavy lanterns ([`LANTERN_MASS`] times a link) on strings:
/// a rope across three posts with four lanterns between them, and a chandelier — a knot held by
/// ropes from three posts, a lantern below it. Both are trees held by three pins, which the
/// solver splits at its pins and closes once per pin (`solver::tree`): exact at any mass
/// ratio. Returns `[rope, chandelier]`, each composite's first three particles its posts.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::scenes;
/// let mut world = World::new();
/// assert_eq!(scenes::lanterns(&mut world.commands()).len(), 2);
/// ```
pub fn lanterns(commands: &mut Commands) -> Vec<Composite> {
    commands.spawn((Name::new("Window"), window_bounds(0.0, 0.3)));
    // The rope across three posts: two sagging spans, a lantern on a string from 3/16 and 7/16
    // of the way along each.
    let mut points = vec![
        Vec3::new(-560.0, 200.0, 0.0),
        Vec3::new(-150.0, 230.0, 0.0),
        Vec3::new(250.0, 200.0, 0.0),
    ];
    let mut sticks = Vec::new();
    let mut hangers = Vec::new();
    for (from, to) in [(0, 1), (1, 2)] {
        let span = sag(&mut points, &mut sticks, [from, to], 16, 0.15);
        hangers.extend([span[3], span[7]]);
    }
    let lanterns: Vec<usize> = hangers
        .into_iter()
        .map(|top| hang(&mut points, &mut sticks, top, 5))
        .collect();
    let mut rope = StructureBuilder::new(points);
    for (a, b) in sticks {
        rope = rope.stick(a, b);
    }
    let rope = [0, 1, 2].into_iter().fold(rope, |rope, i| rope.pin(i));
    let rope = rope.spawn(commands);
    let rope = weigh_lanterns(commands, rope, &lanterns, "Lantern rope");
    // The chandelier: a knot held by three sagging ropes from three posts, a lantern below.
    let mut points = vec![
        Vec3::new(350.0, 230.0, 0.0),
        Vec3::new(600.0, 230.0, 0.0),
        Vec3::new(470.0, 300.0, 0.0),
        Vec3::new(470.0, 80.0, 0.0),
    ];
    let mut sticks = Vec::new();
    for post in 0..3 {
        sag(&mut points, &mut sticks, [post, 3], 8, 0.1);
    }
    let lantern = hang(&mut points, &mut sticks, 3, 6);
    let mut chandelier = StructureBuilder::new(points);
    for (a, b) in sticks {
        chandelier = chandelier.stick(a, b);
    }
    let chandelier = [0, 1, 2].into_iter().fold(chandelier, |c, i| c.pin(i));
    let chandelier = chandelier.spawn(commands);
    let chandelier = weigh_lanterns(commands, chandelier, &[lantern], "Chandelier");
    vec![rope, chandelier]
}

/// Appends the points of a rope of `links` (even) equal links sagging in a V from point
/// `ends[0]` to point `ends[1]`, `slack` longer than the straight line, and its sticks; returns
/// the indices of the rope's points from end to end.
fn sag(
    points: &mut Vec<Vec3>,
    sticks: &mut Vec<(usize, usize)>,
    ends: [usize; 2],
    links: usize,
    slack: f32,
) -> Vec<usize> {
    let [a, b] = ends.map(|i| points[i]);
    let half = (b - a).length() / 2.0;
    let depth = ((half * (1.0 + slack)).powi(2) - half * half).sqrt();
    let across = (b - a).normalize_or_zero();
    let down = Vec3::new(across.y, -across.x, 0.0) * if across.x >= 0.0 { 1.0 } else { -1.0 };
    let apex = (a + b) / 2.0 + down * depth;
    let mut path = vec![ends[0]];
    for i in 1..links {
        let t = i as f32 / links as f32 * 2.0;
        let at = if t <= 1.0 {
            a.lerp(apex, t)
        } else {
            apex.lerp(b, t - 1.0)
        };
        points.push(at);
        path.push(points.len() - 1);
    }
    path.push(ends[1]);
    sticks.extend(path.windows(2).map(|pair| (pair[0], pair[1])));
    path
}

/// Appends a string of `links` 18 px links straight down from point `top` and its sticks;
/// returns the index of its bottom point (the lantern).
fn hang(
    points: &mut Vec<Vec3>,
    sticks: &mut Vec<(usize, usize)>,
    top: usize,
    links: usize,
) -> usize {
    let mut above = top;
    for _ in 0..links {
        points.push(points[above] - Vec3::Y * 18.0);
        sticks.push((above, points.len() - 1));
        above = points.len() - 1;
    }
    above
}

/// Makes the particles at `lanterns` (indices into `composite.particles`) [`LANTERN_MASS`]
/// times heavier than the others and 12 px round, and names the composite.
fn weigh_lanterns(
    commands: &mut Commands,
    composite: Composite,
    lanterns: &[usize],
    name: &'static str,
) -> Composite {
    commands.entity(composite.root).insert(Name::new(name));
    for &i in lanterns {
        let lantern = composite.particles[i];
        commands
            .entity(lantern)
            .entry::<Particle>()
            .and_modify(|mut particle| {
                particle.inverse_mass /= LANTERN_MASS;
                particle.radius = 12.0; // (drawn as a circle)
            });
    }
    composite
}

/// verlet-js `tire`: a ring of `segments` particles around a centre, tread sticks between
/// neighbours and to the particle 5 ahead, spokes to the centre, with verlet-js stiffnesses.
pub fn tire(
    commands: &mut Commands,
    center: Vec3,
    radius: f32,
    segments: usize,
    spoke_stiffness: f32,
    tread_stiffness: f32,
) -> Composite {
    let mut points: Vec<Vec3> = (0..segments)
        .map(|i| {
            let theta = i as f32 / segments as f32 * std::f32::consts::TAU;
            center + Vec3::new(theta.cos(), theta.sin(), 0.0) * radius
        })
        .collect();
    points.push(center);
    let mut builder = StructureBuilder::new(points).stiffness(verlet_js_stiffness(tread_stiffness));
    for i in 0..segments {
        builder = builder.stick(i, (i + 1) % segments);
        if segments > 5 {
            builder = builder.stick(i, (i + 5) % segments);
        }
    }
    let mut tire = builder.spawn(commands);
    for i in 0..segments {
        let spoke = Stick::new(tire.particles[i], tire.particles[segments])
            .with_stiffness(verlet_js_stiffness(spoke_stiffness));
        let entity = commands.spawn((spoke, ChildOf(tire.root))).id();
        tire.sticks.push(entity);
    }
    commands.entity(tire.root).insert(tire.clone());
    tire
}

/// A tree of `depth` levels grown from `base` (verlet-js tree demo): each branch is a stick,
/// held at ±30° from its parent by an angle constraint whose compliance grows towards the tips
/// (stiff trunk, floppy twigs). The trunk's two base particles are pinned.
pub fn tree(commands: &mut Commands, base: Vec3, depth: usize, trunk: f32) -> Composite {
    let root = commands.spawn(Name::new("Tree")).id();
    let mut composite = Composite {
        root,
        particles: Vec::new(),
        sticks: Vec::new(),
        angles: Vec::new(),
    };
    let particle = |commands: &mut Commands, composite: &mut Composite, p: Vec3, pinned: bool| {
        let mut e = commands.spawn((Particle::new(p), ChildOf(root)));
        if pinned {
            e.insert(Pin::at(p));
        }
        composite.particles.push(e.id());
        e.id()
    };
    let below = particle(
        commands,
        &mut composite,
        base - Vec3::new(0.0, trunk * 0.3, 0.0),
        true,
    );
    let bottom = particle(commands, &mut composite, base, true);
    // Breadth-first: (parent particle, its parent, position, direction angle, length, level).
    let mut stack = vec![(
        bottom,
        below,
        base,
        std::f32::consts::FRAC_PI_2,
        trunk,
        0usize,
    )];
    while let Some((start, previous, at, angle, length, level)) = stack.pop() {
        let end_pos = at + Vec3::new(angle.cos(), angle.sin(), 0.0) * length;
        let end = particle(commands, &mut composite, end_pos, false);
        let stick = commands.spawn((Stick::new(start, end), ChildOf(root))).id();
        composite.sticks.push(stick);
        // Stiffer near the trunk: compliance grows 4× per level (in pixel units a twig's
        // torque is ~3·10⁴, so the tips bend by ~10⁻² rad and sway when touched).
        let compliance = 1e-9 * 4f32.powi(level as i32);
        let angle_constraint =
            AngleConstraint::new(previous, start, end).with_compliance(compliance);
        composite
            .angles
            .push(commands.spawn((angle_constraint, ChildOf(root))).id());
        if level + 1 < depth {
            for turn in [-std::f32::consts::FRAC_PI_6, std::f32::consts::FRAC_PI_6] {
                stack.push((end, start, end_pos, angle + turn, length * 0.7, level + 1));
            }
        }
    }
    commands.entity(root).insert(composite.clone());
    composite
}

/// Columns and rows of the 3D cloth.
pub const CLOTH_3D: (usize, usize, f32) = (40, 40, 0.05);

/// The 3D cloth: [`CLOTH_3D`] particles (2 m square) lying horizontally 1.6 m up, pinned at two
/// corners and tethered to both, above a sphere of radius 0.5 m on the ground. Returns the
/// cloth.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::scenes;
/// let mut world = World::new();
/// let cloth = scenes::cloth_3d(&mut world.commands());
/// assert_eq!(cloth.particles.len(), 1600);
/// ```
pub fn cloth_3d(commands: &mut Commands) -> Composite {
    let (columns, rows, spacing) = CLOTH_3D;
    let size = (columns - 1) as f32 * spacing;
    commands.spawn((
        Name::new("Sphere"),
        VerletCollider::sphere(0.5).with_friction(0.3),
        Transform::from_xyz(0.0, 0.5, 0.0),
    ));
    commands.spawn((
        Name::new("Ground"),
        VerletCollider::ground(0.0).with_friction(0.5),
    ));
    ClothBuilder::new(
        Vec3::new(-size / 2.0, 1.6, -size / 2.0),
        columns,
        rows,
        spacing,
    )
    .axes(Vec3::X, Vec3::Z)
    .pin_top_corners()
    .shear(1e-4)
    .tethers(true)
    .radius(0.01)
    .spawn(commands)
}
