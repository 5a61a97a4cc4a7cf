//! Unit tests of the hybrid method's resting phase.

use super::super::body::cube_over_ground;
use super::super::contact::prepare_contacts;
use super::super::soft_step::soft_sweep;
use super::*;
use bevy::math::{BVec3, Mat3, Quat};

/// `shock_order`'s blocks in a vector of their own.
fn blocks_in_shock_order(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    manifolds: &[Range<usize>],
    touch: f32,
) -> Vec<Block> {
    let mut blocks = Vec::new();
    shock_order(
        &mut blocks,
        bodies,
        contacts,
        manifolds,
        touch,
        &mut OrderScratch::default(),
    );
    blocks
}

fn cube(motion: Motion, mass: f32) -> SolverBody {
    SolverBody::new(motion, Vec3::ZERO, Quat::IDENTITY).with_mass(
        1.0 / mass,
        Mat3::from_diagonal(Vec3::splat(6.0 / mass)),
        true,
        BVec3::FALSE,
    )
}

/// `resting_phase_idle` counts each body's extra acceleration with gravity: a ball leaving
/// a static floor at `v_n` with `max_push_out_speed` 3 m/s stays out of reach of any push
/// over a 1/60 s step iff `v_n + min(g_n, 0) dt >= 3`. At 3.2 m/s under `g` alone
/// (3.2 - 0.16 = 3.04) it is idle; with an extra `-4 g` (3.2 - 0.82 = 2.38) it is not. At
/// 3.05 m/s it is not under `g` (2.89), and is under an extra `+2 g`, which pulls it away
/// from the floor (`g_n > 0`: its `v_n` only grows).
#[test]
fn idle_check_counts_extra_accelerations() {
    let g = Vec3::new(0.0, -9.81, 0.0);
    let config = SolverConfig::default();
    let idle = |vn: f32, extra: Vec3| {
        let mut ball = cube(Motion::Dynamic, 1.0).with_velocity(Vec3::Y * vn, Vec3::ZERO);
        ball.position = Vec3::Y * 0.5;
        ball.extra_acceleration = extra;
        let bodies = [cube(Motion::Static, 1.0), ball];
        let mut contacts = [ContactConstraint::new(
            0,
            1,
            Vec3::ZERO,
            Vec3::Y,
            0.0,
            0.0,
            0.0,
        )];
        prepare_contacts(&bodies, &mut contacts);
        resting_phase_idle(&bodies, &contacts, &config, g, 1.0 / 60.0)
    };
    assert!(idle(3.2, Vec3::ZERO));
    assert!(!idle(3.2, 4.0 * g));
    assert!(!idle(3.05, Vec3::ZERO));
    assert!(idle(3.05, -2.0 * g));
}

/// Levels worked out by hand: a static floor (0) and a kinematic platform (5) are level 0;
/// a column 1, 2, 3 on the floor is 1, 2, and 2 for 3, which also touches 4; body 4 rests on
/// 3 and on the platform, so it is 1 (its lowest neighbour, not the column below it); 6
/// hangs on 4 only (2); 7 touches
/// nothing fixed through any chain, nor does 8 that rests on it (u32::MAX). Pairs listed
/// top-down and twice, so one pass in list order would not find the answer.
#[test]
fn levels_are_hops_from_the_nearest_fixed_body() {
    let mut bodies: Vec<SolverBody> = (0..9).map(|_| cube(Motion::Dynamic, 1.0)).collect();
    bodies[0] = cube(Motion::Static, 1.0);
    bodies[5] = cube(Motion::Kinematic, 1.0);
    let pairs = [
        (8, 7),
        (6, 4),
        (3, 4),
        (2, 3),
        (1, 2),
        (0, 1),
        (4, 5),
        (3, 2),
    ];
    let mut levels = Levels::default();
    let level = levels.compute(&bodies, pairs.iter().copied());
    assert_eq!(level, vec![0, 1, 2, 2, 1, 0, 2, u32::MAX, u32::MAX]);
}

/// One single-point manifold per body pair (normals from the first body to the second).
fn manifolds(pairs: &[(usize, usize)]) -> (Vec<ContactConstraint>, Vec<Range<usize>>) {
    let contacts = pairs
        .iter()
        .map(|&(a, b)| ContactConstraint::new(a, b, Vec3::ZERO, Vec3::Y, 0.0, 0.0, 0.0))
        .collect();
    let ranges = (0..pairs.len()).map(|i| i..i + 1).collect();
    (contacts, ranges)
}

/// A static ground (body 0) and dynamic cubes of 1, 1, 2 and 1 kg (bodies 1-4).
fn ground_and_cubes_of_1_1_2_1_kg() -> [SolverBody; 5] {
    [
        SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
        cube(Motion::Dynamic, 1.0),
        cube(Motion::Dynamic, 1.0),
        cube(Motion::Dynamic, 2.0),
        cube(Motion::Dynamic, 1.0),
    ]
}

