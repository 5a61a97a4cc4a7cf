//! The ECS systems of a physics step: thin gather and scatter around the plain functions of
//! [`crate::collision`] and [`crate::dynamics::solver`]. Their order is set in
//! [`crate::schedule`].

use std::ops::Range;

use bevy::ecs::query::QueryData;
use bevy::ecs::system::{SystemChangeTick, SystemParam};
use bevy::prelude::*;
use parry3d::bounding_volume::BoundingVolume;
use parry3d::math::Pose;
use parry3d::query::cast_shapes_nonlinear;
use parry3d::shape::{Ball, Shape, SharedShape};

use crate::collision::broad_phase::pairs_with_active;
use crate::collision::narrow_phase::{
    ContactImpulse, Meeting, StepMotion, TOUCH_DISTANCE, UnitShapes, binary_unit, time_of_impact,
};
use crate::collision::{Collider, ContactPairs};
use crate::dynamics::sleep::{
    SleepConfig, SleepTimer, Sleeper, Sleeping, SleepingSet, islands_to_sleep,
};
use crate::dynamics::solver::{self, ContactConstraint, Motion, SolverBody};
use crate::dynamics::validation::{
    DEFAULT_DT, MAX_ANGULAR_SPEED, MAX_COORDINATE, MAX_LINEAR_SPEED, PhysicsLengthUnit, body_label,
    check_length, validated_dt, within,
};
use crate::dynamics::{
    AngularVelocity, ComputedMass, Density, Friction, Gravity, ImpactMessages, LinearVelocity,
    LockedAxes, Mass, Quarantined, Restitution, RigidBody, SolverConfig, SolverStats,
};
use crate::messages::{CollisionEnded, CollisionStarted, Impact};

/// The packed arrays of the current step, gathered once and shared by the stages.
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
    sort_scratch: Vec<u32>,
    /// Broad-phase pairs as entities `(a, b)`, `a < b`, sorted, with their body indices.
    candidates: Vec<(Entity, Entity)>,
    candidate_indices: Vec<(usize, usize)>,
    /// Per candidate: neither body is awake and dynamic (a sleeping body with a sleeping or
    /// static one), so the pair keeps its manifolds and touching state without a narrow phase.
    dormant: Vec<bool>,
    contacts: Vec<ContactConstraint>,
    /// Contact index ranges of one body pair each.
    pair_ranges: Vec<Range<usize>>,
    /// For each contact: (pair, manifold, point) in [`ContactPairs`].
    contact_keys: Vec<(u32, u32, u32)>,
    impacts: Vec<Impact>,
    started: Vec<(Entity, Entity)>,
    ended: Vec<(Entity, Entity)>,
    /// Bounding radius of each body about its centre of mass, m.
    radius: Vec<f32>,
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
        }
    }
}

/// Validates the settings resources and the step length against the last good values (see
/// [`SolverConfig::validated`]), logging each invalid value once, as an error naming the
/// field and the value, for as long as it stays.
fn validate_settings(
    state: &mut PhysicsState,
    config: &SolverConfig,
    gravity: &Gravity,
    sleep: &SleepConfig,
    unit: &PhysicsLengthUnit,
    dt: f32,
) {
    let last = &state.last_good;
    let (config, mut errors) = config.validated(&last.config);
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

/// The components of a body as the prepare stage reads them.
#[derive(QueryData)]
#[query_data(mutable)]
pub struct BodyData {
    entity: Entity,
    collider: Ref<'static, Collider>,
    body: Option<Ref<'static, RigidBody>>,
    transform: Ref<'static, Transform>,
    linear_velocity: Option<Ref<'static, LinearVelocity>>,
    angular_velocity: Option<Ref<'static, AngularVelocity>>,
    restitution: Option<Ref<'static, Restitution>>,
    friction: Option<Ref<'static, Friction>>,
    mass: Option<Ref<'static, Mass>>,
    density: Option<Ref<'static, Density>>,
    computed: Option<&'static mut ComputedMass>,
    locked: Option<&'static LockedAxes>,
    name: Option<&'static Name>,
    quarantined: Option<&'static Quarantined>,
    sleeping: Option<Ref<'static, Sleeping>>,
}

/// Change filter of a sleeping body: any of the components the prepare stage reads changed
/// since its last run (or the marker was just added). A sleeping body that matches none sits
/// out the step (see [`SleepingSet`]).
type Disturbed = Or<(
    Changed<Sleeping>,
    Changed<Transform>,
    Changed<Collider>,
    Changed<RigidBody>,
    Changed<LinearVelocity>,
    Changed<AngularVelocity>,
    Changed<Restitution>,
    Changed<Friction>,
    Changed<Mass>,
    Changed<Density>,
    Changed<ComputedMass>,
    Changed<LockedAxes>,
)>;

/// The settings resources and the clock a step reads.
#[derive(SystemParam)]
pub struct StepSettings<'w> {
    time: Res<'w, Time>,
    config: Res<'w, SolverConfig>,
    gravity: Res<'w, Gravity>,
    sleep: Res<'w, SleepConfig>,
    unit: Res<'w, PhysicsLengthUnit>,
}

/// The sleeping bodies: the entities of those disturbed since the last step, and every
/// sleeping body with the components the prepare stage reads.
type SleepingBodies<'w, 's> = ParamSet<
    'w,
    's,
    (
        Query<'static, 'static, Entity, (With<Sleeping>, With<Collider>, Disturbed)>,
        Query<'static, 'static, BodyData, With<Sleeping>>,
    ),
>;

/// The removals of components a body's gathered state depends on. A sleeping body that lost
/// one is read again; one that lost its collider (or was despawned) ends its resting pairs.
#[derive(SystemParam)]
pub struct BodyRemovals<'w, 's> {
    sleeping: RemovedComponents<'w, 's, Sleeping>,
    collider: RemovedComponents<'w, 's, Collider>,
    body: RemovedComponents<'w, 's, RigidBody>,
    transform: RemovedComponents<'w, 's, Transform>,
    linear: RemovedComponents<'w, 's, LinearVelocity>,
    angular: RemovedComponents<'w, 's, AngularVelocity>,
    restitution: RemovedComponents<'w, 's, Restitution>,
    friction: RemovedComponents<'w, 's, Friction>,
    mass: RemovedComponents<'w, 's, Mass>,
    density: RemovedComponents<'w, 's, Density>,
    computed: RemovedComponents<'w, 's, ComputedMass>,
    locked: RemovedComponents<'w, 's, LockedAxes>,
}

