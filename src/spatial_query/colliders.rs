//! The world spatial queries see: every body's collider at its pose at the end of the last
//! physics step, found through the broad phase's tree.

use std::cell::Cell;
use std::sync::Arc;

use bevy::prelude::*;
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::math::Pose;
use parry3d::partitioning::TraversalAction;
use parry3d::shape::SharedShape;

use crate::collision::parts::CompoundParts;
use crate::collision::{BroadPhaseTree, CollisionLayers};
use crate::dynamics::solver::Motion;
use crate::pipeline::PhysicsState;

/// One body's collider as queries see it: the shape the step collided with, at the body's pose
/// at the end of the step. A body with colliders on child entities has one record for the
/// body (its compound shape, for the walk of the tree) holding one record for each collider
/// ([`QueryCollider::parts`]), which are the ones queries test and report.
#[derive(Clone)]
pub(crate) struct QueryCollider {
    /// The collider: the body itself, or for a part of a body with child colliders, the child
    /// collider's entity.
    pub entity: Entity,
    /// The body the collider belongs to (the same as `entity` for a body's own collider).
    pub body: Entity,
    /// Its collider's shape, in metres (the one the step used; the narrow phase works on a copy
    /// scaled to the length unit by a power of two, which is the same geometry).
    pub shape: SharedShape,
    /// The body's origin at the end of the step: the pose its `Transform` was given, with the
    /// rotation normalised as the next step reads it.
    pub pose: Pose,
    /// The box of `shape` at `pose` (parry's `compute_aabb`).
    pub aabb: Aabb,
    /// The body's collision layers in the step.
    pub layers: CollisionLayers,
    /// It can be hit: its collider is not disabled and its pose is finite.
    pub hittable: bool,
    /// The step (of [`SpatialQueryColliders`]'s count) this record was last written in.
    step: u32,
    /// `aabb` is not inside the box of its leaf in the tree (the body moved out of the box the
    /// broad phase gave it): it is tested directly, not through the tree.
    straggler: bool,
    /// For a body with child colliders: one record for each subshape of its compound shape,
    /// with the pose, box, entity and layers of the collider it belongs to. Queries test these
    /// in place of the body's record. Empty for any other body.
    parts: Vec<QueryCollider>,
}

impl QueryCollider {
    /// Calls `visit` with this record, or, for a body with child colliders, with each of its
    /// colliders' records whose box passes `enter` (this record's box has passed it already).
    fn visit_colliders(&self, mut enter: impl FnMut(&Aabb) -> bool, mut visit: impl FnMut(&Self)) {
        if self.parts.is_empty() {
            visit(self);
            return;
        }
        for part in &self.parts {
            if enter(&part.aabb) {
                visit(part);
            }
        }
    }

    /// The records of a body's colliders (see [`QueryCollider::parts`]): `body` is the record
    /// of the body as a whole (its shape the compound of its colliders), and `parts` says which
    /// collider each subshape belongs to.
    fn colliders_of(body: &QueryCollider, parts: &CompoundParts) -> Vec<QueryCollider> {
        let Some(compound) = body.shape.as_compound() else {
            return Vec::new();
        };
        compound
            .shapes()
            .iter()
            .enumerate()
            .map(|(k, (local, shape))| {
                let part = parts.of_subshape(k as u32);
                let pose = body.pose * *local;
                let aabb = if body.hittable {
                    shape.compute_aabb(&pose)
                } else {
                    body.aabb
                };
                QueryCollider {
                    entity: part.collider,
                    body: body.entity,
                    shape: shape.clone(),
                    pose,
                    aabb,
                    layers: part.layers,
                    hittable: body.hittable,
                    step: body.step,
                    straggler: false,
                    parts: Vec::new(),
                }
            })
            .collect()
    }
}

/// How far a box is widened for the candidate tests, m: 1e-5 of its largest coordinate (about
/// 80 ulps of it) plus 1e-5, so that a hit on the surface of a shape touching its box is never
/// lost to rounding between the box and the exact test. It grows with the box, so a box inside
/// another stays inside it once both are widened.
pub(crate) fn slack(aabb: &Aabb) -> f32 {
    1e-5 * (1.0 + aabb.mins.abs().max(aabb.maxs.abs()).max_element())
}

/// `aabb` widened by its [`slack`] (as it is when that is not finite: an unbounded box).
pub(crate) fn widened(aabb: &Aabb) -> Aabb {
    let amount = slack(aabb);
    if amount.is_finite() {
        aabb.loosened(amount)
    } else {
        *aabb
    }
}

