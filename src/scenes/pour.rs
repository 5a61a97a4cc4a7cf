//! Throughput scenes: pours of many bodies into a container or onto a triangle-mesh floor,
//! and spheres in sparse free flight.

use bevy::prelude::*;

use super::ball;
use crate::prelude::*;

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
        Self::walled_box_sized(count, bodies, density, friction, 0.5)
    }

    /// [`Pour::walled_box`] with bodies of `size` (m) and every length in proportion: grid
    /// `2.2 size`, layers `2.4 size` apart from `4 size` up, box `42 size` wide, jitter
    /// `0.1 size` (at 0.5 m, `walled_box` exactly).
    pub fn walled_box_sized(
        count: usize,
        bodies: PourBodies,
        density: f32,
        friction: f32,
        size: f32,
    ) -> Self {
        Pour {
            count,
            bodies,
            size,
            mass: PourMass::Density(density),
            friction,
            half_width: Some(21.0 * size),
            spacing: 2.2 * size,
            first_height: 4.0 * size,
            layer_pitch: 2.4 * size,
            jitter: 0.1 * size,
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
