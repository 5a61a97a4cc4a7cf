//! The scene list. Each scene is defined once: impact3d's shared scene builders
//! ([`impact3d::scenes`]) spawn it into a world, and [`SceneSpec::from_world`] copies the
//! spawned bodies (shape, mass, pose, velocities, restitution, friction) and the gravity for
//! the peers, so every engine gets the same geometry, masses and initial conditions. Each scene
//! carries its error metric ([`Check`]) and the tolerance a configuration must meet.

use std::collections::HashMap;

use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes as shared;

use crate::Mode;

/// What a scene is for; it decides how much of the sweep runs on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A closed-form answer exists; the error is relative to it.
    Accuracy,
    /// The answer is "nothing moves"; the error is a drift or a penetration, in metres.
    Stability,
    /// Many bodies: the point is the time per step.
    Throughput,
    /// Issue 8's stress family: piles, walls, columns and small cases that must not gain
    /// energy, run for 20 s at each engine's defaults at 60 Hz only.
    Stress,
}

/// A collision shape, in the body's frame.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// A sphere of this radius, m.
    Ball(f32),
    /// A box with these half extents, m.
    Cuboid(Vec3),
    /// A capsule along the local y axis: radius and half height of its cylinder, m.
    Capsule(f32, f32),
    /// The convex hull of these points, m.
    Hull(Vec<Vec3>),
    /// A triangle mesh (static bodies only): vertices, m, and triangles.
    TriMesh(Vec<Vec3>, Vec<[u32; 3]>),
    /// The half-space behind the plane through the body's origin with this outward normal.
    HalfSpace(Vec3),
}

impl Shape {
    /// Volume, m^3 (zero for a half-space or a mesh).
    pub fn volume(&self) -> f32 {
        match self {
            Shape::Ball(r) => 4.0 / 3.0 * std::f32::consts::PI * r * r * r,
            Shape::Cuboid(h) => 8.0 * h.x * h.y * h.z,
            Shape::Capsule(r, hh) => std::f32::consts::PI * r * r * (2.0 * hh + 4.0 / 3.0 * r),
            Shape::Hull(points) => Collider::convex_hull(points)
                .map_or(0.0, |c| 1.0 / c.shape().mass_properties(1.0).inv_mass),
            Shape::TriMesh(..) | Shape::HalfSpace(_) => 0.0,
        }
    }

    /// Inertia tensor of a body of `mass` kg with this shape, body frame, about its centre of
    /// mass (a hull's is off the body's origin; the energy metric neglects that offset).
    pub fn inertia(&self, mass: f32) -> Mat3 {
        match self {
            Shape::Ball(r) => Mat3::from_diagonal(Vec3::splat(0.4 * mass * r * r)),
            Shape::Cuboid(h) => {
                let s = *h * *h * 4.0;
                Mat3::from_diagonal(Vec3::new(s.y + s.z, s.x + s.z, s.x + s.y) * (mass / 12.0))
            }
            Shape::Capsule(r, hh) => {
                let collider = Collider::capsule(*r, *hh);
                let volume = self.volume();
                collider
                    .shape()
                    .mass_properties(mass / volume)
                    .reconstruct_inertia_matrix()
            }
            Shape::Hull(points) => Collider::convex_hull(points).map_or(Mat3::ZERO, |c| {
                c.shape()
                    .mass_properties(mass / self.volume())
                    .reconstruct_inertia_matrix()
            }),
            Shape::TriMesh(..) | Shape::HalfSpace(_) => Mat3::ZERO,
        }
    }
}

/// One body of a scene as every engine is given it.
#[derive(Clone, Debug, PartialEq)]
pub struct BodySpec {
    /// Dynamic (true) or static (false). No scene uses kinematic bodies.
    pub dynamic: bool,
    /// Its collider.
    pub shape: Shape,
    /// Mass, kg (unused for static bodies).
    pub mass: f32,
    /// Initial position of the centre, m.
    pub position: Vec3,
    /// Initial orientation.
    pub rotation: Quat,
    /// Initial linear velocity, m/s.
    pub linvel: Vec3,
    /// Initial angular velocity, rad/s.
    pub angvel: Vec3,
    /// Restitution coefficient (pairs combine with max).
    pub restitution: f32,
    /// Friction coefficient (pairs combine with max).
    pub friction: f32,
}

/// A scene's bodies and gravity, engine-neutral.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneSpec {
    /// Gravity, m/s^2.
    pub gravity: Vec3,
    /// All bodies, in spawn order.
    pub bodies: Vec<BodySpec>,
}

