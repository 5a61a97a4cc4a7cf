//! What the broad and narrow phases and the solve hand on: the candidate pairs, the contact
//! rows and the step's events, each a resource readable from outside the crate.

use std::ops::Range;

use bevy::prelude::*;

use super::{PairKind, PhysicsState};
use crate::dynamics::solver::{ContactConstraint, Motion};
use crate::messages::Impact;

/// The broad phase's output: the body pairs whose boxes overlap, for the narrow phase.
#[derive(Resource, Default)]
pub struct CandidatePairs {
    /// The pairs as entities `(a, b)`, `a < b`, sorted.
    pub(super) pairs: Vec<(Entity, Entity)>,
    /// Each pair's body indices in [`PhysicsState::entities`], in the order of `(a, b)`.
    pub(super) indices: Vec<(usize, usize)>,
    /// Per pair: neither body is awake and dynamic (a sleeping body with a sleeping or static
    /// one), so the pair keeps its manifolds and touching state without a narrow phase.
    pub(super) dormant: Vec<bool>,
    /// Per pair: its contacts are only detected (touching state and collision messages), never
    /// solved: a sensor is in it, or neither body is dynamic or asleep.
    pub(super) detect_only: Vec<bool>,
    /// [`CandidatePairs::set`]'s buffer of kept pairs, kept between steps so that a steady
    /// step allocates nothing.
    kept: Vec<KeptPair>,
}

/// A kept pair of [`CandidatePairs::set`]: its entities, its body indices in their order,
/// detect-only.
type KeptPair = ((Entity, Entity), (usize, usize), bool);

impl CandidatePairs {
    /// The pairs as entities `(a, b)`, `a < b`, sorted.
    pub fn pairs(&self) -> &[(Entity, Entity)] {
        &self.pairs
    }

    /// Each pair's body indices in [`PhysicsState::entities`], in the order of its entities.
    pub fn indices(&self) -> &[(usize, usize)] {
        &self.indices
    }

    /// Per pair: neither body is awake and dynamic (for a detect-only pair: both are static
    /// or asleep, and neither changed), so the pair keeps its manifolds and touching state
    /// without a narrow phase.
    pub fn dormant(&self) -> &[bool] {
        &self.dormant
    }

    /// Per pair: its contacts are only detected, for touching state and collision messages,
    /// never solved (no contact rows): a [`Sensor`](crate::collision::Sensor) is in it, or
    /// neither body is dynamic or asleep (a pair found because a body asked for reports).
    pub fn detect_only(&self) -> &[bool] {
        &self.detect_only
    }

    /// Sets the candidates from overlapping body index pairs of `state` (each pair once, in
    /// any order and either way round), and sorts them by entity. What a broad phase, the
    /// built-in one or a replacement, ends with; the one place pairs are filtered:
    ///
    /// - neither body has a [`ColliderDisabled`](crate::collision::ColliderDisabled), and the
    ///   bodies' [`CollisionLayers`](crate::collision::CollisionLayers) must interact
    ///   ([`CollisionLayers::interacts_with`](crate::collision::CollisionLayers::interacts_with));
    /// - a pair with a dynamic or sleeping body is kept, solved unless a
    ///   [`Sensor`](crate::collision::Sensor) is in it;
    /// - a pair of non-dynamic bodies (kinematic with static or kinematic, or a static sensor
    ///   with a static body) is kept, detect-only, when either body has a `Sensor`,
    ///   [`CollisionEventsEnabled`](crate::collision::CollisionEventsEnabled) or
    ///   [`CollidingEntities`](crate::collision::CollidingEntities); otherwise it is dropped,
    ///   so it costs nothing past the broad phase.
    pub fn set(
        &mut self,
        state: &PhysicsState,
        overlapping: impl IntoIterator<Item = (usize, usize)>,
    ) {
        let mut keyed = std::mem::take(&mut self.kept);
        keyed.clear();
        keyed.extend(overlapping.into_iter().filter_map(|(i, j)| {
            let detect_only = state.pair_kind(i, j)? == PairKind::DetectOnly;
            let (ei, ej) = (state.entities[i], state.entities[j]);
            Some(if ei < ej {
                ((ei, ej), (i, j), detect_only)
            } else {
                ((ej, ei), (j, i), detect_only)
            })
        }));
        keyed.sort_unstable_by_key(|(k, _, _)| *k);
        self.pairs.clear();
        self.indices.clear();
        self.dormant.clear();
        self.detect_only.clear();
        for &(k, (i, j), detect_only) in &keyed {
            self.pairs.push(k);
            self.indices.push((i, j));
            let dormant = if detect_only {
                // A detect-only pair may have a kinematic body (moving at its velocity) or a
                // static one that changed: it is looked at unless nothing in it can move.
                let still = |k: usize| state.bodies[k].motion == Motion::Static && !state.active[k];
                still(i) && still(j)
            } else {
                let awake = |k: usize| state.bodies[k].motion == Motion::Dynamic;
                !awake(i) && !awake(j)
            };
            self.dormant.push(dormant);
            self.detect_only.push(detect_only);
        }
        self.kept = keyed;
    }
}

