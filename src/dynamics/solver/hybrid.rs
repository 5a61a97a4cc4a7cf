//! The hybrid method (the default, [`SolverMethod::Hybrid`](super::SolverMethod::Hybrid)): an
//! impact phase ([`propagate`], impacts in time order, each
//! manifold a block), then a soft resting phase in which each manifold is solved as a block, in
//! shock order (supports before what they support), with the supports held only as far as
//! they really are held and each manifold as stiff as the load it carries.

use std::ops::Range;

use bevy::prelude::*;

use super::body::{Motion, SolverBody};
use super::contact::{ContactConstraint, solve_friction};
use super::iterative::{Settling, Sweep};
use super::propagation::propagate;
use super::soft_step::{Resting, Softness, soft_substeps};
use super::{SolverConfig, SolverStats, propagation_params};
use crate::impulse::{apply_row_impulse, row_inverse_mass};

/// The hybrid method's solve of one step (see [`super::step`]): the impact phase, then the
/// resting phase over the manifolds as blocks in shock order (or only gravity and integration
/// when no contact can take an impulse).
pub(super) fn solve(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    manifolds: &[Range<usize>],
    config: &SolverConfig,
    gravity: Vec3,
    dt: f32,
    stats: &mut SolverStats,
) {
    let report = propagate(
        bodies,
        contacts,
        manifolds,
        &propagation_params(
            config,
            config.restitution_threshold,
            gravity,
            false,
            true,
            dt,
        ),
    );
    stats.propagation_sweeps = report.sweeps;
    stats.propagation_bound_hit = report.bound_hit;
    if resting_phase_idle(bodies, contacts, config, gravity, dt) {
        soft_substeps(
            bodies,
            contacts,
            Resting::Idle,
            &mut Settling::default(),
            config,
            gravity,
            dt,
            stats,
        );
    } else {
        let mut blocks = shock_order(bodies, contacts, manifolds, config.linear_slop);
        // The sweeps visit the blocks in shock order: lay the contacts out in that order, so
        // that they read them in sequence rather than all over the slice.
        let (mut ordered, origin) = in_block_order(contacts, &mut blocks);
        let resting = Resting::Manifolds(&blocks);
        soft_substeps(
            bodies,
            &mut ordered,
            resting,
            &mut Settling::default(),
            config,
            gravity,
            dt,
            stats,
        );
        for (block, range) in blocks.iter().zip(origin) {
            contacts[range].copy_from_slice(&ordered[block.range.clone()]);
        }
    }
}

/// The manifolds of the hybrid method's resting solve, ordered from the ground up and each with
/// its support, which is held while the manifold is solved (shock propagation, after
/// Guendelman, Bridson and Fedkiw, "Nonconvex rigid bodies with stacking", 2003) as far as its
/// own supports hold it (see [`support_holds`]), and with the mass it carries (see
/// [`carried_loads`]).
///
/// A body's level is its distance, in contacts, from the nearest static or kinematic body
/// (level 0); bodies that touch none share the largest level. A manifold between bodies of
/// different levels is solved with the lower body held (wholly, when it rests squarely on held
/// supports: it then takes no impulse in the solve), and manifolds are solved in ascending order of their lower level, so one sweep settles each
/// body on its support, up a whole stack. Manifolds that support the same body are adjacent,
/// and `manifold_sweep` solves them together.
///
/// Why: Gauss-Seidel passes a correction down a stack and back only slowly (by
/// `cos^2(pi / 2N)` per sweep for N boxes, by `M / (M + m)` for a heavy box on a light one),
/// and while it lags, an upper body tilts almost freely under an off-centre load. A tilted face
/// turns the contact normal, which, with frictionless contacts, pushes the body below sideways,
/// further off centre: the lag acts like a soft hinge and the stack is unstable. Measured with
/// two-body manifold solves and 4 substeps at 60 Hz, a 100:1 pair is squeezed apart within
/// two seconds and a column of 20 cubes topples within ten; with this order both stand. With
/// the support fixed, a manifold's solve no longer has to converge through its support, which
/// is what lets [`carried_loads`] stiffen it by the load it carries without slowing the solve.
///
/// The support's response to the block's impulses comes one substep late, through the warm
/// start that every substep begins with (both bodies receive the accumulated impulses): over
/// substeps the support receives `lambda_0 + ... + lambda_(n-1)` and the supported body
/// `lambda_1 + ... + lambda_n`, so momentum is conserved up to one substep's impulse change
/// `lambda_n - lambda_0`, a bounded amount rather than a drift, and only in islands that touch a
/// static or kinematic body (which take momentum anyway). In an island that touches none, every
/// body has the same level and every manifold is solved two-body, conserving momentum exactly.
///
/// Without a consistent partition of `contacts` into `manifolds` (a caller of [`step`] may pass
/// none), each contact is its own block.
fn shock_order(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    manifolds: &[Range<usize>],
    touch: f32,
) -> Vec<Block> {
    let covered = manifolds.iter().map(|r| r.len()).sum::<usize>() == contacts.len()
        && manifolds
            .iter()
            .all(|r| r.end <= contacts.len() && !r.is_empty());
    let ranges: Vec<Range<usize>> = if covered {
        manifolds.to_vec()
    } else {
        (0..contacts.len()).map(|i| i..i + 1).collect()
    };
    // Only touching manifolds (a point within `touch`) make levels: a speculative contact is no
    // support. (With it, a die resting on another had the level of the lower die: at 1 mm the
    // step's fall `g dt^2`, 2.7 mm at 60 Hz, reaches the ground through the lower die, and the
    // pair of dice was then solved two-body, with no support held and no load carried.)
    let touching: Vec<bool> = ranges
        .iter()
        .map(|r| touches(&contacts[r.clone()], touch))
        .collect();
    let level = levels(
        bodies,
        ranges
            .iter()
            .zip(&touching)
            .filter(|(_, t)| **t)
            .map(|(r, _)| (contacts[r.start].body_a, contacts[r.start].body_b)),
    );
    // Sorted by (lower level, supported body), ties in manifold order: the keys are made unique
    // by the manifold's index, so the blocks themselves are moved once.
    let mut keys: Vec<(u32, usize, usize)> = ranges
        .iter()
        .enumerate()
        .map(|(k, range)| {
            let c = &contacts[range.start];
            let (la, lb) = (level[c.body_a], level[c.body_b]);
            let upper = match la.cmp(&lb) {
                std::cmp::Ordering::Less => c.body_b,
                std::cmp::Ordering::Greater => c.body_a,
                std::cmp::Ordering::Equal => usize::MAX,
            };
            (la.min(lb), upper, k)
        })
        .collect();
    keys.sort_unstable();
    let mut blocks: Vec<Block> = keys
        .iter()
        .map(|&(_, _, k)| {
            let range = ranges[k].clone();
            let c = &contacts[range.start];
            let support = match level[c.body_a].cmp(&level[c.body_b]) {
                std::cmp::Ordering::Less => Support::A,
                std::cmp::Ordering::Greater => Support::B,
                std::cmp::Ordering::Equal => Support::Neither,
            };
            Block {
                range,
                support,
                hold: 0.0,
                push: Vec3::ZERO,
                load: 0.0,
                lever: 0.0,
                spread: 0.0,
                touching: touching[k],
            }
        })
        .collect();
    support_holds(bodies, contacts, &mut blocks, touch);
    release_frictional_groups(bodies.len(), contacts, &mut blocks);
    carried_loads(bodies, contacts, &mut blocks);
    blocks
}

