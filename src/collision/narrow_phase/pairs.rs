//! [`ContactPairs`]: the persistent set of contact pairs, sorted by entity pair, that the
//! narrow phase keeps from step to step.

use bevy::prelude::*;

use super::{ContactImpulse, ContactPair};
use crate::dynamics::solver::ContactConstraint;

/// Every pair the broad phase reported in the last step, sorted by `(a, b)`: the pairs of the
/// step's candidates, and the resting pairs set aside while a sleeping body of theirs sits out
/// the steps (see [`SleepingSet`](crate::dynamics::sleep::SleepingSet)), which keep their
/// manifolds and touching state untouched.
#[derive(Resource, Default)]
pub struct ContactPairs {
    pairs: Vec<ContactPair>,
    resting: Vec<ContactPair>,
    /// Buffers kept between steps, so that a steady step allocates nothing: the pairs' last
    /// list while [`retain_candidates`](Self::retain_candidates) builds the new one, and
    /// [`update_touching`](Self::update_touching)'s flags.
    spare: Vec<ContactPair>,
    touching: Vec<bool>,
}

impl ContactPairs {
    /// Every pair, sorted by `(a, b)`.
    pub fn iter(&self) -> impl Iterator<Item = &ContactPair> {
        let mut live = self.pairs.iter().peekable();
        let mut resting = self.resting.iter().peekable();
        std::iter::from_fn(move || match (live.peek(), resting.peek()) {
            (Some(p), Some(q)) if (q.a, q.b) < (p.a, p.b) => resting.next(),
            (Some(_), _) => live.next(),
            (None, _) => resting.next(),
        })
    }

    /// The pair of `a` and `b` (in either order), if the broad phase reported it.
    pub fn get(&self, a: Entity, b: Entity) -> Option<&ContactPair> {
        let key = (a.min(b), a.max(b));
        let find = |pairs: &'_ [ContactPair]| pairs.binary_search_by(|p| (p.a, p.b).cmp(&key)).ok();
        find(&self.pairs)
            .map(|i| &self.pairs[i])
            .or_else(|| find(&self.resting).map(|i| &self.resting[i]))
    }

    /// The pairs of this step's candidates, in order (the resting pairs set aside are not
    /// among them).
    pub fn candidates(&self) -> &[ContactPair] {
        &self.pairs
    }

    /// Mutable access to the pairs of this step's candidates, in order.
    pub fn pairs_mut(&mut self) -> &mut [ContactPair] {
        &mut self.pairs
    }

    /// Whether any pair is set aside.
    pub fn has_resting(&self) -> bool {
        !self.resting.is_empty()
    }

    /// Moves the candidate pairs whose flag in `aside` is set (one flag per pair of
    /// [`candidates`](Self::candidates)) to the resting pairs.
    pub fn set_aside(&mut self, aside: &[bool]) {
        let (moved, kept): (Vec<_>, Vec<_>) = std::mem::take(&mut self.pairs)
            .into_iter()
            .zip(aside)
            .partition(|&(_, &a)| a);
        self.pairs = kept.into_iter().map(|(p, _)| p).collect();
        let moved = moved.into_iter().map(|(p, _)| p).collect();
        self.resting = merge(std::mem::take(&mut self.resting), moved);
    }

    /// Moves the resting pairs for which `wake` is true back among the candidate pairs.
    pub fn revive(&mut self, mut wake: impl FnMut(&ContactPair) -> bool) {
        let (woken, kept): (Vec<_>, Vec<_>) = std::mem::take(&mut self.resting)
            .into_iter()
            .partition(|p| wake(p));
        self.resting = kept;
        self.pairs = merge(std::mem::take(&mut self.pairs), woken);
    }