/// A column (ground 0, then cubes of 1, 2 and 3 kg, listed top down) with `friction` on every
/// contact: its bodies, its contacts and its blocks in shock order.
fn three_cube_column(friction: f32) -> ([SolverBody; 4], Vec<ContactConstraint>, Vec<Block>) {
    let bodies = [
        SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
        cube(Motion::Dynamic, 1.0),
        cube(Motion::Dynamic, 2.0),
        cube(Motion::Dynamic, 3.0),
    ];
    let (mut contacts, ranges) = manifolds(&[(2, 3), (1, 2), (0, 1)]);
    for c in &mut contacts {
        c.friction = friction;
    }
    prepare_contacts(&bodies, &mut contacts);
    let blocks = blocks_in_shock_order(&bodies, &contacts, &ranges, 0.005);
    (bodies, contacts, blocks)
}

/// A column with friction ([`three_cube_column`]): blocks come out ground up, each supported by
/// the body below, which is held wholly (a column on the ground), so each block's own impulse
/// bears only the body it supports: 1, 2, 3 kg (the mass above, 6, 5 and 3 kg, is carried
/// down the chain, see `transmitted_impulses_are_the_impulses_above`). Frictionless, no block
/// passes its load on (see `Block::passes_on`) and each carries the mass above.
#[test]
fn column_loads_are_the_body_each_block_bears() {
    let (_, _, blocks) = three_cube_column(0.0);
    let loads: Vec<f32> = blocks.iter().map(|b| b.load).collect();
    assert_eq!(loads, [6.0, 5.0, 3.0]);
    assert!(blocks.iter().all(|b| !b.passes_on));
    let (_, _, blocks) = three_cube_column(0.5);
    let order: Vec<(usize, Support, f32)> = blocks
        .iter()
        .map(|b| (b.range.start, b.support, b.load))
        .collect();
    assert_eq!(
        order,
        [
            (2, Support::A, 1.0),
            (1, Support::A, 2.0),
            (0, Support::A, 3.0)
        ]
    );
    assert!(blocks.iter().all(|b| b.passes_on == (b.range.start != 2)));
}

/// The column with friction with each block's normal impulse set to the weight impulse of the
/// body it supports (1, 2 and 3 N s): the top block (cube 3 on cube 2) carries nothing beyond
/// its own; the middle one carries the top's 3 N s; the ground's carries 2 + 3 = 5 N s, so that
/// its friction bound and reported impulse are those of the whole column (1 + 5 = 6 N s).
/// A body resting on two supports shares what it passes on between them in proportion to
/// their own impulses.
#[test]
fn transmitted_impulses_are_the_impulses_above() {
    let (bodies, mut contacts, blocks) = three_cube_column(0.5);
    for (c, impulse) in contacts.iter_mut().zip([3.0, 2.0, 1.0]) {
        c.normal_impulse = impulse;
    }
    let mut transmitted = Transmitted::default();
    transmitted.compute(&bodies, &contacts, &blocks);
    let carried: Vec<(usize, f32)> = (0..blocks.len())
        .map(|k| (blocks[k].range.start, transmitted.of(k)))
        .collect();
    assert_eq!(carried, [(2, 5.0), (1, 3.0), (0, 0.0)]);

    // Cube 3 (2 kg) resting on cubes 1 and 2 (1 kg each, on the ground), all frictionless,
    // and cube 4 (1 kg) on cube 3 with friction, 1 N s: cube 3 passes the 1 N s on to its two
    // supports in proportion to their own impulses (1 and 3 N s), and they, frictionless, pass
    // nothing on to the ground.
    let bodies = ground_and_cubes_of_1_1_2_1_kg();
    let (mut contacts, ranges) = manifolds(&[(3, 4), (1, 3), (2, 3), (0, 1), (0, 2)]);
    contacts[0].friction = 0.5;
    prepare_contacts(&bodies, &mut contacts);
    for (c, impulse) in contacts.iter_mut().zip([1.0, 1.0, 3.0, 2.0, 4.0]) {
        c.normal_impulse = impulse;
    }
    let blocks = blocks_in_shock_order(&bodies, &contacts, &ranges, 0.005);
    transmitted.compute(&bodies, &contacts, &blocks);
    let of = |start: usize| {
        let k = blocks.iter().position(|b| b.range.start == start).unwrap();
        (blocks[k].passes_on, transmitted.of(k))
    };
    assert_eq!(
        [of(0), of(1), of(2), of(3), of(4)],
        [
            (true, 0.0),
            (false, 0.25),
            (false, 0.75),
            (false, 0.0),
            (false, 0.0)
        ]
    );
}