/// Each body's level: 0 for a static or kinematic body, one more than its lowest neighbour
/// through `pairs` for a dynamic one (`u32::MAX` if no chain of pairs reaches a fixed body).
/// A breadth-first search from the fixed bodies over the pairs, in a compressed adjacency
/// list: each pair is looked at twice, however tall the stacks.
fn levels(bodies: &[SolverBody], pairs: impl Iterator<Item = (usize, usize)> + Clone) -> Vec<u32> {
    let mut level: Vec<u32> = bodies
        .iter()
        .map(|b| {
            if b.motion == Motion::Dynamic {
                u32::MAX
            } else {
                0
            }
        })
        .collect();
    let mut start = vec![0u32; bodies.len() + 1];
    for (a, b) in pairs.clone() {
        start[a + 1] += 1;
        start[b + 1] += 1;
    }
    for i in 0..bodies.len() {
        start[i + 1] += start[i];
    }
    let mut next = start.clone();
    let mut neighbours = vec![0u32; start[bodies.len()] as usize];
    for (a, b) in pairs {
        neighbours[next[a] as usize] = b as u32;
        next[a] += 1;
        neighbours[next[b] as usize] = a as u32;
        next[b] += 1;
    }
    let mut queue: Vec<u32> = (0..bodies.len() as u32)
        .filter(|&i| level[i as usize] == 0)
        .collect();
    let mut head = 0;
    while head < queue.len() {
        let from = queue[head] as usize;
        head += 1;
        let via = level[from] + 1;
        for &to in &neighbours[start[from] as usize..start[from + 1] as usize] {
            if level[to as usize] == u32::MAX {
                level[to as usize] = via;
                queue.push(to);
            }
        }
    }
    level
}

/// Solves the manifolds of a body that rests on several supports, with friction on any of
/// them, as plain two-body blocks: no support held, no load carried through them.
///
/// Why: a held support takes the reaction of the block above it one substep late (through the
/// warm start). Under a body on one support that lag is harmless, but a body on several
/// supports (every cube of a wall, resting on two) can rock on them, and each support answers
/// the shift of load a substep late: in the awake wall of base 20 with friction 0.5 that
/// rocking grew, its kinetic energy doubling about every 30 steps from step 60 until the
/// wall's top moved 10 cm (2.1 m before the holds were weighed by the support cone). Solved
/// two-body with the soft stiffness of their own effective mass (Box2D's), the wall's
/// manifolds are stable: the top cube sinks 3.1 cm in the first half second and stays there.
/// Stiffer springs are not: carrying the load through them, or only doubling their own
/// stiffness, lets the wall collapse. Friction is what makes this sound: the held support and
/// the rigid tilt of a frictionless block are there to stop a tilted face pushing the body
/// above it sideways, and friction resists that push. Frictionless groups (a frictionless
/// pyramid needs its supports held) are left as they are. Only touching manifolds
/// ([`Block::touching`]) count as supports: a speculative one (a 1 mm die's contact with the
/// ground through the die it rests on) is not a second support.
fn release_frictional_groups(bodies: usize, contacts: &[ContactConstraint], blocks: &mut [Block]) {
    let mut supports = vec![(0u32, false); bodies];
    for block in blocks.iter().filter(|b| b.touching) {
        if let Some(upper) = block.upper(contacts) {
            supports[upper].0 += 1;
            supports[upper].1 |= contacts[block.range.start].friction > 0.0;
        }
    }
    for block in blocks.iter_mut() {
        if let Some(upper) = block.upper(contacts)
            && supports[upper].0 > 1
            && supports[upper].1
        {
            block.support = Support::Neither;
            block.hold = 0.0;
        }
    }
}

/// Some row of the manifold can push and is within `touch` (m) of touching.
fn touches(rows: &[ContactConstraint], touch: f32) -> bool {
    rows.iter()
        .any(|c| c.separation <= touch && c.normal_mass > 0.0)
}

/// Copies `contacts` in the order of `blocks` and points each block at its copy. Returns the
/// copy and each block's range in `contacts`.
fn in_block_order(
    contacts: &[ContactConstraint],
    blocks: &mut [Block],
) -> (Vec<ContactConstraint>, Vec<Range<usize>>) {
    let mut ordered = Vec::with_capacity(contacts.len());
    let mut origin = Vec::with_capacity(blocks.len());
    for block in blocks.iter_mut() {
        let start = ordered.len();
        ordered.extend_from_slice(&contacts[block.range.clone()]);
        origin.push(std::mem::replace(&mut block.range, start..ordered.len()));
    }
    (ordered, origin)
}

/// A touching manifold that supports a body, as [`support_holds`] sees it from that body.
#[derive(Clone, Copy, Debug, Default)]
struct SupportEntry {
    /// Unit normal from the support to the supported body.
    normal: Vec3,
    /// How firmly the support resists a push along `normal`, in `(0, 1]`: `1 / (1 + m K)`,
    /// `m` the supported body's mass and `K` the support's remaining inverse effective mass
    /// along the manifold (0 for a static or kinematic support, so 1).
    strength: f32,
    /// Its first touching points (world frame), for the tipping test; a manifold's points
    /// beyond these (duplicates of a face's corners) add nothing to its footprint's hull.
    footprint: [Vec3; 4],
    /// How many of `footprint` are set.
    points: u8,
}

/// Most support manifolds of one body that [`support_holds`] looks at; a body resting on more
/// (a sphere wedged among many) is treated as held by the first ones only, which can only
/// under-estimate the hold.
const MAX_SUPPORTS: usize = 8;

