//! Bodies, mass properties and the contact solver.

pub mod forces;
pub mod mass;
pub mod rigid_body;
pub mod sleep;
pub mod solver;
pub mod validation;

pub use forces::{
    AccumulatedForces, AngularDamping, ConstantAngularAcceleration, ConstantForce,
    ConstantLinearAcceleration, ConstantLocalForce, ConstantLocalTorque, ConstantTorque, Forces,
    GravityScale, LinearDamping, MaxAngularSpeed, MaxLinearSpeed,
};
pub use mass::ComputedMass;
pub use rigid_body::{
    AngularVelocity, CoefficientCombine, CombineRules, Density, Friction, FrictionCombine, Gravity,
    LinearVelocity, LockedAxes, Mass, Quarantined, Restitution, RestitutionCombine, RigidBody,
    RigidBodyDisabled,
};
pub use sleep::{SleepConfig, SleepTimer, Sleeping, SleepingDisabled};
pub use solver::{FrictionModel, ImpactMessages, SolverConfig, SolverMethod, SolverStats};
pub use validation::PhysicsLengthUnit;

use bevy::prelude::*;

use crate::messages::Impact;

/// Bodies, mass properties and the solver's settings: registers the components and resources
/// and the `Impact` message. The systems that step them are [`crate::pipeline`]'s stages.
pub struct DynamicsPlugin;

impl Plugin for DynamicsPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<Gravity>()
            .init_resource::<SolverConfig>()
            .init_resource::<SolverStats>()
            .init_resource::<SleepConfig>()
            .init_resource::<validation::PhysicsLengthUnit>()
            .register_type::<validation::PhysicsLengthUnit>()
            .register_type::<Sleeping>()
            .register_type::<SleepTimer>()
            .register_type::<SleepConfig>()
            .add_message::<Impact>()
            .register_type::<RigidBody>()
            .register_type::<LinearVelocity>()
            .register_type::<AngularVelocity>()
            .register_type::<Restitution>()
            .register_type::<Friction>()
            .register_type::<RestitutionCombine>()
            .register_type::<FrictionCombine>()
            .register_type::<Mass>()
            .register_type::<Density>()
            .register_type::<LockedAxes>()
            .register_type::<RigidBodyDisabled>()
            .register_type::<SleepingDisabled>()
            .register_type::<ConstantForce>()
            .register_type::<ConstantTorque>()
            .register_type::<ConstantLocalForce>()
            .register_type::<ConstantLocalTorque>()
            .register_type::<ConstantLinearAcceleration>()
            .register_type::<ConstantAngularAcceleration>()
            .register_type::<AccumulatedForces>()
            .register_type::<GravityScale>()
            .register_type::<LinearDamping>()
            .register_type::<AngularDamping>()
            .register_type::<MaxLinearSpeed>()
            .register_type::<MaxAngularSpeed>()
            .register_type::<Gravity>()
            .register_type::<SolverConfig>()
            .register_type::<SolverStats>();
    }
}
