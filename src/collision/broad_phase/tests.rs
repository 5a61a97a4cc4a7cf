//! Unit tests of the broad phase's tree and box tests.

use super::*;
use bevy::math::Vec3;

/// A fixed linear congruential sequence in [0, 1), so the tests are reproducible.
struct Lcg(u32);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(1664525).wrapping_add(1013904223);
        (self.0 >> 8) as f32 / (1u32 << 24) as f32
    }

    fn aabb(&mut self) -> Aabb {
        let c = Vec3::new(self.next() * 20.0, self.next() * 5.0, self.next() * 20.0);
        let h = Vec3::new(self.next(), self.next(), self.next()) * 0.8 + 0.1;
        Aabb::new(c - h, c + h)
    }
}

/// A body of the test world: its box, whether it sits the step out (as a sleeping body
/// does: in the tree, not in the step's arrays, its box unchanged), and whether it is new
/// (a new body enters the step: a sleeping body was in a step before).
struct Body {
    entity: Entity,
    aabb: Aabb,
    out: bool,
    new: bool,
}

impl Body {
    fn new(entity: Entity, aabb: Aabb) -> Body {
        Body {
            entity,
            aabb,
            out: false,
            new: true,
        }
    }
}

/// The answer the tree must give, found the slow way: every pair of the step's boxes that
/// overlap (faces touching included), at least one of them active.
fn all_pairs(aabbs: &[Aabb], active: &[bool]) -> Vec<(u32, u32)> {
    let mut pairs = Vec::new();
    for i in 0..aabbs.len() {
        for j in i + 1..aabbs.len() {
            if (active[i] || active[j]) && aabbs[i].intersects(&aabbs[j]) {
                pairs.push((i as u32, j as u32));
            }
        }
    }
    pairs
}

