//! Energy as a tested invariant, for every solver method (issue 8).
//!
//! 1. A lone body spinning freely (no contact, no gravity) never gains kinetic energy and keeps
//!    its angular momentum's magnitude, at any spin and step ([`spin_never_gains_energy`]).
//! 2. A property test over seeded random worlds ([`random_worlds`]): each step the mechanical
//!    energy `E = sum(m v^2 / 2 + w.I w / 2 - m g.x)` (x the centre of mass; `E` already
//!    includes the work gravity does) stays below its start plus an allowance derived in
//!    [`Allowance`]; no body is quarantined; and in worlds where nothing static takes part
//!    (no floor, no gravity) the total linear momentum is conserved.
//!
//! One test function per method, so each can fail (and be ignored) on its own. A failure
//! prints each failing world's seed and a one-line description; replay one verbosely with
//!
//! ```text
//! ENERGY_METHOD=Hybrid ENERGY_SEED=17 cargo test --test energy replay_one_seed -- --ignored --nocapture
//! ```
//!
//! The long versions (thousands of worlds) are `#[ignore]`d: `cargo test --release --test
//! energy -- --ignored`.

mod common;

use std::f64::consts::PI;

use bevy::math::DVec3;
use bevy::prelude::*;
use common::*;
use impact3d::prelude::*;
use impact3d::scenes;

// ---------------------------------------------------------------------------------------------
// A seeded PRNG (splitmix64): the worlds are a pure function of the seed.
// ---------------------------------------------------------------------------------------------

/// splitmix64 (Steele, Lea and Flood, 2014): a 64-bit state advanced by a constant and mixed.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        // Mix the seed once, so that neighbouring seeds give unrelated streams.
        let mut rng = Rng(seed ^ 0x5851_F42D_4C95_7F2D);
        rng.next();
        rng
    }

    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }

    /// Log-uniform in [lo, hi).
    fn log_range(&mut self, lo: f32, hi: f32) -> f32 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.unit()).exp()
    }

    /// Uniform in 0..n.
    fn index(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    fn chance(&mut self, p: f32) -> bool {
        self.unit() < p
    }

    /// A uniformly distributed unit vector.
    fn direction(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length();
            if l > 1e-3 && l <= 1.0 {
                return v / l;
            }
        }
    }

    /// A uniformly distributed rotation (Shoemake's method).
    fn rotation(&mut self) -> Quat {
        let (u1, u2, u3) = (self.unit(), self.unit(), self.unit());
        let tau = std::f32::consts::TAU;
        let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
        Quat::from_xyzw(
            a * (tau * u2).sin(),
            a * (tau * u2).cos(),
            b * (tau * u3).sin(),
            b * (tau * u3).cos(),
        )
        .normalize()
    }
}

// ---------------------------------------------------------------------------------------------
// Part 1: a lone spinning body.
// ---------------------------------------------------------------------------------------------

/// The three free bodies: a box (0.5 x 0.3 x 0.1 m half extents, all three moments
/// different), a capsule (r 0.2, half height 0.5: two equal moments), and an asymmetric convex
/// hull whose centre of mass is off its origin.
fn spinning_shapes() -> Vec<(&'static str, Collider)> {
    let hull = Collider::convex_hull(&[
        Vec3::new(0.6, 0.0, 0.0),
        Vec3::new(-0.3, 0.2, 0.0),
        Vec3::new(-0.2, -0.25, 0.1),
        Vec3::new(0.0, 0.1, 0.35),
        Vec3::new(0.1, -0.1, -0.2),
        Vec3::new(0.3, 0.3, 0.15),
    ])
    .expect("a solid hull");
    vec![
        ("box", Collider::cuboid(0.5, 0.3, 0.1)),
        ("capsule", Collider::capsule(0.2, 0.5)),
        ("hull", hull),
    ]
}

/// A general spin axis (not near any principal axis of the shapes above).
const SPIN_AXIS: Vec3 = Vec3::new(0.48, 0.8, 0.36);

/// Runs one lone spinning body for 300 steps under `config` at `hz` and returns the largest
/// relative rise of kinetic energy over its start, its largest relative fall, and the largest
/// relative change of `|L|`.
fn spin_run(config: &SolverConfig, collider: &Collider, spin: f32, hz: f64) -> (f64, f64, f64) {
    let mut app = scenes::headless_app(hz);
    app.insert_resource(config.clone());
    app.insert_resource(Gravity(Vec3::ZERO));
    let body = app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            collider.clone(),
            Mass(1.0),
            Transform::from_rotation(Quat::from_rotation_x(0.3)),
            AngularVelocity(SPIN_AXIS.normalize() * spin),
        ))
        .id();
    app.update();
    // The state after the first step: the first step's own change is measured too, against the
    // spawn state computed from the same mass properties.
    let computed = ComputedMass::from_collider(collider, 1000.0, Some(1.0)).unwrap();
    let start = state_of(
        &computed,
        Vec3::ZERO,
        Quat::from_rotation_x(0.3),
        Vec3::ZERO,
        SPIN_AXIS.normalize() * spin,
    );
    let (mut rise, mut fall, mut momentum) = (0f64, 0f64, 0f64);
    for step in 0..300 {
        if step > 0 {
            app.update();
        }
        let s = body_state(&app, body);
        assert!(
            app.world().get::<Quarantined>(body).is_none(),
            "quarantined"
        );
        rise = rise.max(s.kinetic / start.kinetic - 1.0);
        fall = fall.max(1.0 - s.kinetic / start.kinetic);
        momentum = momentum.max((s.spin_momentum / start.spin_momentum - 1.0).abs());
    }
    (rise, fall, momentum)
}

