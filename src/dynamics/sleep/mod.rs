//! Sleeping: resting islands are taken out of the step until something touches them.
//!
//! A dynamic body is *slow* when `|v| + |w| R` (the speed of its farthest point, `R` its
//! bounding radius about the centre of mass) stays below [`SleepConfig::linear_threshold`].
//! Bodies that touch (a contact point within the contact margin) form an island; when every
//! body of an island has been slow for [`SleepConfig::time_to_sleep`], the whole island sleeps:
//! its velocities are zeroed, it gets the [`Sleeping`] marker, and it sits later steps out: its
//! components are not read, it is not packed, swept or solved, and its resting pairs are set
//! aside as they are ([`SleepingSet`]). Only what detects a touch remains: a change filter on
//! its components, and a look-up of each awake body's box among the sleepers' sorted boxes. A
//! sleeper that an awake body's box reaches enters the step as a static body.
//! An island wakes, all at once, when an awake body touches one of its bodies, or when the user
//! changes a sleeping body's pose or velocity or removes its `Sleeping` marker.

use bevy::ecs::entity::EntityHashMap;
use bevy::prelude::*;
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::math::Pose;
use parry3d::shape::SharedShape;

use crate::collision::broad_phase::{is_unbounded, overlaps, sort_by_lower_bound, sweep_axis};
use crate::collision::layers::CollisionLayers;
use crate::collision::narrow_phase::BOX_MARGIN_SHARE;
use crate::collision::sensor::Reporting;
use crate::dynamics::rigid_body::CombineRules;
use crate::dynamics::solver::{Motion, SolverBody};

/// Marks a sleeping body. Insert `Sleeping::default()` to put a body to sleep on its own;
/// remove it to wake the body.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Eq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct Sleeping {
    /// A body of the island this body fell asleep with, which names the island: bodies of one
    /// island wake together. `Entity::PLACEHOLDER` (the default) is an island of its own.
    pub island: Entity,
}

/// Keeps a body awake: it never falls asleep, and neither does any island it touches (as
/// avian's `SleepingDisabled`). Inserted on a sleeping body, it wakes the body's island.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct SleepingDisabled;

impl Default for Sleeping {
    fn default() -> Self {
        Sleeping {
            island: Entity::PLACEHOLDER,
        }
    }
}

/// How long a dynamic body has been slow, s. Maintained by the plugin.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct SleepTimer(pub f32);

/// Sleeping settings.
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Debug, Default, PartialEq)]
pub struct SleepConfig {
    /// Let resting islands sleep. Default true.
    pub enabled: bool,
    /// A body is slow while `|v| + |w| R` stays below this, m/s. Default 0.05 (Box2D's).
    pub linear_threshold: f32,
    /// An island sleeps once all its bodies have been slow this long, s. Default 0.5.
    pub time_to_sleep: f32,
}

impl Default for SleepConfig {
    fn default() -> Self {
        SleepConfig {
            enabled: true,
            linear_threshold: 0.05,
            time_to_sleep: 0.5,
        }
    }
}

/// Disjoint sets over `0..n` with path halving and union by index (deterministic roots: the
/// smallest index of each set).
pub struct Islands {
    parent: Vec<u32>,
}

impl Islands {
    /// `n` singletons.
    pub fn new(n: usize) -> Self {
        Islands {
            parent: (0..n as u32).collect(),
        }
    }

    /// The root (smallest member) of `i`'s island.
    pub fn find(&mut self, mut i: u32) -> u32 {
        while self.parent[i as usize] != i {
            let grand = self.parent[self.parent[i as usize] as usize];
            self.parent[i as usize] = grand;
            i = grand;
        }
        i
    }

    /// Joins the islands of `a` and `b`.
    pub fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            let (lo, hi) = (ra.min(rb), ra.max(rb));
            self.parent[hi as usize] = lo;
        }
    }
}

/// Whether `body`, awake, wakes a sleeping island its box reaches: a dynamic body, or a
/// kinematic one that moves (a resting kinematic body, like a static one, pushes nothing).
pub fn wakes_sleepers(body: &SolverBody) -> bool {
    body.motion == Motion::Dynamic
        || (body.motion == Motion::Kinematic
            && (body.linear_velocity != Vec3::ZERO || body.angular_velocity != Vec3::ZERO))
}