/// Sets each supported block's [`Block::hold`]: how much of its support's response its
/// support's own supports take. `blocks` must be in `shock_order`'s order, so that a body's
/// supporting blocks come before the blocks it supports.
///
/// Shock propagation holds a support fixed while the body above is solved, and the support
/// gets the reaction a substep later (through the warm start). That is sound only when the
/// support really is held: a push on it must go into its own supports. Where it is not (a
/// light ball on the floor struck from above at an angle, a ball of a pile pushed sideways
/// out of the pocket it sits in), the impulse computed against a fixed support is `1 + M/m`
/// times the true two-body impulse, and the support, which is free to move, leaves with
/// `M/m - 1` times the energy the impact released: a 0.05 kg ball striking a 5 kg one left at
/// 109 m/s, 485 times the energy it came with. So the hold is computed, not assumed:
///
/// - Frictionless rigid supports with normals `g_i` (pointing into the support body S) stop a
///   push on S along `-n` only in the cone they span: S's velocity change per unit push is
///   `-(n - P(n)) / m`, `P` the projection onto the cone `{sum a_i g_i, a_i >= 0}` (Moreau's
///   decomposition), so its inverse effective mass along `n` is `(1 - |P(n)|^2) / m`: the hold
///   is `|P(n)|^2`. A column (`n` along the support normal) is held wholly; the light ball on
///   the floor struck at 52 degrees keeps `sin^2` of its freedom.
/// - A support that is itself partly free holds less: for a chain (S on T), the exact two-row
///   solve gives `|P|^2 / (1 + m_S K_T)`, `K_T` what remains of T's inverse effective mass along
///   its manifold. With several supports the weakest one that takes part is used, which can
///   only under-estimate the hold.
/// - Rotation: where the block can turn S (its rows have angular terms on S), S is held only if
///   the line of action through the block's centroid along `n` meets the polygon of S's support
///   points (projected along the mean support normal); a load outside it tips S, so then the
///   hold is 0.
///
/// Only touching points (separation at most `touch`, the length-scaled linear slop) support.
/// Under-estimating the hold is safe: a hold of 0 is the plain two-body solve, which never adds
/// energy; over-estimating it is what added energy.
fn support_holds(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    blocks: &mut [Block],
    touch: f32,
) {
    let touching = |c: &ContactConstraint| c.separation <= touch && c.normal_mass > 0.0;
    // The support entries of each body, in one buffer: body `i` has at most `room[i]` of them,
    // at `start[i]..start[i] + count[i]`.
    let mut start = vec![0u32; bodies.len() + 1];
    for block in blocks.iter() {
        if let Some(upper) = block.upper(contacts) {
            start[upper + 1] = (start[upper + 1] + 1).min(MAX_SUPPORTS as u32);
        }
    }
    for i in 0..bodies.len() {
        start[i + 1] += start[i];
    }
    let mut count = vec![0u32; bodies.len()];
    let mut entries = vec![SupportEntry::default(); start[bodies.len()] as usize];
    for block in blocks.iter_mut() {
        let Some((upper, lower)) = block.pair(contacts) else {
            continue;
        };
        let rows = &contacts[block.range.clone()];
        let sign = if block.support == Support::A {
            1.0
        } else {
            -1.0
        };
        let normal = sign * rows[0].normal;
        let support_body = &bodies[lower];
        let lower_fixed = support_body.motion != Motion::Dynamic;
        // A pair's rows on several manifolds (a body on a trimesh's triangles) do not share
        // one normal: the support's response along one normal means nothing for the others,
        // so such a block is solved two-body.
        let one_normal = rows
            .iter()
            .all(|c| c.normal.dot(rows[0].normal) >= 1.0 - 1e-6);
        let (hold, push) = if lower_fixed {
            (1.0, Vec3::ZERO)
        } else if !one_normal {
            (0.0, normal)
        } else {
            let centroid = rows.iter().map(|c| c.point).sum::<Vec3>() / rows.len() as f32;
            // The block's rows have a lever arm on the support (relative 1e-7 of its inverse
            // mass is f32 rounding of `r x n` for `r` along `n`, as in `prepare_normal_row`).
            let turns = rows.iter().any(|c| {
                c.angular && {
                    let (rn, ang) = if block.support == Support::A {
                        (c.rn_a, c.ang_a)
                    } else {
                        (c.rn_b, c.ang_b)
                    };
                    rn.dot(ang) > 1e-7 * support_body.inverse_mass
                }
            });
            let first = start[lower] as usize;
            let below = &entries[first..first + count[lower] as usize];
            hold_of(below, normal, centroid, turns)
        };
        block.hold = hold;
        // `push` is along `normal` (support to supported); the block's rows use the contact
        // normal, which is `sign * normal`.
        block.push = sign * push;
        // This manifold, if touching, supports `upper`.
        let room = start[upper + 1] - start[upper];
        if count[upper] >= room {
            continue;
        }
        let mut entry = SupportEntry {
            normal,
            ..SupportEntry::default()
        };
        let mut centroid = Vec3::ZERO;
        let mut points = 0usize;
        for c in rows.iter().filter(|c| touching(c)) {
            centroid += c.point;
            if points < entry.footprint.len() {
                entry.footprint[points] = c.point;
            }
            points += 1;
        }
        if points == 0 {
            continue;
        }
        entry.points = points.min(entry.footprint.len()) as u8;
        entry.strength = if lower_fixed {
            1.0
        } else {
            let r = centroid / points as f32 - support_body.position;
            let rn = r.cross(normal);
            // The support's own side of `K` (the other side is not part of the chain).
            let k_lower = row_inverse_mass(
                [support_body.inverse_mass, 0.0],
                [rn.dot(support_body.inverse_inertia * rn), 0.0],
            );
            let m_upper = 1.0 / bodies[upper].inverse_mass.max(f32::MIN_POSITIVE);
            1.0 / (1.0 + m_upper * (1.0 - block.hold) * k_lower)
        };
        entries[(start[upper] + count[upper]) as usize] = entry;
        count[upper] += 1;
    }
}

/// The hold of a support with the given support manifolds and footprint, for a push along `-n`
/// through `point` (see [`support_holds`]), and the support's free response direction
/// `n - s P(n)` (whose component along `n` is `1 - hold`); `turns`: the push has a lever arm
/// on the support.
fn hold_of(entries: &[SupportEntry], n: Vec3, point: Vec3, turns: bool) -> (f32, Vec3) {
    if entries.is_empty() {
        return (0.0, n);
    }
    if turns {
        let axis = entries
            .iter()
            .map(|e| e.normal)
            .sum::<Vec3>()
            .normalize_or_zero();
        let footprint = entries
            .iter()
            .flat_map(|e| e.footprint[..e.points as usize].iter().copied());
        if axis == Vec3::ZERO || !line_meets_footprint(footprint, point, n, axis) {
            return (0.0, n);
        }
    }
    let normals: Vec<Vec3> = entries.iter().map(|e| e.normal).collect();
    let (projection, used) = cone_projection(n, &normals);
    let strength = entries
        .iter()
        .enumerate()
        .filter(|(i, _)| used & (1 << i) != 0)
        .map(|(_, e)| e.strength)
        .fold(1.0f32, f32::min);
    let hold = (projection.dot(n) * strength).clamp(0.0, 1.0);
    (hold, n - strength * projection)
}

/// Whether the line through `point` along `n` crosses the convex hull of `footprint`, all
/// projected on the plane normal to `axis`: the hull is covered by the triangles of its points,
/// so the test is "inside some triangle" (at most `MAX_SUPPORTS` manifolds of 4 points).
fn line_meets_footprint(
    footprint: impl Iterator<Item = Vec3>,
    point: Vec3,
    n: Vec3,
    axis: Vec3,
) -> bool {
    let along = n.dot(axis);
    if along.abs() < 1e-6 {
        return false;
    }
    let (u, v) = axis.any_orthonormal_pair();
    let flat = |p: Vec3| Vec2::new(p.dot(u), p.dot(v));
    let mut buffer = [Vec2::ZERO; 4 * MAX_SUPPORTS];
    let mut len = 0;
    let mut height = 0.0f32;
    for p in footprint.take(buffer.len()) {
        buffer[len] = flat(p);
        height += p.dot(axis);
        len += 1;
    }
    if len == 0 {
        return false;
    }
    let pts = &buffer[..len];
    // Where the line crosses the plane of the footprint's mean height along `axis`.
    let hit = flat(point + n * ((height / len as f32 - point.dot(axis)) / along));
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a - o).perp_dot(b - o);
    for i in 0..pts.len() {
        for j in i + 1..pts.len() {
            for k in j + 1..pts.len() {
                let (a, b, c) = (pts[i], pts[j], pts[k]);
                let area = cross(a, b, c);
                if area.abs()
                    <= f32::EPSILON * (b - a).length_squared().max((c - a).length_squared())
                {
                    continue;
                }
                let s = area.signum();
                if s * cross(a, b, hit) >= 0.0
                    && s * cross(b, c, hit) >= 0.0
                    && s * cross(c, a, hit) >= 0.0
                {
                    return true;
                }
            }
        }
    }
    false
}