/// The narrow phase's output: one contact row per contact point of the candidate pairs, with
/// the impulses the solve leaves in them.
#[derive(Resource, Default)]
pub struct ContactRows {
    pub(super) contacts: Vec<ContactConstraint>,
    /// Contact index ranges of one body pair each.
    pub(super) pair_ranges: Vec<Range<usize>>,
    /// For each contact: (pair, manifold, point) in [`ContactPairs`](crate::collision::ContactPairs).
    pub(super) keys: Vec<(u32, u32, u32)>,
    /// The detect-only candidate pairs found touching in the step, as indices of
    /// [`CandidatePairs::pairs`], ascending.
    pub(super) detected: Vec<u32>,
    /// The colliders of compound pairs (see [`ContactPair::compound`]) found touching without
    /// rows (a sensor among them, or the pair detect-only): `(pair, collider on a, collider on
    /// b)`, by pair, ascending.
    ///
    /// [`ContactPair::compound`]: crate::collision::ContactPair::compound
    pub(super) detected_parts: Vec<(u32, Entity, Entity)>,
}

impl ContactRows {
    /// The rows of the step: prepared by the narrow phase, with their impulses after the solve.
    pub fn contacts(&self) -> &[ContactConstraint] {
        &self.contacts
    }

    /// The rows of each body pair, as ranges of [`contacts`](Self::contacts).
    pub fn pair_ranges(&self) -> &[Range<usize>] {
        &self.pair_ranges
    }

    /// For each row: its (candidate pair, manifold, point) in
    /// [`ContactPairs`](crate::collision::ContactPairs).
    pub fn keys(&self) -> &[(u32, u32, u32)] {
        &self.keys
    }

    /// The detect-only candidate pairs (see [`CandidatePairs::detect_only`]) whose contacts
    /// touch in the step, as indices of [`CandidatePairs::pairs`], ascending: they have no
    /// rows, so their touching state comes from here.
    pub fn detected(&self) -> &[u32] {
        &self.detected
    }

    /// The colliders of the pairs with child colliders found touching without rows (a
    /// sensor among them, or the pair detect-only): `(candidate pair, collider on its first
    /// body, collider on its second)`, ascending by pair.
    pub fn detected_parts(&self) -> &[(u32, Entity, Entity)] {
        &self.detected_parts
    }
}

/// Two colliders whose touching started or ended, with their bodies: for a body without child
/// colliders, its collider is itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ColliderPair {
    /// The colliders `(on a, on b)`, where `(a, b)` are the bodies.
    pub colliders: (Entity, Entity),
    /// The bodies `(a, b)`, `a < b`.
    pub bodies: (Entity, Entity),
}

impl ColliderPair {
    /// A pair of bodies that are their own colliders.
    pub fn of_bodies(a: Entity, b: Entity) -> Self {
        ColliderPair {
            colliders: (a, b),
            bodies: (a, b),
        }
    }
}

/// What happened in the step, as the messages stage sends it.
#[derive(Resource, Default)]
pub struct StepEvents {
    pub(super) impacts: Vec<Impact>,
    pub(super) started: Vec<(Entity, Entity)>,
    pub(super) ended: Vec<(Entity, Entity)>,
    pub(super) colliders_started: Vec<ColliderPair>,
    pub(super) colliders_ended: Vec<ColliderPair>,
}

impl StepEvents {
    /// The contacts that count as impacts (see
    /// [`SolverConfig::impact_messages`](crate::dynamics::SolverConfig::impact_messages)).
    pub fn impacts(&self) -> &[Impact] {
        &self.impacts
    }

    /// Pairs that started touching in the step.
    pub fn started(&self) -> &[(Entity, Entity)] {
        &self.started
    }

    /// Pairs that stopped touching in the step (or lost a body).
    pub fn ended(&self) -> &[(Entity, Entity)] {
        &self.ended
    }

    /// Pairs of colliders that started touching in the step: the pairs of
    /// [`started`](Self::started) whose bodies have no child colliders, and the touching
    /// colliders of those that have (a body's own collider is named by the body).
    pub fn colliders_started(&self) -> &[ColliderPair] {
        &self.colliders_started
    }

    /// Pairs of colliders that stopped touching in the step (or lost a body), as
    /// [`colliders_started`](Self::colliders_started).
    pub fn colliders_ended(&self) -> &[ColliderPair] {
        &self.colliders_ended
    }
}
