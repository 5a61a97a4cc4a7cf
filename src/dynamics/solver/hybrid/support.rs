//! How far a manifold's support really is held: its own supports' contacts as a cone of
//! directions it cannot move in (see `support_holds`).

use super::*;
use crate::dynamics::solver::refill;

/// A touching manifold that supports a body, as [`support_holds`] sees it from that body.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct SupportEntry {
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
    /// The manifold's friction coefficient where its support is fixed (static or kinematic);
    /// `None` where it is dynamic (see [`held_by_friction`]).
    grip: Option<f32>,
}

/// Most support manifolds of one body that [`support_holds`] looks at; a body resting on more
/// (a sphere wedged among many) is treated as held by the first ones only, which can only
/// under-estimate the hold.
pub(super) const MAX_SUPPORTS: usize = 8;

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
///
/// The blocks marked `released` will be solved two-body (`release_frictional_groups`): their
/// holds are computed only where a held block above depends on them (through the strength of
/// their support entries), and are otherwise left at 0. Why: in a settled pile with friction
/// nearly every block is released, and the cone projections of their holds were a third of
/// the shock order's cost (0.23 ms a step for 2,000 spheres).
pub(super) fn support_holds(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    blocks: &mut [Block],
    touch: f32,
    released: &[bool],
    scratch: &mut HoldScratch,
) {
    // Long on purpose: the three rules of the doc above, applied in order over one shared buffer
    // of support entries per body; split, each part would take that buffer and its index arrays.
    let touching = |c: &ContactConstraint| c.separation <= touch && c.normal_mass > 0.0;
    // The support entries of each body, in one buffer: body `i` has at most `room[i]` of them,
    // at `start[i]..start[i] + count[i]`.
    let HoldScratch {
        start,
        needed,
        read,
        count,
        entries,
    } = scratch;
    refill(start, bodies.len() + 1, 0);
    for block in blocks.iter() {
        if let Some(upper) = block.upper(contacts) {
            start[upper + 1] = (start[upper + 1] + 1).min(MAX_SUPPORTS as u32);
        }
    }
    for i in 0..bodies.len() {
        start[i + 1] += start[i];
    }
    // Which holds are needed, walking down from the top: a block that stays held, and every
    // block that supports a body whose entries a needed block reads. A block reads the
    // entries of its support only after the blocks before it have set them, so a block is
    // needed by the needed readers after it.
    refill(needed, blocks.len(), false);
    refill(read, bodies.len(), false);
    for (k, block) in blocks.iter().enumerate().rev() {
        let Some((upper, lower)) = block.pair(contacts) else {
            continue;
        };
        if !released[k] || read[upper] {
            needed[k] = true;
            read[lower] |= bodies[lower].motion == Motion::Dynamic;
        }
    }
    refill(count, bodies.len(), 0);
    refill(
        entries,
        start[bodies.len()] as usize,
        SupportEntry::default(),
    );
    for (block, _) in blocks.iter_mut().zip(needed.iter()).filter(|(_, n)| **n) {
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
            let (hold, push) = hold_of(below, normal, centroid, turns);
            block.gripped = held_by_friction(below, normal, centroid, (hold, turns));
            (hold, push)
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
        entry.grip = lower_fixed.then_some(rows[0].friction);
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

/// [`support_holds`]' buffers, kept between steps (their contents rebuilt at every call).
#[derive(Clone, Debug, Default)]
pub(super) struct HoldScratch {
    /// Each body's first support entry in `entries`.
    start: Vec<u32>,
    /// Each block's hold is needed.
    needed: Vec<bool>,
    /// Each body's entries are read by a needed block.
    read: Vec<bool>,
    /// Each body's entries set so far.
    count: Vec<u32>,
    /// The support entries, body by body.
    entries: Vec<SupportEntry>,
}

/// The hold of a support with the given support manifolds and footprint, for a push along `-n`
/// through `point` (see [`support_holds`]), and the support's free response direction
/// `n - s P(n)` (whose component along `n` is `1 - hold`); `turns`: the push has a lever arm
/// on the support.
pub(super) fn hold_of(entries: &[SupportEntry], n: Vec3, point: Vec3, turns: bool) -> (f32, Vec3) {
    if entries.is_empty() {
        return (0.0, n);
    }
    if turns && !crosses_footprint(entries, point, n) {
        return (0.0, n);
    }
    // At most `MAX_SUPPORTS` entries (`support_holds` caps each body's): the normals on the
    // stack, since a heap vector here was nearly every allocation of a settled pile's step
    // (1,180 of 1,320 a step for 1,000 spheres).
    debug_assert!(entries.len() <= MAX_SUPPORTS);
    let mut normals = [Vec3::ZERO; MAX_SUPPORTS];
    let k = entries.len().min(MAX_SUPPORTS);
    for (normal, e) in normals.iter_mut().zip(entries) {
        *normal = e.normal;
    }
    let (projection, used) = cone_projection(n, &normals[..k]);
    let strength = entries
        .iter()
        .enumerate()
        .filter(|(i, _)| used & (1 << i) != 0)
        .map(|(_, e)| e.strength)
        .fold(1.0f32, f32::min);
    let hold = (projection.dot(n) * strength).clamp(0.0, 1.0);
    (hold, n - strength * projection)
}

/// How far inside its friction cone a push must lie for friction to hold a support (see
/// [`held_by_friction`]): the cone of `mu / GRIP_MARGIN`.
///
/// Why a margin: the friction rows that hold the support are solved once a substep, and the
/// load passed on that raises their bound is the last substep's; a push near the edge of the
/// cone is held only as they converge. In the mixed pour of 1,000 (density 1000, friction
/// 0.5, `tests/stress.rs`' `mixed_1000_friction`), with the full cone (26.6 degrees) supports
/// pressed up to 26 degrees off their floor's normal (holds down to 0.80) passed their loads
/// on, and a body landing among them was thrown back up: the fastest body 11.1 m/s, against
/// 7.37 m/s without partial holds. Passing only holds of 0.99 and more, or inside the cone of
/// half the coefficient (14 degrees at friction 0.5), a quarter or an eighth, it is 7.37 m/s,
/// the same run bit for bit.
pub const GRIP_MARGIN: f32 = 2.0;

/// Whether friction holds what the hold `hold` of a support leaves free of a push along `-n`
/// through `point` (see [`Block::gripped`]): the support rests on fixed bodies only (its
/// `entries`), each manifold's friction coefficient `mu` stops the push's part off the cone of
/// their normals with [`GRIP_MARGIN`] to spare, `mu^2 hold >= GRIP_MARGIN^2 (1 - hold)` (with
/// fixed supports, `hold = |P(n)|^2`, so this is `GRIP_MARGIN |n - P(n)| <= mu |P(n)|`: the
/// push lies inside the friction cone of `mu / GRIP_MARGIN`), and the push's line crosses the
/// support's footprint, so that the push cannot tip or roll it: a ball or a capsule, whose
/// footprint is a point or a line, rolls under any push off its normals. `(hold, turns)` as
/// [`hold_of`] took and gave them: where the push `turns` the support, `hold_of` has crossed
/// the footprint already (the hold is 0 where it does not), and it is not crossed again.
pub(super) fn held_by_friction(
    entries: &[SupportEntry],
    n: Vec3,
    point: Vec3,
    (hold, turns): (f32, bool),
) -> bool {
    if hold <= 0.0
        || entries.is_empty()
        || !entries.iter().all(|e| {
            e.grip
                .is_some_and(|mu| mu * mu * hold >= GRIP_MARGIN * GRIP_MARGIN * (1.0 - hold))
        })
    {
        return false;
    }
    turns || crosses_footprint(entries, point, n)
}

/// Whether the line through `point` along `n` crosses the footprint of a support's support
/// manifolds `entries` (their points, seen along their mean normal; see
/// [`line_meets_footprint`]): a push along that line cannot tip the support.
fn crosses_footprint(entries: &[SupportEntry], point: Vec3, n: Vec3) -> bool {
    let axis = entries
        .iter()
        .map(|e| e.normal)
        .sum::<Vec3>()
        .normalize_or_zero();
    let footprint = entries
        .iter()
        .flat_map(|e| e.footprint[..e.points as usize].iter().copied());
    axis != Vec3::ZERO && line_meets_footprint(footprint, point, n, axis)
}

/// Whether the line through `point` along `n` crosses the convex hull of `footprint`, all
/// projected on the plane normal to `axis`: the hull is covered by the triangles of its points,
/// so the test is "inside some triangle" (at most `MAX_SUPPORTS` manifolds of 4 points).
pub(super) fn line_meets_footprint(
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
pub(super) fn cone_projection(n: Vec3, generators: &[Vec3]) -> (Vec3, u32) {
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