/// The projection of `n` onto the convex cone spanned by `generators` (at most 32), and a bit
/// mask of the generators with a positive weight in it.
///
/// In 3D the projection is `n` itself when `n` is inside the cone of some three generators,
/// and otherwise lies on a ray or a two-generator face of the cone (Caratheodory), so trying
/// every single generator, pair and triple and keeping the closest feasible point is exact.
fn cone_projection(n: Vec3, generators: &[Vec3]) -> (Vec3, u32) {
    let mut best = (Vec3::ZERO, 0u32, n.length_squared());
    let consider = |p: Vec3, used: u32, best: &mut (Vec3, u32, f32)| {
        let d = (n - p).length_squared();
        if d < best.2 {
            *best = (p, used, d);
        }
    };
    let k = generators.len().min(32);
    for i in 0..k {
        let a = n.dot(generators[i]);
        if a > 0.0 {
            consider(a * generators[i], 1 << i, &mut best);
        }
        for j in i + 1..k {
            let (gi, gj) = (generators[i], generators[j]);
            // Least squares on the plane of gi, gj: [gi.gi gi.gj; gi.gj gj.gj] a = [n.gi; n.gj].
            let (aa, ab, bb) = (gi.dot(gi), gi.dot(gj), gj.dot(gj));
            let det = aa * bb - ab * ab;
            if det > 1e-9 {
                let (ni, nj) = (n.dot(gi), n.dot(gj));
                let (x, y) = ((bb * ni - ab * nj) / det, (aa * nj - ab * ni) / det);
                if x > 0.0 && y > 0.0 {
                    consider(x * gi + y * gj, (1 << i) | (1 << j), &mut best);
                }
            }
            for (l, &gl) in generators.iter().enumerate().take(k).skip(j + 1) {
                let m = Mat3::from_cols(gi, gj, gl);
                let det = m.determinant();
                if det.abs() > 1e-9 {
                    let w = m.inverse() * n;
                    if w.min_element() > 0.0 {
                        consider(n, (1 << i) | (1 << j) | (1 << l), &mut best);
                    }
                }
            }
        }
    }
    (best.0, best.1)
}

/// Sets each supported block's [`Block::load`]: the mass of its upper body plus everything that
/// body carries, shared equally among the body's supports. `blocks` must be in `shock_order`'s
/// order (ascending lower level), so that walking it backwards visits every block a body
/// supports before the blocks that support it.
///
/// Why: a soft manifold sinks by `W K / (2 pi f)^2` under a load `W`, `K` being its inverse
/// effective mass in the soft step. With `K` the manifold's own, the weight piles up: a column
/// of `N` cubes sinks by about `g N^2 / (2 pi f)^2` (11 cm for 20 cubes at 30 Hz), and a light
/// box under a 1000 times heavier one by 28 cm, deep enough for the contact normals to turn
/// and squeeze it out. Setting `K = 1 / load` (never softer than the manifold's own `K`) makes
/// every supporting contact sink by the same `g / (2 pi f)^2`, 0.28 mm at 30 Hz, whatever rests
/// on it: 5.5 mm for the 20-cube column, 0.28 mm under the 1000:1 pair. Only the
/// regularisation changes, and with the support held fixed the stiffer block still converges
/// in one pass: its only free body is the supported one.
fn carried_loads(bodies: &[SolverBody], contacts: &[ContactConstraint], blocks: &mut [Block]) {
    let mass = |i: usize| {
        let b = &bodies[i];
        if b.motion == Motion::Dynamic && b.inverse_mass > 0.0 {
            1.0 / b.inverse_mass
        } else {
            0.0
        }
    };
    let mut load: Vec<f32> = (0..bodies.len()).map(mass).collect();
    // The mass-weighted sum of the positions of what each body carries (itself included), for
    // each block's lever.
    let mut moment: Vec<Vec3> = bodies
        .iter()
        .enumerate()
        .map(|(i, b)| mass(i) * b.position)
        .collect();
    // Only touching blocks share the load; a speculative one (not touching) is given the whole
    // load of its upper body, as if it were its only support, and passes none on.
    let mut supports = vec![0u32; bodies.len()];
    for block in blocks.iter().filter(|b| b.touching) {
        if let Some(upper) = block.upper(contacts) {
            supports[upper] += 1;
        }
    }
    for block in blocks.iter_mut().rev() {
        if let Some((upper, lower)) = block.pair(contacts) {
            if load[upper] > 0.0 {
                let center = moment[upper] / load[upper];
                (block.lever, block.spread) = lever(&contacts[block.range.clone()], upper, center);
            }
            if !block.touching {
                block.load = load[upper];
                continue;
            }
            let fraction = 1.0 / supports[upper] as f32;
            let share = load[upper] * fraction;
            block.load = share;
            if bodies[lower].motion == Motion::Dynamic {
                load[lower] += share;
                let carried = moment[upper] * fraction;
                moment[lower] += carried;
            }
        }
    }
}

/// A manifold's [`Block::lever`] and [`Block::spread`]: how high the centre of mass `center`
/// of what it carries stands above the manifold's centroid, along its normal towards the
/// supported body `upper`, m (0 if below); and the mean square distance of its points from
/// that centroid over two, m^2 (the second moment about one axis of a rectangle's corners).
fn lever(rows: &[ContactConstraint], upper: usize, center: Vec3) -> (f32, f32) {
    let c = &rows[0];
    let up = if c.body_b == upper {
        c.normal
    } else {
        -c.normal
    };
    let n = rows.len() as f32;
    let centroid = rows.iter().map(|r| r.point).sum::<Vec3>() / n;
    let spread = rows
        .iter()
        .map(|r| (r.point - centroid).length_squared())
        .sum::<f32>()
        / (2.0 * n);
    ((center - centroid).dot(up).max(0.0), spread)
}

/// True when, after the impact phase, no contact can take any impulse in the hybrid method's
/// resting phase, which can then be skipped: so an island of one impact and no resting contact
/// costs one propagation pass and nothing else.
///
/// A row of the resting phase pushes only while `v_n + bias < 0`, and its bias is at least
/// `-max_push_out_speed` (a speculative row's `s/h` is positive). Between substeps only gravity
/// (with the bodies' extra accelerations, [`SolverBody::acceleration`]) changes `v_n`, by at
/// least `min(g_n, 0) dt` over the step. So a contact with no accumulated
/// impulse to warm-start and `v_n + min(g_n, 0) dt >= max_push_out_speed` stays inactive, and
/// if every contact does, no impulse is applied at all.
fn resting_phase_idle(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    config: &SolverConfig,
    gravity: Vec3,
    dt: f32,
) -> bool {
    contacts.iter().all(|c| {
        if c.normal_mass == 0.0 {
            return true;
        }
        // Each body's gravity with its extra acceleration, which can pull a contact apart
        // (a body with `GravityScale(0.0)` on the floor) or press it together harder.
        let g = |i: usize| bodies[i].acceleration(gravity);
        let gn = (g(c.body_b) - g(c.body_a)).dot(c.normal);
        c.normal_impulse == 0.0
            && c.normal_velocity(bodies) + gn.min(0.0) * dt >= config.max_push_out_speed
    })
}

