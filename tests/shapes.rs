//! The shapes beyond sphere, box and capsule (cylinder, cone, rounded box, compound,
//! heightfield): each rests on the ground at the height its geometry gives, and the dynamic
//! ones have the closed-form mass properties. Coefficient combine rules give the closed-form
//! bounce. `ColliderConstructor` and `ColliderConstructorHierarchy` become colliders.

mod common;

use bevy::prelude::*;
use common::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, headless_app, run_steps};
use std::f32::consts::PI;

/// Drops `collider` (density 1000) with its origin `rest + 0.05` m above the ground, upright,
/// runs 2 s at 60 Hz and returns the app and the body.
fn settle(collider: Collider, rest: f32) -> (App, Entity) {
    let (mut app, body) = on_ground((
        RigidBody::Dynamic,
        collider,
        Transform::from_xyz(0.0, rest + 0.05, 0.0),
    ));
    run_steps(&mut app, 120);
    (app, body)
}

/// Asserts that `body` rests upright with its origin at `rest` m. Tolerance 1 mm: a resting
/// contact sinks 0.28 mm under the default soft contact (`g / (2 pi 30 Hz)^2`): every shape
/// here measured 0.27 mm low, upright to the bit. Upright within 1e-3 rad, at rest within
/// 1 cm/s.
fn assert_rests(app: &App, body: Entity, rest: f32, what: &str) {
    let y = position(app, body).y;
    assert!(
        (y - rest).abs() < 1e-3,
        "{what}: rests at {y}, expected {rest}"
    );
    let tilt = rotation(app, body).angle_between(Quat::IDENTITY);
    assert!(tilt < 1e-3, "{what}: tilted {tilt} rad");
    assert!(velocity(app, body).length() < 0.01, "{what}: still moving");
    assert!(app.world().get::<Quarantined>(body).is_none(), "{what}");
}

/// A cylinder of radius 0.4 m and height 1 m stands on a flat end with its centre at 0.5 m.
#[test]
fn cylinder_rests_on_its_flat_end() {
    let (app, body) = settle(Collider::cylinder(0.4, 1.0), 0.5);
    assert_rests(&app, body, 0.5, "cylinder");
}

/// A cone of base radius 0.5 m and height 1.2 m stands on its base: the origin (mid-height) at
/// 0.6 m.
#[test]
fn cone_rests_on_its_base() {
    let (app, body) = settle(Collider::cone(0.5, 1.2), 0.6);
    assert_rests(&app, body, 0.6, "cone");
}

/// A box of lengths 1 x 0.6 x 0.8 m rounded by 0.1 m rests at half its height plus the radius:
/// 0.3 + 0.1 = 0.4 m.
#[test]
fn round_cuboid_rests_at_half_extent_plus_radius() {
    let (app, body) = settle(Collider::round_cuboid(1.0, 0.6, 0.8, 0.1), 0.4);
    assert_rests(&app, body, 0.4, "round cuboid");
}

/// Two boxes as one body: a 1 x 0.5 x 1 m slab at the origin and a 0.5 m cube on top of it at
/// y = 0.5 (touching). The slab's bottom is 0.25 m below the origin, so the origin rests at
/// 0.25 m and the top is at 1 m: the combined height.
#[test]
fn compound_of_two_boxes_rests_at_its_combined_height() {
    let compound = Collider::compound(vec![
        (Vec3::ZERO, Quat::IDENTITY, Collider::cuboid(0.5, 0.25, 0.5)),
        (
            Vec3::new(0.0, 0.5, 0.0),
            Quat::IDENTITY,
            Collider::cuboid(0.25, 0.25, 0.25),
        ),
    ]);
    let (app, body) = settle(compound, 0.25);
    assert_rests(&app, body, 0.25, "compound");
}

