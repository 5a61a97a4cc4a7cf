//! The ECS side of a physics step, one file a stage, in the order [`crate::schedule`] chains
//! them: [`prepare`], [`broad_phase`], [`narrow_phase`], [`solve`], [`write_back`](mod@write_back), [`sleep`],
//! [`messages`]. Each stage is a thin gather and scatter around the plain functions of
//! [`crate::collision`] and [`crate::dynamics`], and has its own plugin adding its system to its
//! [`PhysicsSystems`](crate::schedule::PhysicsSystems) set, so a stage can be left out or
//! replaced in [`PhysicsPlugins`](crate::PhysicsPlugins). What a stage writes is a resource of
//! its own, readable from outside the crate: the bodies of the step in [`PhysicsState`]
//! (prepare), the overlapping pairs in [`CandidatePairs`] (broad phase), the contact rows in
//! [`ContactRows`] (narrow phase, impulses from the solve), the step's events in
//! [`StepEvents`] (narrow phase and solve); the broad phase also keeps the persistent
//! [`BroadPhaseTree`] of every body's box for spatial queries. A
//! replacement broad phase reads the bodies' boxes and ends with [`CandidatePairs::set`]
//! (`tests/replace_stage.rs` swaps in an all-pairs one and gets bit-identical results); the
//! tree is then left empty. Nothing in `collision`, `dynamics` or `schedule` imports
//! this module.

pub mod broad_phase;
pub mod messages;
pub mod narrow_phase;
pub mod prepare;
pub mod sleep;
pub mod solve;
pub mod write_back;

pub use broad_phase::{BroadPhasePlugin, update_broad_phase};
pub use messages::{MessagesPlugin, send_messages};
pub use narrow_phase::{NarrowPhasePlugin, update_narrow_phase};
pub use prepare::{PreparePlugin, prepare_bodies};
pub use sleep::{SleepPlugin, update_sleep};
pub use solve::{SolvePlugin, solve_contacts};
pub use write_back::{WriteBackPlugin, write_back};

use std::ops::Range;

use bevy::prelude::*;
use parry3d::math::Pose;
use parry3d::shape::SharedShape;

use crate::collision::BroadPhaseTree;
use crate::collision::layers::CollisionLayers;
use crate::collision::narrow_phase::{TOUCH_DISTANCE, UnitShapes};
use crate::collision::sensor::Reporting;
use crate::dynamics::forces::BodyMotion;
use crate::dynamics::sleep::{SleepConfig, SleepingSet};
use crate::dynamics::solver::{ContactConstraint, Motion, SolverBody};
use crate::dynamics::validation::{DEFAULT_DT, PhysicsLengthUnit, validated_dt};
use crate::dynamics::{CombineRules, Gravity, SolverConfig};
use crate::messages::Impact;
use crate::schedule::PhysicsTime;

/// Initialises the resources the stages share, so that each stage plugin can run with any of
/// the others replaced or left out.
fn init_stage_state(app: &mut App) -> &mut App {
    app.init_resource::<PhysicsState>()
        .init_resource::<BroadPhaseTree>()
        .init_resource::<CandidatePairs>()
        .init_resource::<ContactRows>()
        .init_resource::<StepEvents>()
}