/// Settings of [`manifold_sweep`].
#[derive(Clone, Copy, Debug)]
pub struct ManifoldSolve {
    /// The soft spring for penetrating points; `None` for the rigid relax pass.
    pub soft: Option<Softness>,
    /// `1/h`, 1/s.
    pub inv_h: f32,
    /// Largest push-out speed, m/s.
    pub max_push_out: f32,
    /// Skip speculative rows approaching faster than this, m/s (see [`soft_sweep`](super::soft_step::soft_sweep)).
    pub leave_impacts: Option<f32>,
    /// Most Gauss-Seidel iterations spent on one manifold per sweep.
    pub max_block_iterations: u32,
    /// A manifold's iterations stop once no row changes by more than this, m/s.
    pub tolerance: f32,
    /// `omega^2 / |g|`, 1/m: the soft contact's angular frequency squared over gravity's
    /// magnitude (infinite without gravity; the world's gravity, not counting the bodies' extra
    /// accelerations). A load-carrying manifold with friction gets soft
    /// rows only where this times its points' second moment is at least [`TILT_MARGIN`] times
    /// its lever (see [`manifold_sweep`]).
    pub tilt_stiffness: f32,
}

/// How much stiffer than its load's toppling moment the soft tilt of a load-carrying manifold
/// must be, for its points to be solved as soft rows (see [`manifold_sweep`]).
pub const TILT_MARGIN: f32 = 4.0;

/// One sweep of the hybrid method's resting solve: the soft step with each body pair's
/// manifold (`blocks`, contiguous ranges of `contacts` sharing one normal) solved as a block,
/// to convergence, before the next, and with only the manifold's mean penetration soft.
///
/// Why: a soft row per point lets an off-centre load tilt a face contact, since each corner
/// sinks in proportion to its share of the load. The contact normal turns with the tilted face,
/// so the load then pushes the body above sideways, further off centre: with frictionless
/// contacts this feedback grows exponentially at a rate of about `W / sqrt(k m)` (`W` the load,
/// `k` the contact's stiffness against tilting, `m` the mass pushed sideways). Point-by-point
/// Gauss-Seidel also adds a spurious tilt of its own, since the first corner solved takes more
/// than its share. Measured with Box2D's row-by-row soft step (`SolverMethod::SoftStep`): a
/// column of 10 cubes topples within 20 s and a light box is squeezed out from under a 100
/// times heavier one within a second. Solving the block removes the spurious tilt and the
/// compliance of a single manifold; the lag between manifolds is handled by their order (see
/// `shock_order`).
///
/// The manifold's rows therefore solve the regularised block problem
///
/// ```text
/// v_i' + b_i + c * sum_j(lambda_j') = 0   (lambda_i' >= 0, complementary),
/// c = K_mean / a2,  K_mean = 1^T A 1 / N^2,
/// ```
///
/// over its `N` penetrating points, with `A` the manifold's Delassus matrix (so `K_mean` is
/// the inverse effective mass of the manifold's centroid), `b_i = max(bias_rate s_i, -cap)` the
/// soft push-out, and `a2 = mass_scale / impulse_scale` Box2D's softness coefficient. Summed
/// over the points this is exactly Box2D's soft constraint for the manifold as a whole,
/// `v' + b + (K/a2) lambda' = 0`: the manifold sinks by the predictable
/// `W K_mean / (2 pi f)^2` under a load `W`. The tilt modes carry no regularisation, so they
/// are rigid: any load distribution is taken without tilting, and differences in penetration
/// are pushed out at the soft rate. With one point it is Box2D's soft row exactly. Speculative
/// points (`s > 0`) of a manifold none of whose points penetrates are rigid rows that may close
/// the gap, as in [`soft_sweep`](super::soft_step::soft_sweep); in a manifold that penetrates they are points of the same
/// soft plane, in the sum and with their gap `s/h` as bias, so that they close against the
/// plane as it sinks (the block's rows then change continuously as a point's separation
/// crosses zero). Why: held at its gap, a point a hair apart (a rounding's 1e-10 m at 1 mm)
/// is a hinge while the other points sink at the soft rate, and the body turns about it: a
/// 1 mm die landed on another turned 1e-2 rad in one step (the soft sink, 0.28 mm, is a
/// quarter of its size). The Gauss-Seidel update of row `i` is
///
/// ```text
/// delta_i = -(v_i + b_i + c * sum_j lambda_j) / (K_ii + c).
/// ```
///
/// Sweeps between manifolds stay Gauss-Seidel (one per call), except that consecutive blocks
/// supporting the same body are swept together until none changes by more than the
/// tolerance: a cube resting on two others (in a pyramid) otherwise takes its whole load on
/// whichever support is solved first, rocks, and, frictionless, pushes its supports apart (a
/// pyramid of base 10 spread 0.8 m in 20 s that way; 4.8 cm solved together). A block with a
/// [`Support`] holds that body by [`Block::hold`]: its terms in `A` and its response to the
/// block's impulses are scaled by `1 - hold` (left out entirely when it is held wholly).
/// With [`Block::load`] set, `K_mean` is replaced by `min(K_mean, 1 / load)`, so the manifold
/// sinks by `g / (2 pi f)^2` under the load it carries.
///
/// A manifold with friction is solved point by point instead: each penetrating point is
/// Box2D's soft row, `v_i' + b_i + c_i lambda_i' = 0` with `c_i = K_s / a2`, `K_s = N / load`
/// (its share of the load) or, where the block carries none, the row's own `K_ii`. The tilt is
/// then soft too, as stiff as the load it carries allows, and the manifold still sinks by
/// `g / (2 pi f)^2` under its load. Why: with a rigid tilt, a block stops at `tolerance` with a
/// residual tilt that becomes slip at the faces, and friction, warm-started from step to step,
/// stores it and feeds it back: a column of 20 cubes with friction 0.5 rocked in a growing
/// cone (27 cm in 20 s; 0.23 mm point by point). The rigid tilt exists to stop a tilted face
/// pushing a frictionless body sideways, which friction resists on its own.
///
/// A soft tilt must also hold its load up: tilted by `theta`, a manifold's rows push back with
/// a moment `W omega^2 <r^2> theta / g` (their load-scaled springs at their distances `r` from
/// the centroid), while the weight `W` it carries, its centre of mass a lever `l` above the
/// manifold, tips it by `W l theta`. Soft rows are used only where the first is at least
/// [`TILT_MARGIN`] times the second, `omega^2 <r^2> / g >= 4 l`; otherwise the block keeps its
/// rigid tilt. The soft sink `g / omega^2` (0.28 mm) is a fixed length, so this only tells
/// small bodies from large ones: a 1 m cube carrying a column of 20 has 90 times the moment it
/// needs, a 1 mm die under two more has 0.6 of it, and with soft rows a stack of three 1 mm dice
/// toppled within 10 steps.
pub fn manifold_sweep(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    blocks: &[Block],
    solve: &ManifoldSolve,
    settling: &mut Settling,
    rows: &mut Vec<BlockRow>,
) -> Sweep {
    settling.begin(bodies.len());
    let mut sweep = Sweep {
        largest: 0.0,
        settled: true,
    };
    let mut start = 0;
    while start < blocks.len() {
        // Consecutive blocks that support the same body are solved together, block after
        // block, until none changes by more than the tolerance: a body resting on several
        // supports takes its load consistently from all of them within the sweep.
        let upper = blocks[start].upper(contacts);
        let end = match upper {
            Some(_) => {
                start
                    + blocks[start..]
                        .iter()
                        .take_while(|b| b.upper(contacts) == upper)
                        .count()
            }
            None => start + 1,
        };
        let passes = if end - start > 1 {
            solve.max_block_iterations.max(1)
        } else {
            1
        };
        for pass in 0..passes {
            let mut largest = 0.0f32;
            for (k, block) in blocks.iter().enumerate().take(end).skip(start) {
                let group = &mut contacts[block.range.clone()];
                let (converged, first, changed) = solve_block(bodies, group, block, solve, rows);
                largest = largest.max(first);
                if pass == 0 {
                    sweep.largest = sweep.largest.max(first);
                    sweep.settled &= converged;
                } else if changed {
                    // A later pass re-solved a block after its neighbours: the marks below
                    // no longer order the changes, so the sweep cannot count as settled.
                    sweep.settled = false;
                }
                if changed {
                    settling.changed(bodies, group[0].body_a, group[0].body_b, k);
                }
            }
            if largest <= solve.tolerance {
                break;
            }
        }
        for block in &blocks[start..end] {
            for c in contacts[block.range.clone()]
                .iter_mut()
                .filter(|c| c.friction > 0.0)
            {
                settling.friction_changed |= solve_friction(bodies, c);
            }
        }
        start = end;
    }
    sweep.settled &= !settling.friction_changed
        && blocks.iter().enumerate().all(|(k, block)| {
            let c = &contacts[block.range.start];
            settling.undisturbed(c.body_a, c.body_b, k)
        });
    sweep
}

