//! Gathering one body: from its components, through the checks of its input, to its entries in
//! the step's arrays (solver body, shape, pose, materials, swept box).

use bevy::ecs::change_detection::Tick;
use bevy::ecs::system::SystemChangeTick;
use bevy::prelude::*;
use parry3d::bounding_volume::{Aabb, BoundingVolume};
use parry3d::math::Pose;
use parry3d::shape::SharedShape;

use std::sync::Arc;

use crate::collision::collider::is_unbounded_or_hollow;
use crate::collision::narrow_phase::BOX_MARGIN_SHARE;
use crate::collision::parts::CompoundParts;
use crate::collision::sensor::Reporting;
use crate::dynamics::forces::{AccumulatedForces, BodyMotion};
use crate::dynamics::solver::{Motion, SolverBody};
use crate::dynamics::validation::body_label;
use crate::dynamics::{CombineRules, Quarantined, RigidBody};

use super::super::{PhysicsState, Settings};
use super::hierarchy::sorted_contains;
use super::motion::{body_motion, pushed_since};
use super::parts::compound_parts;
use super::query::BodyDataItem;
use super::scale::{BuiltBody, build_body};
use super::sleepers::enter_asleep;
use super::validation::{clamp_coefficient, validate, warn_on_coefficients};

/// What [`gather_body`] made of a body.
pub(super) enum Gathered {
    /// Left out of the step (bad input).
    Quarantined,
    /// Packed as a dynamic, kinematic or static body.
    Awake,
    /// Packed as a sleeping body (static in the solve unless woken).
    Asleep,
    /// Not a body of the step: a collider that is a part of another body, or a body with no
    /// collider.
    Skipped,
}

/// Validates one body and packs it into the step's arrays (see
/// [`prepare_bodies`](super::prepare_bodies)).
pub(super) fn gather_body(
    state: &mut PhysicsState,
    commands: &mut Commands,
    ticks: &SystemChangeTick,
    item: &mut BodyDataItem,
) -> Gathered {
    let entity = item.entity;
    let hierarchy = &state.hierarchy;
    if hierarchy.is_attached(entity) {
        return Gathered::Skipped;
    }
    let has_parts = hierarchy.has_parts(entity);
    if item.collider.is_none() && !has_parts {
        return Gathered::Skipped;
    }
    // The world pose: the `Transform` of a top-level entity, read as it is (in place: a copy
    // read back field by field stalled on its own stores).
    let parented = hierarchy.world_pose(entity);
    let world: &Transform = match &parented {
        Some(world) => world,
        None => item.transform.into_inner(),
    };
    let disturbed = hierarchy.is_disturbed(entity);
    let reshaped = hierarchy.is_reshaped(entity);
    let was_built = hierarchy.was_built(entity);
    let kind = item.body.as_deref().copied().unwrap_or(RigidBody::Static);
    let Some(built) = built_shape(state, item, has_parts, world.scale) else {
        return Gathered::Skipped;
    };
    let geometry = match &built {
        Ok(Some(changed)) => Some((state.hierarchy.built.get(&entity), *changed)),
        _ => None,
    };
    let check = built
        .and_then(|_| {
            // Built in an earlier step and no longer (its scale went back to 1, or it lost its
            // child colliders): its mass properties are its own collider's again.
            let unbuilt = geometry.is_none() && was_built;
            validate(item, kind, world, geometry, reshaped || unbuilt)
        })
        .and_then(|()| match kind {
            RigidBody::Dynamic => body_motion(item, world.rotation, state.settings.gravity.0),
            _ => Ok(None),
        });
    let pushed = spend_forces(item, ticks.this_run());
    let Some(extra) = admit(commands, item, check) else {
        return Gathered::Quarantined;
    };
    warn_on_coefficients(item);
    let rotation = world.rotation.normalize();
    let translation = world.translation;
    let (built_shape, rebuilt) = step_shape(geometry, item);
    let parts = match geometry {
        Some((Some(built), _)) if has_parts => compound_parts(state, item, built),
        _ => None,
    };
    // The solver body goes to its array at once and is changed there: moved by value through
    // the gathering (with its sleeping twin), it cost more than the gathering itself.
    let i = state.bodies.len();
    let local_com = push_solver_body(state, item, kind, translation, rotation, extra.as_ref());
    let shape = built_shape.as_ref().unwrap_or_else(|| own_shape(item));
    let radius = put_shape(state, i, shape, local_com);
    // A sleeping body enters the step as static; it is swapped back in if woken.
    let asleep = enter_asleep(state, i, item, kind, ticks.this_run(), pushed || disturbed);
    let pose = Pose::from_parts(translation, rotation);
    let body = &state.bodies[i];
    let sweep = sweep(&state.settings, body, shape, &pose, radius);
    let active = is_active(state, item, body.motion, disturbed || rebuilt);
    if let Some(motion) = extra {
        let position = body.position;
        state.motion.push((i, motion, position));
    }
    let packed = Packed {
        pose,
        sweep,
        active,
        parts,
    };
    pack(state, item, packed, asleep)
}