/// The bodies of the current step, packed by the prepare stage (and the sleeping bodies the
/// broad phase wakes), with the settings of the step and the bookkeeping of sleeping bodies.
#[derive(Resource, Default)]
pub struct PhysicsState {
    /// Step length, s.
    dt: f32,
    /// The entity of each solver body.
    entities: Vec<Entity>,
    /// Solver bodies, in the order of `entities`.
    bodies: Vec<SolverBody>,
    /// Local centre of mass of each body (the pose in `Transform` is the body origin).
    local_com: Vec<Vec3>,
    shapes: Vec<SharedShape>,
    /// Collider pose (the body origin) at the start of the step.
    poses: Vec<Pose>,
    restitution: Vec<f32>,
    friction: Vec<f32>,
    /// The combine rules each body asks for.
    combine: Vec<CombineRules>,
    /// Each body's collision layers ([`CollisionLayers::DEFAULT`] without the component).
    layers: Vec<CollisionLayers>,
    /// What each body asks the step to report (sensor, events, colliding entities).
    reporting: Vec<Reporting>,
    /// Scratch: the bodies that lost their `CollisionLayers` or `Sensor` since the last step,
    /// sorted (they are active: pairs they had been filtered from may start).
    layers_removed: Vec<Entity>,
    /// How far each body can move in one step, m: `|v| dt + |w| dt R`.
    reach: Vec<f32>,
    /// How far rotation alone can carry a point of each body in one step, m: `|w| dt R`, zero
    /// for spheres (a turning sphere's surface stays in place) and static bodies.
    spin_reach: Vec<f32>,
    aabbs: Vec<parry3d::bounding_volume::Aabb>,
    /// The body can have gained or lost an overlap since the last step: awake, kinematic, or
    /// static or sleeping but changed (or asleep only since the end of the last step). Pairs
    /// of two inactive bodies are carried over from the last step instead of being searched.
    active: Vec<bool>,
    /// Scratch: (entity, body index), sorted, to find the carried-over pairs' bodies.
    index_of: Vec<(Entity, u32)>,
    index_pairs: Vec<(u32, u32)>,
    /// Bounding radius of each body about its centre of mass, m.
    radius: Vec<f32>,
    /// Each body's collider takes part in contacts (no `ColliderDisabled`).
    collides: Vec<bool>,
    /// The dynamic bodies with forces, damping, speed caps or translation locks: index, what
    /// they have, and the centre of mass at the start of the step.
    motion: Vec<(usize, BodyMotion, Vec3)>,
    /// For a body that entered the step asleep: the island it sleeps with, and the dynamic
    /// solver body it becomes if it is woken in this step.
    asleep: Vec<Option<(Entity, SolverBody)>>,
    /// Islands woken in this step; their `Sleeping` markers are removed.
    woken: Vec<Entity>,
    /// Bodies of pairs that disappeared in this step (a neighbour despawned, was quarantined
    /// or moved away): a sleeping one wakes its island.
    lost: Vec<Entity>,
    /// The sleeping bodies that sit out the step until something touches them.
    sleepers: SleepingSet,
    /// Counts steps (wrapping), to mark the sleepers put into this step's arrays.
    step: u32,
    /// Sleeping bodies put into this step's arrays (read, or brought in).
    entered: Vec<Entity>,
    /// Bodies that left the step since the last one: despawned, collider removed, or
    /// quarantined. Their resting pairs end.
    departed: Vec<Entity>,
    /// Sleeping-marked bodies read every step: quarantined ones, and those that are not
    /// dynamic (they take part in the step as any other body).
    read_every_step: Vec<Entity>,
    /// Steps since the propagation bound warning was last logged.
    steps_since_bound_warning: u32,
    /// The shapes scaled to the length unit, for contact generation.
    unit_shapes: UnitShapes,
    /// Colliders on child entities, parented bodies and scaled shapes (see
    /// [`prepare::resolve_hierarchy`]).
    hierarchy: prepare::HierarchyState,
    /// The settings of this step, validated (see [`validate_settings`]) and with lengths and
    /// speeds scaled by the length unit: the stages read these, never the resources, so the
    /// solver only sees valid values.
    settings: Settings,
    /// The last valid settings as the user gave them (unscaled): what an invalid value falls
    /// back on.
    last_good: Settings,
    /// The messages about invalid settings logged in the last step: a message is logged when
    /// it first appears, not again while the same bad value stays.
    settings_reported: Vec<String>,
}

impl PhysicsState {
    /// Step length of the current step, s.
    pub fn dt(&self) -> f32 {
        self.dt
    }

    /// The entity of each body in the step; a body's index in the step is its index here.
    pub fn entities(&self) -> &[Entity] {
        &self.entities
    }

    /// The solver bodies of the step, in the order of [`entities`](Self::entities): as the
    /// prepare stage packed them until the solve, as the solve left them after it.
    pub fn bodies(&self) -> &[SolverBody] {
        &self.bodies
    }

    /// Each body's bounding box for the broad phase: its collider's box at the start of the
    /// step, swept along its motion over the step and widened by the contact margin.
    pub fn aabbs(&self) -> &[parry3d::bounding_volume::Aabb] {
        &self.aabbs
    }

