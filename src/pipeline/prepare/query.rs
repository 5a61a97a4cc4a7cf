//! What the prepare stage reads: a body's components, the settings of the step, and the
//! removals that make a sleeping body be read again.

use bevy::ecs::query::QueryData;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;

use crate::collision::{
    Collider, ColliderDisabled, CollidingEntities, CollisionEventsEnabled, CollisionLayers,
    NarrowPhaseConfig, Sensor,
};
use crate::dynamics::forces::{
    AccumulatedForces, AngularDamping, ConstantAngularAcceleration, ConstantForce,
    ConstantLinearAcceleration, ConstantLocalForce, ConstantLocalTorque, ConstantTorque,
    GravityScale, LinearDamping, MaxAngularSpeed, MaxLinearSpeed,
};
use crate::dynamics::sleep::{SleepConfig, Sleeping, SleepingDisabled};
use crate::dynamics::validation::PhysicsLengthUnit;
use crate::dynamics::{
    AngularVelocity, ComputedMass, Density, Friction, FrictionCombine, Gravity, LinearVelocity,
    LockedAxes, Mass, Quarantined, Restitution, RestitutionCombine, RigidBody, RigidBodyDisabled,
    SolverConfig,
};
use crate::schedule::PhysicsTime;

/// The components of a body as the prepare stage reads them.
#[derive(QueryData)]
#[query_data(mutable)]
pub struct BodyData {
    pub(super) entity: Entity,
    pub(super) collider: Option<Ref<'static, Collider>>,
    pub(super) body: Option<Ref<'static, RigidBody>>,
    pub(super) transform: Ref<'static, Transform>,
    pub(super) linear_velocity: Option<Ref<'static, LinearVelocity>>,
    pub(super) angular_velocity: Option<Ref<'static, AngularVelocity>>,
    pub(super) restitution: Option<Ref<'static, Restitution>>,
    pub(super) friction: Option<Ref<'static, Friction>>,
    pub(super) restitution_combine: Option<&'static RestitutionCombine>,
    pub(super) friction_combine: Option<&'static FrictionCombine>,
    pub(super) mass: Option<Ref<'static, Mass>>,
    pub(super) density: Option<Ref<'static, Density>>,
    pub(super) computed: Option<&'static mut ComputedMass>,
    pub(super) locked: Option<&'static LockedAxes>,
    pub(super) name: Option<&'static Name>,
    pub(super) quarantined: Option<&'static Quarantined>,
    pub(super) sleeping: Option<Ref<'static, Sleeping>>,
    pub(super) layers: Option<Ref<'static, CollisionLayers>>,
    pub(super) sensor: Option<Ref<'static, Sensor>>,
    pub(super) events: Has<CollisionEventsEnabled>,
    pub(super) colliding: Has<CollidingEntities>,
    pub(super) motion: MotionData,
}

/// The components of a body beyond gravity and contacts: forces, accelerations, damping, speed
/// caps, and the markers that keep it awake or its collider out of contacts.
#[derive(QueryData)]
#[query_data(mutable)]
pub struct MotionData {
    pub(super) constant_force: Option<Ref<'static, ConstantForce>>,
    pub(super) constant_torque: Option<Ref<'static, ConstantTorque>>,
    pub(super) constant_local_force: Option<Ref<'static, ConstantLocalForce>>,
    pub(super) constant_local_torque: Option<Ref<'static, ConstantLocalTorque>>,
    pub(super) linear_acceleration: Option<Ref<'static, ConstantLinearAcceleration>>,
    pub(super) angular_acceleration: Option<Ref<'static, ConstantAngularAcceleration>>,
    pub(super) accumulated: Option<&'static mut AccumulatedForces>,
    pub(super) gravity_scale: Option<Ref<'static, GravityScale>>,
    pub(super) linear_damping: Option<&'static LinearDamping>,
    pub(super) angular_damping: Option<&'static AngularDamping>,
    pub(super) max_linear_speed: Option<&'static MaxLinearSpeed>,
    pub(super) max_angular_speed: Option<&'static MaxAngularSpeed>,
    pub(super) sleeping_disabled: Has<SleepingDisabled>,
    pub(super) collider_disabled: Has<ColliderDisabled>,
}

/// Change filter of a sleeping body: any of the components the prepare stage reads changed
/// since its last run (or the marker was just added). A sleeping body that matches none sits
/// out the step (see [`SleepingSet`](crate::dynamics::sleep::SleepingSet)).
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
    pub(super) time: Res<'w, Time>,
    pub(super) config: Res<'w, SolverConfig>,
    pub(super) narrow: Res<'w, NarrowPhaseConfig>,
    pub(super) gravity: Res<'w, Gravity>,
    pub(super) sleep: Res<'w, SleepConfig>,
    pub(super) unit: Res<'w, PhysicsLengthUnit>,
    pub(super) clock: Res<'w, PhysicsTime>,
}

/// The awake bodies a step gathers: any entity with a collider or a body (a body may have its
/// colliders on its children only), not disabled.
pub(super) type AwakeBodies = (
    Without<Sleeping>,
    Without<RigidBodyDisabled>,
    Or<(With<Collider>, With<RigidBody>)>,
);

/// The sleeping bodies: the entities of those disturbed since the last step, and every
/// sleeping body with the components the prepare stage reads.
pub(super) type SleepingBodies<'w, 's> = ParamSet<
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
    pub(super) sleeping: RemovedComponents<'w, 's, Sleeping>,
    pub(super) collider: RemovedComponents<'w, 's, Collider>,
    pub(super) body: RemovedComponents<'w, 's, RigidBody>,
    pub(super) transform: RemovedComponents<'w, 's, Transform>,
    pub(super) linear: RemovedComponents<'w, 's, LinearVelocity>,
    pub(super) angular: RemovedComponents<'w, 's, AngularVelocity>,
    pub(super) restitution: RemovedComponents<'w, 's, Restitution>,
    pub(super) friction: RemovedComponents<'w, 's, Friction>,
    pub(super) restitution_combine: RemovedComponents<'w, 's, RestitutionCombine>,
    pub(super) friction_combine: RemovedComponents<'w, 's, FrictionCombine>,
    pub(super) mass: RemovedComponents<'w, 's, Mass>,
    pub(super) density: RemovedComponents<'w, 's, Density>,
    pub(super) computed: RemovedComponents<'w, 's, ComputedMass>,
    pub(super) locked: RemovedComponents<'w, 's, LockedAxes>,
    pub(super) layers: RemovedComponents<'w, 's, CollisionLayers>,
    pub(super) sensor: RemovedComponents<'w, 's, Sensor>,
    pub(super) motion: MotionRemovals<'w, 's>,
    /// The bodies disabled since the last step: they leave it as a despawned body does.
    pub(super) disabled: Query<'w, 's, Entity, Added<RigidBodyDisabled>>,
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
    pub(super) fn read(&mut self) -> Vec<Entity> {
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