/// A heightfield 10 m along x (6 rows) by 6 m along z (4 columns), with a step along x: the
/// samples of rows 0-2 (x = -5, -3, -1) at 0.2 and of rows 3-5 (x = 1, 3, 5) at 0.6, times
/// scale y = 1.5: flat ground at 0.3 m for x < -1 and at 0.9 m for x > 1. Spheres of radius
/// 0.3 m dropped at x = -3 and x = 3 (z = 0) rest at 0.6 and 1.2 m. Were rows along z (a
/// transposed layout), both would sit on the slope between. Tolerance as for the other
/// shapes (1 mm).
#[test]
fn spheres_rest_on_a_heightfield_at_the_sampled_height() {
    let mut app = headless_app(60.0);
    let heights: Vec<Vec<f32>> = (0..6)
        .map(|i| vec![if i < 3 { 0.2 } else { 0.6 }; 4])
        .collect();
    spawn_static(
        app.world_mut(),
        Collider::heightfield(heights, Vec3::new(10.0, 1.5, 6.0)),
        Transform::IDENTITY,
    );
    let balls: Vec<(Entity, f32)> = [(-3.0, 0.3 + 0.3), (3.0, 0.9 + 0.3)]
        .into_iter()
        .map(|(x, rest)| {
            let ball = app
                .world_mut()
                .spawn((
                    RigidBody::Dynamic,
                    Collider::sphere(0.3),
                    Transform::from_xyz(x, rest + 0.05, 0.0),
                ))
                .id();
            (ball, rest)
        })
        .collect();
    run_steps(&mut app, 120);
    for (ball, rest) in balls {
        let p = position(&app, ball);
        assert!(
            (p.y - rest).abs() < 1e-3,
            "ball rests at {p}, expected y {rest}"
        );
        assert!(
            p.xz().distance(Vec2::new(p.x.signum() * 3.0, 0.0)) < 1e-3,
            "{p}"
        );
    }
}

/// Mass properties against closed form (density 1000 kg/m^3). Tolerance: relative 1e-4, the
/// f32 rounding of parry's and these few products and sums.
fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-4 * b.abs().max(1e-6)
}

fn inertia_diagonal(m: &ComputedMass) -> Vec3 {
    let i = m.local_inverse_inertia.inverse();
    Vec3::new(i.x_axis.x, i.y_axis.y, i.z_axis.z)
}

/// Cylinder, radius r = 0.4, height h = 1: m = pi r^2 h rho, I_y = m r^2 / 2,
/// I_x = I_z = m (3 r^2 + h^2) / 12, centre of mass at the origin.
#[test]
fn cylinder_mass_properties_match_closed_form() {
    let (r, h, rho) = (0.4f32, 1.0f32, 1000.0);
    let m = ComputedMass::from_collider(&Collider::cylinder(r, h), rho, None).unwrap();
    let mass = PI * r * r * h * rho;
    assert!(close(1.0 / m.inverse_mass, mass));
    let i = inertia_diagonal(&m);
    let side = mass * (3.0 * r * r + h * h) / 12.0;
    assert!(close(i.x, side) && close(i.z, side), "{i}");
    assert!(close(i.y, mass * r * r / 2.0), "{i}");
    assert!(m.local_center_of_mass.length() < 1e-6);
}

/// Cone, radius r = 0.5, height h = 1.2: m = pi r^2 h rho / 3, centre of mass h/4 above the
/// base (y = -h/4 from the mid-height origin), I_y = 3 m r^2 / 10 and, about the centre of
/// mass, I_x = I_z = 3 m r^2 / 20 + 3 m h^2 / 80.
#[test]
fn cone_mass_properties_match_closed_form() {
    let (r, h, rho) = (0.5f32, 1.2f32, 1000.0);
    let m = ComputedMass::from_collider(&Collider::cone(r, h), rho, None).unwrap();
    let mass = PI * r * r * h * rho / 3.0;
    assert!(close(1.0 / m.inverse_mass, mass));
    assert!((m.local_center_of_mass - Vec3::new(0.0, -h / 4.0, 0.0)).length() < 1e-6);
    let i = inertia_diagonal(&m);
    let side = 3.0 * mass * r * r / 20.0 + 3.0 * mass * h * h / 80.0;
    assert!(close(i.x, side) && close(i.z, side), "{i}");
    assert!(close(i.y, 0.3 * mass * r * r), "{i}");
}