impl SceneSpec {
    /// Copies the bodies an impact3d scene builder spawned into `world` (an app made by
    /// [`crate::engines::impact3d::physics_app`]), in spawn order.
    ///
    /// # Panics
    ///
    /// On a kinematic body or a collider that is not a sphere, box, capsule along y, convex
    /// hull, triangle mesh or half-space: no scene of the lab uses them.
    pub fn from_world(world: &mut World) -> Self {
        let gravity = world.resource::<Gravity>().0;
        let order = world.resource::<SpawnOrder>().0.clone();
        let mut query = world.query::<(
            &RigidBody,
            &Collider,
            Option<&Mass>,
            &Density,
            &Transform,
            &LinearVelocity,
            &AngularVelocity,
            &Restitution,
            &Friction,
        )>();
        let bodies = order
            .iter()
            .map(|&entity| {
                let (body, collider, mass, density, transform, v, w, e, f) = query
                    .get(world, entity)
                    .expect("a spawned body has every body component");
                let shape = collider.shape();
                let shape = if let Some(ball) = shape.as_ball() {
                    Shape::Ball(ball.radius)
                } else if let Some(cuboid) = shape.as_cuboid() {
                    Shape::Cuboid(cuboid.half_extents)
                } else if let Some(capsule) = shape.as_capsule() {
                    let (a, b) = (capsule.segment.a, capsule.segment.b);
                    assert!(
                        a.x == 0.0 && a.z == 0.0 && b.x == 0.0 && b.z == 0.0 && a.y == -b.y,
                        "the lab's capsules lie along y, centred"
                    );
                    Shape::Capsule(capsule.radius, b.y.abs())
                } else if let Some(hull) = shape.as_convex_polyhedron() {
                    Shape::Hull(hull.points().to_vec())
                } else if let Some(mesh) = shape.as_trimesh() {
                    Shape::TriMesh(mesh.vertices().to_vec(), mesh.indices().to_vec())
                } else if let Some(half_space) = shape.as_halfspace() {
                    Shape::HalfSpace(half_space.normal)
                } else {
                    panic!("the lab supports spheres, boxes, capsules, hulls, meshes and half-spaces only")
                };
                assert!(
                    *body != RigidBody::Kinematic,
                    "the lab has no kinematic bodies"
                );
                BodySpec {
                    dynamic: body.is_dynamic(),
                    mass: mass.map_or_else(|| density.0 * shape.volume(), |m| m.0),
                    shape,
                    position: transform.translation,
                    rotation: transform.rotation,
                    linvel: v.0,
                    angvel: w.0,
                    restitution: e.0,
                    friction: f.0,
                }
            })
            .collect();
        SceneSpec { gravity, bodies }
    }

    /// The dynamic bodies, in the order every engine reports their states.
    pub fn dynamic(&self) -> impl Iterator<Item = &BodySpec> {
        self.bodies.iter().filter(|b| b.dynamic)
    }
}

/// The bodies of an impact3d world in the order they were spawned (entity ids do not tell
/// it), kept by an observer that [`crate::engines::impact3d::physics_app`] adds.
#[derive(Resource, Default)]
pub struct SpawnOrder(pub Vec<Entity>);

/// Records a new body in [`SpawnOrder`].
pub fn record_spawn(add: On<Add, RigidBody>, mut order: ResMut<SpawnOrder>) {
    order.0.push(add.entity);
}

/// The dynamic bodies of an impact3d world in spawn order: the order of
/// [`SceneSpec::dynamic`].
pub fn dynamic_entities(world: &World) -> Vec<Entity> {
    let order = &world.resource::<SpawnOrder>().0;
    order
        .iter()
        .copied()
        .filter(|&e| world.get::<RigidBody>(e).is_some_and(|b| b.is_dynamic()))
        .collect()
}

/// The state of one dynamic body after a step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BodyState {
    /// Centre, m.
    pub position: Vec3,
    /// Orientation.
    pub rotation: Quat,
    /// Linear velocity, m/s.
    pub linvel: Vec3,
    /// Angular velocity, rad/s.
    pub angvel: Vec3,
}

impl BodyState {
    fn is_finite(&self) -> bool {
        self.position.is_finite()
            && self.rotation.is_finite()
            && self.linvel.is_finite()
            && self.angvel.is_finite()
    }
}

/// A body's expected velocity at the end of an accuracy scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Expected {
    /// Index among the dynamic bodies.
    pub body: usize,
    /// Linear velocity, m/s.
    pub linvel: Vec3,
    /// Angular velocity, rad/s.
    pub angvel: Vec3,
}

/// How a scene's error is measured.
#[derive(Clone, Debug, PartialEq)]
pub enum Check {
    /// Bounce apexes of dynamic body 0 (a ball of `radius` under gravity `g`), each estimated
    /// from the last state before the ball starts falling (`y + v^2 / 2g`). Error: the largest
    /// relative error over the expected apexes (a missing apex counts as 1).
    Apexes {
        /// Ball radius, m.
        radius: f32,
        /// Gravity, m/s^2.
        g: f32,
        /// Heights of the lowest point at the apexes, m.
        expected: Vec<f32>,
    },
    /// Velocities at the end of the run. Error: the largest over the listed bodies of the
    /// velocity error in the body's kinetic-energy norm, `sqrt(|dv|^2 + dw.(I/m)dw) / scale`
    /// (the speed whose kinetic energy equals that of the error), so a spin error counts as
    /// much as the motion it really gives the body's mass.
    Velocities {
        /// The exact answers.
        expected: Vec<Expected>,
        /// Reference speed, m/s.
        scale: f32,
    },
    /// Error: the largest displacement of any body from its start over the run, m.
    Drift,
    /// A sphere of `radius` moving along +x towards a wall whose near face is at `face_x`.
    /// Error: how far the sphere got past the face over the run, m.
    Tunnel {
        /// x of the wall's near face, m.
        face_x: f32,
        /// Sphere radius, m.
        radius: f32,
    },
    /// Error: the deepest penetration over the run, m.
    Penetration,
    /// Bodies in free flight. Error: the largest distance from `p0 + v0 t` at the end, m.
    FreeFlight,
    /// Error: the largest speed of any body over the run divided by `limit` (the scene's
    /// largest free-fall speed plus the 3 m/s push-out cap; see `tests/stress.rs`), so 1 is
    /// the most a run may reach.
    Speed {
        /// m/s.
        limit: f32,
    },
    /// Error: the largest rise of mechanical energy over its start during the run, relative
    /// to the start's kinetic energy (0 when it never rises).
    EnergyRise,
}