/// Over 12 steps of a seeded random cloud of 300 boxes and two unbounded ones (a
/// half-space's, and one wider than 1e6 m), with a third of the boxes moving each step (some
/// within their leaf's margin, some far), some despawned (one entity index reused by a new
/// entity), some inserted, some sitting steps out, one becoming unbounded and bounded
/// again, and the active set changing, both pair searches give exactly the all-pairs
/// answer; the tree holds exactly the live bounded bodies with their boxes, and a ray cast
/// gives exactly the bodies whose boxes the ray enters.
#[test]
fn tree_gives_the_all_pairs_answer_as_bodies_come_move_and_go() {
    let mut world = World::new();
    let mut rng = Lcg(12345);
    let mut bodies: Vec<Body> = (0..300)
        .map(|_| Body::new(world.spawn_empty().id(), rng.aabb()))
        .collect();
    let unbounded = [
        Aabb::new(Vec3::splat(-f32::MAX * 0.5), Vec3::splat(f32::MAX * 0.5)),
        Aabb::new(Vec3::new(-1e7, -1.0, -1e7), Vec3::new(1e7, 0.5, 1e7)),
    ];
    for aabb in unbounded {
        bodies.push(Body::new(world.spawn_empty().id(), aabb));
    }
    let mut tree = BroadPhaseTree::default();
    let mut gone = Vec::new();
    let mut searches = Vec::new();
    for step in 0..12 {
        if step > 0 {
            // Despawn a few, and one more whose index is reused at once by an entity of
            // the next generation that the tree was never told about.
            for _ in 0..4 {
                let k = (rng.next() * 300.0) as usize;
                let body = bodies.remove(k);
                tree.remove(body.entity);
                gone.push(body.entity);
            }
            let k = (rng.next() * 290.0) as usize;
            let body = bodies.remove(k);
            gone.push(body.entity);
            let reused = Entity::from_index_and_generation(
                body.entity.index(),
                body.entity.generation().after_versions(1),
            );
            bodies.push(Body::new(reused, rng.aabb()));
            for _ in 0..5 {
                bodies.push(Body::new(world.spawn_empty().id(), rng.aabb()));
            }
            for body in &mut bodies {
                if std::mem::take(&mut body.new) || is_unbounded(&body.aabb) {
                    continue;
                }
                // A body sits a step out one time in ten, as it is: unmoved.
                body.out = rng.next() < 0.1;
                if !body.out && rng.next() < 0.33 {
                    // Moves by up to 0.01 m (within the leaf's margin) or up to 2 m.
                    let reach = if rng.next() < 0.5 { 0.01 } else { 2.0 };
                    let d = (Vec3::new(rng.next(), rng.next(), rng.next()) - 0.5) * reach;
                    body.aabb = Aabb::new(body.aabb.mins + d, body.aabb.maxs + d);
                }
            }
        }
        // Body 7 is unbounded in steps 4 and 5 (its collider became a half-space).
        if step == 4 {
            bodies[7].aabb = unbounded[0];
            bodies[7].out = false;
        }
        if step == 6 {
            bodies[7].aabb = rng.aabb();
        }
        let in_step: Vec<&Body> = bodies.iter().filter(|b| !b.out).collect();
        let entities: Vec<Entity> = in_step.iter().map(|b| b.entity).collect();
        let aabbs: Vec<Aabb> = in_step.iter().map(|b| b.aabb).collect();
        // Most steps a third of the bodies are active, the unbounded ones among them in
        // turn; in the last two steps only one or two bodies.
        let active: Vec<bool> = (0..aabbs.len())
            .map(|i| match step {
                10 => i == 5,
                11 => i == 5 || is_unbounded(&aabbs[i]),
                _ => (i + step) % 3 == 0,
            })
            .collect();
        tree.sync(&entities, &aabbs, TREE_MARGIN);
        let expected = all_pairs(&aabbs, &active);
        // A third active pairs with many; one body at least with the box of half-space
        // size, inside which every box is; with it active, every box pairs with it.
        let least = match step {
            10 => 1,
            11 => aabbs.len() - 1,
            _ => 100,
        };
        assert!(
            expected.len() >= least,
            "step {step}: {} pairs",
            expected.len()
        );
        for search in [PairSearch::Queries, PairSearch::Traversal] {
            let mut pairs = Vec::new();
            tree.pairs_with_active_by(search, &aabbs, &active, &mut pairs);
            assert_eq!(pairs, expected, "step {step}, {search:?}");
        }
        let mut pairs = Vec::new();
        tree.pairs_with_active(&aabbs, &active, &mut pairs);
        assert_eq!(pairs, expected, "step {step}, the search chosen");
        searches.push(PairSearch::for_active(&tree, &active));
        tree.optimize();

        let bounded: Vec<&Body> = bodies.iter().filter(|b| !is_unbounded(&b.aabb)).collect();
        assert_eq!(tree.bvh().leaf_count() as usize, bounded.len());
        for body in &bounded {
            let leaf = tree.leaf(body.entity).expect("a live body has a leaf");
            assert_eq!(tree.entity(leaf), Some(body.entity));
            assert_eq!(tree.aabb(body.entity), Some(body.aabb));
        }
        for &entity in &gone {
            assert_eq!(tree.leaf(entity), None);
            assert_eq!(tree.aabb(entity), None);
        }
        let listed: Vec<Entity> = tree.unbounded().map(|(e, _)| e).collect();
        let expected: Vec<Entity> = in_step
            .iter()
            .filter(|b| is_unbounded(&b.aabb))
            .map(|b| b.entity)
            .collect();
        assert_eq!(listed, expected);

        for _ in 0..4 {
            let origin = Vec3::new(rng.next() * 20.0, 10.0, rng.next() * 20.0);
            let dir = Vec3::new(rng.next() - 0.5, -1.0, rng.next() - 0.5);
            let ray = Ray::new(origin, dir);
            let mut hits: Vec<(Entity, f32)> = tree.cast_ray(&ray, 12.0).collect();
            hits.sort_by_key(|h| h.0);
            // The tree's boxes for the bodies sitting out, the step's for the others.
            let mut expected: Vec<(Entity, f32)> = bodies
                .iter()
                .filter(|b| !(b.out && is_unbounded(&b.aabb)))
                .filter_map(|b| {
                    let t = b.aabb.cast_local_ray(&ray, 12.0, true)?;
                    Some((b.entity, t))
                })
                .collect();
            expected.sort_by_key(|h| h.0);
            assert_eq!(hits, expected, "step {step}");
        }
    }
    // Both searches were chosen: traversals while a third is active, queries for one or
    // two active bodies among 300.
    assert_eq!(searches[0], PairSearch::Traversal);
    assert_eq!(searches[10..], [PairSearch::Queries, PairSearch::Queries]);
}

/// Trees of no, one, two and three leaves (parry keeps a partial root below two) give the
/// all-pairs answer, and removing every body empties the tree.
#[test]
fn small_trees() {
    let mut world = World::new();
    let entities: Vec<Entity> = (0..3).map(|_| world.spawn_empty().id()).collect();
    let all = [
        Aabb::new(Vec3::ZERO, Vec3::ONE),
        // Touching the first along x: faces touching count.
        Aabb::new(Vec3::new(1.0, 0.5, 0.5), Vec3::new(2.0, 1.5, 1.5)),
        Aabb::new(Vec3::splat(5.0), Vec3::splat(6.0)),
    ];
    let mut tree = BroadPhaseTree::default();
    for n in [0, 1, 2, 3, 2, 1, 0] {
        for e in &entities[n..] {
            tree.remove(*e);
        }
        tree.sync(&entities[..n], &all[..n], TREE_MARGIN);
        tree.optimize();
        assert_eq!(tree.bvh().leaf_count() as usize, n);
        let active = vec![true; n];
        let expected = if n >= 2 { vec![(0, 1)] } else { vec![] };
        for search in [PairSearch::Queries, PairSearch::Traversal] {
            let mut pairs = Vec::new();
            tree.pairs_with_active_by(search, &all[..n], &active, &mut pairs);
            assert_eq!(pairs, expected, "{n} leaves, {search:?}");
        }
    }
    assert!(tree.bvh().is_empty());
}
