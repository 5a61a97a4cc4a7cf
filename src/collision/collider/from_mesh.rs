//! The constructors from a Bevy `Mesh` (feature `mesh`).

use bevy::mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;

use super::Collider;

impl Collider {
    /// A static triangle mesh ([`trimesh`](Self::trimesh)) from a Bevy `Mesh`'s positions
    /// and triangles (feature `mesh`). Unlike avian3d, which returns an `Option`, a mesh
    /// that cannot be read (not a triangle list, no `Float32x3` positions) gives a collider
    /// that carries the error, as every other constructor here.
    pub fn trimesh_from_mesh(mesh: &Mesh) -> Self {
        match mesh_triangles(mesh) {
            Ok((vertices, indices)) => Self::trimesh(vertices, indices),
            Err(error) => Self::invalid(error),
        }
    }

    /// The convex hull of a Bevy `Mesh`'s vertex positions ([`convex_hull`](Self::convex_hull);
    /// feature `mesh`); a mesh that cannot be read or whose hull is degenerate gives a
    /// collider that carries the error.
    pub fn convex_hull_from_mesh(mesh: &Mesh) -> Self {
        match mesh_triangles(mesh) {
            Ok((vertices, _)) => Self::convex_hull(&vertices).unwrap_or_else(|| {
                Self::invalid(
                    "mesh's convex hull is degenerate or a vertex is not finite or too far"
                        .to_string(),
                )
            }),
            Err(error) => Self::invalid(error),
        }
    }

    /// A compound of convex parts from a Bevy `Mesh`
    /// ([`convex_decomposition`](Self::convex_decomposition); feature `mesh`).
    pub fn convex_decomposition_from_mesh(mesh: &Mesh) -> Self {
        match mesh_triangles(mesh) {
            Ok((vertices, indices)) => Self::convex_decomposition(vertices, indices),
            Err(error) => Self::invalid(error),
        }
    }
}

/// The positions and triangles of a triangle-list `mesh` (without indices, every three
/// vertices are a triangle).
fn mesh_triangles(mesh: &Mesh) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), String> {
    if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
        return Err(format!(
            "mesh topology is {:?}, not a triangle list",
            mesh.primitive_topology()
        ));
    }
    let unreadable = |e| format!("mesh data cannot be read here: {e}");
    let vertices: Vec<Vec3> = match mesh
        .try_attribute_option(Mesh::ATTRIBUTE_POSITION)
        .map_err(unreadable)?
    {
        Some(VertexAttributeValues::Float32x3(positions)) => {
            positions.iter().map(|&p| Vec3::from_array(p)).collect()
        }
        Some(_) => return Err("mesh positions are not Float32x3".to_string()),
        None => return Err("mesh has no positions".to_string()),
    };
    let flat: Vec<u32> = match mesh.try_indices_option().map_err(unreadable)? {
        Some(Indices::U16(i)) => i.iter().map(|&i| i as u32).collect(),
        Some(Indices::U32(i)) => i.clone(),
        None => (0..vertices.len() as u32).collect(),
    };
    let indices = flat.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    Ok((vertices, indices))
}