/// Validates every body, quarantines bad ones (logging an error that names the entity), keeps
/// mass properties up to date and packs the solver bodies. A collider without a `RigidBody` is
/// static.
///
/// A sleeping body is read only when something may have touched it (a component it depends
/// on changed or was removed, or it was just put to sleep); the others keep their record in
/// the [`SleepingSet`] and sit out the step, unless the broad phase finds an awake body's box
/// over theirs or their island wakes.
pub fn prepare_bodies(
    mut commands: Commands,
    ticks: SystemChangeTick,
    settings: StepSettings,
    mut state: ResMut<PhysicsState>,
    mut awake: Query<BodyData, Without<Sleeping>>,
    mut sleeping: SleepingBodies,
    mut removals: BodyRemovals,
) {
    let state = &mut *state;
    validate_settings(
        state,
        &settings.config,
        &settings.gravity,
        &settings.sleep,
        &settings.unit,
        settings.time.delta_secs(),
    );
    let sleep_enabled = state.settings.sleep.enabled;
    state.dt = state.settings.dt;
    state.step = state.step.wrapping_add(1);
    state.entities.clear();
    state.bodies.clear();
    state.local_com.clear();
    state.shapes.clear();
    state.poses.clear();
    state.restitution.clear();
    state.friction.clear();
    state.reach.clear();
    state.spin_reach.clear();
    state.aabbs.clear();
    state.active.clear();
    state.radius.clear();
    state.asleep.clear();
    state.woken.clear();
    state.entered.clear();
    state.departed.clear();

    for mut item in awake.iter_mut() {
        if let Gathered::Quarantined = gather_body(state, &mut commands, &ticks, &mut item) {
            state.departed.push(item.entity);
        }
    }

    // The sleeping bodies to read: the disturbed ones, those that lost a component, and those
    // that must be read every step (quarantined, or not dynamic); all of them when sleeping
    // is off.
    let mut read: Vec<Entity> = std::mem::take(&mut state.read_every_step);
    state.departed.extend(removals.collider.read());
    for entity in removals.sleeping.read() {
        state.sleepers.remove(entity);
    }
    let removed = [
        removals.body.read().collect::<Vec<_>>(),
        removals.transform.read().collect(),
        removals.linear.read().collect(),
        removals.angular.read().collect(),
        removals.restitution.read().collect(),
        removals.friction.read().collect(),
        removals.mass.read().collect(),
        removals.density.read().collect(),
        removals.computed.read().collect(),
        removals.locked.read().collect(),
    ];
    for entity in removed.into_iter().flatten() {
        if state.sleepers.get(entity).is_some() {
            state.sleepers.remove(entity);
            read.push(entity);
        }
    }
    let departed = state.departed.clone();
    for &entity in &departed {
        state.sleepers.remove(entity);
    }
    if sleep_enabled {
        read.extend(sleeping.p0().iter());
    } else {
        state.sleepers.clear();
        read.extend(sleeping.p1().iter().map(|item| item.entity));
    }
    read.sort_unstable();
    read.dedup();
    state
        .sleepers
        .set_margin(state.settings.config.contact_margin);
    let mut query = sleeping.p1();
    for entity in read {
        let Ok(mut item) = query.get_mut(entity) else {
            continue;
        };
        match gather_body(state, &mut commands, &ticks, &mut item) {
            Gathered::Asleep => {
                let i = state.entities.len() - 1;
                let (island, body) = state.asleep[i].expect("gathered asleep");
                state.sleepers.insert(
                    Sleeper {
                        entity,
                        island,
                        body,
                        local_com: state.local_com[i],
                        shape: state.shapes[i].clone(),
                        pose: state.poses[i],
                        restitution: state.restitution[i],
                        friction: state.friction[i],
                        radius: state.radius[i],
                    },
                    state.step,
                );
                state.entered.push(entity);
            }
            Gathered::Quarantined => {
                state.sleepers.remove(entity);
                state.departed.push(entity);
                state.read_every_step.push(entity);
            }
            Gathered::Awake => {
                state.sleepers.remove(entity);
                state.read_every_step.push(entity);
            }
        }
    }
    if !sleep_enabled {
        state.read_every_step.clear();
        return;
    }
    // Islands the user touched wake whole.
    let woken = std::mem::take(&mut state.woken);
    wake_islands(state, &woken);
    mark_awake_active(state);
}

/// What [`gather_body`] made of a body.
enum Gathered {
    /// Left out of the step (bad input).
    Quarantined,
    /// Packed as a dynamic, kinematic or static body.
    Awake,
    /// Packed as a sleeping body (static in the solve unless woken).
    Asleep,
}

