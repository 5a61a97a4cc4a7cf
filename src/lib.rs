#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

pub mod character;
pub mod collision;
#[cfg(feature = "debug")]
pub mod debug;
pub mod dynamics;
pub mod impulse;
pub mod interpolation;
pub mod messages;
pub mod pipeline;
pub mod scenes;
pub mod schedule;
pub mod spatial_query;

use bevy::app::{PluginGroup, PluginGroupBuilder};
use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;

pub use messages::{CollisionEnd, CollisionEnded, CollisionStart, CollisionStarted, Impact};

/// Everything a user of the plugin writes.
pub mod prelude {
    pub use crate::PhysicsPlugins;
    pub use crate::character::{
        CharacterConfig, CharacterOutput, CharacterPlugin, CharacterSystems, KinematicCharacter,
        MoveAndSlide, MoveAndSlideConfig, MoveAndSlideHitData, MoveAndSlideHitResponse,
        MoveAndSlideOutput,
    };
    pub use crate::collision::{
        Collider, ColliderConstructor, ColliderConstructorHierarchy,
        ColliderConstructorHierarchyConfig, ColliderConstructorHierarchyReady,
        ColliderConstructorReady, ColliderDisabled, ColliderOf, CollidingEntities,
        CollisionEventsEnabled, CollisionLayers, LayerMask, NarrowPhaseConfig, PhysicsLayer,
        Sensor,
    };
    #[cfg(feature = "debug")]
    pub use crate::debug::{DebugRender, PhysicsDebugPlugin, PhysicsGizmos};
    pub use crate::dynamics::{
        AccumulatedForces, AngularDamping, AngularVelocity, CoefficientCombine, ComputedMass,
        ConstantAngularAcceleration, ConstantForce, ConstantLinearAcceleration, ConstantLocalForce,
        ConstantLocalTorque, ConstantTorque, Density, Forces, Friction, FrictionCombine,
        FrictionModel, Gravity, GravityScale, ImpactMessages, LinearDamping, LinearVelocity,
        LockedAxes, Mass, MaxAngularSpeed, MaxLinearSpeed, PhysicsLengthUnit, Quarantined,
        Restitution, RestitutionCombine, RigidBody, RigidBodyDisabled, SleepConfig, Sleeping,
        SleepingDisabled, SolverConfig, SolverMethod, SolverStats,
    };
    pub use crate::interpolation::{
        InterpolationConfig, InterpolationPlugin, TransformInterpolation,
    };
    pub use crate::messages::{
        CollisionEnd, CollisionEnded, CollisionStart, CollisionStarted, Impact,
    };
    pub use crate::schedule::{PhysicsSchedule, PhysicsSystems, PhysicsTime};
    pub use crate::spatial_query::{
        ColliderAabb, PointProjection, RayCaster, RayHitData, RayHits, ShapeCastConfig,
        ShapeCaster, ShapeHitData, ShapeHits, SpatialQuery, SpatialQueryFilter, SpatialQueryPlugin,
        SpatialQuerySystems,
    };
}

/// All of impact3d's plugins. `PhysicsPlugins::default()` steps physics in `FixedPostUpdate`;
/// `PhysicsPlugins::new(schedule)` in another schedule. Each plugin can be replaced with
/// `PhysicsPlugins::default().set(...)` or left out with `.disable::<P>()`.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// App::new().add_plugins((MinimalPlugins, PhysicsPlugins::default()));
/// ```
pub struct PhysicsPlugins {
    schedule: Interned<dyn ScheduleLabel>,
}

impl PhysicsPlugins {
    /// Physics stepped once per run of `schedule`, with that schedule's `Time` delta as `dt`.
    pub fn new(schedule: impl ScheduleLabel) -> Self {
        PhysicsPlugins {
            schedule: schedule.intern(),
        }
    }
}

impl Default for PhysicsPlugins {
    fn default() -> Self {
        Self::new(FixedPostUpdate)
    }
}

impl PluginGroup for PhysicsPlugins {
    fn build(self) -> PluginGroupBuilder {
        PluginGroupBuilder::start::<Self>()
            .add(schedule::PhysicsSchedulePlugin {
                schedule: self.schedule,
            })
            .add(collision::CollisionPlugin)
            .add(dynamics::DynamicsPlugin)
            .add(pipeline::PreparePlugin)
            .add(pipeline::BroadPhasePlugin)
            .add(pipeline::NarrowPhasePlugin)
            .add(pipeline::SolvePlugin)
            .add(pipeline::WriteBackPlugin)
            .add(pipeline::SleepPlugin)
            .add(pipeline::MessagesPlugin)
            .add(spatial_query::SpatialQueryPlugin::new(self.schedule))
            .add(interpolation::InterpolationPlugin::default())
    }
}
