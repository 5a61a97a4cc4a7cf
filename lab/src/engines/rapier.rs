//! Rapier 0.36 directly (no Bevy): one step = one `PhysicsPipeline::step` (through
//! `PhysicsWorld::step`, which calls it with the world's fields and nothing else).
//!
//! Set to match impact3d where Rapier allows: restitution and friction per collider with the
//! `Max` combine rule, mass from the collider with the spec's mass (inertia from the shape),
//! no sleeping. Everything else is Rapier's default; the solver iteration count is Rapier's
//! default (4) unless the sweep sets it. Rapier's vectors are glam 0.33 types, converted
//! through arrays.

use rapier3d::math::{Pose, Rotation, Vector};
use rapier3d::prelude::{
    CoefficientCombineRule, ColliderBuilder, PhysicsWorld, RigidBodyBuilder, RigidBodyHandle,
    SharedShape,
};

use super::Engine;
use crate::scenes::{BodyState, SceneSpec, Shape};
use crate::sweep::RunConfig;

/// Rapier with one scene loaded.
pub struct Rapier {
    world: PhysicsWorld,
    bodies: Vec<RigidBodyHandle>,
}

fn to_rapier(v: bevy::math::Vec3) -> Vector {
    Vector::from_array(v.to_array())
}

fn from_rapier(v: Vector) -> bevy::math::Vec3 {
    bevy::math::Vec3::from_array(v.to_array())
}

impl Rapier {
    /// The bodies of `spec` with the solver iterations of `config` (Rapier's own when `config` is its default).
    pub fn new(spec: &SceneSpec, config: &RunConfig) -> Self {
        let mut world = PhysicsWorld::new();
        world.gravity = to_rapier(spec.gravity);
        world.integration_parameters.dt = config.dt().as_secs_f32();
        if !config.default_settings {
            world.integration_parameters.num_solver_iterations = config.iterations as usize;
        }
        let max = CoefficientCombineRule::Max;
        let mut bodies = Vec::new();
        for b in &spec.bodies {
            let pose = Pose::from_parts(
                to_rapier(b.position),
                Rotation::from_array(b.rotation.to_array()),
            );
            let body = if b.dynamic {
                RigidBodyBuilder::dynamic()
                    .pose(pose)
                    .linvel(to_rapier(b.linvel))
                    .angvel(to_rapier(b.angvel))
                    .can_sleep(false)
            } else {
                RigidBodyBuilder::fixed().pose(pose)
            };
            let collider = match &b.shape {
                &Shape::Ball(r) => ColliderBuilder::ball(r),
                &Shape::Cuboid(h) => ColliderBuilder::cuboid(h.x, h.y, h.z),
                &Shape::Capsule(r, hh) => ColliderBuilder::capsule_y(hh, r),
                Shape::Hull(points) => {
                    let points: Vec<Vector> = points.iter().map(|&p| to_rapier(p)).collect();
                    ColliderBuilder::convex_hull(&points).expect("a hull impact3d accepted")
                }
                Shape::TriMesh(vertices, indices) => ColliderBuilder::trimesh(
                    vertices.iter().map(|&v| to_rapier(v)).collect(),
                    indices.clone(),
                )
                .expect("a mesh impact3d accepted"),
                &Shape::HalfSpace(n) => ColliderBuilder::new(SharedShape::halfspace(to_rapier(n))),
            };
            let collider = collider
                .restitution(b.restitution)
                .restitution_combine_rule(max)
                .friction(b.friction)
                .friction_combine_rule(max);
            let collider = if b.dynamic {
                collider.mass(b.mass)
            } else {
                collider
            };
            let (handle, _) = world.insert(body, collider);
            if b.dynamic {
                bodies.push(handle);
            }
        }
        Rapier { world, bodies }
    }
}

impl Engine for Rapier {
    fn step(&mut self) {
        self.world.step();
    }

    fn read(&mut self, out: &mut Vec<BodyState>) {
        out.clear();
        out.extend(self.bodies.iter().map(|&h| {
            let body = &self.world.bodies[h];
            BodyState {
                position: from_rapier(body.translation()),
                rotation: bevy::math::Quat::from_array(body.rotation().to_array()),
                linvel: from_rapier(body.linvel()),
                angvel: from_rapier(body.angvel()),
            }
        }));
    }
}
