//! Reference scenes and a headless test harness, shared by the tests, the examples and the lab,
//! so that each scene is written once. The numbers refer to the reference scenes with known
//! answers (`SCENES.md` in the project's shared notes; each builder's doc restates what it
//! needs).
//!
//! # Examples
//!
//! ```
//! use bevy::prelude::*;
//! use impact3d::prelude::*;
//! use impact3d::scenes;
//!
//! let mut app = scenes::headless_app(60.0);
//! let (_, ball) = scenes::bouncing_ball(app.world_mut(), 1.0, 0.8);
//! scenes::run_steps(&mut app, 30);
//! let y = app.world().get::<Transform>(ball).unwrap().translation.y;
//! assert!(y < 1.5, "the ball fell");
//! ```

use bevy::app::Plugins;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;

use crate::prelude::*;

/// A headless app (`MinimalPlugins` + [`PhysicsPlugins`]) in which every `app.update()` runs
/// exactly one fixed step of `1/hz` s. The first update, which Bevy spends recording the start
/// instant, has already run.
pub fn headless_app(hz: f64) -> App {
    headless_app_with(hz, (MinimalPlugins, PhysicsPlugins::default()))
}

/// [`headless_app`] with other `plugins` in place of `MinimalPlugins` + [`PhysicsPlugins`]:
/// `MinimalPlugins` set up otherwise (e.g. its task pools' threads), a physics plugin group
/// with a stage replaced. They must bring the time plugins and a fixed-step schedule, as
/// `MinimalPlugins` does.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
/// use impact3d::scenes;
///
/// let app = scenes::headless_app_with(60.0, (MinimalPlugins, PhysicsPlugins::default()));
/// assert!(app.world().contains_resource::<Gravity>());
/// ```
pub fn headless_app_with<M>(hz: f64, plugins: impl Plugins<M>) -> App {
    let mut app = App::new();
    app.add_plugins(plugins)
        .insert_resource(Time::<Fixed>::from_hz(hz))
        .insert_resource(TimeUpdateStrategy::FixedTimesteps(1));
    app.update();
    app
}

/// Runs `steps` fixed steps.
pub fn run_steps(app: &mut App, steps: u32) {
    for _ in 0..steps {
        app.update();
    }
}

/// A dynamic sphere of `radius` m and `mass` kg at `position` moving at `velocity`.
pub fn ball(radius: f32, mass: f32, position: Vec3, velocity: Vec3) -> impl Bundle {
    (
        RigidBody::Dynamic,
        Collider::sphere(radius),
        Mass(mass),
        Transform::from_translation(position),
        LinearVelocity(velocity),
    )
}

/// A dynamic box with half extents `half` (m) and `mass` kg at `position`.
pub fn cuboid(half: Vec3, mass: f32, position: Vec3) -> impl Bundle {
    (
        RigidBody::Dynamic,
        Collider::cuboid(half.x, half.y, half.z),
        Mass(mass),
        Transform::from_translation(position),
    )
}

/// Static ground: the half-space `y < 0`.
pub fn ground(world: &mut World) -> Entity {
    world
        .spawn((
            RigidBody::Static,
            Collider::half_space(Vec3::Y),
            Transform::IDENTITY,
        ))
        .id()
}

/// A 1 m cube of 1 kg dropped from 2 m onto the ground (default gravity); it comes to rest with
/// its centre at y = 0.5. Returns (ground, cube).
pub fn box_drop(world: &mut World) -> (Entity, Entity) {
    let ground = ground(world);
    let cube = world
        .spawn(cuboid(Vec3::splat(0.5), 1.0, Vec3::new(0.0, 2.0, 0.0)))
        .id();
    (ground, cube)
}

/// Case 3: a ball of radius 0.1 m whose lowest point starts `h0` m above the ground, at rest,
/// restitution `e`, gravity 10 m/s^2. Impact speed `sqrt(2 g h0)`, k-th apex `e^(2k) h0`.
/// Returns (ground, ball).
pub fn bouncing_ball(world: &mut World, h0: f32, e: f32) -> (Entity, Entity) {
    world.insert_resource(Gravity(Vec3::new(0.0, -10.0, 0.0)));
    let ground = ground(world);
    let ball = world
        .spawn((
            ball(
                BOUNCE_RADIUS,
                1.0,
                Vec3::new(0.0, h0 + BOUNCE_RADIUS, 0.0),
                Vec3::ZERO,
            ),
            Restitution(e),
        ))
        .id();
    (ground, ball)
}