/// Validates one body and packs it into the step's arrays (see [`prepare_bodies`]).
fn gather_body(
    state: &mut PhysicsState,
    commands: &mut Commands,
    ticks: &SystemChangeTick,
    item: &mut BodyDataItem,
) -> Gathered {
    let (config, sleep) = (&state.settings.config, &state.settings.sleep);
    let (margin, speculative, sleep_enabled) = (
        config.contact_margin,
        config.speculative_contacts,
        sleep.enabled,
    );
    let dt = state.settings.dt;
    let gravity_speed = state.settings.gravity.0.length() * dt;
    let entity = item.entity;
    let kind = item.body.as_deref().copied().unwrap_or(RigidBody::Static);
    let check = validate(item, kind);
    let label = || body_label(entity, item.name);
    match (check, item.quarantined) {
        (Err(reason), quarantined) => {
            if quarantined.is_none_or(|q| q.reason != reason) {
                log::error!(
                    "impact3d: {} is left out of the physics step: {reason}",
                    label()
                );
                commands.entity(entity).insert(Quarantined { reason });
            }
            return Gathered::Quarantined;
        }
        (Ok(()), Some(_)) => {
            log::info!(
                "impact3d: {} is valid again and rejoins the physics step",
                label()
            );
            commands.entity(entity).remove::<Quarantined>();
        }
        (Ok(()), None) => {}
    }
    warn_on_coefficient_change(&label, item.restitution.as_ref(), "restitution", 1.0);
    warn_on_coefficient_change(&label, item.friction.as_ref(), "friction", f32::INFINITY);
    let rotation = item.transform.rotation.normalize();
    let translation = item.transform.translation;
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
    let body = SolverBody::new(motion, translation + rotation * local_com, rotation)
        .with_mass(
            computed.inverse_mass,
            computed.local_inverse_inertia,
            computed.isotropic,
            item.locked.map_or(BVec3::FALSE, |l| l.rotation),
        )
        .with_velocity(linear, angular);

    let shape = item.collider.shape().clone();
    let pose = Pose::from_parts(translation, rotation);
    let radius = if item.collider.is_unbounded_or_hollow() {
        0.0
    } else {
        let local = shape.compute_local_aabb();
        (local.mins - local_com)
            .abs()
            .max((local.maxs - local_com).abs())
            .length()
    };
    // A sleeping body enters the step as static; it is swapped back in if woken.
    let asleep = match (&item.sleeping, kind) {
        (Some(marker), RigidBody::Dynamic) if sleep_enabled => {
            let since = marker.added();
            let now = ticks.this_run();
            let touched = item.transform.last_changed().is_newer_than(since, now)
                || item
                    .linear_velocity
                    .as_ref()
                    .is_some_and(|v| v.last_changed().is_newer_than(since, now))
                || item
                    .angular_velocity
                    .as_ref()
                    .is_some_and(|w| w.last_changed().is_newer_than(since, now));
            let island = if marker.island == Entity::PLACEHOLDER {
                entity
            } else {
                marker.island
            };
            if touched {
                state.woken.push(island);
            }
            Some(island)
        }
        _ => None,
    };
    let (body, asleep) = match asleep {
        Some(island) => (
            SolverBody::new(Motion::Static, body.position, body.rotation),
            Some((island, body)),
        ),
        None => (body, None),
    };
    let moving = speculative && body.motion != Motion::Static;
    // Gravity adds up to |g| dt to a dynamic body's speed within the step: without it, a
    // body falling from just beyond its reach lands `|g| dt^2` deep.
    let gained = if body.motion == Motion::Dynamic {
        gravity_speed
    } else {
        0.0
    };
    let reach = if moving {
        (body.linear_velocity.length() + gained + body.angular_velocity.length() * radius) * dt
    } else {
        0.0
    };
    // The box swept along the step's linear motion, widened by the margin and by how far
    // rotation can carry a point (|w| dt R): unlike a box widened by the whole reach in
    // every direction, it does not pull in bodies beside a fast body's path.
    let aabb = shape.compute_aabb(&pose);
    let aabb = if moving {
        let travel = body.linear_velocity * dt
            + 0.5 * gained * dt * state.settings.gravity.0.normalize_or_zero();
        let end = parry3d::bounding_volume::Aabb::new(aabb.mins + travel, aabb.maxs + travel);
        aabb.merged(&end)
            .loosened(0.5 * margin + body.angular_velocity.length() * radius * dt)
    } else {
        aabb.loosened(0.5 * margin)
    };

    state.entities.push(entity);
    state.bodies.push(body);
    state.local_com.push(local_com);
    state.shapes.push(shape);
    state.poses.push(pose);
    state.restitution.push(clamp_coefficient(
        item.restitution.as_deref().map(|r| r.0),
        1.0,
    ));
    state.friction.push(clamp_coefficient(
        item.friction.as_deref().map(|f| f.0),
        f32::INFINITY,
    ));
    state.reach.push(reach);
    state
        .spin_reach
        .push(if moving && !item.collider.is_sphere() {
            body.angular_velocity.length() * radius * dt
        } else {
            0.0
        });
    state.aabbs.push(aabb);
    // Dynamic and kinematic bodies are active (asleep ones are static here, and turned
    // back by `wake_islands` if woken); a static or sleeping body only if something about
    // it changed, or it fell asleep at the end of the last step (its pairs were found
    // from the box it had at the start of that step).
    state.active.push(
        body.motion != Motion::Static
            || item.transform.is_changed()
            || item.collider.is_changed()
            || item.body.as_ref().is_some_and(|b| b.is_changed())
            || item.quarantined.is_some()
            || item.sleeping.as_ref().is_some_and(|m| m.is_added()),
    );
    state.radius.push(radius);
    state.asleep.push(asleep);
    if state.asleep.last().is_some_and(Option::is_some) {
        Gathered::Asleep
    } else {
        Gathered::Awake
    }
}

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
    state.reach.push(0.0);
    state.spin_reach.push(0.0);
    state.aabbs.push(state.sleepers.aabb(i));
    state.active.push(false);
    state.radius.push(s.radius);
    state.asleep.push(Some((s.island, s.body)));
    state.entered.push(s.entity);
}

/// Brings in every sleeping body whose box an active body's box overlaps, so that the sweep
/// finds their pairs as if every sleeping body were in the arrays.
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

/// Checks one body's input and refreshes its mass properties when their inputs changed.
fn validate(item: &mut BodyDataItem, kind: RigidBody) -> Result<(), String> {
    if let Some(error) = item.collider.error() {
        return Err(format!("invalid collider: {error}"));
    }
    let t = &*item.transform;
    if !within(t.translation.abs().max_element(), MAX_COORDINATE) {
        return Err(format!(
            "translation {} is not finite or beyond {MAX_COORDINATE:e} m",
            t.translation
        ));
    }
    let norm = t.rotation.length_squared();
    if !(norm.is_finite() && norm >= 1e-12) {
        return Err(format!(
            "invalid rotation {} (a quaternion of finite, non-zero length is needed)",
            t.rotation
        ));
    }
    if kind != RigidBody::Static {
        if let Some(v) = item.linear_velocity.as_deref() {
            check_length("linear velocity", v.0, MAX_LINEAR_SPEED)?;
        }
        if let Some(w) = item.angular_velocity.as_deref() {
            check_length("angular velocity", w.0, MAX_ANGULAR_SPEED)?;
        }
    }
    if kind == RigidBody::Dynamic {
        // `ComputedMass` is the plugin's own: written by anyone else (its change tick is newer
        // than this system's last run, which is when the plugin last wrote it), it is
        // recomputed like any stale value.
        let written = item
            .computed
            .as_ref()
            .is_some_and(|c| c.is_changed() && !c.is_added());
        let changed = written
            || item.computed.as_ref().is_some_and(|c| c.is_added())
            || item.collider.is_changed()
            || item.body.as_ref().is_some_and(|b| b.is_changed())
            || item.mass.as_ref().is_some_and(|m| m.is_changed())
            || item.density.as_ref().is_some_and(|d| d.is_changed())
            || item.quarantined.is_some()
            || item.computed.as_ref().is_none_or(|c| c.inverse_mass == 0.0);
        if changed {
            let density = item
                .density
                .as_deref()
                .map_or(Density::default().0, |d| d.0);
            let computed = ComputedMass::from_collider(
                &item.collider,
                density,
                item.mass.as_deref().map(|m| m.0),
            )?;
            if let Some(mut c) = item.computed.take() {
                if written && *c != computed {
                    log::warn!(
                        "impact3d: {} had its ComputedMass written ({:?}); it is read-only and \
                         was recomputed from the collider, Density and Mass",
                        body_label(item.entity, item.name),
                        *c
                    );
                }
                c.set_if_neq(computed);
                item.computed = Some(c);
            }
        }
        if item.computed.is_none() {
            return Err("dynamic body has no ComputedMass component".to_string());
        }
    }
    Ok(())
}

/// Warns, naming the entity, when a coefficient is set outside `[0, max]` or to NaN.
fn warn_on_coefficient_change<T: std::ops::Deref<Target = f32> + Component>(
    label: &dyn Fn() -> String,
    value: Option<&Ref<T>>,
    what: &str,
    max: f32,
) {
    let Some(value) = value.filter(|v| v.is_changed()) else {
        return;
    };
    let v = ***value;
    if !(0.0..=max).contains(&v) {
        log::warn!(
            "impact3d: {} has {what} {v}, outside [0, {max}]; it is clamped to {}",
            label(),
            clamp_coefficient(Some(v), max)
        );
    }
}

/// Clamps a coefficient into `[0, max]`; NaN and missing become 0.
fn clamp_coefficient(value: Option<f32>, max: f32) -> f32 {
    match value {
        Some(v) if v.is_nan() => 0.0,
        Some(v) => v.clamp(0.0, max),
        None => 0.0,
    }
}