    /// Stores each solved row's impulses in its manifold point (`keys`: the row's candidate
    /// pair, manifold and point), so that the next step starts from them (warm starting). A
    /// non-finite impulse (its bodies' results are non-finite too, and they are quarantined) is
    /// not carried over: warm-started, it would make the next step non-finite again, and the
    /// quarantine would never end.
    pub fn store_impulses(&mut self, rows: &[ContactConstraint], keys: &[(u32, u32, u32)]) {
        for (c, &(p, m, k)) in rows.iter().zip(keys) {
            let finite = c.normal_impulse.is_finite()
                && c.tangent_impulse[0].is_finite()
                && c.tangent_impulse[1].is_finite()
                && c.twist_impulse.is_finite();
            self.pairs[p as usize].manifolds[m as usize].points[k as usize].data = if finite {
                ContactImpulse {
                    normal: c.normal_impulse,
                    tangent: c.tangent_impulse,
                    twist: c.twist_impulse,
                }
            } else {
                ContactImpulse::default()
            };
        }
    }

    /// Sets each candidate pair's touching state from the step's solved rows: a pair touches
    /// when a row is within `touch` (m) or pushed in the step, or (a pair without rows: a
    /// detect-only pair) when it is among `detected`; a `dormant` pair keeps its state. Pairs
    /// that start and stop touching are pushed to `started` and `ended`.
    #[allow(clippy::too_many_arguments)]
    pub fn update_touching(
        &mut self,
        rows: &[ContactConstraint],
        keys: &[(u32, u32, u32)],
        detected: &[u32],
        dormant: &[bool],
        touch: f32,
        started: &mut Vec<(Entity, Entity)>,
        ended: &mut Vec<(Entity, Entity)>,
    ) {
        let mut touching = std::mem::take(&mut self.touching);
        touching.clear();
        touching.extend(
            self.pairs
                .iter()
                .zip(dormant)
                .map(|(pair, &dormant)| dormant && pair.touching),
        );
        for (c, &(p, _, _)) in rows.iter().zip(keys) {
            if c.separation <= touch || c.total_impulse > 0.0 {
                touching[p as usize] = true;
            }
        }
        for &p in detected {
            touching[p as usize] = true;
        }
        for (pair, &now) in self.pairs.iter_mut().zip(&touching) {
            match (pair.touching, now) {
                (false, true) => started.push((pair.a, pair.b)),
                (true, false) => ended.push((pair.a, pair.b)),
                _ => {}
            }
            pair.touching = now;
        }
        self.touching = touching;
    }

    /// Replaces the candidate pairs with `candidates` (sorted by `(a, b)`, `a < b`), keeping the
    /// state of pairs that persist. Pairs that are gone are passed to `removed` (touching ones
    /// end a collision). The resting pairs are left as they are.
    pub fn retain_candidates(
        &mut self,
        candidates: &[(Entity, Entity)],
        mut removed: impl FnMut(&ContactPair),
    ) {
        let mut last = std::mem::replace(&mut self.pairs, std::mem::take(&mut self.spare));
        self.pairs.clear();
        self.pairs.reserve(candidates.len());
        let mut old = last.drain(..).peekable();
        for &(a, b) in candidates {
            while let Some(p) = old.next_if(|p| (p.a, p.b) < (a, b)) {
                removed(&p);
            }
            match old.next_if(|p| (p.a, p.b) == (a, b)) {
                Some(p) => self.pairs.push(p),
                None => self.pairs.push(ContactPair::new(a, b)),
            }
        }
        for p in old {
            removed(&p);
        }
        self.spare = last;
    }
}

/// Two lists of pairs sorted by `(a, b)`, merged.
fn merge(a: Vec<ContactPair>, b: Vec<ContactPair>) -> Vec<ContactPair> {
    if b.is_empty() {
        return a;
    }
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut a, mut b) = (a.into_iter().peekable(), b.into_iter().peekable());
    loop {
        let take_b = match (a.peek(), b.peek()) {
            (Some(p), Some(q)) => (q.a, q.b) < (p.a, p.b),
            (Some(_), None) => false,
            (None, Some(_)) => true,
            (None, None) => return out,
        };
        out.extend(if take_b { b.next() } else { a.next() });
    }
}
