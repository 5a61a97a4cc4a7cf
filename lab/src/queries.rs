//! What a ray cast costs: 10,000 seeded rays into a world of 10,000 static bodies (spheres of
//! radius 0.5 m and turned cuboids of half side 0.4 m, in turn, on a 25 x 20 x 20 grid 2 m
//! apart), through impact3d's `SpatialQuery::cast_ray` and, with the `peers` feature,
//! avian3d's, after one physics step has built each engine's tree. Each ray starts at a seeded
//! point of the grid's box, goes in a seeded direction, up to 20 m, solid. Timed per engine as
//! the fastest of `rounds` passes over all the rays (one thread, as the whole lab); the two
//! engines' hits are compared ray by ray (the same geometry must give the same distances).
//! Written to `queries.md`.

use std::io;
use std::path::Path;
use std::time::Instant;

use bevy::ecs::system::SystemState;
use bevy::prelude::*;

use crate::engines::{LabStep, bevy_app, step_bevy};
use crate::report::machine_and_date;

/// Bodies along x, y and z.
const GRID: [usize; 3] = [25, 20, 20];
/// Distance between grid points, m.
const SPACING: f32 = 2.0;
/// Longest ray, m.
const MAX_DISTANCE: f32 = 20.0;

/// One engine's pass over the rays.
#[derive(Clone, Debug, PartialEq)]
pub struct QueryRow {
    /// The engine's name.
    pub engine: &'static str,
    /// Microseconds per ray (fastest pass).
    pub us_per_ray: f64,
    /// Rays that hit something.
    pub hits: usize,
    /// Each ray's hit distance (NaN for a miss), for the comparison.
    pub distances: Vec<f32>,
}

/// A body of the grid: position, rotation, and whether it is a sphere (else a cuboid).
fn bodies() -> Vec<(Vec3, Quat, bool)> {
    let mut rng = Rng(0x5eed_0000_0001);
    let mut out = Vec::with_capacity(GRID.iter().product());
    for x in 0..GRID[0] {
        for y in 0..GRID[1] {
            for z in 0..GRID[2] {
                let at = Vec3::new(x as f32, y as f32, z as f32) * SPACING;
                let axis = rng.direction();
                let turn = Quat::from_axis_angle(axis, rng.unit() * std::f32::consts::TAU);
                out.push((at, turn, out.len() % 2 == 0));
            }
        }
    }
    out
}

/// The rays: origin and direction.
fn rays(count: usize) -> Vec<(Vec3, Dir3)> {
    let mut rng = Rng(0x5eed_0000_0002);
    let size = Vec3::new(GRID[0] as f32, GRID[1] as f32, GRID[2] as f32) * SPACING;
    (0..count)
        .map(|_| {
            let origin = Vec3::new(rng.unit(), rng.unit(), rng.unit()) * size - Vec3::splat(1.0);
            let direction = Dir3::new(rng.direction()).expect("a unit direction");
            (origin, direction)
        })
        .collect()
}

/// impact3d's pass.
fn impact3d(rays: &[(Vec3, Dir3)], rounds: usize) -> QueryRow {
    use impact3d::prelude::*;
    let mut app = bevy_app(PhysicsPlugins::new(LabStep));
    for (at, turn, sphere) in bodies() {
        let collider = if sphere {
            Collider::sphere(0.5)
        } else {
            Collider::cuboid(0.4, 0.4, 0.4)
        };
        app.world_mut().spawn((
            RigidBody::Static,
            collider,
            Transform::from_translation(at).with_rotation(turn),
        ));
    }
    step_bevy(
        app.world_mut(),
        std::time::Duration::from_secs_f64(1.0 / 60.0),
    );
    let mut state: SystemState<SpatialQuery> = SystemState::new(app.world_mut());
    let query = state.get(app.world()).expect("the query reads the world");
    let filter = SpatialQueryFilter::default();
    time_rays("impact3d", rays, rounds, |origin, direction| {
        query
            .cast_ray(origin, direction, MAX_DISTANCE, true, &filter)
            .map(|hit| hit.distance)
    })
}

