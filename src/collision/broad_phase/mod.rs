//! Broad phase: a persistent bounding volume hierarchy over the bodies' boxes
//! ([`BroadPhaseTree`]), and the box tests the sleeping set's sorted boxes share.

use bevy::prelude::*;
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::partitioning::{Bvh, BvhNode, BvhWorkspace};
use parry3d::query::{Ray, RayCast};

/// How far a leaf's box in the tree reaches beyond its body's box on every side, in metres
/// times the length unit: a body whose box stays inside its leaf's (a resting one) leaves the
/// tree untouched. A wider margin lets more leaf pairs through to the exact test: in a cloud
/// of 10,000 boxes of 0.52 m with 39,181 overlapping pairs, the leaves overlap in 48,591 pairs
/// with this margin, in 100,854 with 0.1 m.
pub const TREE_MARGIN: f32 = 0.02;

/// A leaf id or body index meaning "none".
const NONE: u32 = u32::MAX;

/// A persistent bounding volume hierarchy (parry's [`Bvh`]) over the boxes of every body with a
/// collider: awake, static and sleeping. It lives across steps: a body is inserted when it
/// first appears in a step, removed when it is despawned, loses its collider or is quarantined,
/// and its leaf is updated only when its box leaves the leaf's box (the body's box widened by
/// [`TREE_MARGIN`]), so unchanged static and sleeping bodies cost nothing. After a step's
/// updates the tree is refitted and incrementally optimised (a part of it rebuilt each step).
///
/// Unbounded bodies (a half-space, or a box wider than 1e6 m) are kept out of the tree and
/// listed by [`unbounded`](Self::unbounded): a query must test them directly.
///
/// The built-in broad phase ([`crate::pipeline::BroadPhasePlugin`]) maintains it and reads it
/// for the step's pairs (with a replacement broad phase it stays empty); it can be read from
/// any system for spatial queries, between steps. It holds the bodies as the last step's broad
/// phase saw them: a body despawned, moved or spawned since is updated in the next step. Its
/// structure depends on the order bodies were inserted in (that order is deterministic); what
/// a query finds does not.
///
/// # Examples
///
/// Which bodies a ray along +x from the origin may hit, nearest box first:
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::collision::BroadPhaseTree;
/// use impact3d::prelude::*;
/// use parry3d::query::Ray;
///
/// let mut app = impact3d::scenes::headless_app(60.0);
/// let ball = app
///     .world_mut()
///     .spawn((RigidBody::Static, Collider::sphere(0.5), Transform::from_xyz(3.0, 0.0, 0.0)))
///     .id();
/// impact3d::scenes::run_steps(&mut app, 1);
/// let tree = app.world().resource::<BroadPhaseTree>();
/// let ray = Ray::new(Vec3::ZERO, Vec3::X);
/// let mut hits: Vec<(Entity, f32)> = tree.cast_ray(&ray, 100.0).collect();
/// hits.sort_by(|a, b| a.1.total_cmp(&b.1));
/// assert_eq!(hits[0].0, ball);
/// // The ray enters the ball's box (radius 0.5 widened by half the 0.02 m contact margin).
/// assert!((hits[0].1 - 2.49).abs() < 1e-5);
/// ```
#[derive(Resource, Default)]
pub struct BroadPhaseTree {
    bvh: Bvh,
    workspace: BvhWorkspace,
    /// Each leaf id's record (a free id's entity is [`Entity::PLACEHOLDER`]).
    leaves: Vec<Leaf>,
    /// Each leaf id's body index in the step's arrays ([`NONE`] when it sits the step out, or
    /// is free), apart from `leaves` so that the pair search reads it from a small array.
    index: Vec<u32>,
    /// Leaf ids free for reuse.
    free: Vec<u32>,
    /// The leaf id of each entity, by entity index ([`NONE`] for none).
    leaf_of: Vec<u32>,
    /// The unbounded bodies of the last step: entity, box, body index in that step.
    unbounded: Vec<(Entity, Aabb, u32)>,
    /// The leaves whose body index was set by the last [`sync`](Self::sync).
    in_step: Vec<u32>,
    /// The tree was refitted since the last [`optimize`](Self::optimize).
    refitted: bool,
}

/// What the tree keeps about one leaf.
#[derive(Clone, Copy, Debug)]
struct Leaf {
    entity: Entity,
    /// The body's box, as last synced.
    aabb: Aabb,
    /// The leaf's box in the tree: `aabb` when it was last inserted, widened by the margin.
    fat: Aabb,
}