/// The shape of a body with child colliders or a world `scale`, built (and kept until it
/// changes; see [`build_body`]): `Some(Ok(Some(changed)))`; any other body has its collider's
/// shape, as it is: `Some(Ok(None))`. `None`: the body has no collider left (every part
/// disabled); an error names a bad scale or collider.
fn built_shape(
    state: &mut PhysicsState,
    item: &BodyDataItem,
    has_parts: bool,
    scale: Vec3,
) -> Option<Result<Option<bool>, String>> {
    if !has_parts && scale == Vec3::ONE {
        return Some(Ok(None));
    }
    match build_body(state, item, scale) {
        Ok(None) => None,
        built => Some(built),
    }
}

/// The shape built for the body (`geometry`, see [`validate`]) and whether it changed in this
/// step; `None` for a body with its own collider's shape (see [`own_shape`]).
fn step_shape(
    geometry: Option<(Option<&BuiltBody>, bool)>,
    item: &BodyDataItem,
) -> (Option<SharedShape>, bool) {
    match geometry {
        Some((Some(built), changed)) => (Some(built.shape.clone()), changed),
        _ => {
            debug_assert!(item.collider.is_some());
            (None, false)
        }
    }
}

/// The shape of a body whose shape is not built: its own collider's.
fn own_shape<'a>(item: &'a BodyDataItem) -> &'a SharedShape {
    item.collider
        .as_deref()
        .expect("a body without parts has its own collider")
        .shape()
}

/// Sets body `i`'s shape, local centre of mass and bounding radius in the step's arrays, which
/// still hold the last step's entries from `i` on (see `begin_step`), and returns the radius.
/// An entry that holds the same shape (the same `Arc`, kept alive by that entry, so no other
/// shape can have its address) about the same centre of mass is kept as it is: a body that
/// keeps its place and shape from step to step costs neither reference counting nor a radius.
fn put_shape(state: &mut PhysicsState, i: usize, shape: &SharedShape, local_com: Vec3) -> f32 {
    if i < state.shapes.len() {
        if Arc::ptr_eq(&state.shapes[i].0, &shape.0) && state.local_com[i] == local_com {
            return state.radius[i];
        }
        let radius = bounding_radius(shape, local_com);
        state.shapes[i] = shape.clone();
        state.local_com[i] = local_com;
        state.radius[i] = radius;
        return radius;
    }
    let radius = bounding_radius(shape, local_com);
    state.shapes.push(shape.clone());
    state.local_com.push(local_com);
    state.radius.push(radius);
    radius
}

/// Whether a sleeping body was pushed (see [`pushed_since`]) before tick `now`, read before
/// its one-off forces are spent: this step has read them, so they are spent, whatever becomes
/// of the body.
fn spend_forces(item: &mut BodyDataItem, now: Tick) -> bool {
    let pushed = item
        .sleeping
        .as_ref()
        .is_some_and(|marker| pushed_since(&item.motion, marker.added(), now));
    if let Some(accumulated) = item.motion.accumulated.as_mut() {
        accumulated.set_if_neq(AccumulatedForces::default());
    }
    pushed
}

/// A body's place in the step given the outcome of its checks: with bad input it is
/// quarantined (`None`; the error is logged, naming the entity, once for each reason); valid
/// again after a quarantine, it rejoins. `Some` holds its motion beyond gravity and contacts.
fn admit(
    commands: &mut Commands,
    item: &BodyDataItem,
    check: Result<Option<BodyMotion>, String>,
) -> Option<Option<BodyMotion>> {
    let label = || body_label(item.entity, item.name);
    match (check, item.quarantined) {
        (Err(reason), quarantined) => {
            if quarantined.is_none_or(|q| q.reason != reason) {
                log::error!(
                    "impact3d: {} is left out of the physics step: {reason}",
                    label()
                );
                commands.entity(item.entity).insert(Quarantined { reason });
            }
            None
        }
        (Ok(extra), Some(_)) => {
            log::info!(
                "impact3d: {} is valid again and rejoins the physics step",
                label()
            );
            commands.entity(item.entity).remove::<Quarantined>();
            Some(extra)
        }
        (Ok(extra), None) => Some(extra),
    }
}