/// A 0.01 kg cube on the ground under a 1 kg cube whose contact normal leans `theta` = 0.1 rad
/// off the ground's (friction 0.5 between the cubes, `ground_friction` on the ground; bodies
/// and points at the origin, so nothing turns): the light cube's hold is `cos^2 theta` = 0.990
/// (the ground stops only the push's part along its own normal), short of a whole one. It
/// passes the load on only where the ground's friction stops the rest with `GRIP_MARGIN` (2)
/// to spare, `tan theta` = 0.1003 <= mu / 2: with mu 0.3, not with 0.15, and not when it rests
/// on a dynamic cube (a chain, whose lower links may move), whatever the friction. Straight
/// down (theta 0) the hold is whole and needs no grip. What it passes on is the held part: the
/// ground's block carries `cos^2 theta` of the upper block's impulse. (The cubes sit at the
/// origin, the upper contact at its centre, the ground's four points at the light cube's bottom
/// corners: the push's line crosses that face, so it cannot tip the light cube.)
#[test]
fn a_support_held_by_friction_passes_its_load_on() {
    let theta = 0.1f32;
    let lean = Vec3::new(theta.sin(), theta.cos(), 0.0);
    let light_then_heavy = |normal: Vec3, ground_friction: f32, on_a_cube: bool| {
        let mut bodies = vec![
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            cube(Motion::Dynamic, 0.01),
            cube(Motion::Dynamic, 1.0),
            cube(Motion::Dynamic, 1.0),
        ];
        let row = |a: usize, b: usize, point: Vec3, normal: Vec3, friction: f32| {
            ContactConstraint::new(a, b, point, normal, 0.0, 0.0, friction)
        };
        let mut contacts = vec![row(1, 2, Vec3::ZERO, normal, 0.5)];
        let ranges = if on_a_cube {
            contacts.push(row(3, 1, Vec3::ZERO, Vec3::Y, ground_friction));
            contacts.push(row(0, 3, Vec3::ZERO, Vec3::Y, ground_friction));
            vec![0..1, 1..2, 2..3]
        } else {
            bodies.pop();
            for (x, z) in [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)] {
                let corner = Vec3::new(x, -0.5, z);
                contacts.push(row(0, 1, corner, Vec3::Y, ground_friction));
            }
            vec![0..1, 1..5]
        };
        prepare_contacts(&bodies, &mut contacts);
        let blocks = blocks_in_shock_order(&bodies, &contacts, &ranges, 0.005);
        let top = blocks.iter().position(|b| b.range.start == 0).unwrap();
        (bodies, contacts, blocks, top)
    };
    let (_, _, blocks, top) = light_then_heavy(lean, 0.3, false);
    let cos2 = theta.cos().powi(2);
    assert!(
        (blocks[top].hold - cos2).abs() < 1e-6,
        "{}",
        blocks[top].hold
    );
    assert!(blocks[top].hold < WHOLLY_HELD);
    assert!(blocks[top].passes_on);
    let passes = |(_, _, blocks, top): (_, _, Vec<Block>, usize)| blocks[top].passes_on;
    assert!(!passes(light_then_heavy(lean, 0.15, false)));
    assert!(!passes(light_then_heavy(lean, 1.0, true)));
    let (_, _, blocks, top) = light_then_heavy(Vec3::Y, 0.0, false);
    assert!(blocks[top].hold >= WHOLLY_HELD && blocks[top].passes_on);

    let (bodies, mut contacts, blocks, top) = light_then_heavy(lean, 0.3, false);
    contacts[0].normal_impulse = 1.0;
    for c in &mut contacts[1..] {
        c.normal_impulse = 0.0025;
    }
    let mut transmitted = Transmitted::default();
    transmitted.compute(&bodies, &contacts, &blocks);
    let ground = blocks.iter().position(|b| b.range.start == 1).unwrap();
    assert_eq!(transmitted.of(top), 0.0);
    assert!((transmitted.of(ground) - cos2).abs() < 1e-6);
}