/// One row of a manifold block: `(bias, soft)`, or `None` when the row takes no part.
pub type BlockRow = Option<(f32, bool)>;

/// Which body of a manifold block is its support, held by [`Block::hold`] while the block is
/// solved (see `shock_order` and `support_holds`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Support {
    /// Neither: both bodies respond (the usual two-body solve).
    Neither,
    /// Body A supports body B.
    A,
    /// Body B supports body A.
    B,
}

/// One manifold of the hybrid method's resting solve: its contacts, its support, how firmly
/// that support is held, and the mass it carries.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    /// The manifold's range in the contact slice.
    pub range: Range<usize>,
    /// The body held (wholly or partly) while the block is solved.
    pub support: Support,
    /// The fraction of the support's response to this block's impulse that the support's own
    /// supports take, in `[0, 1]`: the support responds in the block's solve with its inverse
    /// mass and inertia scaled by `1 - hold`. 1 for a static or kinematic support and for a body
    /// resting squarely on supports that are themselves held; 0 for a body free to move along
    /// the block's normal (see `support_holds`).
    pub hold: f32,
    /// The support's linear response per unit impulse along the contact normal, in place of
    /// the normal itself (scaled by its inverse mass): the part of a push that its own supports
    /// do not take, `n - s P(n)` in `support_holds`' terms. Its component along the normal is
    /// `1 - hold`. Unused without a support.
    pub push: Vec3,
    /// The mass this manifold carries, kg: its supported body and that body's share of
    /// everything it carries in turn (see `shock_order`). 0 for a manifold
    /// with no support, whose stiffness is then set by its own effective mass.
    pub load: f32,
    /// How high the centre of mass of what it carries stands above its centroid, along its
    /// normal, m (see `carried_loads`): the arm through which a tilt of
    /// the manifold moves that weight sideways. 0 with no support.
    pub lever: f32,
    /// The mean square distance of its points from their centroid over two, m^2 (the second
    /// moment about one axis of a rectangle's corners), set with [`Block::lever`].
    pub spread: f32,
    /// Some point of it can push and is within the touch distance at the start of the step:
    /// only touching manifolds make levels, support, share loads (see `shock_order`).
    pub touching: bool,
}

impl Block {
    /// (the body this block supports, its support), if it has a support.
    pub fn pair(&self, contacts: &[ContactConstraint]) -> Option<(usize, usize)> {
        let c = &contacts[self.range.start];
        match self.support {
            Support::A => Some((c.body_b, c.body_a)),
            Support::B => Some((c.body_a, c.body_b)),
            Support::Neither => None,
        }
    }

    /// The body this block supports, if it has a support.
    pub fn upper(&self, contacts: &[ContactConstraint]) -> Option<usize> {
        self.pair(contacts).map(|(upper, _)| upper)
    }

    /// How each body responds to the block's impulse along `normal`: per body, its linear
    /// direction (the normal for a free body, [`Block::push`] for the support) and the factor on
    /// its angular response (1 for a free body, `1 - hold` for the support).
    pub fn response(&self, normal: Vec3) -> Response {
        let free = Side {
            direction: None,
            along_normal: 1.0,
            angular: 1.0,
        };
        let held = if self.hold > 0.0 {
            Side {
                direction: Some(self.push),
                along_normal: normal.dot(self.push),
                angular: 1.0 - self.hold.min(1.0),
            }
        } else {
            free
        };
        let (a, b) = match self.support {
            Support::Neither => (free, free),
            Support::A => (held, free),
            Support::B => (free, held),
        };
        Response { a, b }
    }
}

/// How one body of a block responds to the block's impulse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Side {
    /// Direction of its velocity change per unit impulse, before its inverse mass; `None`: the
    /// row's own normal (a free body).
    pub direction: Option<Vec3>,
    /// `direction . n`: 1 for a free body (exactly), `1 - hold` for a held support.
    pub along_normal: f32,
    /// Factor on its angular response.
    pub angular: f32,
}

/// How the two bodies of a block respond to its impulse (see [`Block::response`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Response {
    /// Body A.
    pub a: Side,
    /// Body B.
    pub b: Side,
}

/// Applies `+impulse` to B and `-impulse` to A along each body's response direction, with its
/// angular response scaled by its factor.
#[inline]
fn apply_response(c: &ContactConstraint, bodies: &mut [SolverBody], impulse: f32, r: &Response) {
    let (a, b) = super::body::pair_mut(bodies, c.body_a, c.body_b);
    let (dir_a, dir_b) = (
        r.a.direction.unwrap_or(c.normal),
        r.b.direction.unwrap_or(c.normal),
    );
    apply_row_impulse(
        &mut a.linear_velocity,
        &mut a.angular_velocity,
        a.inverse_mass,
        (dir_a != Vec3::ZERO).then(|| -(impulse * dir_a)),
        (c.angular && r.a.angular > 0.0).then(|| (-(r.a.angular * impulse), c.ang_a)),
    );
    apply_row_impulse(
        &mut b.linear_velocity,
        &mut b.angular_velocity,
        b.inverse_mass,
        (dir_b != Vec3::ZERO).then(|| impulse * dir_b),
        (c.angular && r.b.angular > 0.0).then_some((r.b.angular * impulse, c.ang_b)),
    );
}

