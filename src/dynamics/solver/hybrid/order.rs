//! The hybrid's shock order: the manifolds as blocks from the ground up (levels, supports
//! held, the contacts laid out block by block).

use super::*;
use crate::dynamics::solver::refill;
use crate::dynamics::solver::rows::CompressedRows;

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
/// A block with friction whose support is held wholly ([`Block::passes_on`]) is the exception:
/// its support takes none of the block's normal impulse, which is carried down the chain to
/// the friction bounds beneath instead (see [`held_warm_start`]: a light support handed the
/// load of a heavy body a substep late was launched by it).
///
/// Without a consistent partition of `contacts` into `manifolds` (a caller of [`step`](crate::dynamics::solver::step) may pass
/// none, or ranges that mix body pairs), each contact is its own block. The blocks are written into `blocks` (its earlier
/// contents dropped, its memory kept); `scratch` holds the other buffers.
pub(super) fn shock_order(
    blocks: &mut Vec<Block>,
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    manifolds: &[Range<usize>],
    touch: f32,
    scratch: &mut OrderScratch,
) {
    let OrderScratch {
        singles,
        touching,
        ends,
        levels,
        sort,
        supports,
        released,
        carrying,
        on_released,
        holds,
        loads,
    } = scratch;
    // A block's solve reads and writes its two bodies once for all its rows (see
    // `PairVelocities`): each range must join one pair.
    let pair = |c: &ContactConstraint| (c.body_a, c.body_b);
    let covered = manifolds.iter().map(|r| r.len()).sum::<usize>() == contacts.len()
        && manifolds.iter().all(|r| {
            r.end <= contacts.len()
                && !r.is_empty()
                && contacts[r.clone()]
                    .iter()
                    .all(|c| pair(c) == pair(&contacts[r.start]))
        });
    let ranges: &[Range<usize>] = if covered {
        manifolds
    } else {
        singles.clear();
        singles.extend((0..contacts.len()).map(|i| i..i + 1));
        singles
    };
    // Only touching manifolds (a point within `touch`) make levels: a speculative contact is no
    // support. (With it, a die resting on another had the level of the lower die: at 1 mm the
    // step's fall `g dt^2`, 2.7 mm at 60 Hz, reaches the ground through the lower die, and the
    // pair of dice was then solved two-body, with no support held and no load carried.)
    touching.clear();
    touching.extend(ranges.iter().map(|r| touches(&contacts[r.clone()], touch)));
    // Each manifold's bodies, read once: the passes below look them up out of order, and a
    // contact row is large.
    ends.clear();
    ends.extend(
        ranges
            .iter()
            .map(|r| (contacts[r.start].body_a, contacts[r.start].body_b)),
    );
    let level = levels.compute(
        bodies,
        ends.iter()
            .zip(touching.iter())
            .filter(|(_, t)| **t)
            .map(|(&ends, _)| ends),
    );
    let support = |k: usize| {
        let (a, b) = ends[k];
        match level[a].cmp(&level[b]) {
            std::cmp::Ordering::Less => Support::A,
            std::cmp::Ordering::Greater => Support::B,
            std::cmp::Ordering::Equal => Support::Neither,
        }
    };
    // Sorted by (lower level, supported body), ties in manifold order.
    let lower = |k: usize| level[ends[k].0].min(level[ends[k].1]);
    let upper = |k: usize| match support(k) {
        Support::A => Some(ends[k].1),
        Support::B => Some(ends[k].0),
        Support::Neither => None,
    };
    let order = sort.sorted_by_level(ranges.len(), bodies.len(), lower, upper);
    blocks.clear();
    blocks.extend(order.iter().map(|&k| Block {
        range: ranges[k as usize].clone(),
        support: support(k as usize),
        hold: 0.0,
        push: Vec3::ZERO,
        load: 0.0,
        lever: 0.0,
        spread: 0.0,
        touching: touching[k as usize],
        carries_released: false,
        passes_on: false,
        gripped: false,
    }));
    // Which blocks are released is known before the holds: `support_holds` then skips the
    // holds that no held block depends on.
    frictional_groups(bodies.len(), contacts, blocks, supports, released);
    support_holds(bodies, contacts, blocks, touch, released, holds);
    mark_carrying_released(bodies.len(), contacts, blocks, released, carrying);
    mark_passing_on(bodies, contacts, blocks, released, on_released);
    release_frictional_groups(blocks, released);
    carried_loads(bodies, contacts, blocks, loads);
}