/// A small pyramid: cubes 1 and 2 (1 kg) on the ground, cube 3 (2 kg) on both, and cube 4
/// (1 kg) touching cube 1 from the side at the same level. Cube 3's load is shared equally
/// (1 kg per support), each ground manifold carries its cube plus that share (2 kg: the
/// contacts are frictionless, so no load is passed on, see `Block::passes_on`), and the side
/// contact has no support and no load. Cube 3's two manifolds are adjacent.
#[test]
fn shared_loads_split_between_supports() {
    let bodies = ground_and_cubes_of_1_1_2_1_kg();
    let (mut contacts, ranges) = manifolds(&[(1, 3), (0, 1), (4, 1), (2, 3), (0, 2), (0, 4)]);
    prepare_contacts(&bodies, &mut contacts);
    let blocks = blocks_in_shock_order(&bodies, &contacts, &ranges, 0.005);
    let load = |start: usize| blocks.iter().find(|b| b.range.start == start).unwrap();
    assert_eq!(load(1).load, 2.0);
    assert_eq!(load(4).load, 2.0);
    assert_eq!(load(5).load, 1.0);
    assert_eq!(load(0).load, 1.0);
    assert_eq!(load(3).load, 1.0);
    assert_eq!((load(2).support, load(2).load), (Support::Neither, 0.0));
    let tops: Vec<usize> = blocks
        .iter()
        .enumerate()
        .filter(|(_, b)| b.upper(&contacts) == Some(3))
        .map(|(i, _)| i)
        .collect();
    assert_eq!(tops.len(), 2);
    assert_eq!(tops[1], tops[0] + 1);
}
/// The projection onto a cone: a vector inside the cone of three generators is its own
/// projection; outside a single generator's ray it is `(n . g) g`; between two generators
/// (outside their plane) it lies on their face; opposite every generator it is zero.
#[test]
fn cone_projection_cases() {
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    let n = Vec3::new(1.0, 2.0, 3.0).normalize();
    let (p, used) = cone_projection(n, &[x, y, z]);
    assert!((p - n).length() < 1e-6 && used == 0b111);
    let n = Vec3::new(0.6, 0.8, 0.0);
    let (p, used) = cone_projection(n, &[y]);
    assert!((p - 0.8 * y).length() < 1e-6 && used == 1);
    // Between x and y, with a z part: the face's projection drops the z part.
    let n = Vec3::new(0.48, 0.64, 0.6);
    let (p, used) = cone_projection(n, &[x, y]);
    assert!((p - Vec3::new(0.48, 0.64, 0.0)).length() < 1e-6 && used == 0b11);
    let (p, used) = cone_projection(-y, &[y, x]);
    assert_eq!((p, used), (Vec3::ZERO, 0));
}

/// A ball of 1 kg on static ground, struck from above along `n` at angle `theta` from the
/// vertical: its hold is `cos^2 theta` and it is free to move along `n - cos theta y` (the
/// projection of `n` across the ground normal), exactly the frictionless rigid answer. A
/// ball on another ball that rests squarely on the ground (a column of two) is held wholly
/// along the vertical, and a ball with nothing below it (touching only speculatively) not
/// at all.
#[test]
fn holds_follow_the_support_cone() {
    let ball = |y: f32| {
        SolverBody::new(Motion::Dynamic, Vec3::new(0.0, y, 0.0), Quat::IDENTITY).with_mass(
            1.0,
            Mat3::from_diagonal(Vec3::splat(10.0)),
            true,
            BVec3::FALSE,
        )
    };
    let theta = 0.9f32;
    let n = Vec3::new(theta.sin(), theta.cos(), 0.0);
    let bodies = [
        SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
        ball(0.5),
        ball(0.5 + 1.0),
    ];
    let floor = ContactConstraint::new(0, 1, Vec3::ZERO, Vec3::Y, 0.0, 0.0, 0.0);
    let hit = ContactConstraint::new(1, 2, Vec3::new(0.0, 0.5, 0.0) + 0.5 * n, n, 0.0, 0.0, 0.0);
    let mut contacts = [floor, hit];
    prepare_contacts(&bodies, &mut contacts);
    let blocks = blocks_in_shock_order(&bodies, &contacts, &[0..1, 1..2], 0.005);
    let struck = blocks.iter().find(|b| b.range == (1..2)).unwrap();
    let c2 = theta.cos().powi(2);
    assert!((struck.hold - c2).abs() < 1e-6, "{}", struck.hold);
    assert!((struck.push - (n - theta.cos() * Vec3::Y)).length() < 1e-6);
    // A column of two: held wholly.
    let column = ContactConstraint::new(1, 2, Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 0.0, 0.0, 0.0);
    let mut contacts = [floor, column];
    prepare_contacts(&bodies, &mut contacts);
    let blocks = blocks_in_shock_order(&bodies, &contacts, &[0..1, 1..2], 0.005);
    let top = blocks.iter().find(|b| b.range == (1..2)).unwrap();
    assert!((top.hold - 1.0).abs() < 1e-6 && top.push.length() < 1e-6);
    // The lower ball only speculatively on the ground (a 1 cm gap): not held.
    let gap = ContactConstraint::new(0, 1, Vec3::ZERO, Vec3::Y, 0.01, 0.0, 0.0);
    let mut contacts = [gap, column];
    prepare_contacts(&bodies, &mut contacts);
    let blocks = blocks_in_shock_order(&bodies, &contacts, &[0..1, 1..2], 0.005);
    let top = blocks.iter().find(|b| b.range == (1..2)).unwrap();
    assert_eq!(top.hold, 0.0);
}