/// The compound of the rest test (slab of half extents (0.5, 0.25, 0.5) at the origin, cube of
/// half extent 0.25 at y = 0.5), by the parallel-axis theorem: each box's inertia about its own
/// centre, `m/3 (b^2 + c^2)` and so on, plus `m d^2` for its distance `d` from the combined
/// centre of mass perpendicular to the axis.
#[test]
fn compound_mass_properties_follow_the_parallel_axis_theorem() {
    let rho = 1000.0;
    let compound = Collider::compound(vec![
        (Vec3::ZERO, Quat::IDENTITY, Collider::cuboid(0.5, 0.25, 0.5)),
        (
            Vec3::new(0.0, 0.5, 0.0),
            Quat::IDENTITY,
            Collider::cuboid(0.25, 0.25, 0.25),
        ),
    ]);
    let m = ComputedMass::from_collider(&compound, rho, None).unwrap();
    let (m1, m2) = (rho * 1.0 * 0.5 * 1.0, rho * 0.5 * 0.5 * 0.5);
    let total = m1 + m2;
    let com = m2 * 0.5 / total;
    assert!(close(1.0 / m.inverse_mass, total));
    assert!((m.local_center_of_mass - Vec3::new(0.0, com, 0.0)).length() < 1e-6);
    let own = |m: f32, h: Vec3| {
        Vec3::new(
            m / 3.0 * (h.y * h.y + h.z * h.z),
            m / 3.0 * (h.x * h.x + h.z * h.z),
            m / 3.0 * (h.x * h.x + h.y * h.y),
        )
    };
    // Offsets from the combined centre are along y only: they add to I_x and I_z.
    let shift = |m: f32, dy: f32| Vec3::new(m * dy * dy, 0.0, m * dy * dy);
    let expected = own(m1, Vec3::new(0.5, 0.25, 0.5))
        + shift(m1, com)
        + own(m2, Vec3::splat(0.25))
        + shift(m2, 0.5 - com);
    let i = inertia_diagonal(&m);
    for k in 0..3 {
        assert!(close(i[k], expected[k]), "{i} vs {expected}");
    }
}

/// A rounded box's mass and inertia against a numerical integration of its solid (points
/// within `r` of the inner box), independent of the closed form in the crate: the midpoint
/// rule on a 160^3 grid over its bounding box. A cell straddles the surface only in a shell one
/// cell thick; the errors there largely cancel (about as many cells in as out): measured
/// relative errors 2.2e-4 (mass) and at most 4.3e-4 (inertia); tolerance 1e-3. Parry's own
/// figures (the inner box alone) are off by a factor of 2.
#[test]
fn round_cuboid_mass_properties_match_integration() {
    let (h, r, rho) = (Vec3::new(0.5, 0.3, 0.4), 0.1f32, 1000.0);
    let m = ComputedMass::from_collider(
        &Collider::round_cuboid(2.0 * h.x, 2.0 * h.y, 2.0 * h.z, r),
        rho,
        None,
    )
    .unwrap();
    let outer = h + Vec3::splat(r);
    let n = 160;
    let cell = 2.0 * outer / n as f32;
    let dv = (cell.x * cell.y * cell.z) as f64;
    let (mut mass, mut second) = (0.0f64, [0.0f64; 3]);
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let p = -outer + cell * (Vec3::new(i as f32, j as f32, k as f32) + 0.5);
                if (p.abs() - h).max(Vec3::ZERO).length() <= r {
                    let dm = rho as f64 * dv;
                    mass += dm;
                    for a in 0..3 {
                        second[a] += dm * (p[a] as f64).powi(2);
                    }
                }
            }
        }
    }
    let expected = [
        second[1] + second[2],
        second[0] + second[2],
        second[0] + second[1],
    ];
    let got_mass = 1.0 / m.inverse_mass as f64;
    assert!(
        (got_mass - mass).abs() <= 1e-3 * mass,
        "{got_mass} vs {mass}"
    );
    let i = inertia_diagonal(&m);
    for a in 0..3 {
        assert!(
            (i[a] as f64 - expected[a]).abs() <= 1e-3 * expected[a],
            "{i} vs {expected:?}"
        );
    }
    assert!(m.local_center_of_mass.length() < 1e-6);
}