impl BroadPhaseTree {
    /// The tree. A leaf's data is its leaf id ([`entity`](Self::entity) gives its body); a
    /// leaf's box holds its body's box (widened by [`TREE_MARGIN`]), and an inner node's holds
    /// its children's.
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// The body of leaf `leaf`, if the leaf is in the tree.
    pub fn entity(&self, leaf: u32) -> Option<Entity> {
        self.leaves
            .get(leaf as usize)
            .map(|l| l.entity)
            .filter(|&e| e != Entity::PLACEHOLDER)
    }

    /// The leaf of `entity`, if it is in the tree.
    pub fn leaf(&self, entity: Entity) -> Option<u32> {
        let leaf = *self.leaf_of.get(entity.index_u32() as usize)?;
        (leaf != NONE && self.leaves[leaf as usize].entity == entity).then_some(leaf)
    }

    /// The box of `entity` as the broad phase last saw it (in the tree or unbounded): its
    /// collider's box widened by half the contact margin and swept along its motion in that
    /// step (see [`PhysicsState::aabbs`](crate::pipeline::PhysicsState::aabbs)); a sleeping
    /// body's box from the step it was last read in.
    pub fn aabb(&self, entity: Entity) -> Option<Aabb> {
        match self.leaf(entity) {
            Some(leaf) => Some(self.leaves[leaf as usize].aabb),
            None => self
                .unbounded
                .iter()
                .find(|u| u.0 == entity)
                .map(|&(_, aabb, _)| aabb),
        }
    }

