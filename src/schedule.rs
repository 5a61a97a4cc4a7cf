//! The physics schedule: its stages, in order, in one place.
//!
//! Each fixed step, [`PhysicsSchedule`] runs these sets, chained:
//!
//! | set | what runs |
//! |---|---|
//! | [`PhysicsSystems::Prepare`] | read new and changed bodies, validate them (quarantine bad input), compute mass properties, pack solver bodies |
//! | [`PhysicsSystems::BroadPhase`] | pairs of overlapping bounding boxes (widened by the contact margin and each body's motion), through the persistent [`BroadPhaseTree`](crate::collision::BroadPhaseTree) |
//! | [`PhysicsSystems::NarrowPhase`] | parry3d contact manifolds per pair, persistent so impulses carry over; contact constraints |
//! | [`PhysicsSystems::Solve`] | gravity, impacts and resting contact by the chosen [`SolverMethod`](crate::dynamics::SolverMethod), position integration |
//! | [`PhysicsSystems::WriteBack`] | `Transform`, `LinearVelocity`, `AngularVelocity` |
//! | [`PhysicsSystems::Sleep`] | resting islands fall asleep; woken ones lose their marker |
//! | [`PhysicsSystems::Messages`] | `Impact`, `CollisionStarted`, `CollisionEnded`; `CollisionStart` and `CollisionEnd` (messages and entity events) for bodies with `CollisionEventsEnabled`; `CollidingEntities` |

use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::{ScheduleLabel, SingleThreadedExecutor};
use bevy::prelude::*;

/// The schedule that runs one physics step. It is run once per run of the schedule the plugins
/// were given (`FixedPostUpdate` by default), single-threaded, so results are deterministic.
#[derive(ScheduleLabel, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PhysicsSchedule;

/// The stages of a physics step, chained in this order inside [`PhysicsSchedule`].
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PhysicsSystems {
    /// Validate and gather bodies.
    Prepare,
    /// Candidate pairs from bounding boxes.
    BroadPhase,
    /// Contact manifolds and constraints.
    NarrowPhase,
    /// The contact solve and integration.
    Solve,
    /// Results back to components.
    WriteBack,
    /// Sleeping islands.
    Sleep,
    /// Messages.
    Messages,
}

/// Sets up [`PhysicsSchedule`] and runs it from `schedule`.
pub struct PhysicsSchedulePlugin {
    /// The schedule that runs the physics step.
    pub schedule: Interned<dyn ScheduleLabel>,
}

impl Plugin for PhysicsSchedulePlugin {
    fn build(&self, app: &mut App) {
        let mut schedule = Schedule::new(PhysicsSchedule);
        schedule.set_executor(SingleThreadedExecutor::new());
        schedule.configure_sets(
            (
                PhysicsSystems::Prepare,
                PhysicsSystems::BroadPhase,
                PhysicsSystems::NarrowPhase,
                PhysicsSystems::Solve,
                PhysicsSystems::WriteBack,
                PhysicsSystems::Sleep,
                PhysicsSystems::Messages,
            )
                .chain(),
        );
        app.add_schedule(schedule);
        app.add_systems(self.schedule, run_physics_schedule);
    }
}

/// Runs one physics step.
pub fn run_physics_schedule(world: &mut World) {
    world.run_schedule(PhysicsSchedule);
}