/// Bad sizes and lists give colliders that carry their error; nothing panics.
#[test]
fn bad_shape_input_carries_an_error() {
    let bad = [
        ("zero cylinder radius", Collider::cylinder(0.0, 1.0)),
        ("NaN cylinder height", Collider::cylinder(0.5, f32::NAN)),
        ("negative cone height", Collider::cone(0.5, -1.0)),
        ("infinite cone radius", Collider::cone(f32::INFINITY, 1.0)),
        ("zero rounding", Collider::round_cuboid(1.0, 1.0, 1.0, 0.0)),
        (
            "negative length",
            Collider::round_cuboid(1.0, -1.0, 1.0, 0.1),
        ),
        ("empty compound", Collider::compound(vec![])),
        (
            "bad part",
            Collider::compound(vec![(Vec3::ZERO, Quat::IDENTITY, Collider::sphere(-1.0))]),
        ),
        (
            "NaN part position",
            Collider::compound(vec![(Vec3::NAN, Quat::IDENTITY, Collider::sphere(1.0))]),
        ),
        (
            "zero part rotation",
            Collider::compound(vec![(
                Vec3::ZERO,
                Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
                Collider::sphere(1.0),
            )]),
        ),
        (
            "half-space part",
            Collider::compound(vec![(
                Vec3::ZERO,
                Quat::IDENTITY,
                Collider::half_space(Vec3::Y),
            )]),
        ),
        (
            "one row",
            Collider::heightfield(vec![vec![0.0, 1.0]], Vec3::ONE),
        ),
        (
            "one column",
            Collider::heightfield(vec![vec![0.0], vec![1.0]], Vec3::ONE),
        ),
        (
            "ragged rows",
            Collider::heightfield(vec![vec![0.0, 1.0], vec![1.0]], Vec3::ONE),
        ),
        (
            "NaN height",
            Collider::heightfield(vec![vec![0.0, f32::NAN], vec![0.0, 0.0]], Vec3::ONE),
        ),
        (
            "zero scale",
            Collider::heightfield(vec![vec![0.0; 2]; 2], Vec3::new(1.0, 1.0, 0.0)),
        ),
        (
            "empty decomposition",
            Collider::convex_decomposition(vec![], vec![]),
        ),
    ];
    for (what, collider) in &bad {
        assert!(collider.error().is_some(), "{what}: no error");
    }
    // A nested compound is flattened into one with every part.
    let inner = Collider::compound(vec![
        (Vec3::X, Quat::IDENTITY, Collider::sphere(0.5)),
        (-Vec3::X, Quat::IDENTITY, Collider::sphere(0.5)),
    ]);
    let outer = Collider::compound(vec![
        (Vec3::Y, Quat::IDENTITY, inner),
        (Vec3::ZERO, Quat::IDENTITY, Collider::cuboid(0.5, 0.5, 0.5)),
    ]);
    assert!(outer.error().is_none());
    assert_eq!(outer.shape().as_compound().unwrap().shapes().len(), 3);
}

/// A heightfield or a compound of them cannot carry a dynamic body: it is quarantined with one
/// logged error naming it, never panicking the schedule.
#[test]
fn dynamic_heightfield_is_quarantined() {
    capture_logs();
    let mut app = headless_app(60.0);
    let body = app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            Collider::heightfield(vec![vec![0.0; 3]; 3], Vec3::ONE),
            Name::new("terrain"),
        ))
        .id();
    run_steps(&mut app, 3);
    assert!(app.world().get::<Quarantined>(body).is_some());
    let errors: Vec<_> = take_logs()
        .into_iter()
        .filter(|(l, _)| *l == log::Level::Error)
        .collect();
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert!(errors[0].1.contains("\"terrain\""), "{errors:?}");
}

