//! Bodies, mass properties and the contact solver.

pub mod mass;
pub mod rigid_body;
pub mod sleep;
pub mod solver;
pub mod validation;

pub use mass::ComputedMass;
pub use rigid_body::{
    AngularVelocity, CoefficientCombine, CombineRules, Density, Friction, FrictionCombine, Gravity,
    LinearVelocity, LockedAxes, Mass, Quarantined, Restitution, RestitutionCombine, RigidBody,
};
pub use sleep::{SleepConfig, SleepTimer, Sleeping};
pub use solver::{ImpactMessages, SolverConfig, SolverMethod, SolverStats};
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
            .register_type::<Gravity>()
            .register_type::<SolverConfig>()
            .register_type::<SolverStats>();
    }
}