/// A friction manifold's soft tilt holds its load up where `omega^2 <r^2> / g` is at least
/// four times the lever (worked by hand below), whatever its size otherwise.
#[test]
fn soft_tilt_stands_by_size_against_lever() {
    // A face of four corners at +-h: <r^2> = h^2 (2 h^2 from the centroid, over two).
    let face = |h: f32| -> Vec<ContactConstraint> {
        [(-h, -h), (h, -h), (h, h), (-h, h)]
            .iter()
            .map(|&(x, z)| {
                ContactConstraint::new(0, 1, Vec3::new(x, 0.0, z), Vec3::Y, 0.0, 0.0, 0.5)
            })
            .collect()
    };
    // The block carrying a load whose centre of mass stands `l` above the face's centroid,
    // with its lever and spread as the solver derives them (`carried_loads`).
    let block = |h: f32, l: f32| {
        let (lever, spread) = lever(&face(h), 1, Vec3::new(0.0, l, 0.0));
        assert!((lever - l).abs() <= 1e-6 * l, "lever {lever} for {l}");
        assert!(
            (spread - h * h).abs() <= 1e-6 * h * h,
            "spread {spread} for {h}"
        );
        Block {
            range: 0..4,
            support: Support::A,
            hold: 1.0,
            push: Vec3::Y,
            load: 1.0,
            lever,
            spread,
            touching: true,
            carries_released: false,
            passes_on: false,
            gripped: false,
        }
    };
    // 30 Hz over 9.81 m/s^2: omega^2 / g = 3621.9 1/m.
    let omega = 2.0 * std::f32::consts::PI * 30.0;
    let solve = ManifoldSolve {
        soft: None,
        inv_h: 240.0,
        max_push_out: 3.0,
        leave_impacts: None,
        max_block_iterations: 64,
        tolerance: 1e-4,
        tilt_stiffness: omega * omega / 9.81,
    };
    // A 1 m cube's face under a column of 20 (centre of mass 10 m up): 3621.9 x 0.25 = 905
    // against 4 x 10 = 40.
    assert!(soft_tilt_stands(&block(0.5, 10.0), &solve));
    // A 1 mm die's face under two more (lever 1.5 mm): 3621.9 x 2.5e-7 = 9.1e-4 against
    // 4 x 1.5e-3 = 6e-3.
    assert!(!soft_tilt_stands(&block(5e-4, 1.5e-3), &solve));
    // The bound: h^2 omega^2 / g = 4 l, for h = 0.5, at l = 226.4 m.
    let l = 0.25 * omega * omega / 9.81 / TILT_MARGIN;
    assert!(soft_tilt_stands(&block(0.5, l * 0.999), &solve));
    assert!(!soft_tilt_stands(&block(0.5, l * 1.001), &solve));
    // No load: Box2D's own-mass row, always.
    let mut free = block(5e-4, 1e3);
    free.load = 0.0;
    assert!(soft_tilt_stands(&free, &solve));
}

fn box_on_ground(corners: &[Vec3]) -> (Vec<SolverBody>, Vec<ContactConstraint>) {
    let bodies =
        cube_over_ground(0.49, Vec3::new(0.0, -0.5, 0.0), Vec3::new(0.3, 0.0, -0.2)).to_vec();
    let mut contacts: Vec<_> = corners
        .iter()
        .map(|&p| ContactConstraint::new(0, 1, p, Vec3::Y, -0.01, 0.0, 0.0))
        .collect();
    prepare_contacts(&bodies, &mut contacts);
    (bodies, contacts)
}

/// The soft pass's settings at `h = 1/240` s with Box2D's 3 m/s push-out cap, a block iterated
/// to `tolerance` (m/s) within 64 passes, every soft tilt standing.
fn soft_solve(soft: Softness, tolerance: f32) -> ManifoldSolve {
    ManifoldSolve {
        soft: Some(soft),
        inv_h: 240.0,
        max_push_out: 3.0,
        leave_impacts: None,
        max_block_iterations: 64,
        tolerance,
        tilt_stiffness: f32::INFINITY,
    }
}

/// One `manifold_sweep` over `contacts` as a single two-body block (no support, no load) at
/// `h = 1/240` s with Box2D's 3 m/s push-out cap, iterated to `tolerance`.
fn sweep_one_block(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    soft: Softness,
    tolerance: f32,
) -> Sweep {
    let solve = soft_solve(soft, tolerance);
    let blocks = [Block {
        range: 0..contacts.len(),
        support: Support::Neither,
        hold: 0.0,
        push: Vec3::ZERO,
        load: 0.0,
        lever: 0.0,
        spread: 0.0,
        touching: true,
        carries_released: false,
        passes_on: false,
        gripped: false,
    }];
    manifold_sweep(
        bodies,
        contacts,
        &blocks,
        (&[], &Transmitted::default()),
        &solve,
        &mut Settling::default(),
        &mut Vec::new(),
    )
}