/// Finds candidate pairs by sweep and prune, keeping only pairs where at least one body is
/// dynamic.
pub fn update_broad_phase(mut state: ResMut<PhysicsState>, mut pairs: ResMut<ContactPairs>) {
    let state = &mut *state;
    // An awake body (dynamic, or kinematic and moving) overlapping a sleeping one wakes its
    // island now, so that the contact is solved with the sleeper's real mass; repeat until no
    // more islands wake (a woken island may overlap another sleeping one).
    loop {
        bring_in_overlapped(state);
        pairs_with_active(
            &state.aabbs,
            &state.active,
            &mut state.index_pairs,
            &mut state.sort_scratch,
        );
        let mut islands = Vec::new();
        for &(i, j) in &state.index_pairs {
            for (me, other) in [(i as usize, j as usize), (j as usize, i as usize)] {
                if let Some((island, _)) = state.asleep[me] {
                    let o = &state.bodies[other];
                    let active = o.motion == Motion::Dynamic
                        || (o.motion == Motion::Kinematic
                            && (o.linear_velocity != Vec3::ZERO
                                || o.angular_velocity != Vec3::ZERO));
                    if active && state.asleep[other].is_none() && !islands.contains(&island) {
                        islands.push(island);
                    }
                }
            }
        }
        if islands.is_empty() || !wake_islands(state, &islands) {
            break;
        }
        // The woken bodies are active now: search their pairs too.
        mark_awake_active(state);
    }
    // Resting pairs set aside while their sleeping bodies sat out come back among the
    // candidates when one of their bodies is in the step again, when the other body (static)
    // changed, or when it is gone.
    if pairs.has_resting() {
        let mut back: Vec<Entity> = state.entered.clone();
        back.extend(state.departed.iter().copied());
        back.extend(
            state
                .entities
                .iter()
                .zip(&state.active)
                .zip(&state.bodies)
                .filter(|&((_, &active), body)| active && body.motion == Motion::Static)
                .map(|((&e, _), _)| e),
        );
        if !back.is_empty() {
            back.sort_unstable();
            pairs.revive(|p| back.binary_search(&p.a).is_ok() || back.binary_search(&p.b).is_ok());
        }
    }
    // Pairs of two inactive bodies cannot have changed since the last step (neither moved):
    // carry them over instead of sweeping every sleeping and static body each step. A pair of
    // which a body sits out the step asleep, the other sitting out too or inactive, is set
    // aside as it is.
    if !pairs.candidates().is_empty()
        && (state.active.iter().any(|a| !a) || !state.sleepers.is_empty())
    {
        state.index_of.clear();
        state.index_of.extend(
            state
                .entities
                .iter()
                .enumerate()
                .map(|(i, &e)| (e, i as u32)),
        );
        state.index_of.sort_unstable();
        let find = |e: Entity| {
            state
                .index_of
                .binary_search_by_key(&e, |&(e, _)| e)
                .ok()
                .map(|k| state.index_of[k].1)
        };
        let mut aside = Vec::new();
        for (k, p) in pairs.candidates().iter().enumerate() {
            match (find(p.a), find(p.b)) {
                (Some(i), Some(j)) => {
                    if !state.active[i as usize] && !state.active[j as usize] {
                        state.index_pairs.push((i.min(j), i.max(j)));
                    }
                }
                (i, j) => {
                    let resting = |e: Entity, i: Option<u32>| match i {
                        Some(i) => !state.active[i as usize],
                        None => state.sleepers.get(e).is_some(),
                    };
                    if resting(p.a, i) && resting(p.b, j) {
                        aside.resize(pairs.candidates().len(), false);
                        aside[k] = true;
                    }
                }
            }
        }
        if !aside.is_empty() {
            aside.resize(pairs.candidates().len(), false);
            pairs.set_aside(&aside);
        }
    }
    let mut keyed: Vec<((Entity, Entity), (usize, usize))> = state
        .index_pairs
        .iter()
        .map(|&(i, j)| (i as usize, j as usize))
        .filter(|&(i, j)| {
            // Pairs with a sleeping body are kept (dormant), so sleep does not end collisions.
            let live =
                |k: usize| state.bodies[k].motion == Motion::Dynamic || state.asleep[k].is_some();
            live(i) || live(j)
        })
        .map(|(i, j)| {
            let (ei, ej) = (state.entities[i], state.entities[j]);
            if ei < ej {
                ((ei, ej), (i, j))
            } else {
                ((ej, ei), (j, i))
            }
        })
        .collect();
    keyed.sort_unstable_by_key(|(k, _)| *k);
    state.candidates.clear();
    state.candidate_indices.clear();
    state.dormant.clear();
    for (k, (i, j)) in keyed {
        state.candidates.push(k);
        state.candidate_indices.push((i, j));
        let awake = |k: usize| state.bodies[k].motion == Motion::Dynamic;
        state.dormant.push(!awake(i) && !awake(j));
    }
}