/// One scene of the lab.
pub struct Scene {
    /// Short name, used for file names.
    pub name: &'static str,
    /// What it is for.
    pub kind: Kind,
    /// One line on what it is and what the error means.
    pub description: String,
    /// Spawns the scene into an impact3d world.
    pub build: Box<dyn Fn(&mut World)>,
    /// Simulated time, s.
    pub duration: f32,
    /// The error metric.
    pub check: Check,
    /// Largest error that passes.
    pub tolerance: f64,
    /// Unit of the error ("relative" or "m").
    pub unit: &'static str,
}

impl Scene {
    /// Builds the scene once in a scratch impact3d world and copies its bodies.
    pub fn spec(&self) -> SceneSpec {
        let mut app = crate::engines::impact3d::physics_app(SolverConfig::default());
        (self.build)(app.world_mut());
        SceneSpec::from_world(app.world_mut())
    }
}

/// The bounce: case 3, h0 = 1 m, e = 0.8, g = 10.
const BOUNCE_E: f32 = 0.8;
/// Oblique spheres: case 2 with e = 0.8.
const OBLIQUE_E: f32 = 0.8;
/// Box landing flat: case 9 with e = 0.5 (the order-dependent case for propagation).
const BOX_E: f32 = 0.5;
/// Cradle: case 8 with 3 balls struck at 2 m/s, well above every engine's restitution
/// threshold, e = 1.
const CRADLE_N: usize = 3;
const CRADLE_SPEED: f32 = 2.0;
/// Thin rod: case 4, tilted 30 degrees, v0 = 1 m/s, e = 1, L = 1 m, m = 1 kg, 2 cm square.
const ROD_TILT_DEG: f32 = 30.0;
const ROD_HALF: Vec3 = Vec3::new(0.5, 0.01, 0.01);