/// Whether a manifold's soft tilt holds its load up with [`TILT_MARGIN`] to spare (see
/// [`manifold_sweep`]): `omega^2 <r^2> / g >= TILT_MARGIN * lever`, `<r^2>` its
/// [`Block::spread`]. A manifold that carries no load has its own effective mass's stiffness,
/// Box2D's soft row, and always stands.
fn soft_tilt_stands(block: &Block, solve: &ManifoldSolve) -> bool {
    if block.load <= 0.0 || block.lever <= 0.0 {
        return true;
    }
    solve.tilt_stiffness * block.spread >= TILT_MARGIN * block.lever
}

/// Solves one manifold block to convergence (see [`manifold_sweep`]). Returns whether it
/// converged exactly, the largest change of its first pass, and whether any velocity changed.
fn solve_block(
    bodies: &mut [SolverBody],
    group: &mut [ContactConstraint],
    block: &Block,
    solve: &ManifoldSolve,
    rows: &mut Vec<BlockRow>,
) -> (bool, f32, bool) {
    // The support responds along its free direction, its rotation scaled by `1 - hold`.
    let response = block.response(group[0].normal);
    let (fa, fb) = (response.a.angular, response.b.angular);
    let linear_a = response.a.along_normal * bodies[group[0].body_a].inverse_mass;
    let linear_b = response.b.along_normal * bodies[group[0].body_b].inverse_mass;
    let linear = linear_a + linear_b;
    // `K_ii` of row `c` with the support's response scaled.
    let diagonal = |c: &ContactConstraint| {
        if c.angular {
            row_inverse_mass(
                [linear_a, linear_b],
                [fa * c.rn_a.dot(c.ang_a), fb * c.rn_b.dot(c.ang_b)],
            )
        } else {
            linear
        }
    };
    rows.clear();
    // Sums over the soft points: count, r x n and I^-1 (r x n) of each body, and the impulse.
    let mut count = 0u32;
    let [mut rn_a, mut ang_a, mut rn_b, mut ang_b] = [Vec3::ZERO; 4];
    let mut total = 0.0f32;
    for c in group.iter() {
        if c.normal_mass == 0.0 {
            rows.push(None);
            continue;
        }
        let s = c.current_separation(bodies);
        if solve
            .leave_impacts
            .is_some_and(|t| s > 0.0 && c.normal_velocity(bodies) < -t)
        {
            rows.push(None);
            continue;
        }
        let row = if s > 0.0 {
            (s * solve.inv_h, false)
        } else if let Some(soft) = solve.soft {
            (
                (soft.bias_rate * s).max(-solve.max_push_out),
                soft.impulse_scale > 0.0,
            )
        } else {
            (0.0, false)
        };
        if row.1 {
            count += 1;
            rn_a += c.rn_a;
            ang_a += c.ang_a;
            rn_b += c.rn_b;
            ang_b += c.ang_b;
            total += c.normal_impulse;
        }
        rows.push(Some(row));
    }
    // A manifold that penetrates is one soft plane: its speculative points (`s > 0`) are soft
    // rows too, with their gap `s/h` as bias, so that they close against the plane as it
    // sinks. See `manifold_sweep`.
    if count > 0 {
        for (c, row) in group.iter().zip(rows.iter_mut()) {
            if let Some((_, soft)) = row
                && !*soft
            {
                *soft = true;
                total += c.normal_impulse;
            }
        }
    }
    // With friction, each penetrating point is its own soft row, Box2D's, with the stiffness of
    // its share of the load the block carries (`load / N`), or of its own effective mass where
    // the block carries none: the tilt is soft, and the manifold still sinks by `g / (2 pi f)^2`
    // under its load. See `manifold_sweep`.
    let pointwise = group[0].friction > 0.0 && soft_tilt_stands(block, solve);
    let share = if block.load > 0.0 && count > 0 {
        count as f32 / block.load
    } else {
        0.0
    };
    let softness = solve
        .soft
        .map_or(0.0, |soft| soft.impulse_scale / soft.mass_scale);
    // c = K_mean / a2, K_mean = 1^T A 1 / N^2 (the points share the normal, so the linear part
    // of 1^T A 1 is N^2 (1/m_A + 1/m_B)): the `K` of the manifold's centroid, from the rows'
    // `r x n` and `I^-1 (r x n)` terms summed over the points (each row's own `K` is
    // `row_inverse_mass`'s, in `diagonal` above).
    let coupling = match (solve.soft, count) {
        // Point by point, the rows do not use it.
        _ if pointwise => 0.0,
        (Some(soft), n) if n > 0 => {
            let n2 = (n * n) as f32;
            let sum = row_inverse_mass(
                [n2 * linear_a, n2 * linear_b],
                [fa * rn_a.dot(ang_a), fb * rn_b.dot(ang_b)],
            );
            let mut k = sum / n2;
            if block.load > 0.0 {
                k = k.min(1.0 / block.load);
            }
            k * soft.impulse_scale / soft.mass_scale
        }
        _ => 0.0,
    };

    let mut first = 0.0f32;
    let mut changed = false;
    // Every row of the block touches the same two bodies, so a row stays satisfied (see
    // [`Settling`]) unless a later row changes something: the pass has converged when no row
    // after the first taking part changed.
    let first_row = rows.iter().position(Option::is_some);
    for iteration in 0..solve.max_block_iterations.max(1) {
        let mut last_changed = None;
        let mut largest = 0.0f32;
        for (i, (c, row)) in group.iter_mut().zip(rows.iter()).enumerate() {
            let Some((bias, soft)) = *row else { continue };
            let k = diagonal(c);
            if k <= 0.0 {
                continue;
            }
            let vn = c.normal_velocity(bodies);
            let (residual, diagonal) = if soft && pointwise {
                let own = if share > 0.0 { share } else { k } * softness;
                (vn + bias + own * c.normal_impulse, k + own)
            } else if soft {
                (vn + bias + coupling * total, k + coupling)
            } else {
                (vn + bias, k)
            };
            let new = (c.normal_impulse - residual / diagonal).max(0.0);
            let delta = new - c.normal_impulse;
            if delta != 0.0 {
                c.normal_impulse = new;
                apply_response(c, bodies, delta, &response);
                if soft {
                    total += delta;
                }
                largest = largest.max(delta.abs() * k);
                last_changed = Some(i);
                changed = true;
            }
            c.max_normal_impulse = c.max_normal_impulse.max(new);
        }
        if iteration == 0 {
            first = largest;
        }
        if last_changed <= first_row {
            return (true, first, changed);
        }
        if largest <= solve.tolerance {
            break;
        }
    }
    (false, first, changed)
}

#[cfg(test)]
mod tests {
    use super::super::contact::prepare_contacts;
    use super::super::soft_step::soft_sweep;
    use super::*;
    use bevy::math::{BVec3, Mat3, Quat};

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
        let level = levels(&bodies, pairs.iter().copied());
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

    /// A column (ground 0, then cubes of 1, 2 and 3 kg, listed top down): blocks come out
    /// ground up, each supported by the body below and carrying the mass above it: 6, 5, 3 kg.
    #[test]
    fn column_loads_are_the_mass_above() {
        let bodies = [
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            cube(Motion::Dynamic, 1.0),
            cube(Motion::Dynamic, 2.0),
            cube(Motion::Dynamic, 3.0),
        ];
        let (mut contacts, ranges) = manifolds(&[(2, 3), (1, 2), (0, 1)]);
        prepare_contacts(&bodies, &mut contacts);
        let blocks = shock_order(&bodies, &contacts, &ranges, 0.005);
        let order: Vec<(usize, Support, f32)> = blocks
            .iter()
            .map(|b| (b.range.start, b.support, b.load))
            .collect();
        assert_eq!(
            order,
            [
                (2, Support::A, 6.0),
                (1, Support::A, 5.0),
                (0, Support::A, 3.0)
            ]
        );
    }

