//! The prepare stage: validates the settings and every body (quarantining bad input, logging
//! an error that names the entity), keeps mass properties up to date, and packs the solver
//! bodies; sleeping bodies sit the step out until something may touch them.

use bevy::ecs::change_detection::Tick;
use bevy::ecs::query::QueryData;
use bevy::ecs::system::{SystemChangeTick, SystemParam};
use bevy::prelude::*;
use parry3d::bounding_volume::BoundingVolume;
use parry3d::math::Pose;

use crate::collision::sensor::Reporting;
use crate::collision::{
    Collider, ColliderDisabled, CollidingEntities, CollisionEventsEnabled, CollisionLayers, Sensor,
};
use crate::dynamics::forces::{
    AccumulatedForces, AngularDamping, BodyMotion, ConstantAngularAcceleration, ConstantForce,
    ConstantLinearAcceleration, ConstantLocalForce, ConstantLocalTorque, ConstantTorque,
    GravityScale, LinearDamping, MaxAngularSpeed, MaxLinearSpeed,
};
use crate::dynamics::sleep::{SleepConfig, Sleeper, Sleeping, SleepingDisabled};
use crate::dynamics::solver::{Motion, SolverBody};
use crate::dynamics::validation::{
    MAX_ACCELERATION, MAX_ANGULAR_ACCELERATION, MAX_ANGULAR_SPEED, MAX_COORDINATE,
    MAX_LINEAR_SPEED, PhysicsLengthUnit, body_label, check_length, within,
};
use crate::dynamics::{
    AngularVelocity, CombineRules, ComputedMass, Density, Friction, FrictionCombine, Gravity,
    LinearVelocity, LockedAxes, Mass, Quarantined, Restitution, RestitutionCombine, RigidBody,
    RigidBodyDisabled, SolverConfig,
};
use crate::schedule::{PhysicsSchedule, PhysicsSystems, PhysicsTime};

use super::{PhysicsState, init_stage_state, mark_awake_active, validate_settings, wake_islands};

/// Adds [`prepare_bodies`] to [`PhysicsSystems::Prepare`].
pub struct PreparePlugin;

impl Plugin for PreparePlugin {
    fn build(&self, app: &mut App) {
        init_stage_state(app).add_systems(
            PhysicsSchedule,
            prepare_bodies.in_set(PhysicsSystems::Prepare),
        );
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
    restitution_combine: Option<&'static RestitutionCombine>,
    friction_combine: Option<&'static FrictionCombine>,
    mass: Option<Ref<'static, Mass>>,
    density: Option<Ref<'static, Density>>,
    computed: Option<&'static mut ComputedMass>,
    locked: Option<&'static LockedAxes>,
    name: Option<&'static Name>,
    quarantined: Option<&'static Quarantined>,
    sleeping: Option<Ref<'static, Sleeping>>,
    layers: Option<Ref<'static, CollisionLayers>>,
    sensor: Option<Ref<'static, Sensor>>,
    events: Has<CollisionEventsEnabled>,
    colliding: Has<CollidingEntities>,
    motion: MotionData,
}

/// The components of a body beyond gravity and contacts: forces, accelerations, damping, speed
/// caps, and the markers that keep it awake or its collider out of contacts.
#[derive(QueryData)]
#[query_data(mutable)]
pub struct MotionData {
    constant_force: Option<Ref<'static, ConstantForce>>,
    constant_torque: Option<Ref<'static, ConstantTorque>>,
    constant_local_force: Option<Ref<'static, ConstantLocalForce>>,
    constant_local_torque: Option<Ref<'static, ConstantLocalTorque>>,
    linear_acceleration: Option<Ref<'static, ConstantLinearAcceleration>>,
    angular_acceleration: Option<Ref<'static, ConstantAngularAcceleration>>,
    accumulated: Option<&'static mut AccumulatedForces>,
    gravity_scale: Option<Ref<'static, GravityScale>>,
    linear_damping: Option<&'static LinearDamping>,
    angular_damping: Option<&'static AngularDamping>,
    max_linear_speed: Option<&'static MaxLinearSpeed>,
    max_angular_speed: Option<&'static MaxAngularSpeed>,
    sleeping_disabled: Has<SleepingDisabled>,
    collider_disabled: Has<ColliderDisabled>,
}

/// Change filter of a sleeping body: any of the components the prepare stage reads changed
/// since its last run (or the marker was just added). A sleeping body that matches none sits
/// out the step (see [`SleepingSet`]).
type Disturbed = Or<(
    Or<(
        Changed<ConstantForce>,
        Changed<ConstantTorque>,
        Changed<ConstantLocalForce>,
        Changed<ConstantLocalTorque>,
        Changed<ConstantLinearAcceleration>,
        Changed<ConstantAngularAcceleration>,
        Changed<AccumulatedForces>,
        Changed<GravityScale>,
        Changed<LinearDamping>,
        Changed<AngularDamping>,
        Changed<MaxLinearSpeed>,
        Changed<MaxAngularSpeed>,
        Changed<SleepingDisabled>,
        Changed<ColliderDisabled>,
    )>,
    Changed<Sleeping>,
    Changed<Transform>,
    Changed<Collider>,
    Changed<RigidBody>,
    Changed<LinearVelocity>,
    Changed<AngularVelocity>,
    // (Bevy's filter tuples hold at most 15.)
    Or<(
        Changed<Restitution>,
        Changed<Friction>,
        Changed<RestitutionCombine>,
        Changed<FrictionCombine>,
    )>,
    Changed<Mass>,
    Changed<Density>,
    Changed<ComputedMass>,
    Changed<LockedAxes>,
    Changed<CollisionLayers>,
    Changed<Sensor>,
)>;

/// The settings resources and the clock a step reads.
#[derive(SystemParam)]
pub struct StepSettings<'w> {
    time: Res<'w, Time>,
    config: Res<'w, SolverConfig>,
    gravity: Res<'w, Gravity>,
    sleep: Res<'w, SleepConfig>,
    unit: Res<'w, PhysicsLengthUnit>,
    clock: Res<'w, PhysicsTime>,
}