/// Updates the persistent contact pairs and builds one contact constraint per contact point,
/// carrying each point's impulses from the last step.
pub fn update_narrow_phase(mut state: ResMut<PhysicsState>, mut pairs: ResMut<ContactPairs>) {
    let state = &mut *state;
    let config = &state.settings.config;
    state.ended.clear();
    state.started.clear();
    state.lost.clear();
    let (ended, lost) = (&mut state.ended, &mut state.lost);
    pairs.retain_candidates(&state.candidates, |p| {
        if p.touching {
            ended.push((p.a, p.b));
            lost.extend([p.a, p.b]);
        }
    });
    state.contacts.clear();
    state.pair_ranges.clear();
    state.contact_keys.clear();
    // Contacts are generated with the shapes scaled to the length unit (see
    // `ContactPair::update`); a pair with a shape parry cannot scale keeps metres.
    let unit = binary_unit(state.settings.length_unit);
    let mut unit_shapes = std::mem::take(&mut state.unit_shapes);
    for (pair_index, (pair, &(ia, ib))) in pairs
        .pairs_mut()
        .iter_mut()
        .zip(&state.candidate_indices)
        .enumerate()
    {
        if state.dormant[pair_index] {
            continue;
        }
        let margin = config.contact_margin;
        let reach = state.reach[ia] + state.reach[ib];
        let (pose_a, pose_b) = (&state.poses[ia], &state.poses[ib]);
        let (shape_a, shape_b) = (state.shapes[ia].as_ref(), state.shapes[ib].as_ref());
        let scaled = if unit == 1.0 {
            None
        } else {
            unit_shapes
                .get(&state.shapes[ia], unit)
                .zip(unit_shapes.get(&state.shapes[ib], unit))
        };
        let (unit_a, unit_b, pair_unit) = match &scaled {
            Some((a, b)) => (a.as_ref(), b.as_ref(), unit),
            None => (shape_a, shape_b, 1.0),
        };
        // Speculative contacts (a prediction wider than the margin) only for pairs that really
        // meet within the step: a near miss of fast bodies is a miss (no ghost collision).
        // Gravity bends a path by at most |g| dt^2 / 2 from the straight line the cast follows.
        let mut prediction = margin + reach;
        let mut impact_time = None;
        if reach > margin {
            let motion = |i: usize| StepMotion {
                pose: state.poses[i],
                local_center: state.local_com[i],
                linear: state.bodies[i].linear_velocity,
                angular: state.bodies[i].angular_velocity,
                spin_reach: state.spin_reach[i],
            };
            let bend = 0.5 * state.settings.gravity.0.length() * state.dt * state.dt;
            // The start pose's contact geometry (anchors turned to first order) holds for small
            // turns; past a quarter radian in the step (14 degrees: the first-order rotation of
            // a point is then 1% off in length, 12% off in direction at a full radian), and
            // where the turn carries a point beyond the margin, the contact is generated at the
            // time of impact instead.
            let turns_far = |i: usize| {
                state.spin_reach[i] > margin
                    && state.bodies[i].angular_velocity.length() * state.dt > 0.25
            };
            match time_of_impact(
                shape_a,
                &motion(ia),
                shape_b,
                &motion(ib),
                state.dt,
                bend,
                margin,
            ) {
                Meeting::Miss => prediction = margin,
                Meeting::At(t) if t > 0.0 && (turns_far(ia) || turns_far(ib)) => {
                    impact_time = Some((t, motion(ia), motion(ib)));
                }
                Meeting::At(_) | Meeting::Unknown => {}
            }
        }
        let restitution = state.restitution[ia].max(state.restitution[ib]);
        let friction = state.friction[ia].max(state.friction[ib]);
        let turning = Turning::of(state, ia, ib);
        let start = state.contacts.len();
        if let Some((t, motion_a, motion_b)) = impact_time {
            // A spinning body: the contact of its first point to meet the other is generated
            // at the time-of-impact poses (the start pose's normal and points would miss the
            // rotation), with its points mapped back to where they are at the start and a
            // separation that the approach velocity there closes exactly at the impact time.
            let (toi_a, toi_b) = (motion_a.pose_at(t), motion_b.pose_at(t));
            if !pair.update(&toi_a, unit_a, &toi_b, unit_b, margin, pair_unit) {
                pair.manifolds.clear();
                continue;
            }
            let (a, b) = (&state.bodies[ia], &state.bodies[ib]);
            // The point is moved back with the body that turns farther, so that its lever arm
            // is the one at impact (`p - x(t)`): the impulse then turns it as the impact does.
            let carrier = if state.spin_reach[ia] >= state.spin_reach[ib] {
                &motion_a
            } else {
                &motion_b
            };
            let shift = carrier.linear * t;
            for (m, k, impact_point, normal, dist) in pair.world_points(&toi_a, &toi_b) {
                let point = impact_point - shift;
                let point_velocity = |body: &SolverBody| {
                    body.linear_velocity + body.angular_velocity.cross(point - body.position)
                };
                let approach = (point_velocity(b) - point_velocity(a)).dot(normal);
                if approach >= 0.0 {
                    continue;
                }
                let separation = dist.max(0.0) - approach * t;
                let mut c = ContactConstraint::new(
                    ia,
                    ib,
                    point,
                    normal,
                    separation,
                    restitution,
                    friction,
                );
                if let Some(turning) = &turning {
                    let (toi_k, other) = if turning.sign > 0.0 {
                        (&toi_a, &motion_b)
                    } else {
                        (&toi_b, &motion_a)
                    };
                    let face = turning.face(pair.surface_points(m, k, &toi_a, &toi_b), |p| {
                        p - other.linear * t
                    });
                    turning.carry(&mut c, toi_k, face, &state.bodies, state.dt);
                }
                let carried = pair.manifolds[m].points[k].data;
                push_row(
                    &mut state.contacts,
                    &mut state.contact_keys,
                    c,
                    carried,
                    (pair_index, m, k),
                );
            }
            close_pair_range(&state.contacts, &mut state.pair_ranges, start);
            continue;
        }
        if !pair.update(pose_a, unit_a, pose_b, unit_b, prediction, pair_unit) {
            pair.manifolds.clear();
            continue;
        }
        for (m, k, point, normal, dist) in pair.world_points(pose_a, pose_b) {
            let mut c = ContactConstraint::new(ia, ib, point, normal, dist, restitution, friction);
            if let Some(turning) = &turning {
                let face = turning.face(pair.surface_points(m, k, pose_a, pose_b), |p| p);
                turning.carry(&mut c, &turning.motion.pose, face, &state.bodies, state.dt);
            }
            let carried = pair.manifolds[m].points[k].data;
            push_row(
                &mut state.contacts,
                &mut state.contact_keys,
                c,
                carried,
                (pair_index, m, k),
            );
        }
        close_pair_range(&state.contacts, &mut state.pair_ranges, start);
    }
    unit_shapes.prune();
    state.unit_shapes = unit_shapes;
}

/// A kinematic body that turns, in a pair with a dynamic body, and its prescribed motion over
/// the step: the contacts of the pair are carried with it to the end of the step (see
/// [`Turning::carry`]).
#[derive(Clone, Copy)]
struct Turning {
    /// +1 when the kinematic body is the pair's first body (the normal points away from it),
    /// -1 when it is the second.
    sign: f32,
    /// The kinematic body's motion over the step, from its start pose.
    motion: StepMotion,
    /// Its pose at the end of the step.
    end: Pose,
    /// The dynamic body's sphere, if it is one: its centre at the start of the step and its
    /// radius.
    ball: Option<(Vec3, f32)>,
}

/// A contact point on a face of the turning kinematic body: the point on that face when the
/// contact was built, and the dynamic body's contact point at the start of the step.
struct Face {
    on_kinematic: Vec3,
    on_dynamic: Vec3,
}

impl Turning {
    /// The turning kinematic body of the pair `(ia, ib)` (not a sphere, whose contact normal
    /// does not turn with it) and its motion, if the other body is dynamic.
    fn of(state: &PhysicsState, ia: usize, ib: usize) -> Option<Turning> {
        let (k, d, sign) = Turning::sides(state, ia, ib)?;
        let motion = StepMotion {
            pose: state.poses[k],
            local_center: state.local_com[k],
            linear: state.bodies[k].linear_velocity,
            angular: state.bodies[k].angular_velocity,
            spin_reach: state.spin_reach[k],
        };
        let ball = state.shapes[d]
            .as_ball()
            .map(|b| (state.poses[d].translation, b.radius));
        Some(Turning {
            sign,
            motion,
            end: motion.pose_at(state.dt),
            ball,
        })
    }

    /// `(kinematic body, dynamic body, sign)` of the pair `(ia, ib)` if it has a turning
    /// kinematic body (see [`Turning::of`]).
    fn sides(state: &PhysicsState, ia: usize, ib: usize) -> Option<(usize, usize, f32)> {
        let turns = |k: usize, d: usize| {
            state.bodies[k].motion == Motion::Kinematic
                && state.bodies[k].angular_velocity != Vec3::ZERO
                && state.bodies[d].motion == Motion::Dynamic
                && state.shapes[k].as_ball().is_none()
        };
        if turns(ia, ib) {
            Some((ia, ib, 1.0))
        } else if turns(ib, ia) {
            Some((ib, ia, -1.0))
        } else {
            None
        }
    }

