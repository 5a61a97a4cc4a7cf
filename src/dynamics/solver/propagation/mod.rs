//! Propagation: each approaching contact (or manifold) resolved as an isolated impact with the
//! impulse formula, on the current velocities, sweeping until nothing approaches.
//!
//! This is the method that gets Newton's cradle right: resolving one two-body impact at a time
//! lets momentum travel down the row ball by ball, which is what the real event sequence does.
//! Any simultaneous method (sequential impulses to convergence, Jacobi, an exact LCP) solves all
//! contacts of the row as one block instead. Its weakness is the opposite case: inelastic
//! collapse, where `e = 0` contacts in a stack keep re-approaching by smaller and smaller
//! amounts. So in the hybrid method a touching `e = 0` contact joins the inelastic impact
//! events of its bodies, which are solved exactly (`super::lcp`); and the sweeps are bounded.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::ops::Range;

use bevy::math::Vec3;

use super::body::{Motion, SolverBody};
use super::contact::ContactConstraint;
use crate::dynamics::solver::refill;
use event::*;
use timing::*;
pub(super) use timing::{relative_gravity, time_of_impact};

mod event;
mod friction;
mod timing;

/// What a propagation pass did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PropagationReport {
    /// Sweeps over the groups, the last one finding nothing to resolve (or hitting the bound).
    pub sweeps: u32,
    /// Group resolutions performed.
    pub resolutions: u32,
    /// The sweep bound was hit while contacts still approached.
    pub bound_hit: bool,
}

/// Parameters of a propagation pass.
#[derive(Clone, Copy, Debug)]
pub struct Propagation {
    /// A contact counts as approaching when `v_n < -threshold`, m/s.
    pub threshold: f32,
    /// The threshold, m/s, for a contact with restitution one of whose bodies was struck
    /// earlier in this pass (a chain of impacts); at most `threshold`.
    pub chain_threshold: f32,
    /// At most this many sweeps.
    pub max_sweeps: u32,
    /// Step length, s: a speculative contact (separation s > 0) only takes part when it would
    /// close within the step, and its impact is placed at its time of impact.
    pub dt: f32,
    /// Gravity, m/s^2, when it is integrated *after* this pass over the same step (the hybrid
    /// method); zero when velocities already include it. See [`propagate`].
    pub gravity: Vec3,
    /// Gravity, m/s^2, that the velocities already include over this step (the propagation
    /// method integrates it before the pass); zero otherwise. The part of an approach it made
    /// is not bounced: see `resolve_event`.
    pub integrated_gravity: Vec3,
    /// The bodies' [`extra_acceleration`](SolverBody::extra_acceleration)s are already in the
    /// velocities, with `integrated_gravity` (the propagation method); otherwise they are
    /// integrated after the pass, with `gravity` (the hybrid method).
    pub accelerations_integrated: bool,
    /// Substeps the later integration uses (1 when there is none): semi-implicit Euler over
    /// `n` substeps moves a body `g dt^2 (1 + 1/n) / 2` under gravity, a little more than the
    /// exact `g dt^2 / 2`, and the closing test uses that larger figure.
    pub substeps: u32,
    /// Largest block iterations for a group of several contacts (a manifold).
    pub max_block_iterations: u32,
    /// A group's block solve stops when no contact's velocity changes by more than this, m/s.
    pub velocity_tolerance: f32,
    /// Touching contacts with `e = 0` join the inelastic impact events of their bodies (see
    /// `JOINED_ROWS`): the hybrid method. Not the propagation method, whose pass follows the
    /// step's gravity, so that every resting contact approaches and every stack would be one
    /// event every step (a 100-box column alternating 1000:1 took 0.7 s a step, and a 1 kg box
    /// was squeezed out of it at 50 m/s, where the sweep bound had left it standing).
    pub join_touching: bool,
    /// A contact separated by at most this, m, touches. The resting phase's `linear_slop`.
    pub touch: f32,
    /// An approach later than one that waits for the next sweep in its bodies' cluster of
    /// touching bodies waits too (see `Clusters`). On in both methods that propagate (the
    /// hybrid's impact phase too: its long energy run and long stress run were unchanged by
    /// it, the same failing seeds and scene at the same numbers); off only to show, in a unit
    /// test, what it prevents.
    pub wait_in_cluster: bool,
}