/// [`shock_order`]'s buffers, kept between steps (in the hybrid's scratch): their contents
/// are rebuilt at every call; only their memory is reused, so a steady step allocates nothing.
#[derive(Clone, Debug, Default)]
pub(super) struct OrderScratch {
    /// One single-contact range per contact, when the manifolds do not cover the contacts.
    singles: Vec<Range<usize>>,
    /// Each manifold touches (see [`touches`]).
    touching: Vec<bool>,
    /// Each manifold's two bodies.
    ends: Vec<(usize, usize)>,
    /// The bodies' levels.
    levels: Levels,
    /// The manifolds' order.
    sort: LevelSort,
    /// Each body's touching supports and whether any has friction ([`frictional_groups`]).
    supports: Vec<(u32, bool)>,
    /// Each block is released ([`release_frictional_groups`]).
    released: Vec<bool>,
    /// Each body carries a released block ([`mark_carrying_released`]).
    carrying: Vec<bool>,
    /// Each body rests on a released block ([`mark_passing_on`]).
    on_released: Vec<bool>,
    /// [`support_holds`]' buffers.
    holds: HoldScratch,
    /// [`carried_loads`]' buffers.
    loads: LoadScratch,
}

/// Two stable counting sorts' buffers: see [`LevelSort::sorted_by_level`].
#[derive(Clone, Debug, Default)]
pub(super) struct LevelSort {
    /// Each bucket's start.
    start: Vec<u32>,
    /// The indices sorted by supported body.
    by_upper: Vec<u32>,
    /// The indices sorted by level, then supported body.
    order: Vec<u32>,
}

impl LevelSort {
    /// The indices `0..count` of manifolds sorted by (`lower(k)`, `upper(k)`), no support
    /// (`None`) after every body, ties in index order: the order of `sort_unstable` on the
    /// keys `(lower, upper, k)`, made by two stable counting sorts (by supported body, then by
    /// level). Why: a comparison sort of the keys was a third of the shock order's cost in a
    /// settled pile (0.2 ms a step for 2,000 spheres); each counting sort is one pass over the
    /// manifolds and one over the bodies. A level is at most `bodies - 1` or `u32::MAX`
    /// (unreached), so `bodies + 1` buckets keep both keys in order.
    pub(super) fn sorted_by_level(
        &mut self,
        count: usize,
        bodies: usize,
        lower: impl Fn(usize) -> u32,
        upper: impl Fn(usize) -> Option<usize>,
    ) -> &[u32] {
        let LevelSort {
            start,
            by_upper,
            order,
        } = self;
        counting_sort(0..count as u32, bodies + 1, start, by_upper, |k| {
            upper(k as usize).unwrap_or(bodies)
        });
        counting_sort(by_upper.iter().copied(), bodies + 1, start, order, |k| {
            (lower(k as usize) as usize).min(bodies)
        });
        order
    }
}

/// `items` stably sorted by `bucket` (each below `buckets`) into `sorted`; `start` is a
/// buffer (both buffers' earlier contents dropped).
fn counting_sort(
    items: impl Iterator<Item = u32> + Clone,
    buckets: usize,
    start: &mut Vec<u32>,
    sorted: &mut Vec<u32>,
    bucket: impl Fn(u32) -> usize,
) {
    refill(start, buckets + 1, 0);
    for k in items.clone() {
        start[bucket(k) + 1] += 1;
    }
    for i in 0..buckets {
        start[i + 1] += start[i];
    }
    refill(sorted, start[buckets] as usize, 0);
    for k in items {
        let b = bucket(k);
        sorted[start[b] as usize] = k;
        start[b] += 1;
    }
}

/// Each body's level (see [`Levels::compute`]) and the buffers of its search.
#[derive(Clone, Debug, Default)]
pub(super) struct Levels {
    /// Each body's level.
    level: Vec<u32>,
    /// Each body's neighbours through the pairs.
    neighbours: CompressedRows,
    /// The search's queue.
    queue: Vec<u32>,
}