/// A ball of restitution 0.2 dropped from 1 m (g = 10) onto a static plate of restitution
/// 0.8, with the ball asking for each rule: the pair's e is Average 0.5, Min 0.2, Max 0.8,
/// Multiply 0.16, GeometricMean 0.4, and the first bounce rises to e^2 h. Without a rule on
/// either body, Max (as before combine rules). When both ask, the higher-priority rule wins
/// (avian3d's order): Average on the ball and Multiply on the plate give Multiply.
///
/// Tolerance 3 mm, as for the bouncing ball of `tests/core.rs` (the apex sampled at step
/// times, at most g dt^2 / 8 = 0.35 mm, and the symplectic substeps near the ground); every
/// bounce leaves faster than the 0.5 m/s restitution threshold (0.16 x 4.47 = 0.72 m/s).
/// Measured 0.8-1.8 mm low.
#[test]
fn combine_rules_give_the_closed_form_bounce() {
    use CoefficientCombine::*;
    let cases = [
        (Some(Average), None, 0.5f32),
        (Some(Min), None, 0.2),
        (Some(Max), None, 0.8),
        (Some(Multiply), None, 0.16),
        (Some(GeometricMean), None, 0.4),
        (None, None, 0.8),
        (Some(Average), Some(Multiply), 0.16),
        (Some(Max), Some(Min), 0.8),
    ];
    for (ball_rule, plate_rule, e) in cases {
        let mut app = headless_app(60.0);
        app.insert_resource(Gravity(Vec3::new(0.0, -10.0, 0.0)));
        let plate = scenes::ground(app.world_mut());
        app.world_mut().entity_mut(plate).insert(Restitution(0.8));
        if let Some(rule) = plate_rule {
            app.world_mut()
                .entity_mut(plate)
                .insert(RestitutionCombine(rule));
        }
        let ball = app
            .world_mut()
            .spawn((
                scenes::ball(0.1, 1.0, Vec3::new(0.0, 1.1, 0.0), Vec3::ZERO),
                Restitution(0.2),
            ))
            .id();
        if let Some(rule) = ball_rule {
            app.world_mut()
                .entity_mut(ball)
                .insert(RestitutionCombine(rule));
        }
        let (mut apex, mut rising, mut previous_v) = (f32::NEG_INFINITY, false, 0.0);
        for _ in 0..120 {
            app.update();
            let (y, v) = (position(&app, ball).y - 0.1, velocity(&app, ball).y);
            if v > 0.0 {
                rising = true;
                apex = apex.max(y);
            }
            if rising && previous_v > 0.0 && v <= 0.0 {
                apex = apex.max(y);
                break;
            }
            previous_v = v;
        }
        let expected = e * e;
        assert!(
            (apex - expected).abs() < 3e-3,
            "{ball_rule:?} / {plate_rule:?}: apex {apex}, expected {expected}"
        );
    }
}

/// Friction combine: a box sliding at 2 m/s on a floor, friction 0.2 on the box and 0.8 on the
/// floor. The pair's mu is Average 0.5, Min 0.2, Multiply 0.16, Max (no rule) 0.8; the box
/// decelerates at mu g and stops after v^2 / (2 mu g). Tolerance 2 % of the distance: the
/// stop is quantised to steps (at 2 m/s and 60 Hz a step is 3.3 cm at most, but the speed
/// near the stop is small: the last step covers at most mu g dt^2 / 2 < 1.1 mm) and friction
/// acts in the substeps of the resting solve (measured 0.3-0.6 % short).
#[test]
fn friction_combine_rules_give_the_closed_form_slide() {
    use CoefficientCombine::*;
    for (rule, mu) in [
        (Some(Average), 0.5f32),
        (Some(Min), 0.2),
        (Some(Multiply), 0.16),
        (None, 0.8),
    ] {
        let mut app = headless_app(60.0);
        app.insert_resource(Gravity(Vec3::new(0.0, -10.0, 0.0)));
        let floor = scenes::ground(app.world_mut());
        app.world_mut().entity_mut(floor).insert(Friction(0.8));
        let cube = app
            .world_mut()
            .spawn((
                scenes::cuboid(Vec3::splat(0.1), 1.0, Vec3::new(0.0, 0.1, 0.0)),
                LinearVelocity(Vec3::new(2.0, 0.0, 0.0)),
                Friction(0.2),
            ))
            .id();
        if let Some(rule) = rule {
            app.world_mut()
                .entity_mut(cube)
                .insert(FrictionCombine(rule));
        }
        run_steps(&mut app, 120);
        let distance = position(&app, cube).x;
        let expected = 2.0 * 2.0 / (2.0 * mu * 10.0);
        assert!(
            (distance - expected).abs() < 0.02 * expected,
            "{rule:?}: slid {distance}, expected {expected}"
        );
    }
}

