//! Unit tests of sleeping.

use super::*;

/// A chain 0-1-2 sleeps only when all three are ready; a body linked to a non-participant
/// (here 3, e.g. touching a moving kinematic body, marked None) keeps its island awake.
#[test]
fn islands_sleep_together() {
    let t = |x: f32| Some(x);
    assert_eq!(
        islands_to_sleep(&[t(1.0), t(1.0), t(1.0)], &[(0, 1), (1, 2)], 0.5),
        vec![Some(0); 3]
    );
    assert_eq!(
        islands_to_sleep(&[t(1.0), t(1.0), t(0.2)], &[(0, 1), (1, 2)], 0.5),
        vec![None; 3]
    );
    assert_eq!(
        islands_to_sleep(&[t(1.0), t(1.0), None], &[(1, 2)], 0.5),
        vec![Some(0), None, None]
    );
}

/// The sleepers' sorted boxes give exactly the brute-force overlaps, after inserts, a
/// replaced record and removals (a fixed pseudo-random cloud, so the test is reproducible).
#[test]
fn sleeping_set_finds_every_overlap() {
    use crate::dynamics::solver::Motion;
    use parry3d::shape::Ball;
    let mut seed = 987u32;
    let mut next = || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        (seed >> 8) as f32 / (1u32 << 24) as f32
    };
    let sleeper = |i: u32, p: Vec3, r: f32| Sleeper {
        entity: Entity::from_raw_u32(i + 1).unwrap(),
        island: Entity::PLACEHOLDER,
        body: SolverBody::new(Motion::Dynamic, p, Quat::IDENTITY),
        local_com: Vec3::ZERO,
        shape: SharedShape::new(Ball::new(r)),
        motion: None,
        collides: true,
        pose: Pose::from_parts(p, Quat::IDENTITY),
        restitution: 0.0,
        friction: 0.0,
        combine: CombineRules::default(),
        layers: CollisionLayers::DEFAULT,
        reporting: Reporting::default(),
        parts: None,
        radius: r,
    };
    let mut set = SleepingSet::default();
    set.set_margin(0.02);
    for i in 0..200 {
        let p = Vec3::new(next() * 20.0, next() * 4.0, next() * 20.0);
        set.insert(sleeper(i, p, 0.1 + next()), 0);
    }
    set.insert(sleeper(7, Vec3::new(50.0, 0.0, 0.0), 0.5), 0);
    for i in (0..200).step_by(3) {
        set.remove(Entity::from_raw_u32(i + 1).unwrap());
    }
    assert_eq!(set.len(), 133);
    let mut total = 0;
    for _ in 0..100 {
        let c = Vec3::new(next() * 22.0 - 1.0, next() * 4.0, next() * 22.0 - 1.0);
        let h = Vec3::splat(0.05 + next());
        let query = Aabb::new(c - h, c + h);
        let mut found = Vec::new();
        set.overlapping(&query, &mut found);
        found.sort_unstable();
        let brute: Vec<u32> = (0..set.len() as u32)
            .filter(|&i| overlaps(&query, &set.aabb(i)))
            .collect();
        assert_eq!(found, brute);
        total += found.len();
    }
    assert!(total > 100, "the queries meet boxes: {total}");
}