/// The scenes of `mode`.
pub fn all(mode: Mode) -> Vec<Scene> {
    let full = mode == Mode::Full;
    let smoke = mode == Mode::Smoke;
    let mut scenes = Vec::new();

    // Accuracy: closed-form answers.
    let apexes: Vec<f32> = (1..=if smoke { 1 } else { 3 })
        .map(|k| BOUNCE_E.powi(2 * k))
        .collect();
    scenes.push(Scene {
        name: "bounce",
        kind: Kind::Accuracy,
        description: format!(
            "case 3: ball dropped from 1 m, e = {BOUNCE_E}, g = 10; error = worst relative error of the first {} apexes",
            apexes.len()
        ),
        build: Box::new(|w| {
            shared::bouncing_ball(w, 1.0, BOUNCE_E);
        }),
        duration: if smoke { 0.9 } else { 2.1 },
        check: Check::Apexes { radius: shared::BOUNCE_RADIUS, g: 10.0, expected: apexes },
        tolerance: 0.02,
        unit: "relative",
    });
    if full {
        scenes.push(Scene {
            name: "rod",
            kind: Kind::Accuracy,
            description: format!(
                "case 4: thin rod (1 m, 1 kg, 2 cm square) landing on one end at 1 m/s, tilted {ROD_TILT_DEG} deg, e = 1; error = energy-norm velocity error / 1 m/s"
            ),
            build: Box::new(rod),
            duration: 0.2,
            check: Check::Velocities { expected: vec![rod_answer()], scale: 1.0 },
            tolerance: 0.01,
            unit: "relative",
        });
        scenes.push(Scene {
            name: "oblique",
            kind: Kind::Accuracy,
            description: format!(
                "case 2: oblique equal spheres at 30 deg, e = {OBLIQUE_E}, A spinning; error = energy-norm velocity error / 1 m/s"
            ),
            build: Box::new(|w| {
                shared::oblique(w, OBLIQUE_E);
            }),
            duration: 0.2,
            check: Check::Velocities { expected: oblique_answer(), scale: 1.0 },
            tolerance: 0.01,
            unit: "relative",
        });
    }
    scenes.push(Scene {
        name: "cradle",
        kind: Kind::Accuracy,
        description: format!(
            "case 8: Newton's cradle of {CRADLE_N} balls, first at {CRADLE_SPEED} m/s, e = 1; exact: only the last leaves; error = energy-norm velocity error / {CRADLE_SPEED} m/s"
        ),
        build: Box::new(|w| {
            shared::cradle(w, CRADLE_N, CRADLE_SPEED, 1.0);
        }),
        duration: 0.5,
        check: Check::Velocities {
            expected: (0..CRADLE_N)
                .map(|i| Expected {
                    body: i,
                    linvel: if i + 1 == CRADLE_N { Vec3::X * CRADLE_SPEED } else { Vec3::ZERO },
                    angvel: Vec3::ZERO,
                })
                .collect(),
            scale: CRADLE_SPEED,
        },
        tolerance: 0.01,
        unit: "relative",
    });
    scenes.push(Scene {
        name: "box_flat",
        kind: Kind::Accuracy,
        description: format!(
            "case 9: box (2 x 0.5 x 1 m) landing flat at 1 m/s, e = {BOX_E}; exact: rebound at {BOX_E} m/s, no spin; error = energy-norm velocity error / 1 m/s"
        ),
        build: Box::new(|w| {
            shared::box_landing_flat(w, BOX_E);
        }),
        duration: 0.2,
        check: Check::Velocities {
            expected: vec![Expected { body: 0, linvel: Vec3::Y * BOX_E, angvel: Vec3::ZERO }],
            scale: 1.0,
        },
        tolerance: 0.01,
        unit: "relative",
    });

    // Stability: nothing should move.
    let stacks: &[usize] = if full { &[10, 20] } else { &[10] };
    for &n in stacks {
        scenes.push(Scene {
            name: if n == 10 { "stack10" } else { "stack20" },
            kind: Kind::Stability,
            description: format!(
                "case 12: column of {n} 1 m cubes at rest; error = largest displacement, m"
            ),
            build: Box::new(move |w| {
                shared::stack(w, n);
            }),
            duration: if smoke { 1.0 } else { 5.0 },
            check: Check::Drift,
            tolerance: 0.05,
            unit: "m",
        });
    }
    if full {
        scenes.push(Scene {
            name: "pyramid",
            kind: Kind::Stability,
            description: "case 12: pyramid of 55 1 m cubes (base 10); error = largest displacement, m".into(),
            build: Box::new(|w| {
                shared::pyramid(w, 10);
            }),
            duration: 5.0,
            check: Check::Drift,
            tolerance: 0.05,
            unit: "m",
        });
        for ratio in [100u32, 1000] {
            scenes.push(Scene {
                name: if ratio == 100 { "heavy100" } else { "heavy1000" },
                kind: Kind::Stability,
                description: format!(
                    "case 12: {ratio} kg cube resting on a 1 kg cube; error = largest displacement, m"
                ),
                build: Box::new(move |w| {
                    shared::cube_on_cube(w, ratio as f32);
                }),
                duration: 5.0,
                check: Check::Drift,
                tolerance: 0.05,
                unit: "m",
            });
        }
        scenes.push(Scene {
            name: "resting",
            kind: Kind::Stability,
            description: "case 11: cube at rest on the ground with e = 1 for 60 s; must not hop; error = largest displacement, m".into(),
            build: Box::new(|w| {
                shared::resting_box(w, 1.0);
            }),
            duration: 60.0,
            check: Check::Drift,
            tolerance: 1e-3,
            unit: "m",
        });
        scenes.push(Scene {
            name: "fast_wall",
            kind: Kind::Stability,
            description: "case 13: sphere r = 0.05 m at 100 m/s against a 1 cm wall; error = how far it got past the wall's face, m".into(),
            build: Box::new(|w| {
                shared::fast_thin_wall(w);
            }),
            duration: 0.1,
            check: Check::Tunnel { face_x: 0.0, radius: 0.05 },
            tolerance: 0.01,
            unit: "m",
        });
    }

    // Throughput.
    let pours: &[usize] = match mode {
        Mode::Full => &[1000, 4000],
        Mode::Quick => &[300],
        Mode::Smoke => &[30],
    };
    for &n in pours {
        scenes.push(Scene {
            name: match n {
                4000 => "pour4000",
                1000 => "pour1000",
                _ => "pour",
            },
            kind: Kind::Throughput,
            description: format!(
                "{n} spheres (r = 0.25 m) poured into a box; error = deepest penetration, m"
            ),
            build: Box::new(move |w| {
                shared::pour(w, n);
            }),
            duration: if smoke { 0.5 } else { 1.5 },
            check: Check::Penetration,
            tolerance: 0.01,
            unit: "m",
        });
    }
    if full {
        scenes.extend(stress_family());
    }
    let sparse = match mode {
        Mode::Full => 10_000,
        Mode::Quick => 2000,
        Mode::Smoke => 100,
    };
    scenes.push(Scene {
        name: if full { "sparse10000" } else { "sparse" },
        kind: Kind::Throughput,
        description: format!(
            "{sparse} spheres in free flight, 2 m apart; error = largest distance from the straight path, m"
        ),
        build: Box::new(move |w| {
            shared::sparse_flight(w, sparse);
        }),
        duration: if smoke { 0.2 } else { 0.5 },
        check: Check::FreeFlight,
        tolerance: 1e-3,
        unit: "m",
    });
    scenes
}