/// Radius of the ball of [`bouncing_ball`], m.
pub const BOUNCE_RADIUS: f32 = 0.1;

/// Case 1: head-on in 1D, no gravity: m1 = 1 kg at +2 m/s meets m2 = 3 kg at -1 m/s, spheres
/// of radius 0.5 just touching, restitution `e`. Returns (ball 1, ball 2).
pub fn head_on(world: &mut World, e: f32) -> (Entity, Entity) {
    world.insert_resource(Gravity(Vec3::ZERO));
    let a = world
        .spawn((
            ball(0.5, 1.0, Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0)),
            Restitution(e),
        ))
        .id();
    let b = world
        .spawn((
            ball(0.5, 3.0, Vec3::X, Vec3::new(-1.0, 0.0, 0.0)),
            Restitution(e),
        ))
        .id();
    (a, b)
}

/// Case 2: oblique equal spheres (R = 0.5, 1 kg), no gravity: B at rest, A at (1, 0, 0) m/s
/// spinning (0, 0, 5) rad/s, the line of centres at 30 degrees. Returns (A, B).
pub fn oblique(world: &mut World, e: f32) -> (Entity, Entity) {
    world.insert_resource(Gravity(Vec3::ZERO));
    let angle = 30f32.to_radians();
    let a = world
        .spawn((
            ball(0.5, 1.0, Vec3::ZERO, Vec3::X),
            AngularVelocity(Vec3::new(0.0, 0.0, 5.0)),
            Restitution(e),
        ))
        .id();
    let b = world
        .spawn((
            ball(
                0.5,
                1.0,
                Vec3::new(angle.cos(), angle.sin(), 0.0),
                Vec3::ZERO,
            ),
            Restitution(e),
        ))
        .id();
    (a, b)
}

/// Case 8: Newton's cradle of `n` touching balls (R = 0.5, 1 kg) in a row along x, no gravity,
/// the first struck at `speed` m/s, restitution `e`.
pub fn cradle(world: &mut World, n: usize, speed: f32, e: f32) -> Vec<Entity> {
    world.insert_resource(Gravity(Vec3::ZERO));
    (0..n)
        .map(|i| {
            let v = if i == 0 {
                Vec3::new(speed, 0.0, 0.0)
            } else {
                Vec3::ZERO
            };
            world
                .spawn((
                    ball(0.5, 1.0, Vec3::new(i as f32, 0.0, 0.0), v),
                    Restitution(e),
                ))
                .id()
        })
        .collect()
}

/// Case 9: a box with half extents (1, 0.25, 0.5) and 1 kg falling flat at 1 m/s, no gravity,
/// its bottom 0.005 m above the ground, restitution `e`. Exact answer: it rebounds at `e` m/s
/// with no spin. Returns (ground, box).
pub fn box_landing_flat(world: &mut World, e: f32) -> (Entity, Entity) {
    world.insert_resource(Gravity(Vec3::ZERO));
    let ground = ground(world);
    let b = world
        .spawn((
            cuboid(Vec3::new(1.0, 0.25, 0.5), 1.0, Vec3::new(0.0, 0.255, 0.0)),
            LinearVelocity(Vec3::new(0.0, -1.0, 0.0)),
            Restitution(e),
        ))
        .id();
    (ground, b)
}

/// Case 10: ball 1 (`m1` kg, R = 0.5) under ball 2 (`m2` kg, R = 0.5), touching, both falling at
/// `v0` m/s, ball 1's bottom 0.005 m above the ground, no gravity, e = 1. Event by event, ball 2
/// leaves at `(3 m1 - m2) v0 / (m1 + m2)` upward. Returns (ground, ball 1, ball 2).
pub fn galilean_cannon(world: &mut World, m1: f32, m2: f32, v0: f32) -> (Entity, Entity, Entity) {
    world.insert_resource(Gravity(Vec3::ZERO));
    let ground = ground(world);
    let down = Vec3::new(0.0, -v0, 0.0);
    let b1 = world
        .spawn((
            ball(0.5, m1, Vec3::new(0.0, 0.505, 0.0), down),
            Restitution(1.0),
        ))
        .id();
    let b2 = world
        .spawn((
            ball(0.5, m2, Vec3::new(0.0, 1.505, 0.0), down),
            Restitution(1.0),
        ))
        .id();
    (ground, b1, b2)
}