/// Resolves approaching groups of contacts as impacts until none approaches.
///
/// Each `groups` range is one unit of propagation: a single contact (textbook propagation), or
/// all points of one body pair's manifold, which are then solved together as a small block so
/// that a box landing flat on four corners rebounds without spin. Within a group, the
/// restitution target of each approaching point is `-e v_n`, with `v_n` taken when the group
/// is picked up; with one point this is exactly `j = -(1+e) v_n / K`.
///
/// An impact at a speculative contact happens at the time `t` into the step when the gap
/// closes, or later if one of the bodies was hit later in this step; each body is owed
/// `-(v' - v) t` of position so that, after integration, it moved at its old velocity until `t`
/// and at its new one after.
///
/// When gravity `g` is integrated after this pass (`params.gravity`), the pair's relative
/// acceleration along the normal, `g_n`, is part of the event: the gap closes when
/// `s + v_n t + g_n t^2 / 2 = 0`, the approach speed at impact is `v_n + g_n t`, and the target
/// normal velocity just after the impact is `-e (v_n + g_n t)`. Expressed before gravity (which
/// the later integration adds for the whole step), that target is `-e v_n - (1 + e) g_n t`;
/// the position owed is still `-(v' - v) t`, since the gravity terms cancel.
///
/// Within a sweep, impacts are resolved in time order: the approaching groups wait in a queue
/// by time of impact, and a group that an impact sets approaching joins the queue at its own
/// time. Why: an impact at time `t` places its bodies as if they moved freely until `t`, which
/// is false when a body is stopped before `t` through a contact it touches. Resolved in storage
/// order, a die resting on another, both settling onto the ground, met the ground through the
/// lower die (a speculative contact 1 mm below it, which the step's fall `g dt^2` = 2.7 mm at
/// 60 Hz reaches) at its free-fall time of impact, and was placed 1 mm down, inside the lower
/// die, before the lower die's own contact with the ground (at time 0) was resolved and stopped
/// them both. (Waiting a whole sweep for every earlier impact of a cluster of touching bodies
/// instead, one impact of a pile resolved per sweep, and a pour of 1,000 spheres hit the sweep
/// bound.) A group resolved in a sweep and set approaching again waits for the next one, and
/// with [`Propagation::wait_in_cluster`] so does every later impact of its cluster of touching
/// bodies (see `Clusters`): without, under the propagation method, whose touching contacts do
/// not join events, the same stack's lower die was stopped, struck again by the upper one and
/// left to the next sweep, and the upper die met the ground in this one.
///
/// An event is the group picked up, the approaching groups of its bodies that meet at the same
/// time (see `SIMULTANEOUS`), and, if all these are inelastic, the touching `e = 0` groups of
/// its bodies, transitively, nearest first (see `JOINED_ROWS`); it is solved as one block,
/// exactly up to `DENSE_ROWS` rows. A group approaches when it does at the start of the step
/// and still does where the event solves it (see `approach_time`).
///
/// Long (about 250 lines) on purpose: one loop of sweeps over a time-ordered queue, whose
/// state (per body the stamps, per group the checks, `met`, `done`, `postponed`, the event
/// and the clusters) every part reads and writes; the parts that need none of it are their
/// own functions (`approach_time`, `resolve_event`, `Clusters`, `GroupsOfBody`).
pub fn propagate(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    groups: &[Range<usize>],
    params: &Propagation,
) -> PropagationReport {
    propagate_with(
        bodies,
        contacts,
        groups,
        params,
        &mut PropagationScratch::default(),
    )
}