/// The pair [`crate::sleeping`] times: the sparse free-flight scene's spheres (10,000 in the
/// full mode), awake, and the same spheres all asleep (velocities zeroed, `Sleeping` inserted
/// as a user would put them to sleep); sleeping on in both. The error is the free-flight one:
/// asleep, the straight path is standing still, so any motion counts.
pub fn sleeping_pair(mode: Mode) -> [Scene; 2] {
    let n = match mode {
        Mode::Full => 10_000,
        Mode::Quick => 2000,
        Mode::Smoke => 100,
    };
    let duration = if mode == Mode::Smoke { 0.2 } else { 0.5 };
    let scene = |asleep: bool| Scene {
        name: match (asleep, mode == Mode::Full) {
            (false, true) => "awake10000",
            (true, true) => "asleep10000",
            (false, false) => "awake",
            (true, false) => "asleep",
        },
        kind: Kind::Throughput,
        description: format!(
            "{n} spheres 2 m apart, {}, sleeping on; error = largest distance from the straight path, m",
            if asleep {
                "all asleep"
            } else {
                "awake in free flight"
            }
        ),
        build: Box::new(move |w| {
            w.insert_resource(SleepConfig::default());
            let balls = shared::sparse_flight(w, n);
            if asleep {
                for ball in balls {
                    w.entity_mut(ball)
                        .insert((LinearVelocity(Vec3::ZERO), Sleeping::default()));
                }
            }
        }),
        duration,
        check: Check::FreeFlight,
        tolerance: 1e-3,
        unit: "m",
    };
    [scene(false), scene(true)]
}