/// Case 1 of issue 8 under `method`: a lone body (box, capsule, hull) spinning at 10, 200, 300
/// and 1000 rad/s about a general axis, at 30, 60 and 240 Hz, with the method's usual
/// settings and with 1, 4 and 8 substeps, 300 steps each, no gravity, no contact.
///
/// Asserted: kinetic energy never rises above its start by more than 1e-5 relative, never
/// falls by more than 1e-3, and `|L| = |I w|` stays within 1e-3 relative of its start.
///
/// Tolerances: the implicit midpoint rule conserves both exactly; what is left is f32. The
/// reading converts the stored f32 quaternion (unit to about 1e-7) and the f32 inverse inertia
/// (inverted in f64 here and in the solver, from the same f32 matrix): the solver and the
/// reading agree on the energy to about 4e-7 relative (the largest rise measured), so 1e-5 is
/// 25 times that. The solver projects each substep's result onto the starting energy and, when
/// f32 rounding would leave it above, nudges it down by one f32 rounding step (1.2e-7) at a
/// time: energy and `|L|` may fall by up to about 2.4e-7 per substep, 2,400 substeps at most
/// here (300 steps x 8 substeps): 5.8e-4 in the worst case, and 1e-3 bounds it. Measured: the
/// energy falls at most 2.7e-4 and `|L|` changes at most 1.4e-4 (8 substeps, 300 steps).
///
/// Before the fix (one Newton step of implicit Euler), with one substep at 60 Hz the box's
/// energy rose 14.6x in 300 steps at 200 rad/s (a 1.29x rise in 60 steps in issue 8) and
/// `|L|` changed by 3x; every method had runs with a rise, and `|L|` fell by up to 99%.
fn spin_never_gains_energy(method: SolverMethod) {
    let usual = SolverConfig::for_method(method);
    let mut configs = vec![usual.clone()];
    for substeps in [1, 4, 8] {
        if substeps != usual.substeps {
            configs.push(SolverConfig {
                substeps,
                ..usual.clone()
            });
        }
    }
    let mut failures = Vec::new();
    for (name, collider) in spinning_shapes() {
        for config in &configs {
            for spin in [10.0, 200.0, 300.0, 1000.0] {
                for hz in [30.0, 60.0, 240.0] {
                    let (rise, fall, momentum) = spin_run(config, &collider, spin, hz);
                    if rise > 1e-5 || fall > 1e-3 || momentum > 1e-3 {
                        failures.push(format!(
                            "{method:?} {name} x{} substeps, {spin} rad/s at {hz} Hz: energy rose {rise:.3e}, fell {fall:.3e}, |L| changed {momentum:.3e}",
                            config.substeps
                        ));
                    }
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} runs failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn spin_never_gains_energy_hybrid() {
    spin_never_gains_energy(SolverMethod::Hybrid);
}

#[test]
fn spin_never_gains_energy_propagation() {
    spin_never_gains_energy(SolverMethod::Propagation);
}

#[test]
fn spin_never_gains_energy_sequential_impulses() {
    spin_never_gains_energy(SolverMethod::SequentialImpulses);
}

#[test]
fn spin_never_gains_energy_soft_step() {
    spin_never_gains_energy(SolverMethod::SoftStep);
}

#[test]
fn spin_never_gains_energy_jacobi() {
    spin_never_gains_energy(SolverMethod::Jacobi);
}

// ---------------------------------------------------------------------------------------------
// Part 2: random worlds.
// ---------------------------------------------------------------------------------------------

/// Standard gravity of the worlds that have any, m/s^2.
const G: f32 = 9.81;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Floor {
    None,
    HalfSpace,
    TriMesh,
}

#[derive(Clone, Debug)]
enum Shape {
    Sphere(f32),
    Cuboid(Vec3),
    Capsule(f32, f32),
    Hull(Vec<Vec3>),
}

impl Shape {
    fn collider(&self) -> Collider {
        match self {
            Shape::Sphere(r) => Collider::sphere(*r),
            Shape::Cuboid(h) => Collider::cuboid(h.x, h.y, h.z),
            Shape::Capsule(r, hh) => Collider::capsule(*r, *hh),
            Shape::Hull(points) => Collider::convex_hull(points).expect("checked when made"),
        }
    }

    /// Radius of a sphere about the body's origin containing the shape, m.
    fn bounding_radius(&self) -> f32 {
        match self {
            Shape::Sphere(r) => *r,
            Shape::Cuboid(h) => h.length(),
            Shape::Capsule(r, hh) => r + hh,
            Shape::Hull(points) => points.iter().map(|p| p.length()).fold(0.0, f32::max),
        }
    }

    fn short(&self) -> String {
        match self {
            Shape::Sphere(r) => format!("sphere {r:.2}"),
            Shape::Cuboid(h) => format!("box {:.2}x{:.2}x{:.2}", h.x, h.y, h.z),
            Shape::Capsule(r, hh) => format!("capsule {r:.2}/{hh:.2}"),
            Shape::Hull(p) => format!("hull {}pt", p.len()),
        }
    }
}

#[derive(Clone, Debug)]
struct Body {
    shape: Shape,
    mass: f32,
    position: Vec3,
    rotation: Quat,
    velocity: Vec3,
    spin: Vec3,
    restitution: f32,
    friction: f32,
}

/// One random world: everything a run needs, a pure function of the seed.
#[derive(Clone, Debug)]
struct World3 {
    seed: u64,
    hz: f64,
    substeps: u32,
    steps: u32,
    floor: Floor,
    gravity: Vec3,
    overlapping: bool,
    bodies: Vec<Body>,
}

fn random_shape(rng: &mut Rng) -> Shape {
    match rng.index(4) {
        0 => Shape::Sphere(rng.range(0.1, 0.8)),
        1 => Shape::Cuboid(Vec3::new(
            rng.range(0.05, 0.6),
            rng.range(0.05, 0.6),
            rng.range(0.05, 0.6),
        )),
        2 => Shape::Capsule(rng.range(0.05, 0.4), rng.range(0.0, 0.6)),
        _ => loop {
            let half = Vec3::new(
                rng.range(0.1, 0.6),
                rng.range(0.1, 0.6),
                rng.range(0.1, 0.6),
            );
            let count = 6 + rng.index(10);
            let points: Vec<Vec3> = (0..count)
                .map(|_| {
                    half * Vec3::new(
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                    )
                })
                .collect();
            if let Some(c) = Collider::convex_hull(&points) {
                // A sliver hull (volume under 2% of its box) is legal but not what this test is
                // about; draw again.
                let volume = 1.0 / c.shape().mass_properties(1.0).inv_mass;
                if volume > 0.02 * 8.0 * half.x * half.y * half.z {
                    break Shape::Hull(points);
                }
            }
        },
    }
}

/// A speed: zero a quarter of the time, otherwise log-uniform in [lo, hi).
fn random_speed(rng: &mut Rng, lo: f32, hi: f32) -> f32 {
    if rng.chance(0.25) {
        0.0
    } else {
        rng.log_range(lo, hi)
    }
}

impl World3 {
    /// The world of `seed`: 2-12 bodies (spheres, cuboids, capsules, convex hulls), masses
    /// log-uniform in 1e-3..1e3 kg, speeds to 100 m/s and spins to 300 rad/s, restitution in
    /// [0, 1] (0 and 1 themselves a fifth of the time each), friction 0 or 0.5; no floor, a
    /// half-space or a static trimesh; gravity 9.81 m/s^2 (zero in half the worlds without a
    /// floor); 30-240 Hz; 1-8 substeps; 60-120 steps; a third of the worlds spawned
    /// overlapping, the rest clean (bounding spheres 5 cm apart, and off the floor).
    fn new(seed: u64) -> Self {
        let mut rng = Rng::new(seed);
        let n = 2 + rng.index(11);
        let hz = rng.range(30.0, 240.0) as f64;
        let substeps = 1 + rng.index(8) as u32;
        let steps = 60 + rng.index(61) as u32;
        let floor = [Floor::None, Floor::HalfSpace, Floor::TriMesh][rng.index(3)];
        let gravity = if floor == Floor::None && rng.chance(0.5) {
            Vec3::ZERO
        } else {
            Vec3::new(0.0, -G, 0.0)
        };
        let overlapping = rng.chance(1.0 / 3.0);
        let shapes: Vec<Shape> = (0..n).map(|_| random_shape(&mut rng)).collect();
        let radii: Vec<f32> = shapes.iter().map(Shape::bounding_radius).collect();
        let lift = |r: f32| if floor == Floor::None { 0.0 } else { r + 0.3 };
        let mut positions: Vec<Vec3> = Vec::new();
        if overlapping {
            // Within a ball about half the mean bounding radius times cbrt(n): most bodies
            // overlap one or more others.
            let mean = radii.iter().sum::<f32>() / n as f32;
            let spread = 0.5 * mean * (n as f32).cbrt();
            for &r in &radii {
                let p = rng.direction() * spread * rng.unit().cbrt();
                positions.push(p + Vec3::Y * (lift(r) * rng.unit() + spread));
            }
        } else {
            let mut side = 1.5 * (n as f32).cbrt();
            for &r in &radii {
                let mut tries = 0;
                let p = loop {
                    tries += 1;
                    if tries % 200 == 0 {
                        side *= 1.5;
                    }
                    let p = Vec3::new(
                        rng.range(-side, side),
                        rng.range(0.0, 2.0 * side) + lift(r),
                        rng.range(-side, side),
                    );
                    let clear = positions
                        .iter()
                        .zip(&radii)
                        .all(|(q, &rq)| p.distance(*q) > r + rq + 0.05);
                    if clear {
                        break p;
                    }
                };
                positions.push(p);
            }
        }
        let bodies = shapes
            .into_iter()
            .zip(positions)
            .map(|(shape, position)| {
                let restitution = match rng.index(5) {
                    0 => 0.0,
                    1 => 1.0,
                    _ => rng.unit(),
                };
                Body {
                    shape,
                    mass: rng.log_range(1e-3, 1e3),
                    position,
                    rotation: rng.rotation(),
                    velocity: rng.direction() * random_speed(&mut rng, 0.01, 100.0),
                    spin: rng.direction() * random_speed(&mut rng, 0.1, 300.0),
                    restitution,
                    friction: if rng.chance(0.5) { 0.0 } else { 0.5 },
                }
            })
            .collect();
        World3 {
            seed,
            hz,
            substeps,
            steps,
            floor,
            gravity,
            overlapping,
            bodies,
        }
    }

    /// The solver settings of this world under `method`: the method's usual settings with the
    /// world's substeps.
    fn config(&self, method: SolverMethod, friction_model: FrictionModel) -> SolverConfig {
        SolverConfig {
            substeps: self.substeps,
            friction_model,
            ..SolverConfig::for_method(method)
        }
    }

    /// One line: seed, rate, floor, gravity, spawn, and each body.
    fn describe(&self) -> String {
        let bodies: Vec<String> = self
            .bodies
            .iter()
            .map(|b| {
                format!(
                    "{} {:.3}kg v{:.1} w{:.0} e{:.2} f{}",
                    b.shape.short(),
                    b.mass,
                    b.velocity.length(),
                    b.spin.length(),
                    b.restitution,
                    b.friction
                )
            })
            .collect();
        format!(
            "seed {}: {:.1} Hz x{} substeps, {} steps, floor {:?}, g {}, {} spawn, {} bodies [{}]",
            self.seed,
            self.hz,
            self.substeps,
            self.steps,
            self.floor,
            self.gravity.y,
            if self.overlapping {
                "overlapping"
            } else {
                "clean"
            },
            self.bodies.len(),
            bodies.join("; ")
        )
    }

    /// Spawns the world into `app`; returns the dynamic bodies in order.
    fn spawn(&self, app: &mut App) -> Vec<Entity> {
        let world = app.world_mut();
        world.insert_resource(Gravity(self.gravity));
        match self.floor {
            Floor::None => {}
            Floor::HalfSpace => {
                scenes::ground(world);
            }
            Floor::TriMesh => {
                world.spawn((RigidBody::Static, trimesh_floor(), Transform::IDENTITY));
            }
        }
        self.bodies
            .iter()
            .map(|b| {
                world
                    .spawn((
                        RigidBody::Dynamic,
                        b.shape.collider(),
                        Mass(b.mass),
                        Transform::from_translation(b.position).with_rotation(b.rotation),
                        LinearVelocity(b.velocity),
                        AngularVelocity(b.spin),
                        Restitution(b.restitution),
                        Friction(b.friction),
                    ))
                    .id()
            })
            .collect()
    }

    /// The sum of the overlap depths at spawn over every pair of bodies and every body with
    /// the floor, m (parry's contact query, the narrow phase's own geometry).
    fn overlap_depth(&self) -> (f32, Vec<bool>) {
        let pose = |b: &Body| parry3d::math::Pose::from_parts(b.position, b.rotation);
        let colliders: Vec<Collider> = self.bodies.iter().map(|b| b.shape.collider()).collect();
        // parry's contact query does not take a trimesh; the trimesh floor lies below the plane
        // y = 0.2 m with gentle slopes, so a body's depth into it is at most its depth below
        // that plane: a bound, as the allowance needs.
        let floor = match self.floor {
            Floor::None => None,
            Floor::HalfSpace => Some((Collider::half_space(Vec3::Y), 0.0)),
            Floor::TriMesh => Some((Collider::half_space(Vec3::Y), TRIMESH_TOP)),
        };
        let mut total = 0.0;
        let mut overlapping = vec![false; self.bodies.len()];
        let depth = |p1, s1: &Collider, p2, s2: &Collider| {
            parry3d::query::contact(&p1, s1.shape().as_ref(), &p2, s2.shape().as_ref(), 0.0)
                .ok()
                .flatten()
                .map_or(0.0, |c| (-c.dist).max(0.0))
        };
        for i in 0..self.bodies.len() {
            if let Some((f, top)) = &floor {
                let at = parry3d::math::Pose::from_parts(Vec3::Y * *top, Quat::IDENTITY);
                let d = depth(pose(&self.bodies[i]), &colliders[i], at, f);
                if d > 0.0 {
                    total += d;
                    overlapping[i] = true;
                }
            }
            for j in i + 1..self.bodies.len() {
                let d = depth(
                    pose(&self.bodies[i]),
                    &colliders[i],
                    pose(&self.bodies[j]),
                    &colliders[j],
                );
                if d > 0.0 {
                    total += d;
                    overlapping[i] = true;
                    overlapping[j] = true;
                }
            }
        }
        (total, overlapping)
    }
}

/// Height of the trimesh floor's raised vertices, m.
const TRIMESH_TOP: f32 = 0.2;

/// A static trimesh floor: a 40 m x 40 m grid of 4 m cells (`scenes::bumpy_grid`) whose
/// vertices alternate between heights 0 and [`TRIMESH_TOP`] (a gently bumpy terrain, so contacts are not all vertical).
fn trimesh_floor() -> Collider {
    scenes::bumpy_grid(20.0, 10, TRIMESH_TOP)
}

/// How far above its start a world's mechanical energy may go, J.
///
/// - **Soft contacts** (clean spawns): a soft contact carrying a weight `W` sinks by up to
///   `W K / (2 pi f)^2` and stores up to `W` times that as it does, energy first lost, then
///   given back when the load comes off; only a discrete step's overshoot of that return can
///   show up above `E_0`. With the load scaling of the default, each supporting contact sinks
///   by `delta = |g| / (2 pi f)^2` per unit of weight carried (0.28 mm at 30 Hz), `f` the
///   contact hertz capped at a quarter of the substep rate (7.5 Hz and 4.4 mm at 30 Hz with
///   one substep). A world of `n` bodies has no contact carrying more than its total weight
///   `M |g|`, and no body more than `n` contacts above the floor, so all contacts together
///   store at most `n M |g| delta`; the allowance is 4 times that ("a few times the steady
///   sink"). In a world without gravity it is zero: nothing is carried.
/// - **Push-out** (overlapping spawns): the soft methods push penetration out at no more than
///   `max_push_out_speed` (3 m/s) relative speed (sequential impulses and Jacobi push out by a
///   pseudo-velocity that leaves no speed, and propagation does not push out: for them the
///   kinetic part is zero). An impulse that brings a contact's normal
///   velocity from `v_b` to `v_a <= cap` changes the pair's kinetic energy by
///   `(v_a^2 - v_b^2) / (2 K) <= m_eff cap^2 / 2 <= m cap^2 / 2` for either body's mass `m`,
///   so the kinetic energy push-out can give is at most `sum m cap^2 / 2` over the overlapping
///   bodies; and pushing out lifts no body by more than the sum `D` of all overlap depths at
///   spawn, which bounds the potential energy it can add by `M |g| D`.
/// - **Rounding**: the state is f32; each step rounds every body's position and velocity (a
///   few operations of 6e-8 relative each) and the energy is read back from them, so over 120
///   steps at most about 3e-5 of the energy scale in the worst, linear case (see
///   [`energy_scale`]); the allowance is 1e-4 of the largest energy scale so far.
#[derive(Clone, Copy, Debug)]
struct Allowance {
    soft: f64,
    push_out: f64,
}

impl Allowance {
    fn new(world: &World3, config: &SolverConfig, states: &[BodyState]) -> Self {
        let g = world.gravity.length() as f64;
        let total_mass: f64 = states.iter().map(|s| s.mass).sum();
        let rate = world.hz * config.substeps.max(1) as f64;
        let hertz = (config.contact_hertz as f64).min(0.25 * rate);
        let delta = g / (2.0 * PI * hertz).powi(2);
        let soft = 4.0 * states.len() as f64 * total_mass * g * delta;
        let push_out = if world.overlapping {
            let (depth, overlapping) = world.overlap_depth();
            // Sequential impulses and Jacobi push out with a pseudo-velocity that leaves no
            // speed (split impulses), propagation not at all: only the soft contacts' push-out
            // gives kinetic energy.
            let soft = matches!(config.method, SolverMethod::Hybrid | SolverMethod::SoftStep);
            let cap = if soft {
                config.max_push_out_speed as f64
            } else {
                0.0
            };
            let kinetic: f64 = states
                .iter()
                .zip(&overlapping)
                .filter(|(_, o)| **o)
                .map(|(s, _)| 0.5 * s.mass * cap * cap)
                .sum();
            kinetic + total_mass * g * depth as f64
        } else {
            0.0
        };
        Allowance { soft, push_out }
    }
}

/// Mechanical energy of `states` under `gravity`, J: kinetic minus `m g.x`.
fn mechanical_energy(states: &[BodyState], gravity: Vec3) -> f64 {
    let g = gravity.as_dvec3();
    states
        .iter()
        .map(|s| s.kinetic - s.mass * g.dot(s.center))
        .sum()
}

/// The size of the potential-energy terms, `sum m |g| |x|`, J: their rounding is that of the
/// positions, so it grows as bodies move away from the origin.
fn potential_scale(states: &[BodyState], gravity: Vec3) -> f64 {
    let g = gravity.length() as f64;
    states.iter().map(|s| s.mass * g * s.center.length()).sum()
}

/// The scale against which f32 rounding of the energy is measured at a step, J: the start's
/// kinetic energy and potential scale, plus the potential scale now. Every kinetic energy the
/// world may legitimately reach is below it (at most the start's energy plus the potential
/// energy released), and it does not grow with energy the solver creates, so the rounding
/// allowance cannot follow a blow-up.
fn energy_scale(start: &[BodyState], now: &[BodyState], gravity: Vec3) -> f64 {
    start.iter().map(|s| s.kinetic).sum::<f64>()
        + potential_scale(start, gravity)
        + potential_scale(now, gravity)
}

/// Total linear momentum and its scale `sum m |v|` (for rounding).
fn momentum(states: &[BodyState]) -> (DVec3, f64) {
    states.iter().fold((DVec3::ZERO, 0.0), |(p, s), b| {
        (p + b.mass * b.velocity, s + b.mass * b.velocity.length())
    })
}

/// Relative tolerance of momentum conservation against the largest `sum m |v|` seen: each
/// impulse applied to a body rounds its velocity to f32 (6e-8 relative), and a step applies up
/// to `substeps x iterations x contacts` of them; 1e-4 is the worst case of about 1,600
/// roundings, far above the random walk of the tens of thousands a run applies.
const MOMENTUM_TOLERANCE: f64 = 1e-4;

/// Relative rounding allowance of the energy (see [`Allowance`]).
const ENERGY_ROUNDING: f64 = 1e-4;

/// What went wrong in one world, if anything.
fn check_world(
    world: &World3,
    method: SolverMethod,
    friction: FrictionModel,
    verbose: bool,
) -> Option<String> {
    let config = world.config(method, friction);
    let mut app = scenes::headless_app(world.hz);
    app.insert_resource(config.clone());
    app.insert_resource(SleepConfig {
        enabled: false,
        ..default()
    });
    let bodies = world.spawn(&mut app);
    let start: Vec<BodyState> = world
        .bodies
        .iter()
        .map(|b| {
            let computed =
                ComputedMass::from_collider(&b.shape.collider(), 1000.0, Some(b.mass)).unwrap();
            state_of(&computed, b.position, b.rotation, b.velocity, b.spin)
        })
        .collect();
    let allowance = Allowance::new(world, &config, &start);
    let e0 = mechanical_energy(&start, world.gravity);
    let mut scale = energy_scale(&start, &start, world.gravity);
    let free = world.floor == Floor::None && world.gravity == Vec3::ZERO;
    let (p0, mut p_scale) = momentum(&start);
    if verbose {
        println!("{}", world.describe());
        println!(
            "E0 {e0:.6e} J, allowance soft {:.3e} J, push-out {:.3e} J, scale {scale:.3e} J",
            allowance.soft, allowance.push_out
        );
    }
    for step in 1..=world.steps {
        app.update();
        if let Some(e) = bodies
            .iter()
            .find(|&&e| app.world().get::<Quarantined>(e).is_some())
        {
            let reason = &app.world().get::<Quarantined>(*e).unwrap().reason;
            return Some(format!("step {step}: body {e} quarantined: {reason}"));
        }
        let states: Vec<BodyState> = bodies.iter().map(|&e| body_state(&app, e)).collect();
        let e = mechanical_energy(&states, world.gravity);
        scale = scale.max(energy_scale(&start, &states, world.gravity));
        let limit = e0 + allowance.soft + allowance.push_out + ENERGY_ROUNDING * scale;
        let stats = *app.world().resource::<SolverStats>();
        if verbose {
            let vmax = states
                .iter()
                .map(|s| s.velocity.length())
                .fold(0.0, f64::max);
            let kinetic: f64 = states.iter().map(|s| s.kinetic).sum();
            println!(
                "step {step}: E {e:.6e} J (kinetic {kinetic:.6e}; limit {limit:.6e}), vmax {vmax:.3} m/s, {} contacts, {} impacts, {} sweeps{}",
                stats.contacts,
                stats.impacts,
                stats.propagation_sweeps,
                if stats.propagation_bound_hit {
                    " (bound hit)"
                } else {
                    ""
                }
            );
        }
        if e > limit || !e.is_finite() {
            if verbose {
                for (i, s) in states.iter().enumerate() {
                    println!(
                        "  body {i}: {:.3} kg at {:.4?}, v {:.4?}, kinetic {:.4e} J",
                        s.mass, s.center, s.velocity, s.kinetic
                    );
                }
            }
            return Some(format!(
                "step {step}: E {e:.4e} J > E0 {e0:.4e} J + allowance {:.3e} J ({:.3}x E0 rise {:.3e} J)",
                limit - e0,
                e / e0,
                e - e0
            ));
        }
        if free {
            let (p, s) = momentum(&states);
            p_scale = p_scale.max(s);
            let dp = (p - p0).length();
            if dp > MOMENTUM_TOLERANCE * p_scale {
                return Some(format!(
                    "step {step}: momentum changed by {dp:.3e} kg m/s (scale {p_scale:.3e})"
                ));
            }
        }
    }
    None
}

/// Runs worlds `seeds` under `method` (friction per point) and fails listing every failing
/// world.
fn random_worlds(method: SolverMethod, seeds: std::ops::Range<u64>) {
    random_worlds_with(method, FrictionModel::PerPoint, seeds);
}

/// [`random_worlds`] with the hybrid's friction model `friction`.
fn random_worlds_with(method: SolverMethod, friction: FrictionModel, seeds: std::ops::Range<u64>) {
    let count = seeds.end - seeds.start;
    let failures: Vec<String> = seeds
        .filter_map(|seed| {
            let world = World3::new(seed);
            check_world(&world, method, friction, false)
                .map(|f| format!("{f}\n    {}", world.describe()))
        })
        .collect();
    let model = if friction == FrictionModel::Manifold {
        "ENERGY_FRICTION=manifold "
    } else {
        ""
    };
    assert!(
        failures.is_empty(),
        "{method:?} ({friction:?}): {} of {count} worlds failed (replay one with {model}ENERGY_METHOD={method:?} ENERGY_SEED=<seed> cargo test --test energy replay_one_seed -- --ignored --nocapture):\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// Worlds per method in the default `cargo test`, and in the long, ignored version.
const SHORT: u64 = 200;
const LONG: u64 = 5000;

#[test]
fn energy_never_rises_hybrid() {
    random_worlds(SolverMethod::Hybrid, 0..SHORT);
}

#[test]
fn energy_never_rises_propagation() {
    random_worlds(SolverMethod::Propagation, 0..SHORT);
}

#[test]
fn energy_never_rises_sequential_impulses() {
    random_worlds(SolverMethod::SequentialImpulses, 0..SHORT);
}

#[test]
fn energy_never_rises_soft_step() {
    random_worlds(SolverMethod::SoftStep, 0..SHORT);
}

#[test]
fn energy_never_rises_jacobi() {
    random_worlds(SolverMethod::Jacobi, 0..SHORT);
}

/// The hybrid with [`FrictionModel::Manifold`] (the default since 2026-12-07): its friction
/// rows are each an exact minimiser of the kinetic energy along the row within its bound, so
/// the same invariant holds.
#[test]
fn energy_never_rises_hybrid_manifold_friction() {
    random_worlds_with(SolverMethod::Hybrid, FrictionModel::Manifold, 0..SHORT);
}

#[test]
#[ignore = "long: run with cargo test --release --test energy -- --ignored"]
fn energy_never_rises_long_hybrid_manifold_friction() {
    random_worlds_with(SolverMethod::Hybrid, FrictionModel::Manifold, SHORT..LONG);
}

#[test]
#[ignore = "long: run with cargo test --release --test energy -- --ignored"]
fn energy_never_rises_long_hybrid() {
    random_worlds(SolverMethod::Hybrid, SHORT..LONG);
}

#[test]
#[ignore = "long: run with cargo test --release --test energy -- --ignored"]
fn energy_never_rises_long_propagation() {
    random_worlds(SolverMethod::Propagation, SHORT..LONG);
}

#[test]
#[ignore = "long: run with cargo test --release --test energy -- --ignored"]
fn energy_never_rises_long_sequential_impulses() {
    random_worlds(SolverMethod::SequentialImpulses, SHORT..LONG);
}

#[test]
#[ignore = "long: run with cargo test --release --test energy -- --ignored"]
fn energy_never_rises_long_soft_step() {
    random_worlds(SolverMethod::SoftStep, SHORT..LONG);
}

#[test]
#[ignore = "long: run with cargo test --release --test energy -- --ignored"]
fn energy_never_rises_long_jacobi() {
    random_worlds(SolverMethod::Jacobi, SHORT..LONG);
}

/// Worlds of the long runs (`SHORT..LONG`) that once gained energy, with the method that gained
/// in each: checked in the default `cargo test`, so a change that brings one back fails at once.
///
/// - Bodies turning radians a substep (the default's 3028, 4367, 4734; the soft step's 670,
///   1760, 1925, 2296): a box of 613 kg at 310 rad/s, 30.9 Hz x 4, gained 13 kJ (1.3 %) in a step.
///   Fixed by [`SolverConfig::max_turn_per_substep`].
/// - A bounce warm-started in the next step (the soft step's 1309, 1904, 4734): seed
///   1904, overlapping bodies flying apart, reached 2.6 times its starting energy. Fixed in
///   `apply_restitution`.
/// - A bounce giving back the energy gravity's split from position integration added while a
///   contact held a body (the soft step's 1477, 1570: 0.2-0.3 %). Fixed by
///   `RestitutionLedger::charge_split`.
/// - An impact's owed turn (1.2 rad) taken whole in the first substep (the default's 1057,
///   1.033x). Fixed by spreading it over the substeps (`integrate_positions_owing`).
/// - Sequential impulses and Jacobi (1409 under both: a turned body's time-of-impact cast missed
///   the floor, fixed in `narrow_phase::toi`; 277, 1519, 1570, 1925, 2281, 4001, 4051: the ledger
///   booked a bounce's approach with the substep's gravity after it; 4035: the warm start raised
///   the energy; 3571: two bounces of one body in a substep timed from the first).
const ONCE_GAINED: &[(SolverMethod, u64)] = &[
    (SolverMethod::Hybrid, 1057),
    (SolverMethod::Hybrid, 3028),
    (SolverMethod::Hybrid, 4367),
    (SolverMethod::Hybrid, 4734),
    (SolverMethod::SoftStep, 670),
    (SolverMethod::SoftStep, 1309),
    (SolverMethod::SoftStep, 1477),
    (SolverMethod::SoftStep, 1570),
    (SolverMethod::SoftStep, 1760),
    (SolverMethod::SoftStep, 1904),
    (SolverMethod::SoftStep, 1925),
    (SolverMethod::SoftStep, 2296),
    (SolverMethod::SoftStep, 4734),
    (SolverMethod::SequentialImpulses, 277),
    (SolverMethod::SequentialImpulses, 1409),
    (SolverMethod::SequentialImpulses, 1519),
    (SolverMethod::SequentialImpulses, 1570),
    (SolverMethod::SequentialImpulses, 1925),
    (SolverMethod::SequentialImpulses, 2281),
    (SolverMethod::SequentialImpulses, 3571),
    (SolverMethod::SequentialImpulses, 4001),
    (SolverMethod::SequentialImpulses, 4035),
    (SolverMethod::SequentialImpulses, 4051),
    (SolverMethod::Jacobi, 1409),
    (SolverMethod::Jacobi, 3571),
];

#[test]
fn worlds_that_once_gained_energy() {
    let failures: Vec<String> = ONCE_GAINED
        .iter()
        .filter_map(|&(method, seed)| {
            let world = World3::new(seed);
            check_world(&world, method, FrictionModel::PerPoint, false)
                .map(|f| format!("{method:?} {f}\n    {}", world.describe()))
        })
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Replays one world step by step: `ENERGY_SEED` (default 0) under `ENERGY_METHOD` (a
/// `SolverMethod` name, default `Hybrid`; `ENERGY_FRICTION=manifold` for the hybrid's manifold
/// friction), printing the energy, its limit, the largest speed
/// and the solver's statistics each step.
#[test]
#[ignore = "a tool: ENERGY_METHOD=Hybrid ENERGY_SEED=17 cargo test --test energy replay_one_seed -- --ignored --nocapture"]
fn replay_one_seed() {
    let seed = std::env::var("ENERGY_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let name = std::env::var("ENERGY_METHOD").unwrap_or_else(|_| "Hybrid".into());
    let method = SolverMethod::ALL
        .into_iter()
        .find(|m| format!("{m:?}") == name)
        .expect("ENERGY_METHOD is a SolverMethod name");
    let friction = if std::env::var("ENERGY_FRICTION").as_deref() == Ok("manifold") {
        FrictionModel::Manifold
    } else {
        FrictionModel::PerPoint
    };
    let result = check_world(&World3::new(seed), method, friction, true);
    println!("{}", result.as_deref().unwrap_or("passed"));
}

/// The same seed gives the same world, and a run of it twice is bit-identical (so a printed
/// seed reproduces a failure exactly).
#[test]
fn worlds_are_reproducible() {
    let (a, b) = (World3::new(42), World3::new(42));
    assert_eq!(a.describe(), b.describe());
    assert_ne!(a.describe(), World3::new(43).describe());
    let run = || {
        let world = World3::new(42);
        let mut app = scenes::headless_app(world.hz);
        app.insert_resource(world.config(SolverMethod::Hybrid, FrictionModel::PerPoint));
        let bodies = world.spawn(&mut app);
        scenes::run_steps(&mut app, 30);
        bodies
            .iter()
            .map(|&e| (position(&app, e), velocity(&app, e), spin(&app, e)))
            .collect::<Vec<_>>()
    };
    assert_eq!(run(), run());
}

// ---------------------------------------------------------------------------------------------
// Part 3: the causes the random worlds found, one scene each.
// ---------------------------------------------------------------------------------------------

/// The four methods other than the default.
const OTHERS: [SolverMethod; 4] = [
    SolverMethod::Propagation,
    SolverMethod::SequentialImpulses,
    SolverMethod::SoftStep,
    SolverMethod::Jacobi,
];

/// A ball (r 0.1 m, 1 kg) dropped from 1 m onto a half-space under gravity 10 m/s^2
/// (`scenes::bouncing_ball`), run 3 s: the largest relative rise of its mechanical energy
/// `v^2 / 2 + 10 y` over the start (11 J) and the height of its centre at the first apex.
fn bounce_run(method: SolverMethod, hz: f64, substeps: u32, e: f32) -> (f64, f64) {
    let mut app = scenes::headless_app(hz);
    app.insert_resource(SolverConfig {
        substeps,
        ..SolverConfig::for_method(method)
    });
    app.insert_resource(SleepConfig {
        enabled: false,
        ..default()
    });
    let (_, ball) = scenes::bouncing_ball(app.world_mut(), 1.0, e);
    let e0 = 10.0 * 1.1;
    let (mut rise, mut apex, mut rising) = (f64::MIN, None, false);
    for _ in 0..(3.0 * hz) as u32 {
        app.update();
        let y = position(&app, ball).y as f64;
        let v = velocity(&app, ball).y as f64;
        rise = rise.max((0.5 * v * v + 10.0 * y) / e0 - 1.0);
        if v > 0.0 {
            rising = true;
        } else if rising && apex.is_none() {
            apex = Some(y);
        }
    }
    (rise, apex.expect("the ball bounced"))
}

/// A ball bouncing on the floor never gains energy under propagation, sequential impulses or
/// Jacobi, at 15, 44.5, 60 and 240 Hz with 1 and 4 substeps, e = 1 and 0.8, and it rebounds to the height restitution
/// gives: its centre's first apex is `0.1 + e^2 x 1` m (the impact
/// speed `sqrt(2 g h)` times `e`), at most 1e-4 m above (f32 rounding of the positions) and
/// at most 4% below (the discrete step meets the floor late by up to a step; measured: 3.1%
/// below at 15 Hz, 0.01% at 240 Hz).
///
/// Energy: at most 1e-5 relative above the start. The reading is f32: positions of about 1 m
/// and speeds of about 4.5 m/s each round by 6e-8 relative, and the measured largest rise over
/// 720 steps is 3.7e-6 (240 Hz, 4 substeps), so 1e-5 bounds the rounding with room, and any
/// real gain (a bounce off the step's gravity is `g dt / v`, 2e-3 at 240 Hz) is far above it.
///
/// Before, each method bounced more than the approach the ball arrived with: propagation
/// reflected the step's own gravity `g dt` with the rest (an e = 1 box resting on the floor
/// hopped 3 cm, and a 4 g capsule gained 5-20% of its own energy per bounce: the energy
/// property test, seed 111); sequential impulses and Jacobi held the separation speed against
/// gravity in every substep after the bounce and bounced where the body was at the start of
/// the substep, up to a step short of the floor (the same capsule gained 10% per bounce).
#[test]
fn bouncing_ball_never_gains_energy() {
    let mut failures = Vec::new();
    for method in [
        SolverMethod::Propagation,
        SolverMethod::SequentialImpulses,
        SolverMethod::Jacobi,
    ] {
        for hz in [15.0, 44.5, 60.0, 240.0] {
            for substeps in [1, 4] {
                for e in [1.0f32, 0.8] {
                    let (rise, apex) = bounce_run(method, hz, substeps, e);
                    let exact = 0.1 + (e as f64).powi(2);
                    if rise > 1e-5 || apex > exact + 1e-4 || apex < 0.96 * exact {
                        failures.push(format!(
                            "{method:?} {hz} Hz x{substeps} e {e}: energy rose {rise:.3e}, apex {apex:.4} (exact {exact:.4})"
                        ));
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A thin box (0.8 m x 0.1 m x 0.3 m, 1 kg, three different moments) spinning about a general
/// axis at 100 and 200 rad/s and flying at 10 and 30 m/s into a static wall, no gravity,
/// e = 0, 60 steps at 60 Hz: its kinetic energy never rises above its start (1e-5 relative,
/// f32 rounding), whatever the method. (Nothing can give it energy: the wall is static and the
/// contact inelastic.)
///
/// The methods other than the default rewind a fast body that would pass a wall to where it
/// first touches (`stop_at_first_impact` in the pipeline). That turned the body back without
/// turning its spin with it, which changes `w . I w` when the moments differ: the soft step's
/// box gained 35% at 100 rad/s and 61% at 200 rad/s, and in the energy property test a hull
/// gained 29% of its world's energy in one rewind (propagation, seed 107).
#[test]
fn rewound_spinning_box_never_gains_energy() {
    let axis = Vec3::new(0.48, 0.8, 0.36).normalize();
    let tilt = Quat::from_rotation_z(0.4);
    let collider = Collider::cuboid(0.4, 0.05, 0.15);
    let computed = ComputedMass::from_collider(&collider, 1000.0, Some(1.0)).unwrap();
    let mut failures = Vec::new();
    for method in OTHERS {
        for spin in [100.0, 200.0] {
            for speed in [10.0, 30.0] {
                let mut app = scenes::headless_app(60.0);
                app.insert_resource(SolverConfig::for_method(method));
                app.insert_resource(Gravity(Vec3::ZERO));
                app.world_mut().spawn((
                    RigidBody::Static,
                    Collider::cuboid(0.5, 3.0, 3.0),
                    Transform::from_xyz(1.5, 0.0, 0.0),
                ));
                let body = app
                    .world_mut()
                    .spawn((
                        RigidBody::Dynamic,
                        collider.clone(),
                        Mass(1.0),
                        Transform::from_xyz(-1.0, 0.0, 0.0).with_rotation(tilt),
                        LinearVelocity(Vec3::new(speed, 0.0, 0.0)),
                        AngularVelocity(axis * spin),
                        Restitution(0.0),
                    ))
                    .id();
                let start = state_of(
                    &computed,
                    Vec3::new(-1.0, 0.0, 0.0),
                    tilt,
                    Vec3::new(speed, 0.0, 0.0),
                    axis * spin,
                );
                let mut rise = f64::MIN;
                for _ in 0..60 {
                    app.update();
                    rise = rise.max(body_state(&app, body).kinetic / start.kinetic - 1.0);
                }
                if rise > 1e-5 {
                    failures.push(format!(
                        "{method:?} {spin} rad/s at {speed} m/s: energy rose {rise:.3e}"
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