/// [`propagate`]'s per-body and per-group state and its events' buffers, kept between passes
/// (in the solver's scratch) so that a pass allocates nothing once they have grown to the
/// scene: their contents are rebuilt at every pass, only their memory is reused.
#[derive(Default)]
pub(super) struct PropagationScratch {
    /// The events' buffers.
    event: EventScratch,
    /// Per body, the resolution that last changed it.
    stamp: Vec<u32>,
    /// Per group, the resolution count when it was last checked.
    checked: Vec<u32>,
    /// Per group, it met at an impact of this pass.
    met: Vec<bool>,
    /// Per group, its body pair.
    pairs: Vec<Option<(usize, usize)>>,
    /// Per dynamic body, its groups.
    touching: GroupsOfBody,
    /// The clusters of touching bodies.
    clusters: Clusters,
    /// Per group, postponed in the last sweep.
    postponed: Vec<bool>,
    /// The current event's groups.
    event_groups: Vec<usize>,
    /// Per group, in the current event.
    in_event: Vec<bool>,
    /// Per group, joined the current event as a touching inelastic contact.
    joined: Vec<bool>,
    /// Per group, resolved in the current sweep.
    done: Vec<bool>,
    /// The sweep's approaching groups by time of impact.
    queue: BinaryHeap<Reverse<Queued>>,
    /// Per group, the time of its last impact (NaN: none yet).
    last_impact: Vec<f32>,
    /// Per group, its bounce is spent.
    spent: Vec<bool>,
}

impl std::fmt::Debug for PropagationScratch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PropagationScratch").finish_non_exhaustive()
    }
}

impl Clone for PropagationScratch {
    /// A fresh scratch: only the memory of the buffers would be copied, and none of their
    /// contents is read before a pass rebuilds it.
    fn clone(&self) -> Self {
        PropagationScratch::default()
    }
}