impl Levels {
    /// Each body's level: 0 for a static or kinematic body, one more than its lowest
    /// neighbour through `pairs` for a dynamic one (`u32::MAX` if no chain of pairs reaches a
    /// fixed body). A breadth-first search from the fixed bodies over the pairs, in a
    /// compressed adjacency list: each pair is looked at twice, however tall the stacks.
    pub(super) fn compute(
        &mut self,
        bodies: &[SolverBody],
        pairs: impl Iterator<Item = (usize, usize)> + Clone,
    ) -> &[u32] {
        let Levels {
            level,
            neighbours,
            queue,
        } = self;
        level.clear();
        level.extend(bodies.iter().map(|b| {
            if b.motion == Motion::Dynamic {
                u32::MAX
            } else {
                0
            }
        }));
        neighbours.build(
            bodies.len(),
            pairs.flat_map(|(a, b)| [(a, b as u32), (b, a as u32)]),
        );
        queue.clear();
        queue.extend((0..bodies.len() as u32).filter(|&i| level[i as usize] == 0));
        let mut head = 0;
        while head < queue.len() {
            let from = queue[head] as usize;
            head += 1;
            let via = level[from] + 1;
            for &to in neighbours.row(from) {
                if level[to as usize] == u32::MAX {
                    level[to as usize] = via;
                    queue.push(to);
                }
            }
        }
        level
    }
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
pub(super) fn release_frictional_groups(blocks: &mut [Block], released: &[bool]) {
    for (block, _) in blocks.iter_mut().zip(released).filter(|(_, r)| **r) {
        block.support = Support::Neither;
        block.hold = 0.0;
        block.push = Vec3::ZERO;
    }
}

/// Sets [`Block::carries_released`] on each of `blocks` (before they are released): whether its
/// supported body is the support of a block that `released` marks (`carrying` a buffer, one
/// entry a body; its earlier contents dropped).
pub(super) fn mark_carrying_released(
    bodies: usize,
    contacts: &[ContactConstraint],
    blocks: &mut [Block],
    released: &[bool],
    carrying: &mut Vec<bool>,
) {
    refill(carrying, bodies, false);
    for (block, _) in blocks.iter().zip(released).filter(|(_, r)| **r) {
        if let Some((_, support)) = block.pair(contacts) {
            carrying[support] = true;
        }
    }
    for block in blocks.iter_mut() {
        block.carries_released = block.upper(contacts).is_some_and(|upper| carrying[upper]);
    }
}

/// Which of `blocks` [`release_frictional_groups`] releases, into `released`: those whose
/// supported body has more than one touching support, with friction on any of them
/// (`supports` a buffer; both buffers' earlier contents dropped).
pub(super) fn frictional_groups(
    bodies: usize,
    contacts: &[ContactConstraint],
    blocks: &[Block],
    supports: &mut Vec<(u32, bool)>,
    released: &mut Vec<bool>,
) {
    refill(supports, bodies, (0, false));
    for block in blocks.iter().filter(|b| b.touching) {
        if let Some(upper) = block.upper(contacts) {
            supports[upper].0 += 1;
            supports[upper].1 |= contacts[block.range.start].friction > 0.0;
        }
    }
    released.clear();
    released.extend(blocks.iter().map(|block| {
        block
            .upper(contacts)
            .is_some_and(|upper| supports[upper].0 > 1 && supports[upper].1)
    }));
}

/// Some row of the manifold can push and is within `touch` (m) of touching.
pub(super) fn touches(rows: &[ContactConstraint], touch: f32) -> bool {
    rows.iter()
        .any(|c| c.separation <= touch && c.normal_mass > 0.0)
}

/// Copies `contacts` in the order of `blocks` into `ordered` and points each block at its
/// copy; `origin` gets each block's range in `contacts` (both buffers' earlier contents
/// dropped, their memory kept).
pub(super) fn in_block_order(
    contacts: &[ContactConstraint],
    blocks: &mut [Block],
    ordered: &mut Vec<ContactConstraint>,
    origin: &mut Vec<Range<usize>>,
) {
    ordered.clear();
    origin.clear();
    for block in blocks.iter_mut() {
        let start = ordered.len();
        ordered.extend_from_slice(&contacts[block.range.clone()]);
        origin.push(std::mem::replace(&mut block.range, start..ordered.len()));
    }
}

/// Writes back into `contacts` what the resting phase changed in `ordered` (laid out by
/// [`in_block_order`], `origin` each block's range in `contacts`): the impulses, and the whole
/// row where [`refresh_inertia`](crate::dynamics::solver::refresh_inertia) re-derived its
/// angular terms. Nothing else of a row changes in the resting phase. Why not the whole row
/// always: the rows are large (over 200 bytes), and copying them back was about half the cost
/// of the block order (0.25 ms a step for 2,000 spheres).
pub(super) fn from_block_order(
    bodies: &[SolverBody],
    contacts: &mut [ContactConstraint],
    ordered: &[ContactConstraint],
    blocks: &[Block],
    origin: &[Range<usize>],
) {
    for (block, range) in blocks.iter().zip(origin) {
        for (c, solved) in contacts[range.clone()]
            .iter_mut()
            .zip(&ordered[block.range.clone()])
        {
            if solved.inertia_turns(bodies) {
                *c = *solved;
            } else {
                c.normal_impulse = solved.normal_impulse;
                c.tangent_impulse = solved.tangent_impulse;
                c.twist_impulse = solved.twist_impulse;
                c.max_normal_impulse = solved.max_normal_impulse;
                c.total_impulse = solved.total_impulse;
            }
        }
    }
}