/// A manifold block of one point is Box2D's soft row exactly (see `manifold_sweep`): the
/// same velocities and impulse, to f32 rounding (1e-6), for a penetrating, approaching,
/// spinning box corner.
#[test]
fn manifold_block_of_one_point_is_the_soft_row() {
    let soft = Softness::new(30.0, 10.0, 1.0 / 240.0);
    let (mut rows_bodies, mut rows) = box_on_ground(&[Vec3::new(0.5, -0.01, 0.5)]);
    let (mut block_bodies, mut block) = (rows_bodies.clone(), rows.clone());
    soft_sweep(
        &mut rows_bodies,
        &mut rows,
        Some(&soft),
        240.0,
        3.0,
        None,
        &mut Settling::default(),
    );
    let sweep = sweep_one_block(&mut block_bodies, &mut block, soft, 1e-6);
    assert!(sweep.settled, "one row settles in one pass");
    assert!((rows[0].normal_impulse - block[0].normal_impulse).abs() <= 1e-6);
    let (a, b) = (&rows_bodies[1], &block_bodies[1]);
    assert!((a.linear_velocity - b.linear_velocity).length() <= 1e-6);
    assert!((a.angular_velocity - b.angular_velocity).length() <= 1e-6);
}

/// Asserts that a block's rows move along their normal together (a rigid tilt), to
/// `tolerance` m/s, and returns that normal velocity and the rows' total impulse.
fn untilted(contacts: &[ContactConstraint], bodies: &[SolverBody], tolerance: f32) -> (f32, f32) {
    let v: Vec<f32> = contacts.iter().map(|c| c.normal_velocity(bodies)).collect();
    for vi in &v {
        assert!((vi - v[0]).abs() <= tolerance, "tilted: {v:?}");
    }
    (v[0], contacts.iter().map(|c| c.normal_impulse).sum())
}

/// A face manifold takes any load distribution without tilting: four corners of a spinning
/// box, penetrating equally, end with no relative velocity between the corners (the tilt
/// modes are rigid; 1e-4 m/s is the block tolerance), while the mean obeys the soft law
/// `v' + b + c sum(lambda) = 0` of the manifold as a whole.
#[test]
fn manifold_block_is_rigid_in_tilt() {
    let soft = Softness::new(30.0, 10.0, 1.0 / 240.0);
    let corners =
        [(0.5, 0.5), (0.5, -0.5), (-0.5, 0.5), (-0.5, -0.5)].map(|(x, z)| Vec3::new(x, -0.01, z));
    let (mut bodies, mut contacts) = box_on_ground(&corners);
    sweep_one_block(&mut bodies, &mut contacts, soft, 1e-7);
    let (v, total) = untilted(&contacts, &bodies, 1e-4);
    // Mean law: v' + b + (K/a2) sum(lambda) = 0 with K = 1/m for the centroid under the
    // centre of mass; b = bias_rate s.
    let a2 = soft.mass_scale / soft.impulse_scale;
    let residual = v + soft.bias_rate * -0.01 + total / a2;
    assert!(residual.abs() <= 1e-4, "{residual}");
}