/// Issue 8's stress family (built by [`shared::pour_into`], [`shared::pyramid_with`],
/// [`shared::column`], [`shared::boxes_on_trimesh`], [`shared::light_against_heavy`] and
/// [`shared::three_ball_hit`]), 20 s each at each engine's defaults at 60 Hz (the small cases
/// shorter): the same scenes and criteria as `tests/stress.rs`. Piles: the largest speed
/// against free fall plus the 3 m/s push-out cap (error 1 is the limit). Walls, pyramids and
/// columns at rest: the largest displacement, 1 cm (the criterion for the wall's top
/// cube in 10 s). Light against heavy: the rise of mechanical energy (none allowed beyond
/// f32 rounding). The three-ball hit: the simultaneous answer.
fn stress_family() -> Vec<Scene> {
    type Builder = fn(&mut World);
    use shared::{Pour, PourBodies};
    let limit = |top: f32| (2.0 * 9.81 * top).sqrt() + SolverConfig::default().max_push_out_speed;
    let mut scenes = Vec::new();
    let pours = [
        ("spheres1000_friction", 1000, PourBodies::Spheres, 1.0, 0.5),
        (
            "spheres1000_frictionless",
            1000,
            PourBodies::Spheres,
            1.0,
            0.0,
        ),
        (
            "spheres1000_dense_friction",
            1000,
            PourBodies::Spheres,
            1000.0,
            0.5,
        ),
        (
            "spheres1000_dense_frictionless",
            1000,
            PourBodies::Spheres,
            1000.0,
            0.0,
        ),
        ("spheres4000_friction", 4000, PourBodies::Spheres, 1.0, 0.5),
        (
            "spheres4000_frictionless",
            4000,
            PourBodies::Spheres,
            1000.0,
            0.0,
        ),
        ("boxes1000_friction", 1000, PourBodies::Boxes, 1.0, 0.5),
        (
            "boxes1000_frictionless",
            1000,
            PourBodies::Boxes,
            1000.0,
            0.0,
        ),
        ("mixed1000_friction", 1000, PourBodies::Mixed, 1000.0, 0.5),
    ];
    for (name, count, bodies, density, friction) in pours {
        let pour = Pour::walled_box(count, bodies, density, friction);
        scenes.push(Scene {
            name,
            kind: Kind::Stress,
            description: format!(
                "issue 8: {count} {bodies:?} (size 0.5 m, density {density}, friction {friction}) poured into a 21 m box; error = largest speed / (free fall + 3 m/s)"
            ),
            build: Box::new(move |w| {
                shared::pour_into(w, &pour);
            }),
            duration: 20.0,
            check: Check::Speed { limit: limit(pour.top()) },
            tolerance: 1.0,
            unit: "relative",
        });
    }
    let standing: [(&'static str, &str, Builder); 4] = [
        (
            "wall20",
            "2D pyramid wall of 210 cubes (base 20), friction 0.5",
            |w| {
                shared::pyramid_with(w, 20, false, 0.5);
            },
        ),
        (
            "pyramid3d8",
            "3D pyramid of 204 cubes (base 8), friction 0.5",
            |w| {
                shared::pyramid_with(w, 8, true, 0.5);
            },
        ),
        (
            "column20_friction",
            "column of 20 cubes, friction 0.5",
            |w| {
                shared::column(w, 20, 0.5, 1.0);
            },
        ),
        (
            "column100_alternating",
            "column of 100 cubes alternating 1 kg and 1000 kg",
            |w| {
                shared::column(w, 100, 0.0, 1000.0);
            },
        ),
    ];
    for (name, what, build) in standing {
        scenes.push(Scene {
            name,
            kind: Kind::Stress,
            description: format!("issue 8: {what}, at rest, 20 s; error = largest displacement, m"),
            build: Box::new(build),
            duration: 20.0,
            check: Check::Drift,
            tolerance: 0.01,
            unit: "m",
        });
    }
    scenes.push(Scene {
        name: "trimesh_boxes",
        kind: Kind::Stress,
        description: "issue 8: 200 cubes dropped on a bumpy static trimesh, friction 0.5; error = largest speed / (free fall + 3 m/s)".into(),
        build: Box::new(|w| {
            shared::boxes_on_trimesh(w, 200, 0.5);
        }),
        duration: 20.0,
        check: Check::Speed { limit: limit(3.5) },
        tolerance: 1.0,
        unit: "relative",
    });
    scenes.push(Scene {
        name: "light_heavy",
        kind: Kind::Stress,
        description: "issue 8: a 0.05 kg ball at 5 m/s on the floor hits a floating 5 kg ball, e = 0, no gravity; error = largest rise of mechanical energy / initial kinetic energy".into(),
        build: Box::new(|w| {
            shared::light_against_heavy(w);
        }),
        duration: 5.0,
        check: Check::EnergyRise,
        tolerance: 1e-3,
        unit: "relative",
    });
    let (c, s) = (30f32.to_radians().cos(), 30f32.to_radians().sin());
    let j = 2.0 * c / (1.0 + 2.0 * c * c);
    scenes.push(Scene {
        name: "three_balls",
        kind: Kind::Stress,
        description: "issue 8: a ball at 1 m/s strikes two resting balls at +-30 degrees, e = 1; exact (simultaneous): A (-0.2, 0), B (0.6, +-0.3464); error = energy-norm velocity error / 1 m/s".into(),
        build: Box::new(|w| {
            shared::three_ball_hit(w);
        }),
        duration: 1.0,
        check: Check::Velocities {
            expected: vec![
                Expected { body: 0, linvel: Vec3::new(1.0 - 2.0 * j * c, 0.0, 0.0), angvel: Vec3::ZERO },
                Expected { body: 1, linvel: Vec3::new(c, s, 0.0) * j, angvel: Vec3::ZERO },
                Expected { body: 2, linvel: Vec3::new(c, -s, 0.0) * j, angvel: Vec3::ZERO },
            ],
            scale: 1.0,
        },
        tolerance: 0.01,
        unit: "relative",
    });
    scenes
}

/// Case 4's rod: a 1 m x 2 cm x 2 cm box of 1 kg, tilted about z so that its -x end is low,
/// that end's lowest edge 5 mm above the ground, falling at 1 m/s, e = 1, no gravity. The
/// library has no rod builder, so it is made from [`shared::cuboid`] and [`shared::ground`].
fn rod(world: &mut World) {
    world.insert_resource(Gravity(Vec3::ZERO));
    shared::ground(world);
    let (rotation, centre) = rod_pose();
    world
        .spawn((
            shared::cuboid(ROD_HALF, 1.0, centre),
            LinearVelocity(Vec3::NEG_Y),
            Restitution(1.0),
        ))
        .insert(Transform::from_translation(centre).with_rotation(rotation));
}

/// The rod's orientation and centre.
fn rod_pose() -> (Quat, Vec3) {
    let rotation = Quat::from_rotation_z(ROD_TILT_DEG.to_radians());
    let corner = rotation * Vec3::new(-ROD_HALF.x, -ROD_HALF.y, 0.0);
    (rotation, Vec3::new(0.0, -corner.y + 0.005, 0.0))
}

/// The rod's exact velocities after its impact: the impulse formula with the box's own
/// inertia (`m (a^2 + b^2) / 12`) and contact at the middle of its low edge, which is where
/// the thin-rod answer of case 4 (vy' = -0.3846, w' = -3.1976 for a rod of no thickness) comes
/// from.
fn rod_answer() -> Expected {
    let (rotation, _) = rod_pose();
    let (mass, e, v) = (1.0, 1.0, Vec3::NEG_Y);
    let r = rotation * Vec3::new(-ROD_HALF.x, -ROD_HALF.y, 0.0);
    let inertia = Shape::Cuboid(ROD_HALF).inertia(mass);
    let rot = Mat3::from_quat(rotation);
    let inv_inertia = rot * inertia.inverse() * rot.transpose();
    let n = Vec3::Y;
    let rn = r.cross(n);
    let k = 1.0 / mass + rn.dot(inv_inertia * rn);
    let j = -(1.0 + e) * v.dot(n) / k;
    Expected {
        body: 0,
        linvel: v + n * (j / mass),
        angvel: inv_inertia * r.cross(n * j),
    }
}

/// Case 2's exact answer: spheres exchange the normal component, scaled by `(1 + e) / 2`;
/// tangential velocities and spins are unchanged.
fn oblique_answer() -> Vec<Expected> {
    let angle = 30f32.to_radians();
    let n = Vec3::new(angle.cos(), angle.sin(), 0.0);
    let j = (1.0 + OBLIQUE_E) * Vec3::X.dot(n) / 2.0;
    vec![
        Expected {
            body: 0,
            linvel: Vec3::X - n * j,
            angvel: Vec3::Z * 5.0,
        },
        Expected {
            body: 1,
            linvel: n * j,
            angvel: Vec3::ZERO,
        },
    ]
}

/// A run's error and side metrics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    /// The scene's error (see [`Check`]); infinite if the state became non-finite.
    pub error: f64,
    /// Deepest overlap over the run of a dynamic body with a static body, or of two spheres, m.
    pub penetration: f64,
    /// Largest displacement of a dynamic body from its start over the run, m.
    pub drift: f64,
    /// Relative change of mechanical energy (kinetic + potential) from start to end.
    pub energy_change: f64,
}