/// A `ColliderConstructor` is replaced by the collider it describes after one update, with
/// avian3d's meanings (full lengths); a bad one by a collider that carries the error, which
/// quarantines the body.
#[test]
fn collider_constructor_becomes_a_collider_after_one_update() {
    let mut app = headless_app(60.0);
    let good = app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            ColliderConstructor::Cuboid {
                x_length: 1.0,
                y_length: 0.5,
                z_length: 2.0,
            },
            Transform::from_xyz(0.0, 5.0, 0.0),
        ))
        .id();
    let compound = app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            ColliderConstructor::Compound(vec![
                (
                    Vec3::ZERO,
                    Quat::IDENTITY,
                    ColliderConstructor::Cylinder {
                        radius: 0.5,
                        height: 1.0,
                    },
                ),
                (
                    Vec3::Y,
                    Quat::IDENTITY,
                    ColliderConstructor::Sphere { radius: 0.5 },
                ),
            ]),
            Transform::from_xyz(5.0, 5.0, 0.0),
        ))
        .id();
    let bad = app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            ColliderConstructor::Cone {
                radius: -1.0,
                height: 1.0,
            },
            Transform::from_xyz(-5.0, 5.0, 0.0),
        ))
        .id();
    app.update();
    let world = app.world();
    for e in [good, compound, bad] {
        assert!(world.get::<ColliderConstructor>(e).is_none());
    }
    let cuboid = world.get::<Collider>(good).unwrap();
    assert_eq!(
        cuboid.shape().as_cuboid().unwrap().half_extents,
        Vec3::new(0.5, 0.25, 1.0)
    );
    let parts = world.get::<Collider>(compound).unwrap();
    assert_eq!(parts.shape().as_compound().unwrap().shapes().len(), 2);
    assert!(world.get::<Collider>(bad).unwrap().error().is_some());
    run_steps(&mut app, 2);
    assert!(app.world().get::<Quarantined>(bad).is_some());
    // The good ones fall freely: they joined the step.
    assert!(velocity(&app, good).y < 0.0 && velocity(&app, compound).y < 0.0);
}

/// `ColliderConstructorHierarchy` gives each descendant the default collider, or the one of
/// its name, with the layers and density of its entry; a name mapped to none gets none; the
/// root itself gets none, and the hierarchy is removed once done.
#[test]
fn collider_constructor_hierarchy_builds_the_descendants() {
    let mut app = headless_app(60.0);
    let layers = CollisionLayers::new(LayerMask(0b10), LayerMask::ALL);
    let hierarchy = ColliderConstructorHierarchy::new(ColliderConstructor::Sphere { radius: 0.5 })
        .with_constructor_for_name(
            "post",
            ColliderConstructor::Cylinder {
                radius: 0.1,
                height: 2.0,
            },
        )
        .with_layers_for_name("post", layers)
        .with_density_for_name("post", Density(500.0))
        .without_constructor_for_name("decal");
    let root = app.world_mut().spawn(hierarchy).id();
    let mut spawn_child = |parent: Entity, name: &str| {
        app.world_mut()
            .spawn((Name::new(name.to_string()), ChildOf(parent)))
            .id()
    };
    let ball = spawn_child(root, "ball");
    let post = spawn_child(ball, "post");
    let decal = spawn_child(root, "decal");
    app.update();
    let world = app.world();
    assert!(world.get::<ColliderConstructorHierarchy>(root).is_none());
    assert!(world.get::<Collider>(root).is_none());
    assert!(world.get::<Collider>(decal).is_none());
    let ball_shape = world.get::<Collider>(ball).unwrap();
    assert_eq!(ball_shape.shape().as_ball().unwrap().radius, 0.5);
    assert_eq!(world.get::<Density>(ball), Some(&Density::default()));
    let post_shape = world.get::<Collider>(post).unwrap();
    let cylinder = post_shape.shape().as_cylinder().unwrap();
    assert_eq!((cylinder.radius, cylinder.half_height), (0.1, 1.0));
    assert_eq!(world.get::<CollisionLayers>(post), Some(&layers));
    assert_eq!(world.get::<Density>(post), Some(&Density(500.0)));
}