/// The colliders spatial queries see (a resource kept by
/// [`SpatialQueryPlugin`](super::SpatialQueryPlugin)): each body of the last physics step,
/// with its shape and its pose at the end of that step, by its leaf in the
/// [`BroadPhaseTree`]; the bodies that are not in the tree (unbounded ones, or all of them with
/// a replacement broad phase), and those that moved out of their leaf's box in the step, are
/// listed to be tested directly. Written once per step by [`update_query_colliders`], read by
/// [`SpatialQuery`](super::SpatialQuery).
#[derive(Resource, Default)]
pub struct SpatialQueryColliders {
    /// By leaf id of the tree: the record of the body last written at that leaf (a leaf reused by
    /// another body is checked against [`BroadPhaseTree::entity`]; a body removed from the tree
    /// keeps its record, and its shape alive, until its leaf id is reused).
    records: Vec<Option<QueryCollider>>,
    /// Leaf ids whose record is a straggler, sorted by entity.
    stragglers: Vec<u32>,
    /// The bodies of the last step without a leaf in the tree, in the step's order.
    loose: Vec<QueryCollider>,
    /// Counts the steps (wrapping).
    step: u32,
}

impl SpatialQueryColliders {
    /// The record at `leaf`, if the tree still holds that record's body there.
    fn at_leaf(&self, tree: &BroadPhaseTree, leaf: u32) -> Option<&QueryCollider> {
        self.records
            .get(leaf as usize)?
            .as_ref()
            .filter(|c| tree.entity(leaf) == Some(c.entity))
    }

    /// Calls `visit` with every hittable collider whose box, [`widened`], passes `enter`: the
    /// tree is traversed, pruning every node whose widened box fails `enter`, then the
    /// stragglers and the colliders outside the tree are tested. `enter` must hold for a box if
    /// it holds for any box inside it (a node's box holds its leaves' boxes, a leaf's box its
    /// collider's box, except for the stragglers; widening keeps that), so no collider passing
    /// it is missed; each collider is visited once. The order of the visits depends on the
    /// tree's shape: callers sort.
    pub(crate) fn candidates(
        &self,
        tree: &BroadPhaseTree,
        mut enter: impl FnMut(&Aabb) -> bool,
        mut visit: impl FnMut(&QueryCollider),
    ) {
        tree.bvh().traverse(|node| {
            if !enter(&widened(&node.aabb())) {
                return TraversalAction::Prune;
            }
            if let Some(leaf) = node.leaf_data()
                && let Some(c) = self.at_leaf(tree, leaf)
                && c.hittable
                && !c.straggler
                && enter(&widened(&c.aabb))
            {
                c.visit_colliders(|b| enter(&widened(b)), &mut visit);
            }
            TraversalAction::Continue
        });
        for c in self.outside_tree(tree) {
            if enter(&widened(&c.aabb)) {
                c.visit_colliders(|b| enter(&widened(b)), &mut visit);
            }
        }
    }

    /// Calls `visit` with every hittable collider whose [`widened`] box the cast enters no
    /// later than `bound` (read afresh for each box), nearer boxes first: a best-first walk of
    /// the tree (parry's `find_best`: of a node's two children, the one the cast enters first
    /// is walked first), then the stragglers and the colliders outside the tree. `entry(aabb,
    /// bound)` is the distance at which the cast enters `aabb`, if it does within `bound`: a
    /// lower bound on its distance to anything inside (a node's box holds its leaves' boxes, a
    /// leaf's box its collider's box, except for the stragglers; widening keeps that). `visit`
    /// lowers `bound` to the nearest hit it has found, which prunes every box entered beyond
    /// it; a box entered exactly at `bound` is still visited, so that hits at the same
    /// distance are all seen (the caller decides ties by entity). Against [`candidates`]
    /// (the tree in its stored order), the nearest hit is found as exactly, and sooner.
    ///
    /// [`candidates`]: Self::candidates
    pub(crate) fn nearest_candidates(
        &self,
        tree: &BroadPhaseTree,
        bound: &Cell<f32>,
        entry: impl Fn(&Aabb, f32) -> Option<f32>,
        visit: impl Fn(&QueryCollider),
    ) {
        let reach = |aabb: &Aabb| {
            let limit = bound.get();
            entry(&widened(aabb), limit).filter(|&d| d <= limit)
        };
        // parry's search keeps a leaf only below its best cost, and `visit` keeps the best
        // itself: every leaf reports no cost, every box its entry a hair early (so that a box
        // entered exactly at the bound is not pruned), `f32::MAX` when it is not entered.
        tree.bvh().find_best(
            bound.get(),
            |node, _| reach(&node.aabb()).map_or(f32::MAX, f32::next_down),
            |leaf, _| {
                if let Some(c) = self.at_leaf(tree, leaf)
                    && c.hittable
                    && !c.straggler
                    && reach(&c.aabb).is_some()
                {
                    c.visit_colliders(|b| reach(b).is_some(), &visit);
                }
                None::<f32>
            },
        );
        for c in self.outside_tree(tree) {
            if reach(&c.aabb).is_some() {
                c.visit_colliders(|b| reach(b).is_some(), &visit);
            }
        }
    }