/// The sleeping islands that overlapping `pairs` (body indices) wake, each once, in the order
/// found: for a pair of which one body sleeps in an island (`island(k)`, `None` when awake)
/// and the other is awake and [`wakes_sleepers`] (`wakes(k)`), and that would be solved
/// (`solved(i, j)`: a sensor or a body its layers filter out passes a sleeper without waking
/// it). The broad phase repeats this until no island wakes (a woken island may reach another).
///
/// # Examples
///
/// ```
/// use bevy::prelude::Entity;
/// use impact3d::dynamics::sleep::islands_woken;
///
/// // Body 0 sleeps in island A, body 2 in island B; body 1 is awake and pushes. Pairs (0, 1)
/// // and (1, 2) wake both islands; pair (0, 2) alone (two sleepers) would wake nothing.
/// let (a, b) = (Entity::from_raw_u32(7).unwrap(), Entity::from_raw_u32(9).unwrap());
/// let island = |k: usize| [Some(a), None, Some(b)][k];
/// let woken = islands_woken(&[(0, 2), (0, 1), (1, 2)], island, |k| k == 1, |_, _| true);
/// assert_eq!(woken, vec![a, b]);
/// // Not where the pair would not be solved.
/// let woken = islands_woken(&[(0, 1), (1, 2)], island, |k| k == 1, |i, j| i + j == 3);
/// assert_eq!(woken, vec![b]);
/// ```
pub fn islands_woken(
    pairs: &[(u32, u32)],
    island: impl Fn(usize) -> Option<Entity>,
    wakes: impl Fn(usize) -> bool,
    solved: impl Fn(usize, usize) -> bool,
) -> Vec<Entity> {
    let mut islands = Vec::new();
    for &(i, j) in pairs {
        for (me, other) in [(i as usize, j as usize), (j as usize, i as usize)] {
            if let Some(sleeping) = island(me)
                && wakes(other)
                && island(other).is_none()
                && !islands.contains(&sleeping)
                && solved(me, other)
            {
                islands.push(sleeping);
            }
        }
    }
    islands
}

/// The links that make islands (for [`islands_to_sleep`]): the touching `pairs` (body indices
/// into `bodies`) of two dynamic bodies, or of a dynamic body and a moving kinematic one (a
/// body on a moving platform never sleeps: its island gets a member that is never slow).
pub fn island_links(
    bodies: &[SolverBody],
    pairs: impl IntoIterator<Item = (usize, usize)>,
) -> Vec<(u32, u32)> {
    let dynamic = |i: usize| bodies[i].motion == Motion::Dynamic;
    let moving = |i: usize| {
        let b = &bodies[i];
        b.motion == Motion::Kinematic
            && (b.linear_velocity != Vec3::ZERO || b.angular_velocity != Vec3::ZERO)
    };
    pairs
        .into_iter()
        .filter(|&(a, b)| (dynamic(a) && (dynamic(b) || moving(b))) || (dynamic(b) && moving(a)))
        .map(|(a, b)| (a as u32, b as u32))
        .collect()
}

/// Decides which bodies fall asleep this step. `timers[i]` is body `i`'s slow time (s) after
/// this step, or `None` for bodies that take no part (static, kinematic, sleeping, or kept
/// awake); `links` are pairs of touching participating bodies. Returns, for each body, the
/// island root it sleeps with, if its whole island has been slow for `time_to_sleep`.
///
/// # Examples
///
/// ```
/// use impact3d::dynamics::sleep::islands_to_sleep;
///
/// // Bodies 0-1 touch and are both slow long enough; 2 touches 3, which is not slow yet.
/// let timers = [Some(0.6), Some(0.7), Some(0.9), Some(0.1)];
/// let asleep = islands_to_sleep(&timers, &[(0, 1), (2, 3)], 0.5);
/// assert_eq!(asleep, vec![Some(0), Some(0), None, None]);
/// ```
pub fn islands_to_sleep(
    timers: &[Option<f32>],
    links: &[(u32, u32)],
    time_to_sleep: f32,
) -> Vec<Option<u32>> {
    let mut islands = Islands::new(timers.len());
    for &(a, b) in links {
        islands.union(a, b);
    }
    // An island may sleep only if every member is slow long enough.
    let mut ready = vec![true; timers.len()];
    for (i, timer) in timers.iter().enumerate() {
        let root = islands.find(i as u32) as usize;
        if timer.is_none_or(|t| t < time_to_sleep) {
            ready[root] = false;
        }
    }
    (0..timers.len())
        .map(|i| {
            let root = islands.find(i as u32);
            (timers[i].is_some() && ready[root as usize]).then_some(root)
        })
        .collect()
}

