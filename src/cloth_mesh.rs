//! [`ClothMesh`]: a triangle mesh whose vertices and normals follow a cloth's particles every
//! frame — what a game ships instead of debug lines.

use crate::Particle;
use bevy::asset::RenderAssetUsages;
use bevy::camera::visibility::NoFrustumCulling;
use bevy::math::Affine3A;
use bevy::mesh::{Indices, Mesh, Mesh3d, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;

/// Drives the `Mesh3d` on the same entity from a grid of particles (row-major, as
/// [`ClothBuilder`](crate::ClothBuilder) spawns them). Create the mesh with
/// [`ClothMesh::mesh`]. The mesh moves every frame, so the entity gets `NoFrustumCulling`
/// (its bounding box would otherwise be the one computed at spawn).
///
/// ```
/// use bevy::prelude::*;
/// use bevy_verlet_physics::prelude::*;
/// let mut world = World::new();
/// let cloth = ClothBuilder::new(Vec3::ZERO, 3, 2, 0.1).spawn(&mut world.commands());
/// world.flush();
/// let cloth_mesh = ClothMesh::new(3, 2, cloth.particles.clone());
/// let mesh = cloth_mesh.mesh();
/// assert_eq!(mesh.count_vertices(), 6);
/// ```
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Debug)]
#[require(NoFrustumCulling)]
pub struct ClothMesh {
    /// Particles per row.
    pub columns: usize,
    /// Rows.
    pub rows: usize,
    /// Particle entities, row-major.
    pub particles: Vec<Entity>,
}

impl ClothMesh {
    /// A cloth mesh over `columns × rows` particles.
    pub fn new(columns: usize, rows: usize, particles: Vec<Entity>) -> Self {
        Self {
            columns,
            rows,
            particles,
        }
    }

    /// A mesh with the grid's triangles and UVs (positions are filled in every frame).
    pub fn mesh(&self) -> Mesh {
        let (c, r) = (self.columns, self.rows);
        let mut uvs = Vec::with_capacity(c * r);
        for row in 0..r {
            for column in 0..c {
                uvs.push([
                    column as f32 / (c.max(2) - 1) as f32,
                    row as f32 / (r.max(2) - 1) as f32,
                ]);
            }
        }
        let mut indices = Vec::with_capacity(c.saturating_sub(1) * r.saturating_sub(1) * 6);
        for row in 1..r {
            for column in 1..c {
                let i = |col: usize, row: usize| (row * c + col) as u32;
                let (a, b, cc, d) = (
                    i(column - 1, row - 1),
                    i(column, row - 1),
                    i(column - 1, row),
                    i(column, row),
                );
                indices.extend_from_slice(&[a, cc, b, b, cc, d]);
            }
        }
        Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::MAIN_WORLD | RenderAssetUsages::RENDER_WORLD,
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32; 3]; c * r])
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, vec![[0.0f32, 0.0, 1.0]; c * r])
        .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
        .with_inserted_indices(Indices::U32(indices))
    }
}

/// Adds the per-frame mesh update (part of [`VerletDebugPlugin`](crate::VerletDebugPlugin)'s
/// crate feature, `gizmos`).
pub(crate) fn plugin(app: &mut App) {
    app.register_type::<ClothMesh>()
        .add_systems(PostUpdate, update_cloth_meshes);
}

fn update_cloth_meshes(
    time: Res<Time<Fixed>>,
    config: Res<crate::VerletConfig>,
    cloths: Query<(&ClothMesh, &Mesh3d, Option<&GlobalTransform>)>,
    particles: Query<&Particle>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut positions: Local<Vec<[f32; 3]>>,
    mut normals: Local<Vec<[f32; 3]>>,
) {
    let (positions, normals) = (&mut *positions, &mut *normals);
    let fraction = config.render_fraction(&time);
    for (cloth, mesh, transform) in &cloths {
        // Particles are in world space; undo the mesh entity's own transform.
        let to_local = transform.map_or(Affine3A::IDENTITY, |t| t.affine().inverse());
        positions.clear();
        let mut last = Vec3::ZERO;
        for &entity in &cloth.particles {
            // A particle that is gone (despawned) keeps its last vertex position.
            if let Ok(p) = particles.get(entity) {
                last = to_local.transform_point3(p.interpolated(fraction));
            }
            positions.push(last.to_array());
        }
        let Some(mut mesh) = meshes.get_mut(&mesh.0) else {
            continue;
        };
        if mesh.count_vertices() != positions.len() {
            continue;
        }
        grid_normals(cloth.columns, cloth.rows, positions, normals);
        // Overwrite positions and normals in place (no per-frame allocation).
        for (attribute, values) in [
            (Mesh::ATTRIBUTE_POSITION, &*positions),
            (Mesh::ATTRIBUTE_NORMAL, &*normals),
        ] {
            match mesh.try_attribute_mut(attribute) {
                Ok(VertexAttributeValues::Float32x3(old)) if old.len() == values.len() => {
                    old.copy_from_slice(values);
                }
                _ => mesh.insert_attribute(attribute, values.clone()),
            }
        }
    }
}

/// Smooth vertex normals of a row-major `columns × rows` grid mesh (the triangles of
/// [`ClothMesh::mesh`]): the area-weighted sum of the adjacent triangles' normals, normalized.
/// Writes into `normals`, reusing its allocation.
fn grid_normals(columns: usize, rows: usize, positions: &[[f32; 3]], normals: &mut Vec<[f32; 3]>) {
    normals.clear();
    normals.resize(positions.len(), [0.0; 3]);
    if positions.len() != columns * rows {
        return;
    }
    let at = |i: usize| Vec3::from_array(positions[i]);
    let mut add = |i: usize, n: Vec3| {
        normals[i] = (Vec3::from_array(normals[i]) + n).to_array();
    };
    for row in 1..rows {
        for column in 1..columns {
            let a = (row - 1) * columns + column - 1;
            let (b, c, d) = (a + 1, a + columns, a + columns + 1);
            // The same two triangles as the mesh's indices: (a, c, b) and (b, c, d).
            for [p, q, r] in [[a, c, b], [b, c, d]] {
                let n = (at(q) - at(p)).cross(at(r) - at(p)); // |n| = 2 × area
                add(p, n);
                add(q, n);
                add(r, n);
            }
        }
    }
    for n in normals.iter_mut() {
        *n = Vec3::from_array(*n).normalize_or(Vec3::Z).to_array();
    }
}
