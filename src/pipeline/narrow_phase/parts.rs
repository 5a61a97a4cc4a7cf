//! Compound pairs: a pair with a body made of child colliders (see
//! [`CompoundParts`](crate::collision::parts::CompoundParts)) is sorted out collider by
//! collider, each manifold belonging to one subshape of each body and so to one collider of
//! each: its rows take that pair of colliders' material, a sensor's manifold only detects, and
//! one between colliders whose layers do not interact is left out.

use bevy::prelude::*;

use crate::collision::narrow_phase::ContactPair;
use crate::collision::parts::PartContact;

use super::super::PhysicsState;

/// For each manifold of a compound pair: what its contact does, and its colliders `(on a, on
/// b)`.
pub(super) type ManifoldParts = Vec<ManifoldPart>;

/// What the contact of one manifold of a compound pair does, and its colliders `(on a, on b)`.
pub(super) type ManifoldPart = (PartContact, Entity, Entity);

/// What each manifold of `pair` (bodies `ia` and `ib`) does, with its colliders.
pub(super) fn manifold_parts(
    state: &PhysicsState,
    (ia, ib): (usize, usize),
    pair: &ContactPair,
) -> ManifoldParts {
    pair.manifolds
        .iter()
        .map(|m| {
            let (a, b) = (
                state.part_of(ia, m.subshape1),
                state.part_of(ib, m.subshape2),
            );
            (a.contact(&b), a.collider, b.collider)
        })
        .collect()
}

/// Empties the points of `pair`'s manifolds on a sensor collider, so that parry computes them
/// afresh rather than moving the ones it has: a sensor's manifold overlaps deeply, where
/// parry's coherence keeps stale features (see [`ContactPair::reset`]). The manifolds stay
/// (parry's workspace refers to them by index); their points carry no impulse.
pub(super) fn forget_sensor_points(
    state: &PhysicsState,
    (ia, ib): (usize, usize),
    pair: &mut ContactPair,
) {
    for m in pair.manifolds.iter_mut() {
        let (a, b) = (
            state.part_of(ia, m.subshape1),
            state.part_of(ib, m.subshape2),
        );
        if a.contact(&b) == PartContact::Sensor {
            m.points.clear();
        }
    }
}

/// Whether body `k` has colliders that pair differently with another body (a sensor among
/// them, or layers that differ).
pub(in crate::pipeline) fn mixed(state: &PhysicsState, k: usize) -> bool {
    state.parts[k].as_ref().is_some_and(|p| !p.plain())
}
