//! The ECS side of a physics step, one module a stage, in the order [`crate::schedule`] chains
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

mod outputs;
mod settings;
mod wake;

pub use broad_phase::{BroadPhasePlugin, update_broad_phase};
pub use messages::{MessagesPlugin, send_messages};
pub use narrow_phase::{NarrowPhasePlugin, update_narrow_phase};
pub use prepare::{PreparePlugin, prepare_bodies};
pub use sleep::{SleepPlugin, update_sleep};
pub use solve::{SolvePlugin, solve_contacts};
pub use write_back::{WriteBackPlugin, write_back};

pub use outputs::{CandidatePairs, ColliderPair, ContactRows, StepEvents};
use settings::{Settings, validate_settings};
use wake::{bring_in_overlapped, mark_awake_active, wake_islands};

use bevy::prelude::*;
use parry3d::math::Pose;
use parry3d::shape::SharedShape;

use std::sync::Arc;

use crate::collision::layers::CollisionLayers;
use crate::collision::narrow_phase::UnitShapes;
use crate::collision::parts::{CompoundParts, PartMaterial};
use crate::collision::sensor::Reporting;
use crate::collision::{BroadPhaseTree, NarrowPhaseConfig};
use crate::dynamics::CombineRules;
use crate::dynamics::forces::BodyMotion;
use crate::dynamics::sleep::SleepingSet;
use crate::dynamics::solver::{Motion, SolverBody};

/// Initialises the resources the stages share, so that each stage plugin can run with any of
/// the others replaced or left out: among them the [`NarrowPhaseConfig`] that the prepare stage
/// (boxes widened by the margin), the narrow phase and the solve read.
fn init_stage_state(app: &mut App) -> &mut App {
    app.init_resource::<PhysicsState>()
        .init_resource::<NarrowPhaseConfig>()
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
    /// For each body with child colliders, its colliders as its contacts see them (material,
    /// layers, sensor flag; see [`CompoundParts`]); `None` for any other body, whose contacts
    /// take the body's own.
    parts: Vec<Option<Arc<CompoundParts>>>,
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
    /// For a body that entered the step asleep: the island it sleeps with (`None` once woken).
    asleep: Vec<Option<Entity>>,
    /// For each body that entered the step asleep, by index in the step (increasing): the
    /// dynamic solver body it becomes if it is woken in this step. Kept apart from `asleep`,
    /// whose entry every body of the step has: a solver body in each entry made that array
    /// as large as the bodies' own, written for every body at every step.
    asleep_twins: Vec<(usize, SolverBody)>,
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
    /// Scratch: the solver's buffers, kept between steps.
    solver_scratch: crate::dynamics::solver::SolverScratch,
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

    /// The colliders of each body with child colliders, in the order of
    /// [`entities`](Self::entities) (`None` for any other body; see [`CompoundParts`]).
    pub fn parts(&self) -> &[Option<Arc<CompoundParts>>] {
        &self.parts
    }

    /// The collider of body `k` that its shape's subshape `subshape` belongs to: one of its
    /// colliders for a body with child colliders, else the body itself with its material,
    /// layers and sensor flag.
    pub fn part_of(&self, k: usize, subshape: u32) -> PartMaterial {
        match &self.parts[k] {
            Some(parts) => *parts.of_subshape(subshape),
            None => PartMaterial {
                collider: self.entities[k],
                restitution: self.restitution[k],
                friction: self.friction[k],
                combine: self.combine[k],
                layers: self.layers[k],
                sensor: self.reporting[k].sensor(),
            },
        }
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