/// A 1 m cube of `upper_mass` kg resting on a 1 m cube of 1 kg on the ground (default
/// gravity); with `upper_mass` 100 or 1000, case 12's heavy-on-light pair. Returns (lower,
/// upper).
pub fn cube_on_cube(world: &mut World, upper_mass: f32) -> (Entity, Entity) {
    ground(world);
    let lower = world
        .spawn(cuboid(Vec3::splat(0.5), 1.0, Vec3::new(0.0, 0.5, 0.0)))
        .id();
    let upper = world
        .spawn(cuboid(
            Vec3::splat(0.5),
            upper_mass,
            Vec3::new(0.0, 1.5, 0.0),
        ))
        .id();
    (lower, upper)
}

/// Case 11: a 1 m cube of 1 kg at rest on the ground (default gravity), restitution `e`.
/// Returns (ground, cube).
pub fn resting_box(world: &mut World, e: f32) -> (Entity, Entity) {
    let ground = ground(world);
    let cube = world
        .spawn((
            cuboid(Vec3::splat(0.5), 1.0, Vec3::new(0.0, 0.5, 0.0)),
            Restitution(e),
        ))
        .id();
    (ground, cube)
}

/// Case 12: a vertical stack of `n` 1 m cubes of 1 kg each, resting on the ground (default
/// gravity), frictionless. Returns the cubes, bottom first. (A [`column`](fn@column) of equal masses.)
pub fn stack(world: &mut World, n: usize) -> Vec<Entity> {
    column(world, n, 0.0, 1.0)
}

/// A vertical column of `n` 1 m cubes resting on the ground (default gravity), each with
/// friction coefficient `friction`; the cubes alternate between 1 kg (the bottom one, and every
/// second above it) and `alternate_mass` kg. With `alternate_mass = 1`, case 12's stack; with
/// 1000 and `n = 100`, issue 8's alternating 1000:1 column; with friction 0.5 and `n = 20`,
/// its column with friction. Returns the cubes, bottom first.
pub fn column(world: &mut World, n: usize, friction: f32, alternate_mass: f32) -> Vec<Entity> {
    ground(world);
    (0..n)
        .map(|i| {
            let mass = if i % 2 == 1 { alternate_mass } else { 1.0 };
            world
                .spawn((
                    cuboid(Vec3::splat(0.5), mass, Vec3::new(0.0, 0.5 + i as f32, 0.0)),
                    Friction(friction),
                ))
                .id()
        })
        .collect()
}

/// Case 12: a pyramid of 1 m cubes of 1 kg with `base` cubes in the bottom row (in the xy plane,
/// 0.05 m apart in a row), `base (base + 1) / 2` in all, frictionless. Returns the cubes,
/// bottom row first; the last is the top. (A 2D [`pyramid_with`].)
pub fn pyramid(world: &mut World, base: usize) -> Vec<Entity> {
    pyramid_with(world, base, false, 0.0)
}

/// A pyramid of 1 m cubes of 1 kg on the ground (default gravity), friction coefficient
/// `friction`, cubes 0.05 m apart in a row. 2D (`three_d = false`): a wall in the xy plane
/// with `base` cubes in the bottom row, `base (base + 1) / 2` in all (base 20: issue 8's wall
/// of 210). 3D: square layers of `base^2`, `(base - 1)^2`, ... cubes (base 8: 204). Returns
/// the cubes, bottom layer first; the last is the top.
pub fn pyramid_with(world: &mut World, base: usize, three_d: bool, friction: f32) -> Vec<Entity> {
    ground(world);
    let mut cubes = Vec::new();
    let offset = |i: usize, count: usize| (i as f32 - (count - 1) as f32 * 0.5) * 1.05;
    for row in 0..base {
        let count = base - row;
        let depth = if three_d { count } else { 1 };
        for k in 0..depth {
            for i in 0..count {
                let z = if three_d { offset(k, count) } else { 0.0 };
                let at = Vec3::new(offset(i, count), 0.5 + row as f32, z);
                cubes.push(
                    world
                        .spawn((cuboid(Vec3::splat(0.5), 1.0, at), Friction(friction)))
                        .id(),
                );
            }
        }
    }
    cubes
}