/// Watches a run's states and computes its [`Metrics`].
pub struct Probe<'a> {
    check: &'a Check,
    spec: &'a SceneSpec,
    dynamic: Vec<&'a BodySpec>,
    statics: Vec<&'a BodySpec>,
    energy0: f64,
    penetration: f64,
    drift: f64,
    tunnel: f64,
    apexes: Vec<f32>,
    previous: Option<BodyState>,
    last: Vec<BodyState>,
    time: f32,
    finite: bool,
    fastest: f32,
    energy_peak: f64,
    kinetic0: f64,
}

impl<'a> Probe<'a> {
    /// A probe for `scene` whose bodies are `spec`.
    pub fn new(scene: &'a Scene, spec: &'a SceneSpec) -> Self {
        let dynamic: Vec<_> = spec.dynamic().collect();
        let start: Vec<BodyState> = dynamic
            .iter()
            .map(|b| BodyState {
                position: b.position,
                rotation: b.rotation,
                linvel: b.linvel,
                angvel: b.angvel,
            })
            .collect();
        Probe {
            check: &scene.check,
            spec,
            energy0: energy(&dynamic, &start, spec.gravity),
            kinetic0: kinetic(&dynamic, &start),
            dynamic,
            statics: spec.bodies.iter().filter(|b| !b.dynamic).collect(),
            penetration: 0.0,
            drift: 0.0,
            tunnel: 0.0,
            apexes: Vec::new(),
            previous: None,
            energy_peak: f64::MIN,
            last: start,
            time: 0.0,
            finite: true,
            fastest: 0.0,
        }
    }

    /// The run has failed beyond recovery (non-finite, or a speed check more than ten times
    /// over its limit): [`crate::measure::run`] stops it there, so a blown-up pile does not
    /// spend hours on millions of contacts.
    pub fn hopeless(&self) -> bool {
        !self.finite || matches!(self.check, Check::Speed { limit } if self.fastest > 10.0 * limit)
    }

    /// Records the states at time `time` (s).
    pub fn observe(&mut self, time: f32, states: &[BodyState]) {
        self.time = time;
        if !states.iter().all(BodyState::is_finite) {
            self.finite = false;
            return;
        }
        for (state, body) in states.iter().zip(&self.dynamic) {
            self.drift = self
                .drift
                .max(state.position.distance(body.position) as f64);
        }
        self.penetration = self
            .penetration
            .max(penetration(&self.dynamic, &self.statics, states));
        for state in states {
            self.fastest = self.fastest.max(state.linvel.length());
        }
        if *self.check == Check::EnergyRise {
            self.energy_peak =
                self.energy_peak
                    .max(energy(&self.dynamic, states, self.spec.gravity));
        }
        match self.check {
            Check::Apexes { radius, g, .. } => {
                let ball = states[0];
                if let Some(prev) = self.previous
                    && prev.linvel.y > 0.0
                    && ball.linvel.y <= 0.0
                {
                    self.apexes
                        .push(prev.position.y - radius + prev.linvel.y * prev.linvel.y / (2.0 * g));
                }
                self.previous = Some(ball);
            }
            Check::Tunnel { face_x, radius } => {
                self.tunnel = self
                    .tunnel
                    .max((states[0].position.x + radius - face_x).max(0.0) as f64);
            }
            _ => {}
        }
        self.last.clear();
        self.last.extend_from_slice(states);
    }

