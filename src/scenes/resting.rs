//! Resting scenes: a box on the ground, cubes on cubes, stacks, columns and pyramids.

use bevy::prelude::*;

use super::{cuboid, ground};
use crate::prelude::*;

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