/// Case 13: a sphere of radius 0.05 m at 100 m/s along +x towards a static wall 0.01 m thick
/// (its near face at x = 0), starting 1 m away, no gravity, e = 0. Returns (wall, sphere).
pub fn fast_thin_wall(world: &mut World) -> (Entity, Entity) {
    world.insert_resource(Gravity(Vec3::ZERO));
    let wall = world
        .spawn((
            RigidBody::Static,
            Collider::cuboid(0.005, 2.0, 2.0),
            Transform::from_xyz(0.005, 0.0, 0.0),
        ))
        .id();
    let sphere = world
        .spawn(ball(
            0.05,
            1.0,
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(100.0, 0.0, 0.0),
        ))
        .id();
    (wall, sphere)
}

/// A static open box (floor and four walls) of inner half width `half` m and height `height` m.
pub fn container(world: &mut World, half: f32, height: f32) -> Vec<Entity> {
    let t = 0.5;
    let mut spawn = |size: Vec3, at: Vec3| {
        world
            .spawn((
                RigidBody::Static,
                Collider::cuboid(size.x, size.y, size.z),
                Transform::from_translation(at),
            ))
            .id()
    };
    vec![
        spawn(Vec3::new(half + t, t, half + t), Vec3::new(0.0, -t, 0.0)),
        spawn(
            Vec3::new(t, height * 0.5, half + t),
            Vec3::new(-half - t, height * 0.5, 0.0),
        ),
        spawn(
            Vec3::new(t, height * 0.5, half + t),
            Vec3::new(half + t, height * 0.5, 0.0),
        ),
        spawn(
            Vec3::new(half, height * 0.5, t),
            Vec3::new(0.0, height * 0.5, -half - t),
        ),
        spawn(
            Vec3::new(half, height * 0.5, t),
            Vec3::new(0.0, height * 0.5, half + t),
        ),
    ]
}

/// Throughput: `n` spheres of radius 0.25 m and 1 kg on a jittered grid above a container sized
/// for them, falling in (default gravity), frictionless. Returns the spheres. (The lab's
/// [`Pour`].)
pub fn pour(world: &mut World, n: usize) -> Vec<Entity> {
    pour_into(world, &Pour::lab(n)).bodies
}

/// What a [`Pour`] drops.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PourBodies {
    /// Spheres of radius `size`.
    Spheres,
    /// Cubes of half side `size`.
    Boxes,
    /// In turn a sphere (radius `size`), a cube (half side `size`), a capsule (radius and half
    /// height `size / 2`) and a convex hull (an irregular octahedron within `size`), with
    /// masses 1, 10 and 100 times that of the sphere in turn (mass ratios to 100:1).
    Mixed,
}

/// How heavy a [`Pour`]'s bodies are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PourMass {
    /// Every body this many kg (`Mass`).
    Fixed(f32),
    /// This density, kg/m^3 (`Density`); a mixed pour's masses are then multiples of the mass
    /// of a sphere of radius `size` at this density.
    Density(f32),
}

/// Bodies dropped on a jittered grid into a static open box ([`container`]), under default
/// gravity: [`pour_into`] spawns it. Layers of `side x side` bodies, `side` as many as fit
/// across the box (at most `ceil(sqrt(count))`), the first layer's centres `first_height` m
/// above the floor and each next one `layer_pitch` m higher. The walls rise `size` above the
/// highest centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pour {
    /// Number of bodies.
    pub count: usize,
    /// What is poured.
    pub bodies: PourBodies,
    /// Sphere radius or cube half side, m.
    pub size: f32,
    /// Mass or density.
    pub mass: PourMass,
    /// Friction coefficient of every body (the walls have none; pairs use the larger).
    pub friction: f32,
    /// Inner half width of the box, m; `None`: `1.2 size` per grid column.
    pub half_width: Option<f32>,
    /// Horizontal grid pitch, m.
    pub spacing: f32,
    /// Height of the first layer's centres, m.
    pub first_height: f32,
    /// Vertical pitch of the layers, m.
    pub layer_pitch: f32,
    /// Largest horizontal jitter of a body from its grid point, m.
    pub jitter: f32,
}

