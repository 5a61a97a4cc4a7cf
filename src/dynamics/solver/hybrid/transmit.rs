//! A held chain's loads: what a held support passes on to its own supports, which its warm
//! start does not apply to it.

use super::*;
use crate::dynamics::solver::refill;

/// A block whose [`Block::hold`] is at least this holds its support wholly: the support's own
/// supports take the block's normal impulse (see [`held_warm_start`]).
pub const WHOLLY_HELD: f32 = 1.0 - 1e-4;

/// Sets [`Block::passes_on`] on each of `blocks` (before `release_frictional_groups`, whose
/// marks are `released`; `rests_on_released` a buffer, one entry a body, its earlier contents
/// dropped): a touching block with friction whose support is a dynamic body held wholly (see
/// [`WHOLLY_HELD`]) or by friction ([`Block::gripped`]), and resting only on blocks that are not
/// released, so that what it passes on reaches blocks that carry it down ([`Transmitted`]).
///
/// Why friction: a held support given none of the block's impulse also misses the impulse's
/// part across its own supports' normals (f32 rounding tilts a normal by 1e-7), which nothing
/// else puts back where the contacts are frictionless: the frictionless pyramid of base 10
/// drifted 0.011 kg m/s sideways in 20 s that way (7e-5 with the support answering the
/// impulse itself) and its top moved 12.6 mm (5.7 mm). Frictionless chains keep the support's
/// answer a substep late, which is harmless there: frictionless columns and pyramids stand.
/// Why not onto released blocks: those are solved two-body (see `release_frictional_groups`)
/// and carry nothing passed to them, so a load passed on there would press nothing below.
///
/// Why a hold by friction: a 4 g hull on the floor (friction 1) under a 0.42 kg capsule whose
/// contact normal leans 4 degrees off the floor's has a hold of 0.995, not a whole one; warm
/// started with the whole impulse a substep late, it took the difference of two loads a
/// hundred times its weight and left at 12.9-17.8 m/s (a pour of 0.1 m mixed shapes with
/// friction 1 at 120 Hz, `examples/family_probe`; the free-fall bound is 6.5 m/s); passing
/// the held part on, it stays under 2.7 m/s. Why only where friction on fixed bodies holds the
/// rest (with a margin, see `GRIP_MARGIN`), and the push cannot tip or roll the support: what
/// the support does not take of the push it slides or rolls along, while the body above is
/// held up as by a support that does not give way. A 35 g box pressed by a 95 kg one against
/// a frictionless floor leaning 5 degrees away (hold 0.990) was squeezed out at 3e7 m/s
/// (`tests/energy.rs`' seed 4004 under the manifold friction model); with every hold above 0
/// passed on where the floor has friction, balls pressed 1-4 degrees off their centres
/// rolled away under the bodies landing on them, which were thrown back up at 4.3 m/s (the
/// mixed pour of 1,000, density 1000, friction 0.5, step 38; every contact inelastic).
pub(super) fn mark_passing_on(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    blocks: &mut [Block],
    released: &[bool],
    rests_on_released: &mut Vec<bool>,
) {
    refill(rests_on_released, bodies.len(), false);
    for (block, _) in blocks.iter().zip(released).filter(|(_, r)| **r) {
        if let Some(upper) = block.upper(contacts) {
            rests_on_released[upper] = true;
        }
    }
    for block in blocks.iter_mut() {
        block.passes_on = block.touching
            && (block.hold >= WHOLLY_HELD || block.gripped)
            && contacts[block.range.start].friction > 0.0
            && block.pair(contacts).is_some_and(|(_, lower)| {
                bodies[lower].motion == Motion::Dynamic && !rests_on_released[lower]
            });
    }
}