    /// The face point of a contact whose surface points are `points` (`(on a, on b)`, each with
    /// whether it lies on a face), if the kinematic body's point lies on one of its faces;
    /// `to_start` maps the dynamic body's point back to the start of the step.
    fn face(
        &self,
        ((on_a, face_a), (on_b, face_b)): ((Vec3, bool), (Vec3, bool)),
        to_start: impl Fn(Vec3) -> Vec3,
    ) -> Option<Face> {
        let (on_kinematic, face, on_dynamic) = if self.sign > 0.0 {
            (on_a, face_a, on_b)
        } else {
            (on_b, face_b, on_a)
        };
        face.then(|| Face {
            on_kinematic,
            on_dynamic: to_start(on_dynamic),
        })
    }

    /// Where the kinematic body's material point that is at `p` when the body is at `pose` is
    /// at the end of the step.
    fn at_end(&self, p: Vec3, pose: &Pose) -> Vec3 {
        self.end.transform_point(pose.inverse_transform_point(p))
    }

    /// Carries contact `c`, built with the kinematic body at `at`, with the kinematic body to
    /// the end of the step, so that every method's rows keep the dynamic body out of where the
    /// kinematic body will be rather than where it was.
    ///
    /// A point on a face of the kinematic body gets that face's plane at the end of the step:
    /// the normal turned with the body, and a separation that the rows' own model of the
    /// step (each anchor moved rigidly with its body, `current_separation`) brings at the end of
    /// the step to the dynamic point's distance from that plane, `s_end + d . n` for a
    /// displacement `d` of the dynamic point. (The face plane carried rigidly, the start
    /// separation of a point built at the start pose is unchanged: only the normal turns.) A
    /// sphere's point is moved to where its surface meets the turned normal, so that the row
    /// still passes through its centre. The row gets the [`drive`](ContactConstraint::drive)
    /// that makes it move the kinematic body's point by its exact displacement over the step.
    ///
    /// A point on an edge or a vertex of the kinematic body keeps its start geometry: its
    /// normal is the other body's face (or an edge pair's), which turns with the other body,
    /// not with the kinematic one. (Driving such a row with the kinematic point's exact
    /// displacement alone made things worse: a box spinning at 4 rad/s, its edge sliding along
    /// the face of a cube the push set turning, sank 3.5 mm into it instead of 2.1 under the
    /// hybrid method, 13.5 instead of 10.6 under propagation.)
    ///
    /// Why: with the start normal held for the whole step, the pushed body is kept out of a
    /// plane that no longer exists. A ball pushed along a bar turning at 10 rad/s slides out
    /// along it at several m/s, and the start plane lets it lag the turned face by that
    /// sliding times the turn, `v_r dt theta` (1.4 cm per step at 5 m/s, 0.17 rad): the bar
    /// sank 3.7-5.5 cm into it.
    fn carry(
        &self,
        c: &mut ContactConstraint,
        at: &Pose,
        face: Option<Face>,
        bodies: &[SolverBody],
        dt: f32,
    ) {
        let Some(face) = face else {
            return;
        };
        let start = &self.motion.pose;
        let normal = ((self.end.rotation * at.rotation.inverse()) * c.normal).normalize();
        let on_dynamic = match self.ball {
            Some((centre, radius)) => centre - self.sign * radius * normal,
            None => face.on_dynamic,
        };
        let end_separation =
            self.sign * (on_dynamic - self.at_end(face.on_kinematic, at)).dot(normal);
        // How far the kinematic body's point at `on_dynamic` moves along the normal in the step.
        let travel = (self.at_end(on_dynamic, start) - on_dynamic).dot(normal);
        c.normal = normal;
        c.point = on_dynamic;
        c.separation = end_separation + self.sign * travel;
        let body = if self.sign > 0.0 {
            &bodies[c.body_a]
        } else {
            &bodies[c.body_b]
        };
        let first_order = (body.linear_velocity
            + body.angular_velocity.cross(on_dynamic - body.position))
        .dot(normal);
        c.drive = self.sign * (first_order - travel / dt);
    }
}

/// Adds the contact row of point `k` of manifold `m` of candidate pair `pair` (the `key`),
/// starting from the impulses that point carried from the last step (warm starting).
fn push_row(
    contacts: &mut Vec<ContactConstraint>,
    keys: &mut Vec<(u32, u32, u32)>,
    mut row: ContactConstraint,
    carried: ContactImpulse,
    (pair, m, k): (usize, usize, usize),
) {
    row.normal_impulse = carried.normal;
    row.tangent_impulse = carried.tangent;
    contacts.push(row);
    keys.push((pair as u32, m as u32, k as u32));
}

/// Records the rows pushed since `start` as one body pair's range, if there are any.
fn close_pair_range(contacts: &[ContactConstraint], ranges: &mut Vec<Range<usize>>, start: usize) {
    if contacts.len() > start {
        ranges.push(start..contacts.len());
    }
}