/// A face manifold with three corners touching (`s = 0`) and the fourth a hair apart
/// (`s = 1e-6` m, 16 ulps of the 0.5 m anchors of this 1 m box), carrying the weight of a
/// 1 kg box that lands at `g h` (0.041 m/s), sinks as one plane: the plane sinks 13 um in
/// the substep, far past the hair, so the fourth corner sinks with the others, only
/// faster by its gap's `s/h` (2.4e-4 m/s), and the box hardly turns. Measured: corner
/// velocities within 1.2e-4 m/s of each other, the box turning at 9.5e-5 rad/s; bounds
/// `s/h` plus the block tolerance (1e-4 m/s), and 2e-4 rad/s (that spread over the 1.4 m
/// diagonal, with margin). Before, the corner a hair apart was a rigid row held at its gap
/// while the other three sank at the soft rate: a hinge, corner velocities 1.4e-3 m/s apart
/// and the box turning at 9.7e-4 rad/s. The soft sink is a fixed 0.28 mm whatever the
/// size, so such a hinge tilts a small body the more: a 1 mm die landed on another turned
/// 1e-2 rad in one step (corners 1e-10 m apart, at 1 mm 2 ulps).
#[test]
fn manifold_block_corner_a_hair_apart_sinks_with_the_rest() {
    let soft = Softness::new(30.0, 10.0, 1.0 / 240.0);
    let mut bodies = cube_over_ground(0.5, Vec3::new(0.0, -9.81 / 240.0, 0.0), Vec3::ZERO).to_vec();
    let gap = 1e-6;
    let corners = [
        (0.5, 0.5, gap),
        (0.5, -0.5, 0.0),
        (-0.5, 0.5, 0.0),
        (-0.5, -0.5, 0.0),
    ];
    let mut contacts: Vec<_> = corners
        .into_iter()
        .map(|(x, z, s)| ContactConstraint::new(0, 1, Vec3::new(x, 0.0, z), Vec3::Y, s, 0.0, 0.0))
        .collect();
    prepare_contacts(&bodies, &mut contacts);
    sweep_one_block(&mut bodies, &mut contacts, soft, 1e-7);
    let v: Vec<f32> = contacts
        .iter()
        .map(|c| c.normal_velocity(&bodies))
        .collect();
    let spread =
        v.iter().fold(f32::MIN, |m, &x| m.max(x)) - v.iter().fold(f32::MAX, |m, &x| m.min(x));
    assert!(spread <= gap * 240.0 + 1e-4, "{v:?}");
    assert!(v.iter().all(|&x| x < -1e-3), "the plane sinks: {v:?}");
    let w = bodies[1].angular_velocity.length();
    assert!(w <= 2e-4, "turned at {w} rad/s");
}

/// `sorted_by_level` gives the order of a comparison sort of the keys `(lower, upper, k)`
/// (no support last), over pseudo-random keys with many ties and unreached levels.
#[test]
fn counting_sort_matches_the_key_sort() {
    let (count, bodies) = (500, 40);
    let mut seed = 12345u32;
    let mut next = |n: u32| {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 8) % n
    };
    let keys: Vec<(u32, Option<usize>)> = (0..count)
        .map(|_| {
            let lower = match next(8) {
                0 => u32::MAX,
                _ => next(6),
            };
            let upper = (next(4) > 0).then(|| next(bodies as u32) as usize);
            (lower, upper)
        })
        .collect();
    let mut expected: Vec<(u32, usize, usize)> = keys
        .iter()
        .enumerate()
        .map(|(k, &(lower, upper))| (lower, upper.unwrap_or(usize::MAX), k))
        .collect();
    expected.sort_unstable();
    let mut sort = LevelSort::default();
    let order = sort.sorted_by_level(count, bodies, |k| keys[k].0, |k| keys[k].1);
    let expected: Vec<u32> = expected.iter().map(|&(_, _, k)| k as u32).collect();
    assert_eq!(order, expected);
}

/// A 1 kg cube (the inertia of a 1 m cube) 0.99 m above a support at the origin, 1 cm into
/// it, moving at `v` and turning at `w`.
fn box_above(v: Vec3, w: Vec3) -> SolverBody {
    let mut body = cube(Motion::Dynamic, 1.0).with_velocity(v, w);
    body.position = Vec3::new(0.0, 0.99, 0.0);
    body
}

