//! impact3d through a Bevy app: `MinimalPlugins` + `PhysicsPlugins::new(LabStep)`, the scene
//! spawned by impact3d's own scene builder, one step = one run of [`LabStep`].

use std::time::Duration;

use bevy::prelude::*;
use impact3d::prelude::*;

use super::{Engine, LabStep, bevy_app, step_bevy};
use crate::scenes::{self, BodyState, Scene};
use crate::sweep::RunConfig;

/// An impact3d app with `config` as its solver settings, sleeping off (as in the peers: the
/// lab measures the solve, not how soon bodies fall asleep), and nothing spawned; it records
/// the order in which bodies are spawned ([`scenes::SpawnOrder`]).
pub fn physics_app(config: SolverConfig) -> App {
    let mut app = bevy_app(PhysicsPlugins::new(LabStep));
    app.insert_resource(config)
        .insert_resource(SleepConfig {
            enabled: false,
            ..default()
        })
        .init_resource::<scenes::SpawnOrder>()
        .add_observer(scenes::record_spawn);
    app
}

/// impact3d with one scene loaded.
pub struct Impact3d {
    app: App,
    bodies: Vec<Entity>,
    dt: Duration,
}

impl Impact3d {
    /// `scene` built by its impact3d builder, solved by `method` with the substeps and
    /// iterations of `config` (the rest of [`SolverConfig`] at its defaults).
    pub fn new(scene: &Scene, method: SolverMethod, config: &RunConfig) -> Self {
        let mut app = physics_app(SolverConfig {
            substeps: config.substeps,
            iterations: config.iterations,
            ..SolverConfig::for_method(method)
        });
        (scene.build)(app.world_mut());
        let bodies = scenes::dynamic_entities(app.world());
        Impact3d {
            app,
            bodies,
            dt: config.dt(),
        }
    }
}

impl Engine for Impact3d {
    fn step(&mut self) {
        step_bevy(self.app.world_mut(), self.dt);
    }

    fn read(&mut self, out: &mut Vec<BodyState>) {
        let world = self.app.world();
        out.clear();
        out.extend(self.bodies.iter().map(|&e| {
            let transform = world.get::<Transform>(e).expect("body has a Transform");
            BodyState {
                position: transform.translation,
                rotation: transform.rotation,
                linvel: world
                    .get::<LinearVelocity>(e)
                    .expect("body has a LinearVelocity")
                    .0,
                angvel: world
                    .get::<AngularVelocity>(e)
                    .expect("body has an AngularVelocity")
                    .0,
            }
        }));
    }
}