    /// Whether each body can have gained or lost an overlap since the last step (awake,
    /// kinematic, or changed): a broad phase pairs every active body with every body whose box
    /// its box overlaps; pairs of two inactive bodies carry over from the last step.
    pub fn active(&self) -> &[bool] {
        &self.active
    }

    /// Each body's collision layers, in the order of [`entities`](Self::entities)
    /// ([`CollisionLayers::DEFAULT`] for a body without the component).
    pub fn layers(&self) -> &[CollisionLayers] {
        &self.layers
    }

    /// What each body asks the step to report, in the order of [`entities`](Self::entities).
    pub fn reporting(&self) -> &[Reporting] {
        &self.reporting
    }

    /// Each body's collider shape (in metres), in the order of [`entities`](Self::entities).
    pub(crate) fn shapes(&self) -> &[SharedShape] {
        &self.shapes
    }

    /// Each body's collider pose (its origin) at the start of the step.
    pub(crate) fn poses(&self) -> &[Pose] {
        &self.poses
    }

    /// Each body's local centre of mass (zero for bodies that are not dynamic).
    pub(crate) fn local_com(&self) -> &[Vec3] {
        &self.local_com
    }

    /// Whether each body's collider takes part in contacts (no `ColliderDisabled`).
    pub(crate) fn collides(&self) -> &[bool] {
        &self.collides
    }

    /// Body `k` takes part in contacts: dynamic, or asleep (a sleeping body's pairs are kept, so
    /// sleep does not end collisions).
    fn live(&self, k: usize) -> bool {
        self.bodies[k].motion == Motion::Dynamic || self.asleep[k].is_some()
    }

    /// Whether bodies `i` and `j`, if their boxes overlap, make a candidate pair, and of which
    /// kind (see [`CandidatePairs::set`], which keeps the pairs this accepts). Neither may have a
    /// disabled collider, and their layers must
    /// interact. A pair with a dynamic or sleeping body is [`PairKind::Solved`] unless a sensor
    /// is in it. A pair of two non-dynamic bodies is [`PairKind::DetectOnly`] when one of them
    /// asks for reports (sensor, events or colliding entities) and one of them is kinematic or a
    /// sensor; otherwise (two plain static bodies, or nobody asking) it is not a pair.
    ///
    /// A broad phase that wakes sleeping bodies can ask this first: only a solved pair pushes.
    pub fn pair_kind(&self, i: usize, j: usize) -> Option<PairKind> {
        if !self.collides[i] || !self.collides[j] || !self.layers[i].interacts_with(self.layers[j])
        {
            return None;
        }
        let (ri, rj) = (self.reporting[i], self.reporting[j]);
        let sensor = ri.sensor() || rj.sensor();
        if self.live(i) || self.live(j) {
            return Some(if sensor {
                PairKind::DetectOnly
            } else {
                PairKind::Solved
            });
        }
        let kinematic = |k: usize| self.bodies[k].motion == Motion::Kinematic;
        ((ri.any() || rj.any()) && (sensor || kinematic(i) || kinematic(j)))
            .then_some(PairKind::DetectOnly)
    }
}

/// What the step does with a candidate pair (see [`PhysicsState::pair_kind`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PairKind {
    /// Contacts found and solved: contact rows push the bodies apart.
    Solved,
    /// Contacts found for touching state and collision messages only, never solved: a
    /// [`Sensor`](crate::collision::Sensor) is in the pair, or neither body is dynamic or
    /// asleep.
    DetectOnly,
}