/// Continuous collision after the solve (as Box2D v3's `b2SolveContinuous`): a dynamic body
/// whose solved motion over the step is longer than the contact margin is swept from its start
/// pose to its end pose against each of its broad-phase pairs (parry's nonlinear shape cast).
/// If it would first touch one more than `linear_slop` before the end of its sweep, it is put
/// back at the pose of that first touch, keeping its velocities: the next step's contact
/// resolves them. A body already touching at the start, or paired with a turning kinematic
/// body, is swept by its centre of mass alone (a point), so that at least its centre never
/// passes through. Bodies the solver stopped in time, slow bodies and resting contacts are
/// untouched.
///
/// Why: the solvers resolve each contact with the geometry of the start of the step. A body
/// that turns through several radians within the step (a box at 1e3 rad/s: 2.7 turns per
/// step at 60 Hz) meets the wall in a pose the start geometry does not describe, and every
/// method but the hybrid one, which resolves impacts one at a time at their time of impact,
/// let such a body through.
fn stop_at_first_impact(state: &mut PhysicsState) {
    let dt = state.dt;
    let margin = state.settings.config.contact_margin;
    let slop = state.settings.config.linear_slop;
    let n = state.bodies.len();
    // The solved motion of each body as a rigid motion from its start pose: the centre of
    // mass moves in a straight line to where the solve put it, and the body turns at its
    // solved angular velocity (or along the shortest arc to its end rotation, for turns under
    // a radian, which then reproduces the end pose exactly).
    let motion = |i: usize| {
        let body = &state.bodies[i];
        let start = state.poses[i];
        let com0 = start.transform_point(state.local_com[i]);
        let linear = (body.position - com0) / dt;
        let turn = (body.rotation * start.rotation.inverse()).to_scaled_axis();
        let angular = if turn.length() < 1.0 && body.angular_velocity.length() * dt < 1.0 {
            turn / dt
        } else {
            body.angular_velocity
        };
        let sweep = (body.position - com0).length() + angular.length() * dt * state.radius[i];
        (
            StepMotion {
                pose: start,
                local_center: state.local_com[i],
                linear,
                angular,
                spin_reach: 0.0,
            },
            sweep,
        )
    };
    let fast = |i: usize| {
        state.bodies[i].motion == Motion::Dynamic
            && state.asleep[i].is_none()
            && motion(i).1 > margin
    };
    let mut first: Vec<f32> = Vec::new();
    for (k, &(ia, ib)) in state.candidate_indices.iter().enumerate() {
        if state.dormant[k] || !(fast(ia) || fast(ib)) {
            continue;
        }
        if first.is_empty() {
            first.resize(n, dt);
        }
        let (ma, sweep_a) = motion(ia);
        let (mb, sweep_b) = motion(ib);
        let (sa, sb) = (state.shapes[ia].as_ref(), state.shapes[ib].as_ref());
        let hit = |a: &StepMotion, sa: &dyn Shape, b: &StepMotion, sb: &dyn Shape| {
            let (a, b) = (a.nonlinear(), b.nonlinear());
            cast_shapes_nonlinear(&a, sa, &b, sb, 0.0, dt, false)
                .ok()
                .flatten()
                .map(|h| h.time_of_impact)
        };
        // A pair of a dynamic body and a turning kinematic body (see `Turning`) is solved with
        // the kinematic body's prescribed motion (its faces' contacts carried to its end-of-step
        // pose, its other anchors turned exactly), not with the start geometry this rewind makes
        // up for. Their straight solved paths can still graze mid-step (a ball pushed by a
        // kinematic bar turning at 6 rad/s, its path a chord of the face's arc, dips about 1 mm
        // into it), which a sweep of the whole shapes takes for a first impact: the ball was put
        // back where it started while the bar moved on, and the bar sank 9.9 cm into it under
        // the soft step. Such a pair is swept by the fast body's centre, as a pair touching at
        // the start.
        let carried = Turning::sides(state, ia, ib).is_some();
        let t = match hit(&ma, sa, &mb, sb) {
            Some(t) if t > 0.0 && !carried => Some(t),
            Some(_) => {
                // Touching at the start, or carried: sweep the fast body's centre (a point)
                // instead.
                let point = Ball::new(0.0);
                let centre = |m: &StepMotion| StepMotion {
                    pose: Pose::from_parts(m.pose.transform_point(m.local_center), m.pose.rotation),
                    local_center: Vec3::ZERO,
                    ..*m
                };
                if fast(ia) {
                    hit(&centre(&ma), &point, &mb, sb).filter(|&t| t > 0.0)
                } else {
                    hit(&ma, sa, &centre(&mb), &point).filter(|&t| t > 0.0)
                }
            }
            None => None,
        };
        let Some(t) = t else { continue };
        for (i, sweep) in [(ia, sweep_a), (ib, sweep_b)] {
            if fast(i) && (1.0 - t / dt) * sweep > slop {
                first[i] = first[i].min(t);
            }
        }
    }
    let poses: Vec<(usize, Pose)> = first
        .iter()
        .enumerate()
        .filter(|&(_, &t)| t < dt)
        .map(|(i, &t)| (i, motion(i).0.pose_at(t)))
        .collect();
    let gravity = state.settings.gravity.0;
    for (i, pose) in poses {
        let body = &mut state.bodies[i];
        let position = pose.transform_point(state.local_com[i]);
        // Moved back along its path, the body may stand higher than where the solve left it:
        // the potential energy it gains, `-m g . dx`, is taken from its kinetic energy (its
        // speed is scaled down), so the correction never adds energy. Without this, bodies
        // rewound after falling fast gained up to 22% of a world's energy in a step (the
        // energy property test).
        let gained = -gravity.dot(position - body.position) / body.inverse_mass;
        let kinetic = 0.5 * body.linear_velocity.length_squared() / body.inverse_mass;
        if gained > 0.0 && kinetic > 0.0 {
            body.linear_velocity *= ((kinetic - gained).max(0.0) / kinetic).sqrt();
        }
        // Turned back, the body keeps its spin in its own frame, so that its rotational energy
        // `w . I w / 2` is what the solve left. (Turning it under a fixed world spin changes
        // that energy when the inertia is not isotropic: a 2 kg hull that an e = 1 impact on the
        // trimesh had set spinning gained 130 J, 29% of its world's energy, in one rewind:
        // the energy property test, propagation, seed 107.)
        let rotation = pose.rotation.normalize();
        if !body.isotropic && !body.locked_rotation.any() {
            let back = rotation * body.rotation.inverse();
            body.angular_velocity = back * body.angular_velocity;
        }
        body.position = position;
        body.rotation = rotation;
    }
}

/// Runs the solver over the packed arrays and stores the impulses back into the manifolds.
pub fn solve_contacts(
    mut stats: ResMut<SolverStats>,
    mut state: ResMut<PhysicsState>,
    mut pairs: ResMut<ContactPairs>,
) {
    let state = &mut *state;
    let config = &state.settings.config;
    *stats = solver::step(
        &mut state.bodies,
        &mut state.contacts,
        &state.pair_ranges,
        config,
        state.settings.gravity.0,
        state.dt,
    );
    // The hybrid method resolves impacts one at a time at their time of impact, on contacts
    // generated at the time-of-impact poses, so its bodies already stop where they first touch
    // (a box spinning at 1e3 rad/s stops at a thin wall without the rewind): only the other
    // methods, which solve every contact with the geometry of the start of the step, need it.
    // The rewind is not free: it moves bodies without the solver's knowledge, and in the
    // energy property test it was what raised the energy of 9 of the hybrid's 10 failing
    // worlds.
    if state.settings.config.method != solver::SolverMethod::Hybrid {
        stop_at_first_impact(state);
    }
    let config = &state.settings.config;
    state.steps_since_bound_warning = state.steps_since_bound_warning.saturating_add(1);
    if stats.propagation_bound_hit && state.steps_since_bound_warning >= 60 {
        state.steps_since_bound_warning = 0;
        log::warn!(
            "impact3d: propagation stopped at its bound of {} sweeps with contacts still \
             approaching (raise SolverConfig::max_propagation_sweeps)",
            config.max_propagation_sweeps
        );
    }

    let pairs = pairs.pairs_mut();
    // Dormant pairs keep their touching state; the others are re-evaluated from this step.
    let mut touching: Vec<bool> = pairs
        .iter()
        .zip(&state.dormant)
        .map(|(pair, &dormant)| dormant && pair.touching)
        .collect();
    state.impacts.clear();
    for (c, &(p, m, k)) in state.contacts.iter().zip(&state.contact_keys) {
        let pair = &mut pairs[p as usize];
        // A non-finite impulse (its bodies' results are non-finite too, and they are
        // quarantined in `write_back`) is not carried over: warm-started, it would make the
        // next step non-finite again, and the quarantine would never end.
        let finite = c.normal_impulse.is_finite()
            && c.tangent_impulse[0].is_finite()
            && c.tangent_impulse[1].is_finite();
        pair.manifolds[m as usize].points[k as usize].data = if finite {
            ContactImpulse {
                normal: c.normal_impulse,
                tangent: c.tangent_impulse,
            }
        } else {
            ContactImpulse::default()
        };
        if c.separation <= state.settings.touch_distance || c.total_impulse > 0.0 {
            touching[p as usize] = true;
        }
        let report = match config.impact_messages {
            ImpactMessages::Off => false,
            ImpactMessages::Impacts => c.impact,
            ImpactMessages::AllContacts => c.total_impulse > 0.0,
        };
        if report {
            state.impacts.push(Impact {
                a: pair.a,
                b: pair.b,
                point: c.point,
                normal: c.normal,
                impulse: c.total_impulse,
            });
        }
    }
    for (pair, now) in pairs.iter_mut().zip(touching) {
        match (pair.touching, now) {
            (false, true) => state.started.push((pair.a, pair.b)),
            (true, false) => state.ended.push((pair.a, pair.b)),
            _ => {}
        }
        pair.touching = now;
    }
}