/// The sleeping bodies: the entities of those disturbed since the last step, and every
/// sleeping body with the components the prepare stage reads.
type SleepingBodies<'w, 's> = ParamSet<
    'w,
    's,
    (
        Query<
            'static,
            'static,
            Entity,
            (
                With<Sleeping>,
                With<Collider>,
                Without<RigidBodyDisabled>,
                Disturbed,
            ),
        >,
        Query<'static, 'static, BodyData, (With<Sleeping>, Without<RigidBodyDisabled>)>,
    ),
>;

/// The removals of components a body's gathered state depends on. A sleeping body that lost
/// one is read again; one that lost its collider (or was despawned) ends its resting pairs, as
/// does one that was just disabled.
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
    restitution_combine: RemovedComponents<'w, 's, RestitutionCombine>,
    friction_combine: RemovedComponents<'w, 's, FrictionCombine>,
    mass: RemovedComponents<'w, 's, Mass>,
    density: RemovedComponents<'w, 's, Density>,
    computed: RemovedComponents<'w, 's, ComputedMass>,
    locked: RemovedComponents<'w, 's, LockedAxes>,
    layers: RemovedComponents<'w, 's, CollisionLayers>,
    sensor: RemovedComponents<'w, 's, Sensor>,
    motion: MotionRemovals<'w, 's>,
    /// The bodies disabled since the last step: they leave it as a despawned body does.
    disabled: Query<'w, 's, Entity, Added<RigidBodyDisabled>>,
}

/// The removals of the components of [`MotionData`], and of [`RigidBodyDisabled`]: a sleeping
/// body that lost one is read again.
#[derive(SystemParam)]
pub struct MotionRemovals<'w, 's> {
    force: RemovedComponents<'w, 's, ConstantForce>,
    torque: RemovedComponents<'w, 's, ConstantTorque>,
    local_force: RemovedComponents<'w, 's, ConstantLocalForce>,
    local_torque: RemovedComponents<'w, 's, ConstantLocalTorque>,
    linear_acceleration: RemovedComponents<'w, 's, ConstantLinearAcceleration>,
    angular_acceleration: RemovedComponents<'w, 's, ConstantAngularAcceleration>,
    gravity_scale: RemovedComponents<'w, 's, GravityScale>,
    linear_damping: RemovedComponents<'w, 's, LinearDamping>,
    angular_damping: RemovedComponents<'w, 's, AngularDamping>,
    max_linear_speed: RemovedComponents<'w, 's, MaxLinearSpeed>,
    max_angular_speed: RemovedComponents<'w, 's, MaxAngularSpeed>,
    collider_disabled: RemovedComponents<'w, 's, ColliderDisabled>,
    disabled: RemovedComponents<'w, 's, RigidBodyDisabled>,
}

impl MotionRemovals<'_, '_> {
    /// Every entity that lost one of the components since the last step.
    fn read(&mut self) -> Vec<Entity> {
        let mut out: Vec<Entity> = self.force.read().collect();
        out.extend(self.torque.read());
        out.extend(self.local_force.read());
        out.extend(self.local_torque.read());
        out.extend(self.linear_acceleration.read());
        out.extend(self.angular_acceleration.read());
        out.extend(self.gravity_scale.read());
        out.extend(self.linear_damping.read());
        out.extend(self.angular_damping.read());
        out.extend(self.max_linear_speed.read());
        out.extend(self.max_angular_speed.read());
        out.extend(self.collider_disabled.read());
        out.extend(self.disabled.read());
        out
    }
}

