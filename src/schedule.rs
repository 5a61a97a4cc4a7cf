//! The physics schedule: its stages, in order, in one place.
//!
//! Each fixed step, [`PhysicsSchedule`] runs these sets, chained:
//!
//! | set | what runs |
//! |---|---|
//! | [`PhysicsSystems::Prepare`] | read new and changed bodies, validate them (quarantine bad input), compute mass properties, pack solver bodies, apply their forces, accelerations and damping to their velocities |
//! | [`PhysicsSystems::BroadPhase`] | pairs of overlapping bounding boxes (widened by the contact margin and each body's motion), through the persistent [`BroadPhaseTree`](crate::collision::BroadPhaseTree) |
//! | [`PhysicsSystems::NarrowPhase`] | parry3d contact manifolds per pair, persistent so impulses carry over; contact constraints |
//! | [`PhysicsSystems::Solve`] | gravity, impacts and resting contact by the chosen [`SolverMethod`](crate::dynamics::SolverMethod), position integration; then translation locks and speed caps |
//! | [`PhysicsSystems::WriteBack`] | `Transform`, `LinearVelocity`, `AngularVelocity` |
//! | [`PhysicsSystems::Sleep`] | resting islands fall asleep; woken ones lose their marker |
//! | [`PhysicsSystems::Messages`] | `Impact`, `CollisionStarted`, `CollisionEnded`; `CollisionStart` and `CollisionEnd` (messages and entity events) for bodies with `CollisionEventsEnabled`; `CollidingEntities` |
//! | [`PhysicsSystems::SpatialQuery`] | each body's collider at its pose at the end of the step, for [`SpatialQuery`](crate::spatial_query::SpatialQuery) |

use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::{ScheduleLabel, SingleThreadedExecutor};
use bevy::prelude::*;

/// The schedule that runs one physics step. It is run once per run of the schedule the plugins
/// were given (`FixedPostUpdate` by default), single-threaded, so results are deterministic.
#[derive(ScheduleLabel, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PhysicsSchedule;

/// The stages of a physics step, chained in this order inside [`PhysicsSchedule`]
/// (`Prepare` to `Messages`); and, in the schedule the plugins step physics in
/// (`FixedPostUpdate` by default), `First`, `StepSimulation` (the step itself) and `Last`,
/// chained, so that game systems can run just before or just after the step:
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// fn steer(mut bodies: Query<&mut LinearVelocity>) {}
/// fn react(mut impacts: MessageReader<Impact>) {}
///
/// App::new()
///     .add_plugins((MinimalPlugins, PhysicsPlugins::default()))
///     .add_systems(FixedPostUpdate, steer.in_set(PhysicsSystems::First))
///     .add_systems(FixedPostUpdate, react.in_set(PhysicsSystems::Last));
/// ```
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PhysicsSystems {
    /// In the stepping schedule: before the step.
    First,
    /// In the stepping schedule: the step ([`run_physics_schedule`]).
    StepSimulation,
    /// In the stepping schedule: after the step (its messages and components are new).
    Last,
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
    /// The world spatial queries see brought up to date: each body's collider at its pose at
    /// the end of the step ([`crate::spatial_query`]).
    SpatialQuery,
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
                PhysicsSystems::SpatialQuery,
            )
                .chain(),
        );
        app.add_schedule(schedule);
        app.init_resource::<PhysicsTime>()
            .register_type::<PhysicsTime>()
            .configure_sets(
                self.schedule,
                (
                    PhysicsSystems::First,
                    PhysicsSystems::StepSimulation,
                    PhysicsSystems::Last,
                )
                    .chain(),
            )
            .add_systems(
                self.schedule,
                run_physics_schedule.in_set(PhysicsSystems::StepSimulation),
            );
    }
}

/// The physics clock: pause the simulation or run it faster or slower than the game's clock
/// without touching `Time<Virtual>` (as avian's `Time<Physics>`). Each run of the schedule the
/// plugins were given (`FixedPostUpdate` by default) steps physics once by that schedule's
/// `Time` delta times `relative_speed`; while `paused` (or at speed 0) it does not step at all,
/// so nothing moves and no message is sent. At speed 2 every step is twice as long, so bodies
/// cover twice the distance per frame (with the accuracy of the longer step: the step length
/// is validated as any, at most 1 s).
///
/// `relative_speed` must be finite and `>= 0`; a bad value is logged once and the last good one
/// is used.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// fn toggle_pause(mut clock: ResMut<PhysicsTime>) {
///     clock.paused = !clock.paused;
/// }
/// # bevy::ecs::system::assert_is_system(toggle_pause);
/// let mut clock = PhysicsTime::default();
/// clock.set_relative_speed(0.5); // slow motion
/// assert_eq!(clock.relative_speed, 0.5);
/// ```
#[derive(Resource, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Resource, Debug, Default, PartialEq)]
pub struct PhysicsTime {
    /// Physics does not step while true. Default false.
    pub paused: bool,
    /// Physics time per unit of the schedule's time. Default 1.
    pub relative_speed: f32,
}

impl Default for PhysicsTime {
    fn default() -> Self {
        PhysicsTime {
            paused: false,
            relative_speed: 1.0,
        }
    }
}

impl PhysicsTime {
    /// Stops stepping.
    pub fn pause(&mut self) {
        self.paused = true;
    }

    /// Steps again.
    pub fn unpause(&mut self) {
        self.paused = false;
    }

    /// Sets the physics time per unit of the schedule's time.
    pub fn set_relative_speed(&mut self, speed: f32) {
        self.relative_speed = speed;
    }

    /// Whether physics steps at all: not paused and the speed is not zero.
    pub fn is_running(&self) -> bool {
        !self.paused && self.relative_speed != 0.0
    }

    /// The relative speed, or `last_good` with a message when it is not finite or negative.
    pub fn validated_speed(&self, last_good: f32) -> (f32, Option<String>) {
        if self.relative_speed.is_finite() && self.relative_speed >= 0.0 {
            (self.relative_speed, None)
        } else {
            (
                last_good,
                Some(format!(
                    "PhysicsTime::relative_speed = {:?} is invalid (expected finite and >= 0); \
                     using {last_good:?}",
                    self.relative_speed
                )),
            )
        }
    }
}

/// Runs one physics step, unless [`PhysicsTime`] is paused.
pub fn run_physics_schedule(world: &mut World) {
    if world
        .get_resource::<PhysicsTime>()
        .is_none_or(PhysicsTime::is_running)
    {
        world.run_schedule(PhysicsSchedule);
    }
}