/// A manifold with friction in a held chain is iterated through its Delassus matrix (see
/// `Delassus`), and the bodies are changed once, at the end: checked against what the block's
/// equations say, on the bodies' velocities after the solve. A spinning 1 kg box sinking onto
/// a 2 kg support held by half (`hold` 0.5, its push `(0.1, 0.5, 0)`: along the normal
/// `1 - hold`, and sideways), four corners 1 cm deep, friction 0.5, carrying its own 1 kg:
/// - the tilt is rigid: the corners' normal velocities agree;
/// - the soft plane's law `v' + b + c sum(lambda) = 0` holds, with `c = min(K, 1/load) / a2`:
///   the centroid lies under both centres of mass, so `K = (1 - hold)/m_A + 1/m_B` = 1.25,
///   and the load's `1/load` = 1 is the smaller;
/// - the box gained `sum(lambda) n / m_B` and the support lost `sum(lambda) push / m_A`,
///   nothing more (the bodies move by the impulses the matrix solved for).
///
/// Tolerance 1e-5 m/s: the block is solved to 1e-7 m/s per row change (`RIGID_FRICTION_TOLERANCE`
/// times 1e-4), and the f32 rounding of velocities near 0.5 m/s is 3e-8 per operation.
#[test]
fn held_friction_block_solved_in_velocity_space_meets_its_equations() {
    let support = cube(Motion::Dynamic, 2.0);
    let boxed = box_above(Vec3::new(0.0, -0.5, 0.0), Vec3::new(0.3, 0.0, -0.2));
    let mut bodies = vec![support, boxed];
    let mut contacts: Vec<_> = [(0.5, 0.5), (0.5, -0.5), (-0.5, 0.5), (-0.5, -0.5)]
        .map(|(x, z)| ContactConstraint::new(0, 1, Vec3::new(x, 0.49, z), Vec3::Y, -0.01, 0.0, 0.5))
        .into_iter()
        .collect();
    prepare_contacts(&bodies, &mut contacts);
    let before = bodies.clone();
    let soft = Softness::new(30.0, 10.0, 1.0 / 240.0);
    let solve = soft_solve(soft, 1e-4);
    let push = Vec3::new(0.1, 0.5, 0.0);
    let block = Block {
        range: 0..4,
        support: Support::A,
        hold: 0.5,
        push,
        load: 1.0,
        lever: 0.5,
        spread: 0.125,
        touching: true,
        carries_released: false,
        passes_on: false,
        gripped: false,
    };
    let (converged, _, changed) =
        solve_block(&mut bodies, &mut contacts, &block, &solve, &mut Vec::new());
    assert!(changed);
    assert!(converged, "the block converges within its 64 passes");
    let (v, total) = untilted(&contacts, &bodies, 1e-5);
    assert!(contacts.iter().all(|c| c.normal_impulse > 0.0));
    let a2 = soft.mass_scale / soft.impulse_scale;
    let bias = (soft.bias_rate * -0.01).max(-3.0);
    let law = v + bias + 1.0 * total / a2;
    assert!(law.abs() <= 1e-5, "soft plane law: {law}");
    let gained = bodies[1].linear_velocity - before[1].linear_velocity;
    assert!(
        (gained - total * Vec3::Y).length() <= 1e-5,
        "{gained} vs {total}"
    );
    let lost = before[0].linear_velocity - bodies[0].linear_velocity;
    assert!(
        (lost - 0.5 * total * push).length() <= 1e-5,
        "{lost} vs {total}"
    );
}

/// A face manifold whose corners are one plane but for a rounding (one corner 5e-7 m deeper:
/// half the spacing of f32 positions 10 m from the origin; 4.5e-6 m/s of bias, far above the
/// 1e-7 m/s these blocks are solved to) is solved once and for all: solved again from its own
/// answer (the same velocities, the same impulses), it changes nothing. A block's solution is
/// a fixed point of its Gauss-Seidel passes, so a second solve can only move the impulses by
/// what the tolerance leaves: bound 1e-4 of the mean impulse (the rows' changes are stopped
/// at 1e-7 m/s times a `K` of about 1 /kg, 1e-7 N s, against a mean of 0.068 N s). Without
/// the projection of the biases onto a rigid motion's fields (see `project_biases`) the block
/// has no solution: every solve runs to its 64 passes, moving load around its twist (two
/// diagonal corners taking it from the other two; measured: 3.8e-5 N s a corner in the
/// second solve, 5.6e-4 of the mean, and on at every solve).
#[test]
fn face_manifold_under_rounding_is_solved_once() {
    let support = SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY);
    let boxed = box_above(Vec3::new(0.0, -0.04, 0.0), Vec3::ZERO);
    let mut bodies = vec![support, boxed];
    let depth = [-0.01 - 5e-7, -0.01, -0.01, -0.01];
    let mut contacts: Vec<_> = [(0.5, 0.5), (0.5, -0.5), (-0.5, -0.5), (-0.5, 0.5)]
        .iter()
        .zip(depth)
        .map(|(&(x, z), s)| {
            ContactConstraint::new(0, 1, Vec3::new(x, 0.49, z), Vec3::Y, s, 0.0, 0.5)
        })
        .collect();
    prepare_contacts(&bodies, &mut contacts);
    for c in &mut contacts {
        c.normal_impulse = 0.04;
    }
    let soft = Softness::new(30.0, 10.0, 1.0 / 240.0);
    let solve = soft_solve(soft, 1e-4);
    let block = Block {
        range: 0..4,
        support: Support::A,
        hold: 1.0,
        push: Vec3::ZERO,
        load: 1.0,
        lever: 0.5,
        spread: 0.125,
        touching: true,
        carries_released: false,
        passes_on: false,
        gripped: false,
    };
    solve_block(&mut bodies, &mut contacts, &block, &solve, &mut Vec::new());
    let first: Vec<f32> = contacts.iter().map(|c| c.normal_impulse).collect();
    solve_block(&mut bodies, &mut contacts, &block, &solve, &mut Vec::new());
    let mean = first.iter().sum::<f32>() / 4.0;
    assert!(mean > 0.0);
    for (c, j) in contacts.iter().zip(&first) {
        assert!(
            (c.normal_impulse - j).abs() <= 1e-4 * mean,
            "moved: {first:?} -> {:?}",
            contacts
                .iter()
                .map(|c| c.normal_impulse)
                .collect::<Vec<_>>()
        );
    }
}