/// Validates every body, quarantines bad ones (logging an error that names the entity), keeps
/// mass properties up to date and packs the solver bodies. A collider without a `RigidBody` is
/// static.
///
/// A sleeping body is read only when something may have touched it (a component it depends
/// on changed or was removed, or it was just put to sleep); the others keep their record in
/// the [`SleepingSet`](crate::dynamics::sleep::SleepingSet) and sit out the step, unless the
/// broad phase finds an awake body's box over theirs or their island wakes.
pub fn prepare_bodies(
    mut commands: Commands,
    ticks: SystemChangeTick,
    settings: StepSettings,
    mut state: ResMut<PhysicsState>,
    mut awake: Query<BodyData, (Without<Sleeping>, Without<RigidBodyDisabled>)>,
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
        &settings.clock,
        settings.time.delta_secs(),
    );
    let sleep_enabled = state.settings.sleep.enabled;
    begin_step(state);
    // Bodies that lost their layers or sensor marker may now pair with bodies they were kept
    // from: they are active in this step.
    state.layers_removed.clear();
    state.layers_removed.extend(removals.layers.read());
    state.layers_removed.extend(removals.sensor.read());
    state.layers_removed.sort_unstable();
    state.layers_removed.dedup();
    for mut item in awake.iter_mut() {
        if let Gathered::Quarantined = gather_body(state, &mut commands, &ticks, &mut item) {
            state.departed.push(item.entity);
        }
    }
    // A disabled body leaves the step as a despawned one does: its pairs end.
    state.departed.extend(removals.disabled.iter());
    let read = sleepers_to_read(state, &mut sleeping, &mut removals);
    let mut query = sleeping.p1();
    for entity in read {
        let Ok(mut item) = query.get_mut(entity) else {
            continue;
        };
        gather_sleeper(state, &mut commands, &ticks, &mut item);
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

/// Starts a step's arrays: empty, the step counted.
fn begin_step(state: &mut PhysicsState) {
    state.dt = state.settings.dt;
    state.step = state.step.wrapping_add(1);
    state.entities.clear();
    state.bodies.clear();
    state.local_com.clear();
    state.shapes.clear();
    state.poses.clear();
    state.restitution.clear();
    state.friction.clear();
    state.combine.clear();
    state.layers.clear();
    state.reporting.clear();
    state.reach.clear();
    state.spin_reach.clear();
    state.aabbs.clear();
    state.active.clear();
    state.radius.clear();
    state.collides.clear();
    state.motion.clear();
    state.asleep.clear();
    state.woken.clear();
    state.entered.clear();
    state.departed.clear();
}

/// The sleeping bodies to read in this step, sorted: the disturbed ones, those that lost a
/// component, and those that must be read every step (quarantined, or not dynamic); all of
/// them when sleeping is off. Those that lost their collider (or were despawned) depart, and
/// leave the sleeping set with those read again.
fn sleepers_to_read(
    state: &mut PhysicsState,
    sleeping: &mut SleepingBodies,
    removals: &mut BodyRemovals,
) -> Vec<Entity> {
    let sleep_enabled = state.settings.sleep.enabled;
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
        removals.restitution_combine.read().collect(),
        removals.friction_combine.read().collect(),
        removals.mass.read().collect(),
        removals.density.read().collect(),
        removals.computed.read().collect(),
        removals.locked.read().collect(),
        state.layers_removed.clone(),
    ];
    for entity in removed.into_iter().flatten() {
        if state.sleepers.get(entity).is_some() {
            state.sleepers.remove(entity);
            read.push(entity);
        }
    }
    // A sleeping body no longer disabled is not in the set: it is read again like those that
    // lost a component of `MotionData` (an awake one is read anyway, and the sleeping query
    // skips it).
    for entity in removals.motion.read() {
        if state.sleepers.get(entity).is_some() {
            state.sleepers.remove(entity);
        }
        read.push(entity);
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
    read
}

/// Reads one sleeping body: still asleep, it joins the step and the sleeping set keeps its
/// record; quarantined, it departs; awake (or not dynamic), it is read every step.
fn gather_sleeper(
    state: &mut PhysicsState,
    commands: &mut Commands,
    ticks: &SystemChangeTick,
    item: &mut BodyDataItem,
) {
    let entity = item.entity;
    match gather_body(state, commands, ticks, item) {
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
                    combine: state.combine[i],
                    layers: state.layers[i],
                    reporting: state.reporting[i],
                    radius: state.radius[i],
                    motion: state
                        .motion
                        .last()
                        .filter(|&&(k, _, _)| k == i)
                        .map(|&(_, m, _)| m),
                    collides: state.collides[i],
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
    let gravity = state.settings.gravity.0;
    let check = validate(item, kind).and_then(|()| match kind {
        RigidBody::Dynamic => body_motion(item, gravity),
        _ => Ok(None),
    });
    // Whether a sleeping body was pushed, before the one-off forces are spent.
    let pushed = item
        .sleeping
        .as_ref()
        .is_some_and(|marker| pushed_since(&item.motion, marker.added(), ticks.this_run()));
    // This step has read the one-off forces: they are spent, whatever became of the body.
    if let Some(accumulated) = item.motion.accumulated.as_mut() {
        accumulated.set_if_neq(AccumulatedForces::default());
    }
    let label = || body_label(entity, item.name);
    let extra = match (check, item.quarantined) {
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
        (Ok(extra), Some(_)) => {
            log::info!(
                "impact3d: {} is valid again and rejoins the physics step",
                label()
            );
            commands.entity(entity).remove::<Quarantined>();
            extra
        }
        (Ok(extra), None) => extra,
    };
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
    let mut body = SolverBody::new(motion, translation + rotation * local_com, rotation)
        .with_mass(
            computed.inverse_mass,
            computed.local_inverse_inertia,
            computed.isotropic,
            item.locked.map_or(BVec3::FALSE, |l| l.rotation),
        )
        .with_velocity(linear, angular);
    // Forces, accelerations and damping act before the solve (see `crate::dynamics::forces`).
    if let Some(extra) = &extra {
        extra.start_step(&mut body, dt);
    }

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
                    .is_some_and(|w| w.last_changed().is_newer_than(since, now))
                || pushed;
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
    // The extra acceleration the solver integrates with gravity (see `BodyMotion::start_step`).
    let accelerated = if body.motion == Motion::Dynamic {
        body.extra_acceleration
    } else {
        Vec3::ZERO
    };
    let speed_gained = if accelerated == Vec3::ZERO {
        gained
    } else {
        (gravity + accelerated).length() * dt
    };
    let reach = if moving {
        (body.linear_velocity.length() + speed_gained + body.angular_velocity.length() * radius)
            * dt
    } else {
        0.0
    };
    // The box swept along the step's linear motion, widened by the margin and by how far
    // rotation can carry a point (|w| dt R): unlike a box widened by the whole reach in
    // every direction, it does not pull in bodies beside a fast body's path.
    let aabb = shape.compute_aabb(&pose);
    let aabb = if moving {
        let mut travel = body.linear_velocity * dt
            + 0.5 * gained * dt * state.settings.gravity.0.normalize_or_zero();
        // A free body flies on the parabola of `g + a`.
        if accelerated != Vec3::ZERO {
            travel += 0.5 * accelerated * dt * dt;
        }
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
    state.combine.push(CombineRules {
        restitution: item.restitution_combine.map(|c| c.0),
        friction: item.friction_combine.map(|c| c.0),
    });
    state
        .layers
        .push(item.layers.as_deref().copied().unwrap_or_default());
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
    state.reporting.push(reporting);
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
            || item.sleeping.as_ref().is_some_and(|m| m.is_added())
            || item.layers.as_ref().is_some_and(|l| l.is_changed())
            || item.sensor.as_ref().is_some_and(|s| s.is_added())
            || (!state.layers_removed.is_empty()
                && state.layers_removed.binary_search(&entity).is_ok()),
    );
    state.radius.push(radius);
    state.collides.push(!item.motion.collider_disabled);
    if let Some(extra) = extra {
        let i = state.bodies.len() - 1;
        state.motion.push((i, extra, body.position));
    }
    state.asleep.push(asleep);
    if state.asleep.last().is_some_and(Option::is_some) {
        Gathered::Asleep
    } else {
        Gathered::Awake
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

/// Whether something pushed a sleeping body since it fell asleep (tick `since`): a one-off
/// force waits in its [`AccumulatedForces`], a constant force or gravity scale was set, or it
/// may no longer sleep ([`SleepingDisabled`]). Its island wakes.
fn pushed_since(m: &MotionDataItem, since: Tick, now: Tick) -> bool {
    let newer = |tick: Tick| tick.is_newer_than(since, now);
    m.sleeping_disabled
        || m.accumulated
            .as_ref()
            .is_some_and(|a| **a != AccumulatedForces::default())
        || m.constant_force
            .as_ref()
            .is_some_and(|c| newer(c.last_changed()))
        || m.constant_torque
            .as_ref()
            .is_some_and(|c| newer(c.last_changed()))
        || m.constant_local_force
            .as_ref()
            .is_some_and(|c| newer(c.last_changed()))
        || m.constant_local_torque
            .as_ref()
            .is_some_and(|c| newer(c.last_changed()))
        || m.linear_acceleration
            .as_ref()
            .is_some_and(|c| newer(c.last_changed()))
        || m.angular_acceleration
            .as_ref()
            .is_some_and(|c| newer(c.last_changed()))
        || m.gravity_scale
            .as_ref()
            .is_some_and(|c| newer(c.last_changed()))
}

/// Checks a dynamic body's forces, accelerations, gravity scale, damping and speed caps, and
/// gathers them (world frame) for the step: `None` when it has none of them, so the step
/// leaves it exactly as before. Errors name the component and the value.
fn body_motion(item: &BodyDataItem, gravity: Vec3) -> Result<Option<BodyMotion>, String> {
    let m = &item.motion;
    let finite = |what: &str, v: Vec3| {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(format!("{what} {v} is not finite"))
        }
    };
    let rotation = item.transform.rotation.normalize();
    let locked = item.locked.copied().unwrap_or_default();
    let mut force = Vec3::ZERO;
    let mut torque = Vec3::ZERO;
    let mut linear = Vec3::ZERO;
    let mut angular = Vec3::ZERO;
    if let Some(f) = &m.constant_force {
        force += finite("ConstantForce", f.0)?;
    }
    if let Some(f) = &m.constant_local_force {
        force += rotation * finite("ConstantLocalForce", f.0)?;
    }
    if let Some(t) = &m.constant_torque {
        torque += finite("ConstantTorque", t.0)?;
    }
    if let Some(t) = &m.constant_local_torque {
        torque += rotation * finite("ConstantLocalTorque", t.0)?;
    }
    if let Some(a) = &m.linear_acceleration {
        linear += finite("ConstantLinearAcceleration", a.0)?;
    }
    if let Some(a) = &m.angular_acceleration {
        angular += finite("ConstantAngularAcceleration", a.0)?;
    }
    if let Some(a) = &m.accumulated {
        force += finite("the force applied through Forces", a.force)?;
        torque += finite("the torque applied through Forces", a.torque)?;
        linear += finite(
            "the linear acceleration applied through Forces",
            a.linear_acceleration,
        )?;
        angular += finite(
            "the angular acceleration applied through Forces",
            a.angular_acceleration,
        )?;
    }
    if let Some(scale) = &m.gravity_scale {
        if !scale.0.is_finite() {
            return Err(format!("GravityScale {:?} is not finite", scale.0));
        }
        if scale.0 != 1.0 {
            linear += (scale.0 - 1.0) * gravity;
        }
    }
    let computed = item
        .computed
        .as_deref()
        .ok_or("dynamic body has no ComputedMass component")?;
    if force != Vec3::ZERO {
        linear += computed.inverse_mass * force;
    }
    if torque != Vec3::ZERO {
        angular += computed.world_inverse_inertia(rotation, locked.rotation) * torque;
    }
    angular = Vec3::select(locked.rotation, Vec3::ZERO, angular);
    check_length("linear acceleration", linear, MAX_ACCELERATION)?;
    check_length("angular acceleration", angular, MAX_ANGULAR_ACCELERATION)?;
    let damping = |what: &str, c: Option<f32>| match c {
        Some(c) if !(c.is_finite() && c >= 0.0) => {
            Err(format!("{what} {c:?} must be finite and >= 0"))
        }
        c => Ok(c.unwrap_or(0.0)),
    };
    let cap = |what: &str, c: Option<f32>| match c {
        Some(c) if c.is_nan() || c < 0.0 => Err(format!("{what} {c:?} must be >= 0")),
        c => Ok(c.unwrap_or(f32::INFINITY)),
    };
    let motion = BodyMotion {
        linear_acceleration: linear,
        angular_acceleration: angular,
        linear_damping: damping("LinearDamping", m.linear_damping.map(|c| c.0))?,
        angular_damping: damping("AngularDamping", m.angular_damping.map(|c| c.0))?,
        max_linear_speed: cap("MaxLinearSpeed", m.max_linear_speed.map(|c| c.0))?,
        max_angular_speed: cap("MaxAngularSpeed", m.max_angular_speed.map(|c| c.0))?,
        locked_translation: locked.translation,
    };
    Ok((!motion.is_none()).then_some(motion))
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
