//! Each engine behind one small trait: build a scene from its [`SceneSpec`] (impact3d from the
//! scene's own builder), step once, read the dynamic bodies' states.

pub mod impact3d;

#[cfg(feature = "peers")]
pub mod avian;
#[cfg(feature = "peers")]
pub mod rapier;

use std::time::Duration;

use bevy::app::Plugins;
use bevy::ecs::schedule::{ScheduleLabel, SingleThreadedExecutor};
use bevy::prelude::*;

use crate::scenes::{BodyState, Scene, SceneSpec};
use crate::sweep::{EngineKind, RunConfig};

/// A physics engine with one scene loaded.
pub trait Engine {
    /// Advances the simulation by one time step. This, and only this, is timed.
    fn step(&mut self);
    /// Writes the states of the dynamic bodies into `out`, in the order of
    /// [`SceneSpec::dynamic`].
    fn read(&mut self, out: &mut Vec<BodyState>);
}

/// Loads `scene` (whose bodies are `spec`) into the engine of `config`, set up as `config`
/// says.
///
/// # Panics
///
/// For a peer engine when the `peers` feature is off (the sweep never asks for one then).
pub fn build(scene: &Scene, spec: &SceneSpec, config: &RunConfig) -> Box<dyn Engine> {
    match config.engine {
        EngineKind::Impact3d(method) => Box::new(impact3d::Impact3d::new(scene, method, config)),
        #[cfg(feature = "peers")]
        EngineKind::Avian => Box::new(avian::Avian::new(spec, config)),
        #[cfg(feature = "peers")]
        EngineKind::Rapier => Box::new(rapier::Rapier::new(spec, config)),
        #[cfg(not(feature = "peers"))]
        EngineKind::Avian | EngineKind::Rapier => {
            let _ = spec;
            panic!("peer engines need the `peers` feature")
        }
    }
}

/// The schedule the Bevy engines (impact3d, avian3d) step physics in. The lab runs it by hand,
/// one run per step, so that a step's time is the physics plugin's work and nothing else
/// (no `Main` schedule, no fixed-time loop). Single-threaded.
#[derive(ScheduleLabel, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LabStep;

/// A headless app (`MinimalPlugins` + `physics`, which must step in [`LabStep`]), finished and
/// updated once, as a user's app would be before its first physics step.
pub fn bevy_app<M>(physics: impl Plugins<M>) -> App {
    let mut app = App::new();
    let mut schedule = Schedule::new(LabStep);
    schedule.set_executor(SingleThreadedExecutor::new());
    app.add_schedule(schedule);
    app.add_plugins((MinimalPlugins, physics));
    app.finish();
    app.cleanup();
    app.update();
    app
}

/// One physics step of `dt` in a [`bevy_app`]: the generic `Time` advances by `dt` (which
/// both plugins read as the step length, as they do inside `FixedPostUpdate`), then
/// [`LabStep`] runs.
pub fn step_bevy(world: &mut World, dt: Duration) {
    world.resource_mut::<Time>().advance_by(dt);
    world.run_schedule(LabStep);
}