    /// The metrics of the run.
    pub fn finish(self) -> Metrics {
        if !self.finite {
            let inf = f64::INFINITY;
            return Metrics {
                error: inf,
                penetration: inf,
                drift: inf,
                energy_change: inf,
            };
        }
        let error = match self.check {
            Check::Apexes { expected, .. } => expected
                .iter()
                .enumerate()
                .map(|(k, &h)| {
                    self.apexes
                        .get(k)
                        .map_or(1.0, |&a| ((a - h) / h).abs() as f64)
                })
                .fold(0.0, f64::max),
            Check::Velocities { expected, scale } => expected
                .iter()
                .map(|x| {
                    let (s, b) = (self.last[x.body], self.dynamic[x.body]);
                    let dv = (s.linvel - x.linvel).length_squared();
                    let dw = s.rotation.inverse() * (s.angvel - x.angvel);
                    let spin = dw.dot(b.shape.inertia(1.0) * dw);
                    ((dv + spin).sqrt() / scale) as f64
                })
                .fold(0.0, f64::max),
            Check::Drift => self.drift,
            Check::Tunnel { .. } => self.tunnel,
            Check::Penetration => self.penetration,
            Check::FreeFlight => self
                .dynamic
                .iter()
                .zip(&self.last)
                .map(|(b, s)| s.position.distance(b.position + b.linvel * self.time) as f64)
                .fold(0.0, f64::max),
            Check::Speed { limit } => (self.fastest / limit) as f64,
            Check::EnergyRise => ((self.energy_peak - self.energy0) / self.kinetic0).max(0.0),
        };
        let energy1 = energy(&self.dynamic, &self.last, self.spec.gravity);
        Metrics {
            error,
            penetration: self.penetration,
            drift: self.drift,
            energy_change: (energy1 - self.energy0) / self.energy0.abs().max(1e-12),
        }
    }
}

/// Kinetic energy of the dynamic bodies, J.
fn kinetic(bodies: &[&BodySpec], states: &[BodyState]) -> f64 {
    energy(bodies, states, Vec3::ZERO)
}

/// Kinetic plus potential energy of the dynamic bodies, J (potential zero at the origin).
fn energy(bodies: &[&BodySpec], states: &[BodyState], gravity: Vec3) -> f64 {
    bodies
        .iter()
        .zip(states)
        .map(|(b, s)| {
            let local_w = s.rotation.inverse() * s.angvel;
            let rotational = local_w.dot(b.shape.inertia(b.mass) * local_w);
            (0.5 * b.mass * s.linvel.length_squared() + 0.5 * rotational
                - b.mass * gravity.dot(s.position)) as f64
        })
        .sum()
}

/// Deepest overlap of a dynamic body with a static body (any shape against a half-space,
/// sphere against a box) or of two spheres, m. Other overlaps (box-box, anything against a
/// mesh) are not measured (stacks use the drift, the stress scenes their speeds).
fn penetration(dynamic: &[&BodySpec], statics: &[&BodySpec], states: &[BodyState]) -> f64 {
    let mut deepest = 0f32;
    for (body, s) in dynamic.iter().zip(states) {
        for wall in statics {
            let depth = match (&body.shape, &wall.shape) {
                (shape, &Shape::HalfSpace(normal)) => {
                    let n = wall.rotation * normal;
                    // How far the shape reaches from its origin towards the wall, along -n.
                    let local = s.rotation.inverse() * n;
                    let reach = match shape {
                        Shape::Ball(r) => *r,
                        Shape::Cuboid(h) => (local.abs() * *h).element_sum(),
                        Shape::Capsule(r, hh) => r + hh * local.y.abs(),
                        Shape::Hull(points) => points
                            .iter()
                            .map(|p| -local.dot(*p))
                            .fold(f32::MIN, f32::max),
                        Shape::TriMesh(..) | Shape::HalfSpace(_) => 0.0,
                    };
                    reach - n.dot(s.position - wall.position)
                }
                (&Shape::Ball(r), &Shape::Cuboid(h)) => {
                    let q = wall.rotation.inverse() * (s.position - wall.position);
                    let inside = h - q.abs();
                    if inside.min_element() > 0.0 {
                        r + inside.min_element()
                    } else {
                        r - q.distance(q.clamp(-h, h))
                    }
                }
                _ => 0.0,
            };
            deepest = deepest.max(depth);
        }
    }
    // Sphere pairs, through a uniform grid of cells as wide as the largest sphere.
    let spheres: Vec<(Vec3, f32)> = dynamic
        .iter()
        .zip(states)
        .filter_map(|(b, s)| {
            if let Shape::Ball(r) = b.shape {
                Some((s.position, r))
            } else {
                None
            }
        })
        .collect();
    let cell = spheres.iter().map(|s| 2.0 * s.1).fold(0.0, f32::max);
    if cell > 0.0 {
        let key = |p: Vec3| (p / cell).floor().as_ivec3();
        let mut grid: HashMap<IVec3, Vec<usize>> = HashMap::new();
        for (i, s) in spheres.iter().enumerate() {
            grid.entry(key(s.0)).or_default().push(i);
        }
        for (i, a) in spheres.iter().enumerate() {
            let c = key(a.0);
            for offset in (0..27).map(|k| IVec3::new(k % 3 - 1, (k / 3) % 3 - 1, k / 9 - 1)) {
                for &j in grid.get(&(c + offset)).into_iter().flatten() {
                    if j > i {
                        let b = spheres[j];
                        deepest = deepest.max(a.1 + b.1 - a.0.distance(b.0));
                    }
                }
            }
        }
    }
    deepest as f64
}
