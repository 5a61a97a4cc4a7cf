//! A half-space's manifold with a polyhedral shape, without parry's allocation.
//!
//! parry 0.27's `contact_manifold_halfspace_pfm` moves the manifold's points out
//! (`mem::take`) to match the new points against them, so the manifold's vector is allocated
//! anew at every call: a box resting on a half-space ground allocated once a step. This is the
//! same computation, operation for operation, with the old points kept on the stack (a
//! polygonal feature has at most 4 vertices, so a manifold this function made has at most 4
//! points).

use parry3d::math::{Pose, Vector};
use parry3d::query::{ContactManifold, TrackedContact};
use parry3d::shape::{PackedFeatureId, PolygonalFeature, Shape, ShapeType};

use super::{ContactImpulse, Manifold};

/// Most points of a half-space manifold: the vertices of a polygonal feature.
const MAX_POINTS: usize = 4;

/// The manifolds of a half-space and a polyhedral shape (either way round) into `manifolds`,
/// as parry's dispatcher computes them; `false` (nothing done) for any other pair of shapes,
/// or a manifold with more points than a half-space manifold has (left to parry).
pub(super) fn halfspace_manifold(
    pos12: &Pose,
    shape1: &dyn Shape,
    shape2: &dyn Shape,
    prediction: f32,
    manifolds: &mut Vec<Manifold>,
) -> bool {
    // The dispatcher's order: balls, trimeshes, height fields, voxels and composite shapes are
    // matched before the half-space arms.
    let other = |s: &dyn Shape| {
        !matches!(
            s.shape_type(),
            ShapeType::Ball
                | ShapeType::TriMesh
                | ShapeType::HeightField
                | ShapeType::Voxels
                | ShapeType::HalfSpace
        ) && s.as_composite_shape().is_none()
    };
    let flipped = match (shape1.shape_type(), shape2.shape_type()) {
        (ShapeType::HalfSpace, _) if other(shape2) => false,
        (_, ShapeType::HalfSpace) if other(shape1) => true,
        _ => return false,
    };
    let (half, convex, pos) = if flipped {
        (shape2, shape1, pos12.inverse())
    } else {
        (shape1, shape2, *pos12)
    };
    let (Some(halfspace), Some((pfm, border))) =
        (half.as_halfspace(), convex.as_polygonal_feature_map())
    else {
        return false;
    };
    if manifolds.len() > 1
        || manifolds
            .first()
            .is_some_and(|m| m.points.len() > MAX_POINTS)
    {
        return false;
    }
    if manifolds.is_empty() {
        manifolds.push(ContactManifold::new());
    }
    let manifold = &mut manifolds[0];
    let normal1_2 = pos.rotation.inverse() * halfspace.normal;
    let mut feature = PolygonalFeature::default();
    pfm.local_support_feature(-normal1_2, &mut feature);
    let unused = TrackedContact::<ContactImpulse>::new(
        Vector::ZERO,
        Vector::ZERO,
        PackedFeatureId::UNKNOWN,
        PackedFeatureId::UNKNOWN,
        0.0,
    );
    let mut old = [unused; MAX_POINTS];
    let count = manifold.points.len();
    old[..count].copy_from_slice(&manifold.points);
    manifold.points.clear();
    for i in 0..feature.num_vertices {
        let vertex = feature.vertices[i];
        let vertex1 = pos * vertex;
        let distance = vertex1.dot(halfspace.normal);
        if distance - border <= prediction {
            manifold.points.push(TrackedContact::flipped(
                vertex1 - halfspace.normal * distance,
                vertex - normal1_2 * border,
                PackedFeatureId::face(0),
                feature.vids[i],
                distance - border,
                flipped,
            ));
        }
    }
    if flipped {
        manifold.local_n1 = -normal1_2;
        manifold.local_n2 = halfspace.normal;
    } else {
        manifold.local_n1 = halfspace.normal;
        manifold.local_n2 = -normal1_2;
    }
    manifold.match_contacts(&old[..count]);
    true
}
