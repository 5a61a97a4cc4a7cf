//! avian3d 0.7 through a Bevy app: `MinimalPlugins` + `PhysicsPlugins::new(LabStep)`, one step
//! = one run of [`LabStep`] (which includes avian's transform propagation and
//! position-to-transform write-back, as in a user's app).
//!
//! Set to match impact3d where avian allows: restitution and friction per body with the `Max`
//! combine rule, no sleeping, restitution threshold 0.5 m/s (impact3d's). Everything else is
//! avian's default; the substep count is avian's default (6) unless the sweep sets it.

use std::time::Duration;

use avian3d::prelude as av;
use bevy::prelude::*;

use super::{Engine, LabStep, bevy_app, step_bevy};
use crate::scenes::{BodyState, SceneSpec, Shape};
use crate::sweep::RunConfig;

/// avian3d with one scene loaded.
pub struct Avian {
    app: App,
    bodies: Vec<Entity>,
    dt: Duration,
}

impl Avian {
    /// The bodies of `spec` with the substep count of `config` (avian's own when `config` is its default).
    pub fn new(spec: &SceneSpec, config: &RunConfig) -> Self {
        let mut app = bevy_app(av::PhysicsPlugins::new(LabStep));
        app.insert_resource(av::Gravity(spec.gravity));
        app.insert_resource(avian3d::dynamics::solver::SolverConfig {
            restitution_threshold: impact3d::prelude::SolverConfig::default().restitution_threshold,
            ..default()
        });
        if !config.default_settings {
            app.insert_resource(av::SubstepCount(config.substeps));
        }
        let max = av::CoefficientCombine::Max;
        let world = app.world_mut();
        let mut bodies = Vec::new();
        for b in &spec.bodies {
            let collider = match &b.shape {
                &Shape::Ball(r) => av::Collider::sphere(r),
                &Shape::Cuboid(h) => av::Collider::cuboid(2.0 * h.x, 2.0 * h.y, 2.0 * h.z),
                // avian's length is the cylinder's, without the caps.
                &Shape::Capsule(r, hh) => av::Collider::capsule(r, 2.0 * hh),
                Shape::Hull(points) => {
                    av::Collider::convex_hull(points.clone()).expect("a hull impact3d accepted")
                }
                Shape::TriMesh(vertices, indices) => {
                    av::Collider::trimesh(vertices.clone(), indices.clone())
                }
                &Shape::HalfSpace(n) => av::Collider::half_space(n),
            };
            let mut entity = world.spawn((
                if b.dynamic {
                    av::RigidBody::Dynamic
                } else {
                    av::RigidBody::Static
                },
                collider,
                Transform::from_translation(b.position).with_rotation(b.rotation),
                av::Restitution::new(b.restitution).with_combine_rule(max),
                av::Friction::new(b.friction).with_combine_rule(max),
            ));
            if b.dynamic {
                entity.insert((
                    av::ColliderDensity(b.mass / b.shape.volume()),
                    av::LinearVelocity(b.linvel),
                    av::AngularVelocity(b.angvel),
                    av::SleepingDisabled,
                ));
                bodies.push(entity.id());
            }
        }
        Avian {
            app,
            bodies,
            dt: config.dt(),
        }
    }
}

impl Engine for Avian {
    fn step(&mut self) {
        step_bevy(self.app.world_mut(), self.dt);
    }

    fn read(&mut self, out: &mut Vec<BodyState>) {
        let world = self.app.world();
        out.clear();
        out.extend(self.bodies.iter().map(|&e| {
            BodyState {
                position: world.get::<av::Position>(e).expect("body has a Position").0,
                rotation: world.get::<av::Rotation>(e).expect("body has a Rotation").0,
                linvel: world
                    .get::<av::LinearVelocity>(e)
                    .expect("body has a LinearVelocity")
                    .0,
                angvel: world
                    .get::<av::AngularVelocity>(e)
                    .expect("body has an AngularVelocity")
                    .0,
            }
        }));
    }
}