    /// The hittable colliders a walk of the tree does not reach: the stragglers (bodies that
    /// left their leaf's box in the step), then the colliders outside the tree.
    fn outside_tree<'a>(
        &'a self,
        tree: &'a BroadPhaseTree,
    ) -> impl Iterator<Item = &'a QueryCollider> {
        self.stragglers
            .iter()
            .filter_map(|&leaf| self.at_leaf(tree, leaf))
            .chain(&self.loose)
            .filter(|c| c.hittable)
    }

    /// Records every body of the step that just ended at its pose at the end of the step (see
    /// [`update_query_colliders`]).
    fn update(&mut self, state: &PhysicsState, tree: &BroadPhaseTree) {
        self.step = self.step.wrapping_add(1);
        let step = self.step;
        self.loose.clear();
        let mut stragglers = Vec::new();
        let bodies = state.bodies();
        for (i, &entity) in state.entities().iter().enumerate() {
            let body = &bodies[i];
            // The pose `write_back` gave the `Transform`, as the next step reads it; a static
            // body (or a sleeping one that stayed asleep) is where the step found it.
            let pose = if body.motion == Motion::Static {
                state.poses()[i]
            } else {
                let translation = body.position - body.rotation * state.local_com()[i];
                Pose::from_parts(translation, body.rotation.normalize())
            };
            let finite = pose.translation.is_finite() && pose.rotation.is_finite();
            let shape = &state.shapes()[i];
            let aabb = if finite {
                shape.compute_aabb(&pose)
            } else {
                Aabb::new(Vec3::splat(f32::NAN), Vec3::splat(f32::NAN))
            };
            let (layers, hittable) = (state.layers()[i], finite && state.collides()[i]);
            let leaf = tree.leaf(entity);
            // A body without child colliders at the leaf it had in the last step (most bodies,
            // most steps): its record is written in place, its shape kept unless it changed, so
            // it costs no record built and dropped and no reference counting.
            if state.parts()[i].is_none()
                && let Some(leaf) = leaf
                && let Some(Some(c)) = self.records.get_mut(leaf as usize)
                && c.entity == entity
                && c.parts.is_empty()
            {
                if !Arc::ptr_eq(&c.shape.0, &shape.0) {
                    c.shape = shape.clone();
                }
                c.body = entity;
                c.pose = pose;
                c.aabb = aabb;
                c.layers = layers;
                c.hittable = hittable;
                c.step = step;
                c.straggler = !tree
                    .bvh()
                    .leaf_node(leaf)
                    .is_some_and(|node| node.aabb().contains(&aabb));
                if c.straggler {
                    stragglers.push(leaf);
                }
                continue;
            }
            let mut record = QueryCollider {
                entity,
                body: entity,
                shape: shape.clone(),
                pose,
                aabb,
                layers,
                hittable,
                step,
                straggler: false,
                parts: Vec::new(),
            };
            if let Some(parts) = &state.parts()[i] {
                record.parts = QueryCollider::colliders_of(&record, parts);
            }
            match leaf {
                Some(leaf) => {
                    let inside = tree
                        .bvh()
                        .leaf_node(leaf)
                        .is_some_and(|node| node.aabb().contains(&record.aabb));
                    record.straggler = !inside;
                    if record.straggler {
                        stragglers.push(leaf);
                    }
                    let slot = leaf as usize;
                    if slot >= self.records.len() {
                        self.records.resize(slot + 1, None);
                    }
                    self.records[slot] = Some(record);
                }
                None => self.loose.push(record),
            }
        }
        // Stragglers of earlier steps stay stragglers while their body sits steps out (asleep:
        // its leaf and pose are unchanged), as long as the tree holds it.
        let old = std::mem::take(&mut self.stragglers);
        for leaf in old {
            if let Some(c) = self.at_leaf(tree, leaf)
                && c.step != step
            {
                stragglers.push(leaf);
            }
        }
        stragglers.sort_unstable_by_key(|&leaf| {
            self.records[leaf as usize]
                .as_ref()
                .map_or(Entity::PLACEHOLDER, |c| c.entity)
        });
        self.stragglers = stragglers;
    }
}

/// Records the colliders of the step that just ended, at their poses at the end of it, for
/// spatial queries (runs in [`PhysicsSystems::SpatialQuery`](crate::schedule::PhysicsSystems),
/// the last stage of the step). Costs one box per body of the step; bodies sitting the step out
/// asleep keep their record.
pub fn update_query_colliders(
    state: Res<PhysicsState>,
    tree: Res<BroadPhaseTree>,
    mut colliders: ResMut<SpatialQueryColliders>,
) {
    colliders.update(&state, &tree);
}