    /// A small pyramid: cubes 1 and 2 (1 kg) on the ground, cube 3 (2 kg) on both, and cube 4
    /// (1 kg) touching cube 1 from the side at the same level. Cube 3's load is shared equally
    /// (1 kg per support), each ground manifold carries its cube plus that share (2 kg), and
    /// the side contact has no support and no load. Cube 3's two manifolds are adjacent.
    #[test]
    fn shared_loads_split_between_supports() {
        let bodies = [
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            cube(Motion::Dynamic, 1.0),
            cube(Motion::Dynamic, 1.0),
            cube(Motion::Dynamic, 2.0),
            cube(Motion::Dynamic, 1.0),
        ];
        let (mut contacts, ranges) = manifolds(&[(1, 3), (0, 1), (4, 1), (2, 3), (0, 2), (0, 4)]);
        prepare_contacts(&bodies, &mut contacts);
        let blocks = shock_order(&bodies, &contacts, &ranges, 0.005);
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
        let hit =
            ContactConstraint::new(1, 2, Vec3::new(0.0, 0.5, 0.0) + 0.5 * n, n, 0.0, 0.0, 0.0);
        let mut contacts = [floor, hit];
        prepare_contacts(&bodies, &mut contacts);
        let blocks = shock_order(&bodies, &contacts, &[0..1, 1..2], 0.005);
        let struck = blocks.iter().find(|b| b.range == (1..2)).unwrap();
        let c2 = theta.cos().powi(2);
        assert!((struck.hold - c2).abs() < 1e-6, "{}", struck.hold);
        assert!((struck.push - (n - theta.cos() * Vec3::Y)).length() < 1e-6);
        // A column of two: held wholly.
        let column = ContactConstraint::new(1, 2, Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 0.0, 0.0, 0.0);
        let mut contacts = [floor, column];
        prepare_contacts(&bodies, &mut contacts);
        let blocks = shock_order(&bodies, &contacts, &[0..1, 1..2], 0.005);
        let top = blocks.iter().find(|b| b.range == (1..2)).unwrap();
        assert!((top.hold - 1.0).abs() < 1e-6 && top.push.length() < 1e-6);
        // The lower ball only speculatively on the ground (a 1 cm gap): not held.
        let gap = ContactConstraint::new(0, 1, Vec3::ZERO, Vec3::Y, 0.01, 0.0, 0.0);
        let mut contacts = [gap, column];
        prepare_contacts(&bodies, &mut contacts);
        let blocks = shock_order(&bodies, &contacts, &[0..1, 1..2], 0.005);
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
        use bevy::math::{BVec3, Mat3, Quat};
        let bodies = vec![
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            SolverBody::new(Motion::Dynamic, Vec3::new(0.0, 0.49, 0.0), Quat::IDENTITY)
                .with_mass(
                    1.0,
                    Mat3::from_diagonal(Vec3::splat(6.0)),
                    true,
                    BVec3::FALSE,
                )
                .with_velocity(Vec3::new(0.0, -0.5, 0.0), Vec3::new(0.3, 0.0, -0.2)),
        ];
        let mut contacts: Vec<_> = corners
            .iter()
            .map(|&p| ContactConstraint::new(0, 1, p, Vec3::Y, -0.01, 0.0, 0.0))
            .collect();
        prepare_contacts(&bodies, &mut contacts);
        (bodies, contacts)
    }

    /// One `manifold_sweep` over `contacts` as a single two-body block (no support, no load) at
    /// `h = 1/240` s with Box2D's 3 m/s push-out cap, iterated to `tolerance`.
    fn sweep_one_block(
        bodies: &mut [SolverBody],
        contacts: &mut [ContactConstraint],
        soft: Softness,
        tolerance: f32,
    ) -> Sweep {
        let solve = ManifoldSolve {
            soft: Some(soft),
            inv_h: 240.0,
            max_push_out: 3.0,
            leave_impacts: None,
            max_block_iterations: 64,
            tolerance,
            tilt_stiffness: f32::INFINITY,
        };
        let blocks = [Block {
            range: 0..contacts.len(),
            support: Support::Neither,
            hold: 0.0,
            push: Vec3::ZERO,
            load: 0.0,
            lever: 0.0,
            spread: 0.0,
            touching: true,
        }];
        manifold_sweep(
            bodies,
            contacts,
            &blocks,
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

    /// A face manifold takes any load distribution without tilting: four corners of a spinning
    /// box, penetrating equally, end with no relative velocity between the corners (the tilt
    /// modes are rigid; 1e-4 m/s is the block tolerance), while the mean obeys the soft law
    /// `v' + b + c sum(lambda) = 0` of the manifold as a whole.
    #[test]
    fn manifold_block_is_rigid_in_tilt() {
        let soft = Softness::new(30.0, 10.0, 1.0 / 240.0);
        let corners = [(0.5, 0.5), (0.5, -0.5), (-0.5, 0.5), (-0.5, -0.5)]
            .map(|(x, z)| Vec3::new(x, -0.01, z));
        let (mut bodies, mut contacts) = box_on_ground(&corners);
        sweep_one_block(&mut bodies, &mut contacts, soft, 1e-7);
        let v: Vec<f32> = contacts
            .iter()
            .map(|c| c.normal_velocity(&bodies))
            .collect();
        for vi in &v {
            assert!((vi - v[0]).abs() <= 1e-4, "{v:?}");
        }
        // Mean law: v' + b + (K/a2) sum(lambda) = 0 with K = 1/m for the centroid under the
        // centre of mass; b = bias_rate s.
        let total: f32 = contacts.iter().map(|c| c.normal_impulse).sum();
        let a2 = soft.mass_scale / soft.impulse_scale;
        let residual = v[0] + soft.bias_rate * -0.01 + total / a2;
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
        use bevy::math::{BVec3, Mat3, Quat};
        let soft = Softness::new(30.0, 10.0, 1.0 / 240.0);
        let mut bodies = vec![
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            SolverBody::new(Motion::Dynamic, Vec3::new(0.0, 0.5, 0.0), Quat::IDENTITY)
                .with_mass(
                    1.0,
                    Mat3::from_diagonal(Vec3::splat(6.0)),
                    true,
                    BVec3::FALSE,
                )
                .with_velocity(Vec3::new(0.0, -9.81 / 240.0, 0.0), Vec3::ZERO),
        ];
        let gap = 1e-6;
        let corners = [
            (0.5, 0.5, gap),
            (0.5, -0.5, 0.0),
            (-0.5, 0.5, 0.0),
            (-0.5, -0.5, 0.0),
        ];
        let mut contacts: Vec<_> = corners
            .into_iter()
            .map(|(x, z, s)| {
                ContactConstraint::new(0, 1, Vec3::new(x, 0.0, z), Vec3::Y, s, 0.0, 0.0)
            })
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
}