/// A 1 kg cube of half extent `half` resting on the ground (friction 0.5, g 10, 60 Hz) under
/// the friction `model`, moving as `motion` says: the friction tests' scene.
fn cube_on_ground_with(model: FrictionModel, half: f32, motion: impl Bundle) -> (App, Entity) {
    let mut app = headless_app(60.0);
    app.insert_resource(Gravity(Vec3::new(0.0, -10.0, 0.0)));
    app.insert_resource(SolverConfig {
        friction_model: model,
        ..default()
    });
    scenes::ground(app.world_mut());
    let cube = app
        .world_mut()
        .spawn((
            scenes::cuboid(Vec3::splat(half), 1.0, Vec3::new(0.0, half, 0.0)),
            motion,
            Friction(0.5),
        ))
        .id();
    (app, cube)
}

/// Friction is isotropic: a cube sliding on the floor at 2 m/s in any direction of the plane
/// slides straight and stops after `v^2 / (2 mu g)` (0.4 m at mu 0.5, g 10), under either
/// friction model. Tolerances: 2 % of the distance (as the combine test above) and 1 % of it
/// sideways (a straight path; a friction whose two tangent rows saturate one after the other
/// would brake along one axis first and bend the path into an L).
#[test]
fn friction_slide_is_straight_in_every_direction() {
    for model in [FrictionModel::PerPoint, FrictionModel::Manifold] {
        for degrees in [0.0f32, 30.0, 45.0, 60.0, 135.0, 200.0] {
            let dir = Vec3::new(degrees.to_radians().cos(), 0.0, degrees.to_radians().sin());
            let (mut app, cube) = cube_on_ground_with(model, 0.1, LinearVelocity(2.0 * dir));
            run_steps(&mut app, 120);
            let end = position(&app, cube);
            let along = end.dot(dir);
            let aside = (end - along * dir).with_y(0.0).length();
            let expected = 0.4;
            assert!(
                (along - expected).abs() < 0.02 * expected && aside < 0.01 * expected,
                "{model:?} at {degrees} degrees: slid {along} m along, {aside} m aside (expected {expected} m)"
            );
        }
    }
}

/// A cube of side 1 m and 1 kg spinning at 3 rad/s about the normal while it rests on the
/// floor (mu 0.5, g 10) loses spin at `mu m g r / I` = 21.21 rad/s^2 under either friction
/// model: its four corners, at `r = sqrt(1/2)` m from the centroid, each slide against
/// `mu W / 4`, and the manifold's twist row is bounded by `mu W` times their mean distance,
/// the same `r`; `I = m s^2 / 6`. After 0.1 s (6 steps at 60 Hz) the spin is 0.8787 rad/s
/// (measured 0.87868 under both). Tolerance 0.003 rad/s (0.1 % of the start, for the
/// rounding of 24 substeps and of the load the soft rows carry).
#[test]
fn friction_twist_stops_a_spinning_cube_at_the_closed_form_rate() {
    for model in [FrictionModel::PerPoint, FrictionModel::Manifold] {
        let (mut app, cube) =
            cube_on_ground_with(model, 0.5, AngularVelocity(Vec3::new(0.0, 3.0, 0.0)));
        run_steps(&mut app, 6);
        let spin = app.world().get::<AngularVelocity>(cube).unwrap().0;
        let expected = 3.0 - 0.5 * 10.0 * 0.5f32.sqrt() * 6.0 * 0.1;
        assert!(
            (spin.y - expected).abs() < 0.003 && spin.with_y(0.0).length() < 1e-3,
            "{model:?}: spin {spin}, expected {expected} rad/s about y"
        );
    }
}