/// A sleeping body as the step last gathered it: everything the step needs to bring it back
/// into the packed arrays (as a static body, or as the dynamic body it becomes when woken)
/// without reading its components again.
#[derive(Clone)]
pub struct Sleeper {
    /// The body.
    pub entity: Entity,
    /// The island it sleeps with (see [`Sleeping::island`]).
    pub island: Entity,
    /// The dynamic solver body it becomes when woken.
    pub body: SolverBody,
    /// Centre of mass in the body frame, m.
    pub local_com: Vec3,
    /// Its collider's shape.
    pub shape: SharedShape,
    /// The collider's pose (the body origin).
    pub pose: Pose,
    /// Restitution coefficient, clamped.
    pub restitution: f32,
    /// Friction coefficient, clamped.
    pub friction: f32,
    /// The combine rules it asks for.
    pub combine: CombineRules,
    /// Its collision layers.
    pub layers: CollisionLayers,
    /// What it asks the step to report.
    pub reporting: Reporting,
    /// Its colliders, for a body with child colliders (see
    /// [`CompoundParts`](crate::collision::parts::CompoundParts)).
    pub parts: Option<std::sync::Arc<crate::collision::parts::CompoundParts>>,
    /// Bounding radius about the centre of mass, m.
    pub radius: f32,
    /// The forces, damping, speed caps and translation locks it has, if any (see
    /// [`BodyMotion`](crate::dynamics::forces::BodyMotion)).
    pub motion: Option<crate::dynamics::forces::BodyMotion>,
    /// Its collider takes part in contacts (no
    /// [`ColliderDisabled`](crate::collision::collider::ColliderDisabled)).
    pub collides: bool,
}

/// The sleeping bodies that sit out the step: a body enters the step's packed arrays only when
/// something may have touched it (its components changed, an awake body's box overlaps its
/// box, or its island wakes); the others cost nothing per step. Their boxes are kept sorted
/// along one axis, so finding the sleepers an awake body's box overlaps costs a binary search.
#[derive(Default)]
pub struct SleepingSet {
    records: Vec<Sleeper>,
    /// Each record's box (the shape's box at its pose widened by half the contact margin, as
    /// the broad phase widens a static body's), in the order of `records`.
    boxes: Vec<Aabb>,
    /// The step each record was last put into the packed arrays.
    in_step: Vec<u32>,
    index: EntityHashMap<u32>,
    /// The contact margin the boxes were widened by, m.
    margin: f32,
    /// Bounded boxes sorted by their lower bound on `axis`; rebuilt when the set changed.
    order: Vec<u32>,
    unbounded: Vec<u32>,
    widest: f32,
    axis: usize,
    sorted: bool,
}

impl SleepingSet {
    /// Number of sleeping bodies recorded.
    pub fn len(&self) -> usize {
        self.records.len()
    }

    /// Whether no sleeping body is recorded.
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// The record of `entity`, if it sleeps.
    pub fn get(&self, entity: Entity) -> Option<u32> {
        self.index.get(&entity).copied()
    }

    /// Record `i`.
    pub fn record(&self, i: u32) -> &Sleeper {
        &self.records[i as usize]
    }

    /// Every record, in no particular (but a deterministic) order.
    pub fn records(&self) -> &[Sleeper] {
        &self.records
    }

    /// The box of record `i`, widened by half the contact margin.
    pub fn aabb(&self, i: u32) -> Aabb {
        self.boxes[i as usize]
    }