    /// The unbounded bodies (a half-space's box, or one wider than 1e6 m) and their boxes: they
    /// are not in the tree, so a query tests them directly.
    pub fn unbounded(&self) -> impl Iterator<Item = (Entity, Aabb)> + '_ {
        self.unbounded.iter().map(|&(e, aabb, _)| (e, aabb))
    }

    /// The candidates of a ray cast: every body (in the tree or unbounded) whose box `ray`
    /// enters within `max_time_of_impact` (in units of the ray's direction), with the time at
    /// which it enters it (0 from inside), in no particular order. The hit on a body's shape,
    /// if any, is at or after that time.
    pub fn cast_ray<'a>(
        &'a self,
        ray: &'a Ray,
        max_time_of_impact: f32,
    ) -> impl Iterator<Item = (Entity, f32)> + 'a {
        let enter = move |aabb: &Aabb| aabb.cast_local_ray(ray, max_time_of_impact, true);
        self.bvh
            .leaves(move |node: &BvhNode| enter(&node.aabb()).is_some())
            .filter_map(move |leaf| {
                let l = &self.leaves[leaf as usize];
                enter(&l.aabb).map(|t| (l.entity, t))
            })
            .chain(
                self.unbounded
                    .iter()
                    .filter_map(move |&(e, aabb, _)| enter(&aabb).map(|t| (e, t))),
            )
    }

    /// Removes `entity` from the tree (it was despawned, lost its collider or was
    /// quarantined). Returns whether it was there.
    pub(crate) fn remove(&mut self, entity: Entity) -> bool {
        let Some(leaf) = self.leaf(entity) else {
            return false;
        };
        self.remove_leaf(leaf);
        true
    }

    fn remove_leaf(&mut self, leaf: u32) {
        self.bvh.remove(leaf);
        let l = &mut self.leaves[leaf as usize];
        self.leaf_of[l.entity.index_u32() as usize] = NONE;
        l.entity = Entity::PLACEHOLDER;
        self.index[leaf as usize] = NONE;
        self.free.push(leaf);
    }

    /// Brings the tree up to date with a step's bodies, `entities[i]` with box `aabbs[i]` (in
    /// index order, so the tree is built deterministically): a new body is inserted with its
    /// box widened by `margin`, a body whose box left its leaf's box gets a new leaf box, the
    /// others are left alone. Then, if anything changed, the tree is refitted. Records each
    /// body's index for [`pairs_with_active`](Self::pairs_with_active); bodies in the tree but
    /// not in `entities` (sleeping ones sitting the step out) are left as they are.
    pub(crate) fn sync(&mut self, entities: &[Entity], aabbs: &[Aabb], margin: f32) {
        for leaf in self.in_step.drain(..) {
            self.index[leaf as usize] = NONE;
        }
        self.unbounded.clear();
        let mut changed = false;
        for (i, (&entity, aabb)) in entities.iter().zip(aabbs).enumerate() {
            if is_unbounded(aabb) {
                changed |= self.remove(entity);
                self.unbounded.push((entity, *aabb, i as u32));
                continue;
            }
            let leaf = match self.leaf(entity) {
                Some(leaf) => {
                    let l = &mut self.leaves[leaf as usize];
                    if l.aabb != *aabb {
                        l.aabb = *aabb;
                        if !l.fat.contains(aabb) {
                            l.fat = aabb.loosened(margin);
                            self.bvh.insert_or_update_partially(l.fat, leaf, 0.0);
                            changed = true;
                        }
                    }
                    leaf
                }
                None => {
                    let leaf = self.insert(entity, aabb, margin);
                    changed = true;
                    leaf
                }
            };
            self.index[leaf as usize] = i as u32;
            self.in_step.push(leaf);
        }
        if changed {
            self.bvh.refit(&mut self.workspace);
            self.refitted = true;
        }
    }

    /// Inserts a leaf for `entity` (not in the tree) and returns its id. An entity whose index
    /// still maps to a leaf of an older entity (despawned unseen) replaces it.
    fn insert(&mut self, entity: Entity, aabb: &Aabb, margin: f32) -> u32 {
        let slot = entity.index_u32() as usize;
        if slot >= self.leaf_of.len() {
            self.leaf_of.resize(slot + 1, NONE);
        }
        if self.leaf_of[slot] != NONE {
            self.remove_leaf(self.leaf_of[slot]);
        }
        let record = Leaf {
            entity,
            aabb: *aabb,
            fat: aabb.loosened(margin),
        };
        let leaf = match self.free.pop() {
            Some(leaf) => {
                self.leaves[leaf as usize] = record;
                leaf
            }
            None => {
                self.leaves.push(record);
                self.index.push(NONE);
                self.leaves.len() as u32 - 1
            }
        };
        self.leaf_of[slot] = leaf;
        self.bvh.insert_or_update_partially(record.fat, leaf, 0.0);
        leaf
    }

    /// One step of the tree's incremental optimisation (parry rebuilds a few of its subtrees),
    /// if it was refitted since the last call: a tree that did not change needs none.
    pub(crate) fn optimize(&mut self) {
        if std::mem::take(&mut self.refitted) {
            self.bvh.optimize_incremental(&mut self.workspace);
        }
    }

    /// The pairs of the last [`sync`](Self::sync)'s bodies whose boxes `aabbs` overlap (faces
    /// touching included), at least one of them `active`, as body indices `(i, j)`, `i < j`,
    /// sorted; the unbounded boxes are tested against every box directly. The pairs among the
    /// bounded boxes are found by [`PairSearch::for_active`]'s choice, each leaf pair then
    /// tested exactly; both searches give the same pairs.
    pub(crate) fn pairs_with_active(
        &mut self,
        aabbs: &[Aabb],
        active: &[bool],
        pairs: &mut Vec<(u32, u32)>,
    ) {
        let search = PairSearch::for_active(self, active);
        self.pairs_with_active_by(search, aabbs, active, pairs);
    }

    fn pairs_with_active_by(
        &mut self,
        search: PairSearch,
        aabbs: &[Aabb],
        active: &[bool],
        pairs: &mut Vec<(u32, u32)>,
    ) {
        pairs.clear();
        if !active.iter().any(|&a| a) {
            return;
        }
        for &(_, a, h) in &self.unbounded {
            for j in 0..aabbs.len() as u32 {
                // An unbounded box pairs with the boxes it overlaps when either is active;
                // pairs of two unbounded boxes are found once, from the smaller index.
                let both_unbounded = is_unbounded(&aabbs[j as usize]);
                if j != h
                    && (active[h as usize] || active[j as usize])
                    && (!both_unbounded || h < j)
                    && overlaps(&a, &aabbs[j as usize])
                {
                    pairs.push((h.min(j), h.max(j)));
                }
            }
        }
        // A leaf of a body sitting the step out (asleep) has no index: a sleeping body whose
        // box an active box overlaps was brought into the step before this.
        let index = &self.index;
        let mut test = |i: u32, j: u32| {
            if j != NONE
                && (active[i as usize] || active[j as usize])
                && overlaps(&aabbs[i as usize], &aabbs[j as usize])
            {
                pairs.push((i.min(j), i.max(j)));
            }
        };
        match search {
            PairSearch::Queries => {
                for &leaf in &self.in_step {
                    let i = index[leaf as usize];
                    if !active[i as usize] {
                        continue;
                    }
                    let query = BvhNode::leaf(aabbs[i as usize], leaf);
                    for found in self.bvh.leaves(|node: &BvhNode| node.intersects(&query)) {
                        let j = index[found as usize];
                        // A pair of two active bodies is kept from the smaller index.
                        if j != i && !(j != NONE && active[j as usize] && j < i) {
                            test(i, j);
                        }
                    }
                }
            }
            PairSearch::Traversal => {
                self.bvh
                    .traverse_bvtt_single_tree::<false>(&mut self.workspace, &mut |a, b| {
                        let (i, j) = (index[a as usize], index[b as usize]);
                        if i != NONE {
                            test(i, j);
                        }
                    });
            }
        }
        pairs.sort_unstable();
    }
}