/// Appends the solver body of a body of `kind` at `translation` and unit `rotation`, with its
/// mass properties and velocities, to the step's array; returns its local centre of mass (zero
/// unless it is dynamic). Forces, accelerations and damping (`extra`) act before the solve
/// (see `crate::dynamics::forces`).
fn push_solver_body(
    state: &mut PhysicsState,
    item: &BodyDataItem,
    kind: RigidBody,
    translation: Vec3,
    rotation: Quat,
    extra: Option<&BodyMotion>,
) -> Vec3 {
    let motion = match kind {
        RigidBody::Dynamic => Motion::Dynamic,
        RigidBody::Kinematic => Motion::Kinematic,
        RigidBody::Static => Motion::Static,
    };
    let computed = item.computed.as_deref().copied().unwrap_or_default();
    let local_com = if motion == Motion::Dynamic {
        computed.local_center_of_mass
    } else {
        Vec3::ZERO
    };
    let linear = item.linear_velocity.as_deref().map_or(Vec3::ZERO, |v| v.0);
    let angular = item.angular_velocity.as_deref().map_or(Vec3::ZERO, |w| w.0);
    // Set in its array: each builder call by value copied the (large) body.
    state.bodies.push(SolverBody::new(
        motion,
        translation + rotation * local_com,
        rotation,
    ));
    let body = state.bodies.last_mut().expect("just pushed");
    body.set_mass(
        computed.inverse_mass,
        computed.local_inverse_inertia,
        computed.isotropic,
        item.locked.map_or(BVec3::FALSE, |l| l.rotation),
    );
    body.set_velocity(linear, angular);
    if let Some(extra) = extra {
        extra.start_step(body, state.settings.dt);
    }
    local_com
}

/// The radius of the sphere about `local_com` that holds the shape's local box (0 for an
/// unbounded or hollow shape, which never moves).
fn bounding_radius(shape: &SharedShape, local_com: Vec3) -> f32 {
    if is_unbounded_or_hollow(shape.as_ref()) {
        return 0.0;
    }
    let local = shape.compute_local_aabb();
    (local.mins - local_com)
        .abs()
        .max((local.maxs - local_com).abs())
        .length()
}

/// How far a body can get in the step, and the box the broad phase sees.
struct Sweep {
    /// How far it can move, m: `(|v| + speed gained + |w| R) dt`.
    reach: f32,
    /// How far rotation alone can carry a point, m: `|w| dt R` (zero for spheres).
    spin_reach: f32,
    aabb: Aabb,
}

/// The reach and swept box of `body` (with `shape` at `pose`, bounding radius `radius`).
fn sweep(
    settings: &Settings,
    body: &SolverBody,
    shape: &SharedShape,
    pose: &Pose,
    radius: f32,
) -> Sweep {
    let (dt, gravity) = (settings.dt, settings.gravity.0);
    let margin = settings.narrow.contact_margin;
    let moving = settings.narrow.speculative_contacts && body.motion != Motion::Static;
    let dynamic = body.motion == Motion::Dynamic;
    // Gravity adds up to |g| dt to a dynamic body's speed within the step: without it, a
    // body falling from just beyond its reach lands `|g| dt^2` deep.
    let gained = if dynamic { gravity.length() * dt } else { 0.0 };
    // The extra acceleration the solver integrates with gravity (see `BodyMotion::start_step`).
    let accelerated = if dynamic {
        body.extra_acceleration
    } else {
        Vec3::ZERO
    };
    let speed_gained = if accelerated == Vec3::ZERO {
        gained
    } else {
        (gravity + accelerated).length() * dt
    };
    let spin = body.angular_velocity.length() * radius * dt;
    let reach = if moving {
        (body.linear_velocity.length() + speed_gained + body.angular_velocity.length() * radius)
            * dt
    } else {
        0.0
    };
    // The box swept along the step's linear motion, widened by the margin and by how far
    // rotation can carry a point (|w| dt R): unlike a box widened by the whole reach in
    // every direction, it does not pull in bodies beside a fast body's path.
    let aabb = shape.compute_aabb(pose);
    let aabb = if moving {
        let mut travel =
            body.linear_velocity * dt + 0.5 * gained * dt * gravity.normalize_or_zero();
        // A free body flies on the parabola of `g + a`.
        if accelerated != Vec3::ZERO {
            travel += 0.5 * accelerated * dt * dt;
        }
        let end = Aabb::new(aabb.mins + travel, aabb.maxs + travel);
        aabb.merged(&end).loosened(BOX_MARGIN_SHARE * margin + spin)
    } else {
        aabb.loosened(BOX_MARGIN_SHARE * margin)
    };
    let sphere = shape.as_ball().is_some();
    Sweep {
        reach,
        spin_reach: if moving && !sphere { spin } else { 0.0 },
        aabb,
    }
}

