//! The prepare stage: validates the settings and every body (quarantining bad input, logging
//! an error that names the entity), keeps mass properties up to date, and packs the solver
//! bodies; sleeping bodies sit the step out until something may touch them.

use bevy::ecs::change_detection::Tick;
use bevy::ecs::query::QueryData;
use bevy::ecs::system::{SystemChangeTick, SystemParam};
use bevy::prelude::*;
use parry3d::bounding_volume::BoundingVolume;
use parry3d::math::Pose;

use bevy::ecs::entity::{EntityHashMap, EntityHashSet};
use parry3d::shape::SharedShape;

use crate::collision::collider::{
    BodyPart, ColliderOf, Scaling, body_shape, is_unbounded_or_hollow, scaled_shape,
};
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
    collider: Option<Ref<'static, Collider>>,
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

/// The awake bodies a step gathers: any entity with a collider or a body (a body may have its
/// colliders on its children only), not disabled.
type AwakeBodies = (
    Without<Sleeping>,
    Without<RigidBodyDisabled>,
    Or<(With<Collider>, With<RigidBody>)>,
);

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
                Or<(With<Collider>, With<RigidBody>)>,
                Without<RigidBodyDisabled>,
                Disturbed,
            ),
        >,
        Query<
            'static,
            'static,
            BodyData,
            (
                With<Sleeping>,
                Or<(With<Collider>, With<RigidBody>)>,
                Without<RigidBodyDisabled>,
            ),
        >,
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
/// static, unless it is on a descendant of a body: then it is a part of that body (see
/// [`ColliderOf`] and [`resolve_hierarchy`]).
///
/// A sleeping body is read only when something may have touched it (a component it depends
/// on changed or was removed, or it was just put to sleep); the others keep their record in
/// the [`SleepingSet`](crate::dynamics::sleep::SleepingSet) and sit out the step, unless the
/// broad phase finds an awake body's box over theirs or their island wakes.
#[allow(clippy::too_many_arguments)]
pub fn prepare_bodies(
    mut commands: Commands,
    ticks: SystemChangeTick,
    settings: StepSettings,
    mut state: ResMut<PhysicsState>,
    mut awake: Query<BodyData, AwakeBodies>,
    mut sleeping: SleepingBodies,
    mut removals: BodyRemovals,
    hierarchy: HierarchyData,
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
    resolve_hierarchy(state, &mut commands, &hierarchy);
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
    state.hierarchy.prune();
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
    state.hierarchy.forget(&removed[0]);
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
    // Bodies whose ancestors moved or whose child colliders changed are read (and woken).
    for &entity in &state.hierarchy.disturbed {
        if state.sleepers.get(entity).is_some() {
            state.sleepers.remove(entity);
        }
        read.push(entity);
    }
    // The shapes built for bodies that left are dropped (rebuilt if they come back).
    state.hierarchy.forget(&state.departed);
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
        Gathered::Skipped => {
            state.sleepers.remove(entity);
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
    /// Not a body of the step: a collider that is a part of another body, or a body with no
    /// collider.
    Skipped,
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
    let hierarchy = &state.hierarchy;
    if !hierarchy.attached.is_empty() && hierarchy.attached.binary_search(&entity).is_ok() {
        return Gathered::Skipped;
    }
    let has_parts = hierarchy.has_parts(entity);
    if item.collider.is_none() && !has_parts {
        return Gathered::Skipped;
    }
    // The world pose: the `Transform` of a top-level entity, read as it is.
    let world = hierarchy.world_pose(entity).unwrap_or(*item.transform);
    let disturbed = hierarchy.is_disturbed(entity);
    let reshaped = hierarchy.is_reshaped(entity);
    let was_built = !hierarchy.built.is_empty() && hierarchy.built.contains_key(&entity);
    let kind = item.body.as_deref().copied().unwrap_or(RigidBody::Static);
    let gravity = state.settings.gravity.0;
    // A body with child colliders or a scale has its shape built (and kept until it changes);
    // any other has its collider's shape, as it is.
    let built = if has_parts || world.scale != Vec3::ONE {
        match build_body(state, item, world.scale) {
            Ok(Some(changed)) => Ok(Some(changed)),
            Ok(None) => return Gathered::Skipped,
            Err(reason) => Err(reason),
        }
    } else {
        Ok(None)
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
            validate(item, kind, &world, geometry, reshaped || unbuilt)
        })
        .and_then(|()| match kind {
            RigidBody::Dynamic => body_motion(item, world.rotation, gravity),
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
    let rotation = world.rotation.normalize();
    let translation = world.translation;
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

    let (shape, rebuilt) = match geometry {
        Some((Some(built), changed)) => (built.shape.clone(), changed),
        _ => (
            item.collider
                .as_deref()
                .expect("a body without parts has its own collider")
                .shape()
                .clone(),
            false,
        ),
    };
    let pose = Pose::from_parts(translation, rotation);
    let sphere = shape.as_ball().is_some();
    let radius = if is_unbounded_or_hollow(shape.as_ref()) {
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
                || pushed
                || disturbed;
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
    state.spin_reach.push(if moving && !sphere {
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
            || item.collider.as_ref().is_some_and(|c| c.is_changed())
            || disturbed
            || rebuilt
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

/// Checks one body's input (at its world pose `t`) and refreshes its mass properties when
/// their inputs changed. `geometry`, for a body whose shape is built (child colliders or a
/// scale; already checked by [`build_body`]), is that and whether it changed in this step;
/// `reshaped`: the body's child colliders changed (its mass properties are recomputed).
fn validate(
    item: &mut BodyDataItem,
    kind: RigidBody,
    t: &Transform,
    geometry: Option<(Option<&BuiltBody>, bool)>,
    reshaped: bool,
) -> Result<(), String> {
    if geometry.is_none()
        && let Some(error) = item.collider.as_ref().and_then(|c| c.error())
    {
        return Err(format!("invalid collider: {error}"));
    }
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
            || geometry.is_some_and(|(_, changed)| changed)
            || reshaped
            || item.computed.as_ref().is_some_and(|c| c.is_added())
            || item.collider.as_ref().is_some_and(|c| c.is_changed())
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
            let mass = item.mass.as_deref().map(|m| m.0);
            let computed = match (geometry, item.collider.as_deref()) {
                (Some((Some(built), _)), _) => ComputedMass::from_parts(&built.parts, mass)?,
                (None, Some(collider)) => ComputedMass::from_collider(collider, density, mass)?,
                _ => return Err("dynamic body has no collider".to_string()),
            };
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
fn body_motion(
    item: &BodyDataItem,
    rotation: Quat,
    gravity: Vec3,
) -> Result<Option<BodyMotion>, String> {
    let m = &item.motion;
    let finite = |what: &str, v: Vec3| {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(format!("{what} {v} is not finite"))
        }
    };
    let rotation = rotation.normalize();
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

// The entity hierarchy: colliders on child entities, parented bodies, scale.

/// What the prepare stage knows of the entity hierarchy: rebuilt each step by
/// [`resolve_hierarchy`] (the child colliders, the world poses of parented entities), and kept
/// across steps (each body's built shape, until its inputs change).
#[derive(Default)]
pub(super) struct HierarchyState {
    /// The colliders that are parts of another entity's body in this step, `(body, part)`,
    /// sorted by body, then in the order of the body's descendants (depth first, each entity's
    /// `Children` in their order: the order of `Collider::compound`'s parts when they were
    /// spawned in that order).
    parts: Vec<(Entity, ChildPart)>,
    /// Scratch: the depth-first position of each descendant of the bodies with parts, sorted
    /// by entity.
    order: Vec<(Entity, u32)>,
    /// The entities of those colliders, sorted: they are not bodies of their own.
    attached: Vec<Entity>,
    /// The world pose of each gathered entity with a parent, sorted by entity.
    world: Vec<(Entity, Transform)>,
    /// The world pose of the parent of each body that has one, at the start of the step,
    /// sorted by entity: the write-back turns the solved world pose into a local `Transform`.
    pub(super) parent_frames: Vec<(Entity, Transform)>,
    /// The bodies whose ancestors or child colliders changed since the last step, sorted: read
    /// (and woken) even when asleep.
    disturbed: Vec<Entity>,
    /// The bodies whose child colliders changed since the last step (were added, removed,
    /// moved, or changed shape, density or mass), sorted: their mass properties are recomputed.
    reshaped: Vec<Entity>,
    /// The shape and parts built for each body with child colliders or a scale.
    built: EntityHashMap<BuiltBody>,
    /// The entities a warning has been logged for (a scale their shape cannot take, a child
    /// collider that cannot be a part of its body): each is warned about once.
    warned: EntityHashSet,
}

impl HierarchyState {
    /// The colliders of `body` that sit on other entities.
    fn parts_of(&self, body: Entity) -> &[(Entity, ChildPart)] {
        parts_in(&self.parts, body)
    }

    fn has_parts(&self, body: Entity) -> bool {
        !self.parts_of(body).is_empty()
    }

    /// The world pose of `entity` if it has a parent.
    fn world_pose(&self, entity: Entity) -> Option<Transform> {
        if self.world.is_empty() {
            return None;
        }
        let i = self.world.binary_search_by_key(&entity, |(e, _)| *e).ok()?;
        Some(self.world[i].1)
    }

    fn is_disturbed(&self, entity: Entity) -> bool {
        !self.disturbed.is_empty() && self.disturbed.binary_search(&entity).is_ok()
    }

    fn is_reshaped(&self, entity: Entity) -> bool {
        !self.reshaped.is_empty() && self.reshaped.binary_search(&entity).is_ok()
    }

    /// The world pose of the parent of body `entity`, if it has one.
    pub(super) fn parent_frame(&self, entity: Entity) -> Option<Transform> {
        if self.parent_frames.is_empty() {
            return None;
        }
        let i = self
            .parent_frames
            .binary_search_by_key(&entity, |(e, _)| *e)
            .ok()?;
        Some(self.parent_frames[i].1)
    }

    /// Drops the shapes built for `entities` (bodies that left the step).
    fn forget(&mut self, entities: &[Entity]) {
        if self.built.is_empty() {
            return;
        }
        for entity in entities {
            self.built.remove(entity);
        }
    }

    /// Drops the shapes built for bodies that neither have child colliders nor were built in
    /// this step (no longer scaled, or asleep and scaled: rebuilt, to the same shape, when
    /// read again).
    fn prune(&mut self) {
        self.built.retain(|_, b| b.needed);
    }
}

/// The entries of `body` in `parts` (sorted by body).
fn parts_in(parts: &[(Entity, ChildPart)], body: Entity) -> &[(Entity, ChildPart)] {
    if parts.is_empty() {
        return &[];
    }
    let start = parts.partition_point(|(b, _)| *b < body);
    let end = start + parts[start..].partition_point(|(b, _)| *b == body);
    &parts[start..end]
}

/// A collider on a descendant of a body, as [`resolve_hierarchy`] found it.
#[derive(Clone)]
struct ChildPart {
    collider: Entity,
    /// Its shape, unscaled (kept, so that its address identifies it while it lives).
    shape: SharedShape,
    error: Option<String>,
    /// Its pose and scale relative to the body's frame (the body's world pose without scale):
    /// the body's world scale, then the `Transform`s from the body down to the collider.
    relative: Transform,
    density: Option<f32>,
    mass: Option<f32>,
    disabled: bool,
    name: Option<Name>,
}

impl ChildPart {
    /// The same collider with the same inputs (the same shape allocation, bit-equal numbers).
    fn same(&self, other: &ChildPart) -> bool {
        let bits = |t: &Transform| {
            let mut out = [0u32; 10];
            let values = t
                .translation
                .to_array()
                .into_iter()
                .chain(t.rotation.to_array())
                .chain(t.scale.to_array());
            for (o, x) in out.iter_mut().zip(values) {
                *o = x.to_bits();
            }
            out
        };
        self.collider == other.collider
            && std::sync::Arc::ptr_eq(&self.shape.0, &other.shape.0)
            && bits(&self.relative) == bits(&other.relative)
            && self.density.map(f32::to_bits) == other.density.map(f32::to_bits)
            && self.mass.map(f32::to_bits) == other.mass.map(f32::to_bits)
            && self.disabled == other.disabled
    }
}

/// The shape built for a body with child colliders or a scale, and the inputs it was built
/// from.
struct BuiltBody {
    /// The body's own collider shape, unscaled.
    own: Option<SharedShape>,
    /// The body's world scale, as bits.
    scale: [u32; 3],
    /// The body's density (for its own collider and children without one), as bits.
    density: u32,
    children: Vec<ChildPart>,
    /// The colliders, scaled and placed in the body's frame.
    parts: Vec<BodyPart>,
    /// The shape of the step: the lone scaled collider, or the compound of all.
    shape: SharedShape,
    /// Visited in this step or still needed (see [`HierarchyState::prune`]).
    needed: bool,
}

/// The entity hierarchy the prepare stage reads.
#[derive(SystemParam)]
pub struct HierarchyData<'w, 's> {
    /// Every entity's transform and parent, to walk up the tree.
    nodes: Query<'w, 's, HierarchyNode>,
    /// The entities with a parent that a step may gather: bodies and colliders.
    parented: Query<'w, 's, ParentedEntity, ParentedFilter>,
    /// What a child collider adds to its body.
    info: Query<'w, 's, PartInfo>,
    /// The colliders marked as parts of a body.
    marked: Query<'w, 's, Entity, With<ColliderOf>>,
    /// Each entity's children, in order: a body's parts are ordered as its descendants are.
    children: Query<'w, 's, &'static Children>,
}

/// The world transform of `entity` (its `Transform` composed with its ancestors', as Bevy's
/// `GlobalTransform` holds after propagation, here as it is at the step) and whether any of
/// them, or a parent link on the way, changed since the last step.
fn world_of(nodes: &Query<HierarchyNode>, entity: Entity) -> (Transform, bool) {
    let mut world: Option<Transform> = None;
    let mut changed = false;
    let mut e = entity;
    // Bevy's hierarchy has no cycles; the bound only keeps a broken one from hanging the step.
    for _ in 0..4096 {
        let Ok((transform, parent, _, _)) = nodes.get(e) else {
            break;
        };
        if let Some(t) = transform {
            changed |= t.is_changed();
            world = Some(match world {
                Some(below) => t.mul_transform(below),
                None => *t,
            });
        }
        match parent {
            Some(p) => {
                changed |= p.is_changed();
                e = p.parent();
            }
            None => break,
        }
    }
    (world.unwrap_or_default(), changed)
}

/// An entity with a parent that a step may gather: its parent, whether it is a body, its
/// collider.
type ParentedEntity = (
    Entity,
    &'static ChildOf,
    Has<RigidBody>,
    Option<&'static Collider>,
);

/// Bodies and colliders, not disabled.
type ParentedFilter = (
    Or<(With<RigidBody>, With<Collider>)>,
    Without<RigidBodyDisabled>,
);

/// What a child collider adds to its body: its density, mass, name, whether it is disabled, and
/// the body it was marked a part of.
type PartInfo = (
    Option<&'static Density>,
    Option<&'static Mass>,
    Option<&'static Name>,
    Has<ColliderDisabled>,
    Option<&'static ColliderOf>,
);

/// The item [`HierarchyData::nodes`] reads.
type HierarchyNode = (
    Option<Ref<'static, Transform>>,
    Option<Ref<'static, ChildOf>>,
    Option<&'static RigidBody>,
    Option<&'static Collider>,
);

/// Finds, for this step, the colliders that are parts of a body (each collider without a
/// `RigidBody` under an entity with one: the nearest such ancestor, avian3d's rule), their poses
/// relative to their bodies, and the world poses of parented bodies and static colliders; keeps
/// [`ColliderOf`] on the parts; and marks the bodies whose ancestors or parts changed. A
/// collider with no body above it is a static collider at its world pose.
pub(super) fn resolve_hierarchy(
    state: &mut PhysicsState,
    commands: &mut Commands,
    h: &HierarchyData,
) {
    let hs = &mut state.hierarchy;
    hs.parts.clear();
    hs.attached.clear();
    hs.world.clear();
    hs.parent_frames.clear();
    hs.disturbed.clear();
    hs.reshaped.clear();
    for (entity, child_of, is_body, collider) in h.parented.iter() {
        let parent = child_of.parent();
        if is_body {
            let (frame, moved) = world_of(&h.nodes, parent);
            let (own, up) = match h.nodes.get(entity) {
                Ok((t, up, _, _)) => (t.map_or(Transform::IDENTITY, |t| *t), up),
                Err(_) => (Transform::IDENTITY, None),
            };
            hs.world.push((entity, frame.mul_transform(own)));
            hs.parent_frames.push((entity, frame));
            if moved || up.is_some_and(|p| p.is_changed()) {
                hs.disturbed.push(entity);
            }
            continue;
        }
        let Some(collider) = collider else {
            continue;
        };
        // Up the tree to the nearest body, composing the transforms below it.
        let mut relative = match h.nodes.get(entity) {
            Ok((Some(t), _, _, _)) => *t,
            _ => Transform::IDENTITY,
        };
        let mut body = None;
        let mut e = parent;
        for _ in 0..4096 {
            let Ok((transform, up, rigid, own)) = h.nodes.get(e) else {
                break;
            };
            if let Some(kind) = rigid {
                body = Some((e, *kind, own));
                break;
            }
            if let Some(t) = transform {
                relative = t.mul_transform(relative);
            }
            match up {
                Some(p) => e = p.parent(),
                None => break,
            }
        }
        let Ok((density, mass, name, disabled, marked)) = h.info.get(entity) else {
            continue;
        };
        let composable = |c: Option<&Collider>| c.is_none_or(|c| !c.is_unbounded_or_hollow());
        match body {
            Some((b, _, own)) if composable(Some(collider)) && composable(own) => {
                let scale = world_of(&h.nodes, b).0.scale;
                if scale != Vec3::ONE {
                    relative = Transform::from_scale(scale).mul_transform(relative);
                }
                hs.parts.push((
                    b,
                    ChildPart {
                        collider: entity,
                        shape: collider.shape().clone(),
                        error: collider.error().map(str::to_string),
                        relative,
                        density: density.map(|d| d.0),
                        mass: mass.map(|m| m.0),
                        disabled,
                        name: name.cloned(),
                    },
                ));
                hs.attached.push(entity);
                if marked.map(|m| m.body) != Some(b) {
                    commands.entity(entity).insert(ColliderOf { body: b });
                    // It may have been a static collider of its own until now: its pairs end.
                    state.departed.push(entity);
                }
            }
            found => {
                if let Some((_, kind, _)) = found
                    && kind != RigidBody::Static
                    && hs.warned.insert(entity)
                {
                    log::warn!(
                        "impact3d: {} is a triangle mesh, heightfield or half-space (or its \
                         body's own collider is one) and cannot be a part of its {kind:?} body; \
                         it stays a static collider at its pose",
                        body_label(entity, name)
                    );
                }
                let (world, moved) = world_of(&h.nodes, entity);
                hs.world.push((entity, world));
                if moved {
                    hs.disturbed.push(entity);
                }
            }
        }
    }
    hs.attached.sort_unstable();
    for entity in h.marked.iter() {
        if hs.attached.binary_search(&entity).is_err() {
            commands.entity(entity).remove::<ColliderOf>();
        }
    }
    // The parts of each body in the order of its descendants.
    hs.order.clear();
    let mut bodies: Vec<Entity> = hs.parts.iter().map(|(b, _)| *b).collect();
    bodies.sort_unstable();
    bodies.dedup();
    let mut stack = Vec::new();
    for body in bodies {
        let mut n = 0u32;
        stack.clear();
        stack.push(body);
        while let Some(e) = stack.pop() {
            hs.order.push((e, n));
            n += 1;
            if let Ok(children) = h.children.get(e) {
                stack.extend(children.iter().rev());
            }
        }
    }
    hs.order.sort_unstable_by_key(|(e, _)| *e);
    let order = &hs.order;
    let position = |e: Entity| {
        order
            .binary_search_by_key(&e, |(k, _)| *k)
            .map_or(u32::MAX, |i| order[i].1)
    };
    hs.parts
        .sort_by_cached_key(|(body, part)| (*body, position(part.collider), part.collider));
    hs.world.sort_unstable_by_key(|(e, _)| *e);
    hs.parent_frames.sort_unstable_by_key(|(e, _)| *e);
    // Bodies whose parts changed, and those that lost all of them.
    for b in hs.built.values_mut() {
        b.needed = false;
    }
    let mut i = 0;
    while i < hs.parts.len() {
        let body = hs.parts[i].0;
        let n = hs.parts[i..].partition_point(|(b, _)| *b == body);
        let parts = &hs.parts[i..i + n];
        let same = hs.built.get_mut(&body).is_some_and(|built| {
            built.needed = true;
            built.children.len() == n
                && built
                    .children
                    .iter()
                    .zip(parts)
                    .all(|(a, (_, b))| a.same(b))
        });
        if !same {
            hs.reshaped.push(body);
        }
        i += n;
    }
    for (&body, built) in hs.built.iter() {
        if !built.children.is_empty() && parts_in(&hs.parts, body).is_empty() {
            hs.reshaped.push(body);
        }
    }
    hs.reshaped.sort_unstable();
    hs.disturbed.extend_from_slice(&hs.reshaped);
    hs.disturbed.sort_unstable();
    hs.disturbed.dedup();
}

/// Checks that a scale is usable: each component finite and > 0.
fn check_scale(what: &str, scale: Vec3) -> Result<(), String> {
    if scale.is_finite() && scale.min_element() > 0.0 {
        Ok(())
    } else {
        Err(format!(
            "{what} {scale} is not usable (each component must be finite and > 0)"
        ))
    }
}

/// Builds (or keeps, when its inputs did not change) the shape of a body with child colliders
/// or a world scale `scale`: its own collider scaled by `scale`, and each part scaled and placed
/// relative to the body. `Ok(Some(changed))` when built (`changed`: in this step), `Ok(None)`
/// when the body has no collider left (every part disabled), `Err` naming a bad scale or
/// collider.
fn build_body(
    state: &mut PhysicsState,
    item: &BodyDataItem,
    scale: Vec3,
) -> Result<Option<bool>, String> {
    let entity = item.entity;
    let hs = &mut state.hierarchy;
    let own = item.collider.as_deref();
    if let Some(error) = own.and_then(Collider::error) {
        return Err(format!("invalid collider: {error}"));
    }
    check_scale("scale", scale)?;
    let children = parts_in(&hs.parts, entity);
    for (_, part) in children {
        let label = || {
            format!(
                "child collider {}",
                body_label(part.collider, part.name.as_ref())
            )
        };
        if let Some(error) = &part.error {
            return Err(format!("{}: invalid collider: {error}", label()));
        }
        check_scale(&format!("{} has scale", label()), part.relative.scale)?;
        let norm = part.relative.rotation.length_squared();
        if !(part.relative.translation.is_finite() && norm.is_finite() && norm >= 1e-12) {
            return Err(format!(
                "{}: its pose relative to the body ({:?}) is not finite",
                label(),
                part.relative
            ));
        }
    }
    let density = item
        .density
        .as_deref()
        .map_or(Density::default().0, |d| d.0);
    let scale_bits = scale.to_array().map(f32::to_bits);
    if let Some(built) = hs.built.get_mut(&entity) {
        let same = built.scale == scale_bits
            && built.density == density.to_bits()
            && match (&built.own, own) {
                (Some(a), Some(b)) => std::sync::Arc::ptr_eq(&a.0, &b.shape().0),
                (None, None) => true,
                _ => false,
            }
            && built.children.len() == children.len()
            && built
                .children
                .iter()
                .zip(children)
                .all(|(a, (_, b))| a.same(b));
        if same {
            built.needed = true;
            return Ok((!built.parts.is_empty()).then_some(false));
        }
    }
    let mut parts = Vec::with_capacity(children.len() + 1);
    let mut nearest = Vec::new();
    if let Some(own) = own {
        let (shape, how) = scaled_shape(own.shape(), scale)?;
        if how == Scaling::Nearest {
            nearest.push((entity, item.name.cloned(), scale));
        }
        parts.push(BodyPart {
            shape,
            pose: Pose::IDENTITY,
            density,
            mass: None,
        });
    }
    for (_, part) in children.iter().filter(|(_, p)| !p.disabled) {
        let r = &part.relative;
        let (shape, how) = scaled_shape(&part.shape, r.scale)?;
        if how == Scaling::Nearest {
            nearest.push((part.collider, part.name.clone(), r.scale));
        }
        parts.push(BodyPart {
            shape,
            pose: Pose::from_parts(r.translation, r.rotation.normalize()),
            density: part.density.unwrap_or(density),
            mass: part.mass,
        });
    }
    for (collider, name, s) in nearest {
        if hs.warned.insert(collider) {
            log::warn!(
                "impact3d: {}'s shape cannot take the scale {s}; the nearest it can take is used \
                 (see `scaled_shape`)",
                body_label(collider, name.as_ref())
            );
        }
    }
    let shape = if parts.is_empty() {
        SharedShape::ball(1.0)
    } else {
        body_shape(&parts)
    };
    let empty = parts.is_empty();
    hs.built.insert(
        entity,
        BuiltBody {
            own: own.map(|c| c.shape().clone()),
            scale: scale_bits,
            density: density.to_bits(),
            children: children.iter().map(|(_, p)| p.clone()).collect(),
            parts,
            shape,
            needed: true,
        },
    );
    Ok((!empty).then_some(true))
}