/// The broad phase's output: the body pairs whose boxes overlap, for the narrow phase.
#[derive(Resource, Default)]
pub struct CandidatePairs {
    /// The pairs as entities `(a, b)`, `a < b`, sorted.
    pairs: Vec<(Entity, Entity)>,
    /// Each pair's body indices in [`PhysicsState::entities`], in the order of `(a, b)`.
    indices: Vec<(usize, usize)>,
    /// Per pair: neither body is awake and dynamic (a sleeping body with a sleeping or static
    /// one), so the pair keeps its manifolds and touching state without a narrow phase.
    dormant: Vec<bool>,
    /// Per pair: its contacts are only detected (touching state and collision messages), never
    /// solved: a sensor is in it, or neither body is dynamic or asleep.
    detect_only: Vec<bool>,
}

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
    ///   bodies' [`CollisionLayers`] must interact
    ///   ([`CollisionLayers::interacts_with`]);
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
        /// A kept pair: its entities, its body indices in their order, detect-only.
        type Kept = ((Entity, Entity), (usize, usize), bool);
        let mut keyed: Vec<Kept> = overlapping
            .into_iter()
            .filter_map(|(i, j)| {
                let detect_only = state.pair_kind(i, j)? == PairKind::DetectOnly;
                let (ei, ej) = (state.entities[i], state.entities[j]);
                Some(if ei < ej {
                    ((ei, ej), (i, j), detect_only)
                } else {
                    ((ej, ei), (j, i), detect_only)
                })
            })
            .collect();
        keyed.sort_unstable_by_key(|(k, _, _)| *k);
        self.pairs.clear();
        self.indices.clear();
        self.dormant.clear();
        self.detect_only.clear();
        for (k, (i, j), detect_only) in keyed {
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
    }
}

/// The narrow phase's output: one contact row per contact point of the candidate pairs, with
/// the impulses the solve leaves in them.
#[derive(Resource, Default)]
pub struct ContactRows {
    contacts: Vec<ContactConstraint>,
    /// Contact index ranges of one body pair each.
    pair_ranges: Vec<Range<usize>>,
    /// For each contact: (pair, manifold, point) in [`ContactPairs`](crate::collision::ContactPairs).
    keys: Vec<(u32, u32, u32)>,
    /// The detect-only candidate pairs found touching in the step, as indices of
    /// [`CandidatePairs::pairs`], ascending.
    detected: Vec<u32>,
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
}

/// What happened in the step, as the messages stage sends it.
#[derive(Resource, Default)]
pub struct StepEvents {
    impacts: Vec<Impact>,
    started: Vec<(Entity, Entity)>,
    ended: Vec<(Entity, Entity)>,
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
}

/// The validated settings of one step.
#[derive(Clone, Debug)]
struct Settings {
    config: SolverConfig,
    gravity: Gravity,
    sleep: SleepConfig,
    dt: f32,
    length_unit: f32,
    /// [`TOUCH_DISTANCE`] in the length unit, m.
    touch_distance: f32,
    /// [`PhysicsTime::relative_speed`](crate::schedule::PhysicsTime::relative_speed).
    relative_speed: f32,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            config: SolverConfig::default(),
            gravity: Gravity::default(),
            sleep: SleepConfig::default(),
            dt: DEFAULT_DT,
            length_unit: 1.0,
            touch_distance: TOUCH_DISTANCE,
            relative_speed: 1.0,
        }
    }
}

/// Validates the settings resources and the step length (the schedule's delta times the
/// physics clock's relative speed) against the last good values (see
/// [`SolverConfig::validated`]), logging each invalid value once, as an error naming the
/// field and the value, for as long as it stays.
fn validate_settings(
    state: &mut PhysicsState,
    config: &SolverConfig,
    gravity: &Gravity,
    sleep: &SleepConfig,
    unit: &PhysicsLengthUnit,
    clock: &PhysicsTime,
    delta: f32,
) {
    let last = &state.last_good;
    let (relative_speed, speed_error) = clock.validated_speed(last.relative_speed);
    // Speed 1 leaves the delta as it is, bit for bit (`x * 1.0 == x` in IEEE arithmetic).
    let dt = delta * relative_speed;
    let (config, mut errors) = config.validated(&last.config);
    errors.extend(speed_error);
    let (gravity, e) = gravity.validated(last.gravity);
    errors.extend(e);
    let (sleep, e) = sleep.validated(&last.sleep);
    errors.extend(e);
    let (dt, e) = validated_dt(dt, last.dt);
    errors.extend(e);
    let (unit, e) = unit.validated(last.length_unit);
    errors.extend(e);
    for error in &errors {
        if !state.settings_reported.contains(error) {
            log::error!("impact3d: invalid setting: {error}");
        }
    }
    state.settings_reported = errors;
    state.last_good = Settings {
        config,
        gravity,
        sleep,
        dt,
        length_unit: unit,
        touch_distance: TOUCH_DISTANCE,
        relative_speed,
    };
    state.settings = state.last_good.scaled();
}