/// avian3d's pass.
#[cfg(feature = "peers")]
fn avian(rays: &[(Vec3, Dir3)], rounds: usize) -> QueryRow {
    use avian3d::prelude as av;
    let mut app = bevy_app(av::PhysicsPlugins::new(LabStep));
    for (at, turn, sphere) in bodies() {
        let collider = if sphere {
            av::Collider::sphere(0.5)
        } else {
            av::Collider::cuboid(0.8, 0.8, 0.8)
        };
        app.world_mut().spawn((
            av::RigidBody::Static,
            collider,
            Transform::from_translation(at).with_rotation(turn),
        ));
    }
    step_bevy(
        app.world_mut(),
        std::time::Duration::from_secs_f64(1.0 / 60.0),
    );
    let mut state: SystemState<av::SpatialQuery> = SystemState::new(app.world_mut());
    let query = state.get(app.world()).expect("the query reads the world");
    let filter = av::SpatialQueryFilter::default();
    time_rays("avian3d", rays, rounds, |origin, direction| {
        query
            .cast_ray(origin, direction, MAX_DISTANCE, true, &filter)
            .map(|hit| hit.distance)
    })
}

/// Times `cast` over `rays`, the fastest of `rounds` passes.
fn time_rays(
    engine: &'static str,
    rays: &[(Vec3, Dir3)],
    rounds: usize,
    cast: impl Fn(Vec3, Dir3) -> Option<f32>,
) -> QueryRow {
    let mut fastest = f64::INFINITY;
    let mut distances = Vec::new();
    for _ in 0..rounds.max(1) {
        let start = Instant::now();
        distances = rays
            .iter()
            .map(|&(origin, direction)| cast(origin, direction).unwrap_or(f32::NAN))
            .collect();
        fastest = fastest.min(start.elapsed().as_secs_f64());
    }
    QueryRow {
        engine,
        us_per_ray: fastest * 1e6 / rays.len() as f64,
        hits: distances.iter().filter(|d| !d.is_nan()).count(),
        distances,
    }
}

/// Casts `count` rays through each engine (avian3d only with `peers`), `rounds` passes each.
pub fn run(count: usize, rounds: usize, peers: bool) -> Vec<QueryRow> {
    let rays = rays(count);
    #[cfg_attr(not(feature = "peers"), allow(unused_mut))]
    let mut rows = vec![impact3d(&rays, rounds)];
    #[cfg(feature = "peers")]
    if peers {
        rows.push(avian(&rays, rounds));
    }
    #[cfg(not(feature = "peers"))]
    let _ = peers;
    rows
}

/// Rays on which two rows disagree: one hits and the other misses, or the distances differ
/// by more than `tolerance` m.
pub fn disagreements(a: &QueryRow, b: &QueryRow, tolerance: f32) -> usize {
    a.distances
        .iter()
        .zip(&b.distances)
        .filter(|(x, y)| x.is_nan() != y.is_nan() || (x.is_finite() && (*x - *y).abs() > tolerance))
        .count()
}

/// `rows` as a markdown table, with the machine and date.
pub fn table(rows: &[QueryRow], rays: usize) -> String {
    let mut out = format!(
        "Ray casts: {rays} seeded rays (up to {MAX_DISTANCE} m, solid) into 10,000 static spheres \
         and turned cuboids on a 25 x 20 x 20 grid 2 m apart; fastest of the passes, one thread \
         ({})\n\n| engine | us per ray | hits | vs impact3d |\n|---|---|---|---|\n",
        machine_and_date()
    );
    for r in rows {
        let versus = if r.engine == rows[0].engine {
            String::from("1.00x")
        } else {
            format!(
                "{:.2}x the time; {} rays disagree by more than 1e-3 m",
                r.us_per_ray / rows[0].us_per_ray,
                disagreements(&rows[0], r, 1e-3)
            )
        };
        out.push_str(&format!(
            "| {} | {:.3} | {} | {versus} |\n",
            r.engine, r.us_per_ray, r.hits
        ));
    }
    out
}

/// Writes `queries.md` into `out`.
pub fn write(out: &Path, rows: &[QueryRow], rays: usize) -> io::Result<()> {
    std::fs::create_dir_all(out)?;
    std::fs::write(out.join("queries.md"), table(rows, rays))
}

/// xorshift64*: the lab's rays and turns, the same on every run.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32 / (1u64 << 24) as f32
    }

    fn direction(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.unit(), self.unit(), self.unit()) * 2.0 - Vec3::ONE;
            let l = v.length();
            if l > 1e-3 && l <= 1.0 {
                return v / l;
            }
        }
    }
}