impl Pour {
    /// The lab's throughput pour: `count` frictionless spheres of radius 0.25 m and 1 kg,
    /// 0.55 m apart, in a box sized for them.
    pub fn lab(count: usize) -> Self {
        Pour {
            count,
            bodies: PourBodies::Spheres,
            size: 0.25,
            mass: PourMass::Fixed(1.0),
            friction: 0.0,
            half_width: None,
            spacing: 0.55,
            first_height: 1.0,
            layer_pitch: 0.6,
            jitter: 0.025,
        }
    }

    /// Issue 8's pile: `count` bodies of size 0.5 m (spheres r = 0.5, or 1 m cubes) at
    /// `density`, friction `friction`, dropped on a grid 1.1 m apart (layers 1.2 m apart, the
    /// first at 2 m) into a 21 m x 21 m box of static cuboid walls. With 1,000 spheres,
    /// `Density(1.0)` and `Friction(0.5)`, the case where the default blew up.
    pub fn walled_box(count: usize, bodies: PourBodies, density: f32, friction: f32) -> Self {
        Pour {
            count,
            bodies,
            size: 0.5,
            mass: PourMass::Density(density),
            friction,
            half_width: Some(10.5),
            spacing: 1.1,
            first_height: 2.0,
            layer_pitch: 1.2,
            jitter: 0.05,
        }
    }

    /// Height of the highest layer's centres, m: the pour's largest free-fall speed is
    /// `sqrt(2 g top)`.
    pub fn top(&self) -> f32 {
        let side = self.side();
        let layers = self.count.div_ceil(side * side).max(1);
        self.first_height + (layers - 1) as f32 * self.layer_pitch
    }

    /// Grid columns per row.
    fn side(&self) -> usize {
        let wanted = ((self.count as f32).sqrt().ceil() as usize).max(1);
        match self.half_width {
            Some(half) => wanted
                .min(((2.0 * (half - self.size)) / self.spacing) as usize + 1)
                .max(1),
            None => wanted,
        }
    }
}

/// A stress scene's dynamic bodies and the region they must stay in.
#[derive(Clone, Debug, PartialEq)]
pub struct Spawned {
    /// The dynamic bodies, in spawn order.
    pub bodies: Vec<Entity>,
    /// Bodies' centres must stay within `|x|, |z| <= half_width` (the inner faces of the
    /// walls, or how far a toppled structure can reach), m.
    pub half_width: f32,
    /// Height of the highest centre at spawn above the floor (y = 0), m: the largest
    /// free-fall speed in the scene is `sqrt(2 g top)` plus any initial speed.
    pub top: f32,
    /// The scene has a floor at y = 0 that every centre must stay above.
    pub floor: bool,
}