/// How [`BroadPhaseTree::pairs_with_active`] finds the overlapping leaves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PairSearch {
    /// Each active body's box is looked up in the tree: costs about the active bodies times
    /// the tree's depth.
    Queries,
    /// The tree is traversed against itself once (parry's `traverse_bvtt_single_tree`),
    /// reporting every pair of overlapping leaves: costs about the leaves plus their
    /// overlapping pairs, whatever is active.
    Traversal,
}

impl PairSearch {
    /// Queries when fewer than one leaf in [`QUERIES_BELOW`] is an active body's, else one
    /// traversal.
    fn for_active(tree: &BroadPhaseTree, active: &[bool]) -> PairSearch {
        let queries = tree
            .in_step
            .iter()
            .filter(|&&leaf| active[tree.index[leaf as usize] as usize])
            .count();
        if queries * QUERIES_BELOW < tree.bvh.leaf_count() as usize {
            PairSearch::Queries
        } else {
            PairSearch::Traversal
        }
    }
}

/// One query per active body is cheaper than one traversal of the whole tree while fewer than
/// one leaf in this many is an active body's. Measured on 10,000 boxes of 0.52 m (release, 2
/// busy cores, 2026-12-02): on a grid 2 m apart a query costs 0.1-0.2 us and the traversal
/// 0.08-0.1 ms, even near one active box in 16; in a random cloud 11 m wide (8 overlaps a
/// box) a query costs 0.8-2 us and the traversal 2.4-4.7 ms, even near one in 4.
const QUERIES_BELOW: usize = 8;

/// A box too large to sort or put in a tree usefully (a half-space's), or with a NaN extent:
/// such boxes are checked against every box directly.
pub(crate) fn is_unbounded(b: &Aabb) -> bool {
    (b.maxs - b.mins).max_element().partial_cmp(&1e6) != Some(std::cmp::Ordering::Less)
}

/// Sorts box indices by their lower bound on `axis` (ties by index, so the order is
/// deterministic).
pub(crate) fn sort_by_lower_bound(aabbs: &[Aabb], order: &mut [u32], axis: usize) {
    order.sort_unstable_by(|&i, &j| {
        aabbs[i as usize].mins[axis]
            .total_cmp(&aabbs[j as usize].mins[axis])
            .then(i.cmp(&j))
    });
}

/// Whether two boxes overlap (touching counts).
pub(crate) fn overlaps(a: &Aabb, b: &Aabb) -> bool {
    (0..3).all(|k| a.mins[k] <= b.maxs[k] && b.mins[k] <= a.maxs[k])
}

/// The axis (0, 1 or 2) along which the centres of the bounded boxes spread most.
pub(crate) fn sweep_axis(aabbs: &[Aabb]) -> usize {
    let mut sum = [0.0f64; 3];
    let mut sum_sq = [0.0f64; 3];
    let mut n = 0.0f64;
    for b in aabbs {
        // Unbounded boxes (a half-space's) and NaN extents say nothing about the spread.
        if is_unbounded(b) {
            continue;
        }
        n += 1.0;
        let c = (b.mins + b.maxs) * 0.5;
        for k in 0..3 {
            sum[k] += c[k] as f64;
            sum_sq[k] += (c[k] as f64) * (c[k] as f64);
        }
    }
    if n == 0.0 {
        return 0;
    }
    let variance = |k: usize| sum_sq[k] / n - (sum[k] / n).powi(2);
    (0..3)
        .max_by(|&i, &j| variance(i).total_cmp(&variance(j)).then(j.cmp(&i)))
        .unwrap_or(0)
}

#[cfg(test)]
mod tests;