    /// Whether record `i` was put into the packed arrays in step `step`.
    pub fn in_step(&self, i: u32, step: u32) -> bool {
        self.in_step[i as usize] == step
    }

    /// Marks record `i` as put into the packed arrays in step `step`.
    pub fn mark_in_step(&mut self, i: u32, step: u32) {
        self.in_step[i as usize] = step;
    }

    fn widened(&self, sleeper: &Sleeper) -> Aabb {
        sleeper
            .shape
            .compute_aabb(&sleeper.pose)
            .loosened(BOX_MARGIN_SHARE * self.margin)
    }

    /// Records (or replaces the record of) a sleeping body, put into the arrays in `step`.
    pub fn insert(&mut self, sleeper: Sleeper, step: u32) {
        let aabb = self.widened(&sleeper);
        match self.index.get(&sleeper.entity) {
            Some(&i) => {
                self.sorted &= self.boxes[i as usize] == aabb;
                self.boxes[i as usize] = aabb;
                self.records[i as usize] = sleeper;
                self.in_step[i as usize] = step;
            }
            None => {
                self.index.insert(sleeper.entity, self.records.len() as u32);
                self.records.push(sleeper);
                self.boxes.push(aabb);
                self.in_step.push(step);
                self.sorted = false;
            }
        }
    }

    /// Forgets `entity` (it woke, was despawned, or must be read again).
    pub fn remove(&mut self, entity: Entity) {
        let Some(i) = self.index.remove(&entity) else {
            return;
        };
        let i = i as usize;
        self.records.swap_remove(i);
        self.boxes.swap_remove(i);
        self.in_step.swap_remove(i);
        if let Some(moved) = self.records.get(i) {
            self.index.insert(moved.entity, i as u32);
        }
        self.sorted = false;
    }

    /// Forgets every body.
    pub fn clear(&mut self) {
        *self = SleepingSet {
            margin: self.margin,
            ..default()
        };
    }

    /// Sets the contact margin the boxes are widened by, m; the boxes are recomputed when it
    /// changed.
    pub fn set_margin(&mut self, margin: f32) {
        if margin == self.margin {
            return;
        }
        self.margin = margin;
        self.boxes = self.records.iter().map(|s| self.widened(s)).collect();
        self.sorted = false;
    }

    /// Appends to `out` the records whose boxes overlap `aabb` (touching counts, as in the
    /// broad phase), in ascending order of their lower bound.
    pub fn overlapping(&mut self, aabb: &Aabb, out: &mut Vec<u32>) {
        if self.records.is_empty() {
            return;
        }
        if !self.sorted {
            self.axis = sweep_axis(&self.boxes);
            let boxes = &self.boxes;
            self.unbounded = (0..boxes.len() as u32)
                .filter(|&i| is_unbounded(&boxes[i as usize]))
                .collect();
            self.order.clear();
            self.order
                .extend((0..boxes.len() as u32).filter(|&i| !is_unbounded(&boxes[i as usize])));
            sort_by_lower_bound(boxes, &mut self.order, self.axis);
            self.widest = self
                .order
                .iter()
                .map(|&i| boxes[i as usize].maxs[self.axis] - boxes[i as usize].mins[self.axis])
                .fold(0.0f32, f32::max);
            self.sorted = true;
        }
        let (boxes, axis) = (&self.boxes, self.axis);
        out.extend(
            self.unbounded
                .iter()
                .copied()
                .filter(|&i| overlaps(aabb, &boxes[i as usize])),
        );
        // A box that overlaps `aabb` starts before `aabb` ends, and at most `widest` before
        // `aabb` starts (it ends after `aabb` starts).
        let from = aabb.mins[axis] - self.widest;
        let start = self
            .order
            .partition_point(|&i| boxes[i as usize].mins[axis] < from);
        out.extend(
            self.order[start..]
                .iter()
                .copied()
                .take_while(|&i| boxes[i as usize].mins[axis] <= aabb.maxs[axis])
                .filter(|&i| overlaps(aabb, &boxes[i as usize])),
        );
    }
}

#[cfg(test)]
mod tests;