/// [`propagate`], with its buffers in `scratch`: the same results.
pub(super) fn propagate_with(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    groups: &[Range<usize>],
    params: &Propagation,
    scratch: &mut PropagationScratch,
) -> PropagationReport {
    let mut report = PropagationReport::default();
    if nothing_approaches(bodies, contacts, groups, params) {
        // The first sweep would find no impact and the pass would end with it (a group with
        // rows is checked once, unless the bound allows no sweep).
        let checked = groups.iter().any(|g| has_rows(contacts, g));
        report.sweeps = u32::from(checked && params.max_sweeps > 0);
        return report;
    }
    let PropagationScratch {
        event: scratch,
        stamp,
        checked,
        met,
        pairs,
        touching,
        clusters: cluster_buffers,
        postponed,
        event_groups: event,
        in_event,
        joined,
        done,
        queue,
        last_impact,
        spent,
    } = scratch;
    scratch.reset(bodies.len());
    // Only a group one of whose bodies changed velocity since the group was last checked can
    // have started to approach: `stamp` is, per body, the number of the resolution that last
    // changed it, and `checked` per group the resolution count when it was last found not
    // approaching (or resolved). The pass stops as soon as no group needs a check, so an
    // island of one impact costs one sweep, not a second one that finds nothing.
    refill(stamp, bodies.len(), 0);
    refill(checked, groups.len(), 0);
    // The group's gap closed at an impact earlier in this pass: it touches from then on.
    refill(met, groups.len(), false);
    let mut resolutions = 0u32;
    // The body pair of each group (the groups are single contacts or one pair's manifold).
    pairs.clear();
    pairs.extend(groups.iter().map(|g| {
        has_rows(contacts, g).then(|| (contacts[g.start].body_a, contacts[g.start].body_b))
    }));
    let pairs = &*pairs;
    touching.rebuild(bodies, pairs);
    let touching = &*touching;
    // The bodies in contact, and the approaches that wait for the next sweep (see `Clusters`).
    let mut clusters = params.wait_in_cluster.then(|| {
        cluster_buffers.reset(bodies, contacts, groups, pairs, params.touch);
        cluster_buffers
    });
    // Postponed in the last sweep (see `Clusters`): checked again in the next.
    refill(postponed, groups.len(), false);
    let needs_check = |k: usize, stamp: &[u32], checked: &[u32], postponed: &[bool], sweeps| {
        pairs[k].is_some_and(|(a, b)| {
            sweeps == 0 || postponed[k] || stamp[a].max(stamp[b]) > checked[k]
        })
    };
    event.clear();
    refill(in_event, groups.len(), false);
    // The event's groups that join it as touching inelastic contacts (see `JOINED_ROWS`).
    refill(joined, groups.len(), false);
    // Resolved in the current sweep: each group is resolved at most once a sweep.
    refill(done, groups.len(), false);
    // The sweep's approaching groups by time of impact, earliest first (ties by index).
    queue.clear();
    // The time of each group's last impact in this pass (NaN: none yet), and whether it was
    // struck again at that same instant, which spends its bounce (see `struck_again`):
    // from then on it is inelastic in this pass.
    refill(last_impact, groups.len(), f32::NAN);
    refill(spent, groups.len(), false);
    loop {
        let pending =
            (0..groups.len()).any(|k| needs_check(k, stamp, checked, postponed, report.sweeps));
        if !pending {
            break;
        }
        if report.sweeps == params.max_sweeps {
            report.bound_hit = (0..groups.len()).any(|k| {
                let chain = chained(pairs[k], stamp) && !spent[k];
                approach_time(bodies, contacts, &groups[k], params, met[k], chain).is_some()
            });
            break;
        }
        report.sweeps += 1;
        // The group's time of impact if it approaches then (see `approach_time`).
        let approaches = |k: usize,
                          stamp: &[u32],
                          bodies: &[SolverBody],
                          contacts: &[ContactConstraint],
                          met: &[bool],
                          spent: &[bool]| {
            // A group whose bounce is spent is inelastic: it counts from the threshold of
            // an inelastic contact, not the chain's.
            let chain = chained(pairs[k], stamp) && !spent[k];
            approach_time(bodies, contacts, &groups[k], params, met[k], chain)
        };
        done.fill(false);
        queue.clear();
        if let Some(clusters) = clusters.as_mut() {
            clusters.begin_sweep();
        }
        // In the last sweep the bound allows, nothing waits: an impact resolved out of order
        // is still better than one not resolved at all (a body passing into another).
        let last_sweep = report.sweeps == params.max_sweeps;
        for k in 0..groups.len() {
            if !needs_check(k, stamp, checked, postponed, report.sweeps - 1) {
                continue;
            }
            postponed[k] = false;
            match approaches(k, stamp, bodies, contacts, met, spent) {
                Some(time) => queue.push(Reverse(Queued { time, group: k })),
                None => checked[k] = resolutions,
            }
        }
        while let Some(Reverse(Queued {
            time: queued,
            group: k,
        })) = queue.pop()
        {
            if done[k] {
                continue;
            }
            let Some(time) = approaches(k, stamp, bodies, contacts, met, spent) else {
                checked[k] = resolutions;
                continue;
            };
            // Earlier impacts of this sweep may have moved its time: if it now comes after the
            // next queued one, it waits its turn.
            if time > queued + SIMULTANEOUS * params.dt
                && queue.peek().is_some_and(|next| next.0.time < time)
            {
                queue.push(Reverse(Queued { time, group: k }));
                continue;
            }
            // An approach of its bodies' clusters that comes before it waits for the next
            // sweep: so does it, and what comes after it in turn (see `Clusters`).
            if let Some(clusters) = clusters.as_mut()
                && !last_sweep
                && clusters.waits(pairs[k], time, SIMULTANEOUS * params.dt)
            {
                postponed[k] = true;
                clusters.defer(pairs[k], time, bodies);
                continue;
            }
            // The event: this group and every approaching group that shares a dynamic body
            // with it, transitively, and meets at the same time (see `SIMULTANEOUS`).
            event.clear();
            event.push(k);
            in_event[k] = true;
            // The event's time: the latest of its groups' (all within `SIMULTANEOUS` of `time`).
            let mut event_time = time;
            let mut next = 0;
            while next < event.len() {
                let g = event[next];
                next += 1;
                for l in touching.of_pair(pairs[g]) {
                    if in_event[l] || done[l] {
                        continue;
                    }
                    let Some(t) = approaches(l, stamp, bodies, contacts, met, spent) else {
                        continue;
                    };
                    if (t - time).abs() > SIMULTANEOUS * params.dt {
                        continue;
                    }
                    in_event[l] = true;
                    event.push(l);
                    event_time = event_time.max(t);
                }
            }
            // Then, if the event is inelastic (its groups have no restitution, or have spent
            // their bounce), the touching inelastic groups of its bodies, transitively,
            // nearest first, while it has fewer than `JOINED_ROWS` rows.
            let inelastic = params.join_touching
                && event.iter().all(|&g| {
                    spent[g]
                        || contacts[groups[g].clone()]
                            .iter()
                            .all(|c| c.restitution == 0.0)
                });
            let mut rows = event.iter().map(|&g| groups[g].len()).sum::<usize>();
            let mut next = if inelastic { 0 } else { event.len() };
            while next < event.len() && rows < JOINED_ROWS {
                let g = event[next];
                next += 1;
                for l in touching.of_pair(pairs[g]) {
                    if in_event[l]
                        || rows >= JOINED_ROWS
                        || !joins(&contacts[groups[l].clone()], params.touch, spent[l])
                    {
                        continue;
                    }
                    in_event[l] = true;
                    joined[l] = true;
                    event.push(l);
                    rows += groups[l].len();
                }
            }
            resolve_event(
                bodies, contacts, groups, event, met, joined, spent, inelastic, event_time, params,
                scratch,
            );
            report.resolutions += 1;
            resolutions += 1;
            for &g in event.iter() {
                in_event[g] = false;
                if std::mem::take(&mut joined[g]) {
                    // A joined group was not picked up as an impact: it may still be, in this
                    // sweep, if a later impact sets it approaching. Its bodies count as struck
                    // only if the event changed them (a body struck is part of a chain, whose
                    // contacts with restitution count from the chain threshold).
                    let (a, b) = pairs[g].expect("an event's groups have bodies");
                    for i in [a, b] {
                        if bodies[i].motion == Motion::Dynamic && scratch.changed(i, bodies) {
                            stamp[i] = resolutions;
                        }
                    }
                    continue;
                }
                met[g] = true;
                done[g] = true;
                spent[g] |= struck_again(last_impact[g], event_time, params.dt)
                    && contacts[groups[g].clone()]
                        .iter()
                        .all(|c| c.restitution < 1.0);
                last_impact[g] = event_time;
                let (a, b) = pairs[g].expect("an event's groups have bodies");
                if let Some(clusters) = clusters.as_mut() {
                    clusters.join(a, b, bodies);
                }
                for i in [a, b] {
                    if bodies[i].motion == Motion::Dynamic {
                        stamp[i] = resolutions;
                    }
                }
            }
            // Groups of the bodies the event struck (the event's own among them) that approach
            // now take their turn in this sweep, in time order with the rest, or, resolved
            // already (a block stopped by its iteration bound may still approach), in the next
            // sweep, their bodies' stamps being newer than their checks; those that do not
            // approach are checked as of now. (Each body once: `before` lists them.)
            for &(body, _, _) in &scratch.before {
                if stamp[body] != resolutions {
                    continue;
                }
                for &l in touching.of(body) {
                    let l = l as usize;
                    match approaches(l, stamp, bodies, contacts, met, spent) {
                        None => checked[l] = resolutions,
                        Some(time) if !done[l] => queue.push(Reverse(Queued { time, group: l })),
                        // Resolved in this sweep and approaching again: it waits for the next
                        // sweep, and so does every later approach of its clusters.
                        Some(time) => {
                            if let Some(clusters) = clusters.as_mut() {
                                clusters.defer(pairs[l], time, bodies);
                            }
                        }
                    }
                }
            }
        }
    }
    report
}

/// True when no group approaches at the start of the step (see `approach_time`; before any
/// impact no group has met and none is chained): then a propagation pass does nothing, and a
/// settled pile's pass is this one look at its contacts, without the pass's per-group state.
fn nothing_approaches(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    groups: &[Range<usize>],
    params: &Propagation,
) -> bool {
    groups
        .iter()
        .filter(|g| has_rows(contacts, g))
        .all(|g| approach_time(bodies, contacts, g, params, false, false).is_none())
}

/// The group is not empty and starts within `contacts` (the pass ignores any other).
fn has_rows(contacts: &[ContactConstraint], group: &Range<usize>) -> bool {
    !group.is_empty() && group.start < contacts.len()
}

#[cfg(test)]
mod tests;