/// The warm start of the hybrid's resting phase: each block's accumulated impulses applied as
/// its solve applies them. The support of a block that passes its load on ([`Block::passes_on`])
/// takes only the part of the block's normal impulse that its own supports do not (none where
/// it is held wholly: the block's solve does not move it); friction and twist go to both bodies
/// in full. Every other block is warm-started as
/// [`warm_start`](crate::dynamics::solver::contact::warm_start) does, bit for bit.
///
/// Why: a held block's solve moves only the body it supports. Given the whole accumulated
/// impulse `lambda_H` at the next warm start (Newton's third law a substep late), the support
/// takes a push that its own supports answered in the substep before, against the
/// `lambda_H` of the substep before that, and at the manifold's points as the block split it
/// then: where `lambda_H` changes (a body landing and coming to rest), or its split among the
/// points does (a heavy cube's rigid tilt), a light support gets the difference of two loads
/// many times its own weight. That launched supports out of columns alternating 1 kg and 10 kg
/// (+6.6 J, 0.18 m aside in 20 s at 60 Hz), columns alternating 1 kg and 0.01 kg (+24 J),
/// and 4 g hulls out of mixed pours; correcting only the total for the lag (adding each
/// substep's change of `lambda_H` to the supports' impulses beneath) held none of them, so the
/// split matters too. The load a held support passes on is instead carried down the chain
/// without moving it ([`Transmitted`]), to the friction bounds and reported impulses of the
/// blocks beneath.
pub fn held_warm_start(
    bodies: &mut [SolverBody],
    contacts: &[ContactConstraint],
    blocks: &[Block],
) {
    for block in blocks {
        let rows = &contacts[block.range.clone()];
        let (a, b) = (rows[0].body_a, rows[0].body_b);
        let held = block.passes_on.then(|| block.response(rows[0].normal));
        let mut v = PairVelocities::load(bodies, a, b);
        let mut changed = false;
        for c in rows {
            if c.normal_impulse != 0.0 {
                changed = true;
                match &held {
                    // As the block's solve applies it: the support only along the part of
                    // the normal its own supports do not take.
                    Some(response) => apply_response(c, &mut v, c.normal_impulse, response),
                    None => c.apply_normal_impulse_to(
                        (&mut v.a.linear, &mut v.a.angular, v.a.inverse_mass),
                        (&mut v.b.linear, &mut v.b.angular, v.b.inverse_mass),
                        c.normal_impulse,
                    ),
                }
            }
            changed |= c.warm_start_friction_in(bodies, &mut v);
        }
        if changed {
            v.store(bodies, a, b);
        }
    }
}

/// What each block carries beyond its own normal impulse: the held part (`hold` times) of the
/// impulses of the blocks above its supported body that pass their load on (see
/// [`Block::passes_on`] and [`held_warm_start`]), with what they carry in turn, shared among
/// that body's touching supports in proportion to their own impulses (equally where none
/// pushes). It never moves a body: it enlarges the blocks' friction bounds (a column
/// on a slope holds by the weight of all of it) and the impulses they report.
#[derive(Clone, Debug, Default)]
pub struct Transmitted {
    /// Each block's carried impulse, N s, in block order.
    carried: Vec<f32>,
    /// What each body passes on to its supports, N s.
    passed: Vec<f32>,
    /// The own normal impulses of each body's touching supports, summed.
    pressing: Vec<f32>,
    /// Each body's touching supports.
    supports: Vec<u32>,
}

impl Transmitted {
    /// Recomputes every block's carried impulse from the blocks' accumulated normal impulses
    /// (`blocks` in shock order): walking the blocks top down, each block that passes its load
    /// on passes the held part of its impulse and of what it carries to its support, which
    /// shares it among its own supports.
    pub fn compute(
        &mut self,
        bodies: &[SolverBody],
        contacts: &[ContactConstraint],
        blocks: &[Block],
    ) {
        let Transmitted {
            carried,
            passed,
            pressing,
            supports,
        } = self;
        // Most blocks of a pile pass nothing on (their bodies rest on several supports).
        if !blocks.iter().any(|b| b.passes_on) {
            carried.clear();
            return;
        }
        refill(carried, blocks.len(), 0.0);
        refill(passed, bodies.len(), 0.0);
        refill(pressing, bodies.len(), 0.0);
        refill(supports, bodies.len(), 0);
        let own = |block: &Block| own_impulse(&contacts[block.range.clone()]);
        for block in blocks.iter().filter(|b| b.touching) {
            if let Some(upper) = block.upper(contacts) {
                pressing[upper] += own(block);
                supports[upper] += 1;
            }
        }
        for (k, block) in blocks.iter().enumerate().rev() {
            let Some((upper, lower)) = block.pair(contacts).filter(|_| block.touching) else {
                continue;
            };
            let own = own(block);
            if passed[upper] > 0.0 {
                let share = if pressing[upper] > 0.0 {
                    own / pressing[upper]
                } else {
                    1.0 / supports[upper] as f32
                };
                carried[k] = passed[upper] * share;
            }
            if block.passes_on {
                passed[lower] += block.hold.min(1.0) * (own + carried[k]);
            }
        }
    }

    /// Block `k`'s carried impulse, N s (0 before the first [`Transmitted::compute`]).
    #[inline]
    pub fn of(&self, k: usize) -> f32 {
        self.carried.get(k).copied().unwrap_or(0.0)
    }

    /// The factor on the friction bounds of block `k`, whose rows are `rows`: `(own + carried)
    /// / own`, `own` their normal impulses' sum, so that each row's bound grows in proportion to
    /// its own impulse; 1 where the block carries nothing or its rows push nothing.
    #[inline]
    pub fn bound_scale(&self, k: usize, rows: &[ContactConstraint]) -> f32 {
        let carried = self.of(k);
        if carried <= 0.0 {
            return 1.0;
        }
        let own = own_impulse(rows);
        if own > 0.0 {
            (own + carried) / own
        } else {
            1.0
        }
    }
}

/// The sum of `rows`' own normal impulses (the pushing ones), N s.
#[inline]
fn own_impulse(rows: &[ContactConstraint]) -> f32 {
    rows.iter().map(|c| c.normal_impulse.max(0.0)).sum()
}