/// The components [`write_back`] writes, and the name its log lines give.
type WriteBackData = (
    &'static mut Transform,
    Option<&'static mut LinearVelocity>,
    Option<&'static mut AngularVelocity>,
    Option<&'static Name>,
);

/// Writes poses and velocities of moving bodies back to their components. A body whose result
/// is not finite (finite input that overflowed) is not written: it is quarantined instead, so
/// no NaN ever reaches a component.
pub fn write_back(
    mut commands: Commands,
    state: Res<PhysicsState>,
    mut query: Query<WriteBackData>,
) {
    for ((&entity, body), &local_com) in state
        .entities
        .iter()
        .zip(&state.bodies)
        .zip(&state.local_com)
    {
        if body.motion == Motion::Static {
            continue;
        }
        let finite = body.position.is_finite()
            && body.rotation.is_finite()
            && body.linear_velocity.is_finite()
            && body.angular_velocity.is_finite();
        if !finite {
            let reason = "the step produced a non-finite state (input too large?)".to_string();
            let name = query.get(entity).ok().and_then(|(_, _, _, name)| name);
            log::error!(
                "impact3d: {} is left out of the physics step: {reason}",
                body_label(entity, name)
            );
            commands.entity(entity).insert(Quarantined { reason });
            continue;
        }
        let Ok((mut transform, linear, angular, _)) = query.get_mut(entity) else {
            continue;
        };
        let translation = body.position - body.rotation * local_com;
        if transform.translation != translation || transform.rotation != body.rotation {
            transform.translation = translation;
            transform.rotation = body.rotation;
        }
        if body.motion == Motion::Dynamic {
            if let Some(mut v) = linear {
                v.set_if_neq(LinearVelocity(body.linear_velocity));
            }
            if let Some(mut w) = angular {
                w.set_if_neq(AngularVelocity(body.angular_velocity));
            }
        }
    }
}

/// Writes the step's `Impact`, `CollisionStarted` and `CollisionEnded` messages.
pub fn send_messages(
    state: Res<PhysicsState>,
    mut impacts: MessageWriter<Impact>,
    mut started: MessageWriter<CollisionStarted>,
    mut ended: MessageWriter<CollisionEnded>,
) {
    impacts.write_batch(state.impacts.iter().copied());
    started.write_batch(state.started.iter().map(|&(a, b)| CollisionStarted(a, b)));
    ended.write_batch(state.ended.iter().map(|&(a, b)| CollisionEnded(a, b)));
}

/// Puts resting islands to sleep and wakes the islands woken in this step (see
/// [`crate::dynamics::sleep`]): updates each awake dynamic body's [`SleepTimer`], groups
/// touching bodies into islands, and marks every body of an island whose bodies have all been
/// slow for the configured time, zeroing its velocities.
pub fn update_sleep(
    mut commands: Commands,
    state: Res<PhysicsState>,
    pairs: Res<ContactPairs>,
    mut bodies: Query<(
        Option<&mut SleepTimer>,
        Option<&mut LinearVelocity>,
        Option<&mut AngularVelocity>,
    )>,
    sleepers: Query<(Entity, &Sleeping)>,
) {
    let config = &state.settings.sleep;
    if !config.enabled {
        for (entity, _) in &sleepers {
            commands.entity(entity).remove::<Sleeping>();
        }
        return;
    }
    let island_of = |entity: Entity, marker: &Sleeping| {
        if marker.island == Entity::PLACEHOLDER {
            entity
        } else {
            marker.island
        }
    };
    let mut woken = state.woken.clone();
    for &entity in &state.lost {
        if let Ok((entity, marker)) = sleepers.get(entity) {
            woken.push(island_of(entity, marker));
        }
    }
    if !woken.is_empty() {
        woken.sort_unstable();
        woken.dedup();
        let woken = |island: Entity| woken.binary_search(&island).is_ok();
        // Every body of a woken island: those of the sleeping set (in the step or not), and
        // the sleeping-marked ones read every step.
        for s in state.sleepers.records() {
            if woken(s.island) {
                commands.entity(s.entity).remove::<Sleeping>();
            }
        }
        for &entity in &state.read_every_step {
            if let Ok((entity, marker)) = sleepers.get(entity)
                && woken(island_of(entity, marker))
            {
                commands.entity(entity).remove::<Sleeping>();
            }
        }
    }
    let mut timers: Vec<Option<f32>> = vec![None; state.bodies.len()];
    for (i, (body, slot)) in state.bodies.iter().zip(timers.iter_mut()).enumerate() {
        if body.motion != Motion::Dynamic {
            continue;
        }
        let Ok((Some(mut timer), _, _)) = bodies.get_mut(state.entities[i]) else {
            continue;
        };
        let speed =
            body.linear_velocity.length() + body.angular_velocity.length() * state.radius[i];
        timer.0 = if speed < config.linear_threshold {
            timer.0 + state.dt
        } else {
            0.0
        };
        *slot = Some(timer.0);
    }
    // Islands: touching pairs of dynamic bodies; a body touching a moving kinematic body stays
    // awake (its island gets a member that never sleeps).
    let moving = |i: usize| {
        let b = &state.bodies[i];
        b.motion == Motion::Kinematic
            && (b.linear_velocity != Vec3::ZERO || b.angular_velocity != Vec3::ZERO)
    };
    let mut links = Vec::new();
    for (pair, &(ia, ib)) in pairs.candidates().iter().zip(&state.candidate_indices) {
        let (da, db) = (
            state.bodies[ia].motion == Motion::Dynamic,
            state.bodies[ib].motion == Motion::Dynamic,
        );
        if pair.touching && ((da && (db || moving(ib))) || (db && moving(ia))) {
            links.push((ia as u32, ib as u32));
        }
    }
    for (i, island) in islands_to_sleep(&timers, &links, config.time_to_sleep)
        .into_iter()
        .enumerate()
    {
        let Some(root) = island else { continue };
        let entity = state.entities[i];
        if let Ok((_, linear, angular)) = bodies.get_mut(entity) {
            if let Some(mut v) = linear {
                v.0 = Vec3::ZERO;
            }
            if let Some(mut w) = angular {
                w.0 = Vec3::ZERO;
            }
        }
        commands.entity(entity).insert(Sleeping {
            island: state.entities[root as usize],
        });
    }
}