/// Whether a body can have gained or lost an overlap since the last step. Dynamic and
/// kinematic bodies are active (asleep ones are static here, and turned back by
/// `wake_islands` if woken); a static or sleeping body only if something about it changed
/// (`disturbed`: its ancestors moved, or its parts or built shape changed), or it fell asleep
/// at the end of the last step (its pairs were found from the box it had at the start of that
/// step).
fn is_active(state: &PhysicsState, item: &BodyDataItem, motion: Motion, disturbed: bool) -> bool {
    motion != Motion::Static
        || item.transform.is_changed()
        || item.collider.as_ref().is_some_and(|c| c.is_changed())
        || disturbed
        || item.body.as_ref().is_some_and(|b| b.is_changed())
        || item.quarantined.is_some()
        || item.sleeping.as_ref().is_some_and(|m| m.is_added())
        || item.layers.as_ref().is_some_and(|l| l.is_changed())
        || item.sensor.as_ref().is_some_and(|s| s.is_added())
        || sorted_contains(&state.layers_removed, item.entity)
}

/// The rest of a body as the step's arrays take it (its solver body, sleeping twin, motion,
/// shape, centre of mass and radius are in theirs already).
struct Packed {
    pose: Pose,
    sweep: Sweep,
    active: bool,
    /// A body with child colliders: its colliders as its contacts see them, and whether a
    /// child collider asks for reports.
    parts: Option<(Arc<CompoundParts>, bool)>,
}

/// Appends the rest of a body to the step's arrays, with the materials, layers and reports it
/// asks for; `asleep`: it entered the step asleep.
fn pack(state: &mut PhysicsState, item: &BodyDataItem, packed: Packed, asleep: bool) -> Gathered {
    state.entities.push(item.entity);
    state.poses.push(packed.pose);
    state.restitution.push(clamp_coefficient(
        item.restitution.as_deref().map(|r| r.0),
        1.0,
    ));
    state.friction.push(clamp_coefficient(
        item.friction.as_deref().map(|f| f.0),
        f32::INFINITY,
    ));
    state.combine.push(CombineRules {
        restitution: item.restitution_combine.map(|c| c.0),
        friction: item.friction_combine.map(|c| c.0),
    });
    let (layers, mut reporting) = (
        item.layers.as_deref().copied().unwrap_or_default(),
        reporting(item),
    );
    match &packed.parts {
        Some((parts, reports)) => {
            // Paired as a whole when any two colliders may interact; a sensor only when all
            // its colliders are (the narrow phase sorts out the rest, collider by collider).
            state.layers.push(parts.layers());
            reporting.0 &= !Reporting::SENSOR;
            if parts.all_sensors() {
                reporting.0 |= Reporting::SENSOR;
            }
            if *reports {
                reporting.0 |= Reporting::EVENTS;
            }
        }
        None => state.layers.push(layers),
    }
    state.reporting.push(reporting);
    state.parts.push(packed.parts.map(|(p, _)| p));
    state.reach.push(packed.sweep.reach);
    state.spin_reach.push(packed.sweep.spin_reach);
    state.aabbs.push(packed.sweep.aabb);
    state.active.push(packed.active);
    state.collides.push(!item.motion.collider_disabled);
    if asleep {
        Gathered::Asleep
    } else {
        Gathered::Awake
    }
}

/// What a body asks the step to report: sensor, collision events, colliding entities.
fn reporting(item: &BodyDataItem) -> Reporting {
    let mut reporting = Reporting::default();
    for (has, bit) in [
        (item.sensor.is_some(), Reporting::SENSOR),
        (item.events, Reporting::EVENTS),
        (item.colliding, Reporting::COLLIDING),
    ] {
        if has {
            reporting.0 |= bit;
        }
    }
    reporting
}
