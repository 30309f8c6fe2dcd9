//! Cloth grids.

use super::{Composite, Material, material_methods, spawn_composite};
use bevy::prelude::*;

/// Which top-row particles of a cloth are pinned.
#[derive(Clone, Debug, PartialEq)]
enum Pinning {
    None,
    /// Every `k`-th particle of the top row (verlet-js `pinMod`; 1 = the whole row).
    TopRowEvery(usize),
    /// The two top corners.
    TopCorners,
    /// Explicit `(column, row)` list.
    Cells(Vec<(usize, usize)>),
}

/// Spawns a cloth: a grid of `columns × rows` particles with structural sticks (and optional
/// shear sticks), top-left corner at `origin`, rows going along `down` and columns along `right`.
///
/// Particles are stored row-major: particle `(column, row)` is `particles[row * columns + column]`.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// // The Tuts+ curtain: 61 × 41 particles 6 px apart, top row pinned, tearable.
/// let curtain = ClothBuilder::new(Vec3::new(-180.0, 200.0, 0.0), 61, 41, 6.0)
///     .pin_top_row(1)
///     .tear_strain(2.0)
///     .spawn(&mut world.commands());
/// assert_eq!(curtain.particles.len(), 61 * 41);
/// assert_eq!(curtain.sticks.len(), 60 * 41 + 61 * 40);
/// ```
#[derive(Clone, Debug)]
pub struct ClothBuilder {
    origin: Vec3,
    columns: usize,
    rows: usize,
    spacing: f32,
    right: Vec3,
    down: Vec3,
    pinning: Pinning,
    shear: Option<f32>,
    material: Material,
}

impl ClothBuilder {
    /// A cloth of `columns × rows` particles `spacing` apart in the XY plane (rows going down −Y).
    pub fn new(origin: Vec3, columns: usize, rows: usize, spacing: f32) -> Self {
        Self {
            origin,
            columns: columns.max(1),
            rows: rows.max(1),
            spacing,
            right: Vec3::X,
            down: Vec3::NEG_Y,
            pinning: Pinning::None,
            shear: None,
            material: Material::default(),
        }
    }

    /// Lays the grid along other axes (e.g. `Vec3::X`, `Vec3::Z` for a horizontal 3D cloth).
    pub fn axes(mut self, right: Vec3, down: Vec3) -> Self {
        self.right = right.normalize_or(Vec3::X);
        self.down = down.normalize_or(Vec3::NEG_Y);
        self
    }

    /// Pins every `every`-th particle of the top row (verlet-js `pinMod`; 1 = the whole row).
    pub fn pin_top_row(mut self, every: usize) -> Self {
        self.pinning = Pinning::TopRowEvery(every.max(1));
        self
    }

    /// Pins the two top corners.
    pub fn pin_top_corners(mut self) -> Self {
        self.pinning = Pinning::TopCorners;
        self
    }

    /// Pins the given `(column, row)` cells.
    pub fn pin_cells(mut self, cells: impl IntoIterator<Item = (usize, usize)>) -> Self {
        self.pinning = Pinning::Cells(cells.into_iter().collect());
        self
    }

    /// Adds diagonal (shear) sticks with this compliance (cloth in 3D keeps its shape better).
    pub fn shear(mut self, compliance: f32) -> Self {
        self.shear = Some(compliance);
        self
    }

    material_methods!();

    /// Index of particle `(column, row)` in [`Composite::particles`].
    pub fn index(&self, column: usize, row: usize) -> usize {
        row * self.columns + column
    }

    /// Spawns it.
    pub fn spawn(&self, commands: &mut Commands) -> Composite {
        let (columns, rows) = (self.columns, self.rows);
        let mut points = Vec::with_capacity(columns * rows);
        let mut pinned = Vec::with_capacity(columns * rows);
        for row in 0..rows {
            for column in 0..columns {
                points.push(
                    self.origin
                        + self.right * (column as f32 * self.spacing)
                        + self.down * (row as f32 * self.spacing),
                );
                pinned.push(match &self.pinning {
                    Pinning::None => false,
                    Pinning::TopRowEvery(k) => row == 0 && column % k == 0,
                    Pinning::TopCorners => row == 0 && (column == 0 || column == columns - 1),
                    Pinning::Cells(cells) => cells.contains(&(column, row)),
                });
            }
        }
        let mut sticks = Vec::new();
        for row in 0..rows {
            for column in 0..columns {
                let i = self.index(column, row);
                if column > 0 {
                    sticks.push((i - 1, i));
                }
                if row > 0 {
                    sticks.push((i - columns, i));
                }
            }
        }
        let mut composite =
            spawn_composite(commands, "Cloth", &self.material, &points, &pinned, &sticks);
        if let Some(compliance) = self.shear {
            for row in 1..rows {
                for column in 1..columns {
                    let pairs = [
                        (self.index(column - 1, row - 1), self.index(column, row)),
                        (self.index(column, row - 1), self.index(column - 1, row)),
                    ];
                    for (a, b) in pairs {
                        let mut stick =
                            crate::Stick::new(composite.particles[a], composite.particles[b])
                                .with_compliance(compliance);
                        stick.tear_strain = self.material.tear_strain;
                        let entity = commands.spawn((stick, ChildOf(composite.root))).id();
                        composite.sticks.push(entity);
                    }
                }
            }
            commands.entity(composite.root).insert(composite.clone());
        }
        composite
    }
}