/// Spawns `pour` (see [`Pour`]) and returns its bodies with the box's inner half width.
pub fn pour_into(world: &mut World, pour: &Pour) -> Spawned {
    let side = pour.side();
    let half = pour.half_width.unwrap_or(side as f32 * 1.2 * pour.size);
    let top = pour.top();
    let wall = if pour.half_width.is_none() && pour.bodies == PourBodies::Spheres {
        // The lab's published pour: its original wall height.
        4.0 + pour.count as f32 / (side * side) as f32
    } else {
        top + pour.size
    };
    container(world, half, wall);
    let sphere_mass = |density: f32| density * 4.0 / 3.0 * std::f32::consts::PI * pour.size.powi(3);
    let mut seed = 7u32;
    let bodies = (0..pour.count)
        .map(|i| {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            let jitter = ((seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5) * 2.0 * pour.jitter;
            let (layer, k) = (i / (side * side), i % (side * side));
            let (gx, gz) = (k % side, k / side);
            let p = Vec3::new(
                (gx as f32 - (side - 1) as f32 * 0.5) * pour.spacing + jitter,
                pour.first_height + layer as f32 * pour.layer_pitch,
                (gz as f32 - (side - 1) as f32 * 0.5) * pour.spacing - jitter,
            );
            let kind = match pour.bodies {
                PourBodies::Spheres => 0,
                PourBodies::Boxes => 1,
                PourBodies::Mixed => i % 4,
            };
            let s = pour.size;
            let collider = match kind {
                0 => Collider::sphere(s),
                1 => Collider::cuboid(s, s, s),
                2 => Collider::capsule(0.5 * s, 0.5 * s),
                _ => Collider::convex_hull(&[
                    Vec3::new(s, 0.0, 0.0),
                    Vec3::new(-0.7 * s, 0.1 * s, 0.0),
                    Vec3::new(0.0, 0.9 * s, 0.2 * s),
                    Vec3::new(0.1 * s, -0.8 * s, 0.0),
                    Vec3::new(0.0, 0.0, 0.8 * s),
                    Vec3::new(0.2 * s, 0.0, -0.9 * s),
                ])
                .expect("a solid octahedron"),
            };
            let mut body = world.spawn((
                RigidBody::Dynamic,
                collider,
                Transform::from_translation(p),
                Friction(pour.friction),
            ));
            let ratio = [1.0, 10.0, 100.0][(i / 4) % 3];
            match (pour.mass, pour.bodies) {
                (PourMass::Fixed(m), PourBodies::Mixed) => body.insert(Mass(m * ratio)),
                (PourMass::Fixed(m), _) => body.insert(Mass(m)),
                (PourMass::Density(d), PourBodies::Mixed) => {
                    body.insert(Mass(sphere_mass(d) * ratio))
                }
                (PourMass::Density(d), _) => body.insert(Density(d)),
            };
            body.id()
        })
        .collect();
    Spawned {
        bodies,
        half_width: half,
        top,
        floor: true,
    }
}

/// A static triangle-mesh floor, a square of `2 half` m a side made of `cells x cells` square
/// cells, whose vertices alternate between heights 0 and `bump` m (a gently bumpy terrain, so
/// that contacts are not all vertical).
pub fn trimesh_floor(world: &mut World, half: f32, cells: usize, bump: f32) -> Entity {
    world
        .spawn((
            RigidBody::Static,
            bumpy_grid(half, cells, bump),
            Transform::IDENTITY,
        ))
        .id()
}

/// The collider of [`trimesh_floor`]: a square of `2 half` m a side, `cells x cells` square
/// cells of two triangles each, vertices alternating between heights 0 and `bump` m.
pub fn bumpy_grid(half: f32, cells: usize, bump: f32) -> Collider {
    let size = 2.0 * half / cells as f32;
    let mut vertices = Vec::new();
    for i in 0..=cells {
        for k in 0..=cells {
            let y = if (i + k) % 2 == 0 { 0.0 } else { bump };
            vertices.push(Vec3::new(i as f32 * size - half, y, k as f32 * size - half));
        }
    }
    let at = |i: usize, k: usize| (i * (cells + 1) + k) as u32;
    let mut indices = Vec::new();
    for i in 0..cells {
        for k in 0..cells {
            indices.push([at(i, k), at(i, k + 1), at(i + 1, k)]);
            indices.push([at(i + 1, k), at(i, k + 1), at(i + 1, k + 1)]);
        }
    }
    Collider::trimesh(vertices, indices)
}

/// `count` 1 m cubes of 1 kg, friction `friction`, dropped from a grid 1.5 m apart (layers of
/// 10 x 10, the first at 2 m, each next 1.5 m higher) onto a static [`trimesh_floor`] 40 m a
/// side with 2 m cells and 0.2 m bumps (default gravity). Bodies must stay over the mesh.
pub fn boxes_on_trimesh(world: &mut World, count: usize, friction: f32) -> Spawned {
    trimesh_floor(world, 20.0, 20, 0.2);
    let side = 10;
    let bodies = (0..count)
        .map(|i| {
            let (layer, k) = (i / (side * side), i % (side * side));
            let (gx, gz) = (k % side, k / side);
            let p = Vec3::new(
                (gx as f32 - 4.5) * 1.5,
                2.0 + layer as f32 * 1.5,
                (gz as f32 - 4.5) * 1.5,
            );
            // A small tilt per body, so the cubes do not land flat on the bumps all alike.
            let tilt = Quat::from_rotation_x(0.1 * (i % 7) as f32)
                * Quat::from_rotation_z(0.07 * (i % 5) as f32);
            world
                .spawn((
                    RigidBody::Dynamic,
                    Collider::cuboid(0.5, 0.5, 0.5),
                    Mass(1.0),
                    Transform::from_translation(p).with_rotation(tilt),
                    Friction(friction),
                ))
                .id()
        })
        .collect();
    Spawned {
        bodies,
        half_width: 20.0,
        top: 2.0 + (count.div_ceil(side * side).max(1) - 1) as f32 * 1.5,
        floor: true,
    }
}

/// Issue 8's "light against heavy": no gravity, a half-space floor, a 0.05 kg ball (r 0.2)
/// resting on the floor at the origin moving at (5, 0, 0) m/s into a 5 kg ball (r 0.5)
/// floating at rest at (2, 0.75, 0), frictionless, e = 0. Kinetic energy 0.625 J must never
/// rise (it fell to 0.0159 J for an inelastic simultaneous solve of the hit and the floor:
/// see `tests/stress.rs`). Returns (light, heavy).
pub fn light_against_heavy(world: &mut World) -> (Entity, Entity) {
    world.insert_resource(Gravity(Vec3::ZERO));
    ground(world);
    let light = world
        .spawn(ball(
            0.2,
            0.05,
            Vec3::new(0.0, 0.2, 0.0),
            Vec3::new(5.0, 0.0, 0.0),
        ))
        .id();
    let heavy = world
        .spawn(ball(0.5, 5.0, Vec3::new(2.0, 0.75, 0.0), Vec3::ZERO))
        .id();
    (light, heavy)
}

/// Issue 8's symmetric three-ball hit: no gravity, unit balls (R = 0.5, 1 kg), e = 1; A at the
/// origin moving at (1, 0, 0) m/s strikes B and C at rest, touching it at +30 and -30 degrees
/// (`(cos 30, +-sin 30, 0)`). Both contacts reach their time of impact together; the
/// simultaneous answer is A (-0.2, 0, 0), B (0.6, +0.3464, 0), C (0.6, -0.3464, 0), energy
/// kept (derived in `tests/stress.rs`). Returns (A, B, C).
pub fn three_ball_hit(world: &mut World) -> (Entity, Entity, Entity) {
    world.insert_resource(Gravity(Vec3::ZERO));
    let (c, s) = (30f32.to_radians().cos(), 30f32.to_radians().sin());
    let mut spawn = |p: Vec3, v: Vec3| world.spawn((ball(0.5, 1.0, p, v), Restitution(1.0))).id();
    let a = spawn(Vec3::ZERO, Vec3::X);
    let b = spawn(Vec3::new(c, s, 0.0), Vec3::ZERO);
    let cc = spawn(Vec3::new(c, -s, 0.0), Vec3::ZERO);
    (a, b, cc)
}

/// Throughput: `n` spheres of radius 0.25 m in free flight on a sparse 3D grid (2 m apart),
/// no gravity, moving slowly so that they rarely meet. Returns the spheres.
pub fn sparse_flight(world: &mut World, n: usize) -> Vec<Entity> {
    world.insert_resource(Gravity(Vec3::ZERO));
    let side = ((n as f32).cbrt().ceil() as usize).max(1);
    (0..n)
        .map(|i| {
            let (x, y, z) = (i % side, (i / side) % side, i / (side * side));
            let p = Vec3::new(x as f32, y as f32, z as f32) * 2.0;
            let v = Vec3::new(
                ((i * 7) % 5) as f32 - 2.0,
                ((i * 3) % 5) as f32 - 2.0,
                ((i * 11) % 5) as f32 - 2.0,
            ) * 0.1;
            world.spawn(ball(0.25, 1.0, p, v)).id()
        })
        .collect()
}