impl Settings {
    /// These settings with every length (m) and speed (m/s) multiplied by the length unit.
    fn scaled(&self) -> Settings {
        let u = self.length_unit;
        let mut s = self.clone();
        let c = &mut s.config;
        c.contact_margin *= u;
        c.linear_slop *= u;
        c.velocity_tolerance *= u;
        c.restitution_threshold *= u;
        c.max_push_out_speed *= u;
        s.sleep.linear_threshold *= u;
        s.touch_distance = TOUCH_DISTANCE * u;
        s
    }
}

// The sleeping set's wake fixpoint, shared by the prepare stage and the broad phase.

/// Marks every body that is not static in the solve (a woken sleeper) as active.
fn mark_awake_active(state: &mut PhysicsState) {
    for (active, body) in state.active.iter_mut().zip(&state.bodies) {
        *active |= body.motion != Motion::Static;
    }
}

/// Swaps the bodies of the given islands back in as dynamic bodies (bringing in those that sat
/// out the step) and records the islands as woken (their `Sleeping` markers are removed at the
/// end of the step). Returns whether any body woke.
fn wake_islands(state: &mut PhysicsState, islands: &[Entity]) -> bool {
    if islands.is_empty() {
        return false;
    }
    let mut sorted = islands.to_vec();
    sorted.sort_unstable();
    let members: Vec<u32> = (0..state.sleepers.len() as u32)
        .filter(|&i| {
            !state.sleepers.in_step(i, state.step)
                && sorted
                    .binary_search(&state.sleepers.record(i).island)
                    .is_ok()
        })
        .collect();
    for i in members {
        bring_in(state, i);
    }
    let mut any = false;
    for i in 0..state.bodies.len() {
        if let Some((island, body)) = state.asleep[i]
            && islands.contains(&island)
        {
            state.bodies[i] = body;
            state.asleep[i] = None;
            any = true;
            if !state.woken.contains(&island) {
                state.woken.push(island);
            }
        }
    }
    any
}

/// Puts sleeping body `i` of the [`SleepingSet`] into the step's arrays, as it was gathered:
/// a static body that becomes its dynamic self if its island wakes.
fn bring_in(state: &mut PhysicsState, i: u32) {
    state.sleepers.mark_in_step(i, state.step);
    let s = state.sleepers.record(i);
    state.entities.push(s.entity);
    state.bodies.push(SolverBody::new(
        Motion::Static,
        s.body.position,
        s.body.rotation,
    ));
    state.local_com.push(s.local_com);
    state.shapes.push(s.shape.clone());
    state.poses.push(s.pose);
    state.restitution.push(s.restitution);
    state.friction.push(s.friction);
    state.combine.push(s.combine);
    state.layers.push(s.layers);
    state.reporting.push(s.reporting);
    state.reach.push(0.0);
    state.spin_reach.push(0.0);
    state.aabbs.push(state.sleepers.aabb(i));
    state.active.push(false);
    state.radius.push(s.radius);
    state.collides.push(s.collides);
    if let Some(motion) = s.motion {
        let index = state.bodies.len() - 1;
        state.motion.push((index, motion, s.body.position));
    }
    state.asleep.push(Some((s.island, s.body)));
    state.entered.push(s.entity);
}

/// Brings in every sleeping body whose box an active body's box overlaps, so that the pair
/// search finds their pairs as if every sleeping body were in the arrays.
fn bring_in_overlapped(state: &mut PhysicsState) {
    if state.sleepers.is_empty() {
        return;
    }
    let mut found = Vec::new();
    for i in 0..state.bodies.len() {
        if state.active[i] {
            state.sleepers.overlapping(&state.aabbs[i], &mut found);
        }
    }
    for k in found {
        if !state.sleepers.in_step(k, state.step) {
            bring_in(state, k);
        }
    }
}
