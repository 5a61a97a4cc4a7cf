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

use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;
use std::ops::Range;

use bevy::math::Vec3;

use super::body::{Motion, SolverBody};
use super::contact::ContactConstraint;
use super::lcp::{self, DenseSolve};
use crate::impulse::row_impulse;

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
pub fn propagate(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    groups: &[Range<usize>],
    params: &Propagation,
) -> PropagationReport {
    let mut report = PropagationReport::default();
    let mut scratch = EventScratch {
        slot: vec![u32::MAX; bodies.len()],
        ..EventScratch::default()
    };
    // Only a group one of whose bodies changed velocity since the group was last checked can
    // have started to approach: `stamp` is, per body, the number of the resolution that last
    // changed it, and `checked` per group the resolution count when it was last found not
    // approaching (or resolved). The pass stops as soon as no group needs a check, so an
    // island of one impact costs one sweep, not a second one that finds nothing.
    let mut stamp = vec![0u32; bodies.len()];
    let mut checked = vec![0u32; groups.len()];
    // The group's gap closed at an impact earlier in this pass: it touches from then on.
    let mut met = vec![false; groups.len()];
    let mut resolutions = 0u32;
    // The body pair of each group (the groups are single contacts or one pair's manifold).
    let pairs: Vec<Option<(usize, usize)>> = groups
        .iter()
        .map(|g| {
            contacts
                .get(g.start)
                .filter(|_| !g.is_empty())
                .map(|c| (c.body_a, c.body_b))
        })
        .collect();
    let touching = GroupsOfBody::new(bodies, &pairs);
    // The bodies in contact, and the approaches that wait for the next sweep (see `Clusters`).
    let mut clusters = params
        .wait_in_cluster
        .then(|| Clusters::new(bodies, contacts, groups, &pairs, params.touch));
    // Postponed in the last sweep (see `Clusters`): checked again in the next.
    let mut postponed = vec![false; groups.len()];
    let needs_check = |k: usize, stamp: &[u32], checked: &[u32], postponed: &[bool], sweeps| {
        pairs[k].is_some_and(|(a, b)| {
            sweeps == 0 || postponed[k] || stamp[a].max(stamp[b]) > checked[k]
        })
    };
    let mut event: Vec<usize> = Vec::new();
    let mut in_event = vec![false; groups.len()];
    // The event's groups that join it as touching inelastic contacts (see `JOINED_ROWS`).
    let mut joined = vec![false; groups.len()];
    // Resolved in the current sweep: each group is resolved at most once a sweep.
    let mut done = vec![false; groups.len()];
    // The sweep's approaching groups by time of impact, earliest first (ties by index).
    let mut queue: BinaryHeap<Reverse<Queued>> = BinaryHeap::new();
    loop {
        let pending =
            (0..groups.len()).any(|k| needs_check(k, &stamp, &checked, &postponed, report.sweeps));
        if !pending {
            break;
        }
        if report.sweeps == params.max_sweeps {
            report.bound_hit = (0..groups.len()).any(|k| {
                let chain = chained(pairs[k], &stamp);
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
                          met: &[bool]| {
            let chain = chained(pairs[k], stamp);
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
            if !needs_check(k, &stamp, &checked, &postponed, report.sweeps - 1) {
                continue;
            }
            postponed[k] = false;
            match approaches(k, &stamp, bodies, contacts, &met) {
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
            let Some(time) = approaches(k, &stamp, bodies, contacts, &met) else {
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
                let Some((a, b)) = pairs[g] else { continue };
                for body in [a, b] {
                    for &l in touching.of(body) {
                        let l = l as usize;
                        if in_event[l] || done[l] {
                            continue;
                        }
                        let Some(t) = approaches(l, &stamp, bodies, contacts, &met) else {
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
            }
            // Then, if the event is inelastic, the touching inelastic groups of its bodies,
            // transitively, nearest first, while it has fewer than `JOINED_ROWS` rows.
            let inelastic = params.join_touching
                && event.iter().all(|&g| {
                    contacts[groups[g].clone()]
                        .iter()
                        .all(|c| c.restitution == 0.0)
                });
            let mut rows = event.iter().map(|&g| groups[g].len()).sum::<usize>();
            let mut next = if inelastic { 0 } else { event.len() };
            while next < event.len() && rows < JOINED_ROWS {
                let g = event[next];
                next += 1;
                let Some((a, b)) = pairs[g] else { continue };
                for body in [a, b] {
                    for &l in touching.of(body) {
                        let l = l as usize;
                        if in_event[l]
                            || rows >= JOINED_ROWS
                            || !joins(&contacts[groups[l].clone()], params.touch)
                        {
                            continue;
                        }
                        in_event[l] = true;
                        joined[l] = true;
                        event.push(l);
                        rows += groups[l].len();
                    }
                }
            }
            resolve_event(
                bodies,
                contacts,
                groups,
                &event,
                &met,
                &joined,
                event_time,
                params,
                &mut scratch,
            );
            report.resolutions += 1;
            resolutions += 1;
            for &g in &event {
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
                    match approaches(l, &stamp, bodies, contacts, &met) {
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

/// The dynamic bodies that touch, through contacts touching at the start of the step or met at
/// an impact of this pass (a union-find over bodies), and, per cluster, the earliest approach
/// that waits for the next sweep.
///
/// Why: a sweep resolves each group at most once, so a group that an impact sets approaching
/// again after it was resolved (inelastic collapse: a die pressed onto the ground by the die on
/// it, after the ground has stopped it) waits for the next sweep, and with it the time order
/// of the impacts is lost for every body that contact reaches. Two 1 mm dice one on the other,
/// both falling at the step's `g dt` (0.16 m/s) under the propagation method: the ground
/// stopped the lower die, the pair's contact left both at half the speed, and the lower die's
/// ground contact, approaching again at time 0, waited for the next sweep; the upper die's
/// speculative contact with the ground through the lower die (a 1 mm gap, which the step's
/// fall `g dt^2` = 2.7 mm reaches) was then resolved in the same sweep at its time of impact,
/// 12 ms, as if the lower die were not there: the upper die was placed on the ground, inside
/// the lower one. So an approach later than one that waits, on any body touching-connected
/// to its bodies, waits too, and is itself recorded as waiting at its own time, so that the
/// approaches it would have struck in turn wait after it. Clusters that touch nothing waiting
/// run their impacts in the sweep, in time order, as before.
struct Clusters {
    /// Union-find parent of each body (dynamic bodies only take part).
    parent: Vec<u32>,
    /// Per cluster root: the sweep and the earliest time, s, of an approach waiting in it.
    waiting: Vec<(u32, f32)>,
    /// The current sweep's number.
    sweep: u32,
}

impl Clusters {
    fn new(
        bodies: &[SolverBody],
        contacts: &[ContactConstraint],
        groups: &[Range<usize>],
        pairs: &[Option<(usize, usize)>],
        touch: f32,
    ) -> Self {
        let mut clusters = Clusters {
            parent: (0..bodies.len() as u32).collect(),
            waiting: vec![(0, 0.0); bodies.len()],
            sweep: 0,
        };
        for (range, &pair) in groups.iter().zip(pairs) {
            if let Some((a, b)) = pair
                && contacts[range.clone()].iter().any(|c| touches(c, touch))
            {
                clusters.join(a, b, bodies);
            }
        }
        clusters
    }

    fn root(&mut self, mut i: usize) -> usize {
        while self.parent[i] as usize != i {
            let up = self.parent[self.parent[i] as usize];
            self.parent[i] = up;
            i = up as usize;
        }
        i
    }

    /// Bodies `a` and `b` touch: their clusters are one (static and kinematic bodies join
    /// nothing, their velocities being given).
    fn join(&mut self, a: usize, b: usize, bodies: &[SolverBody]) {
        let dynamic = |i: usize| bodies[i].motion == Motion::Dynamic;
        if !(dynamic(a) && dynamic(b)) {
            return;
        }
        let (ra, rb) = (self.root(a), self.root(b));
        if ra == rb {
            return;
        }
        let merged = match (self.waiting_at(ra), self.waiting_at(rb)) {
            (Some(x), Some(y)) => Some(x.min(y)),
            (x, y) => x.or(y),
        };
        self.parent[rb] = ra as u32;
        if let Some(time) = merged {
            self.waiting[ra] = (self.sweep, time);
        }
    }

    fn begin_sweep(&mut self) {
        self.sweep += 1;
    }

    /// The earliest waiting approach of the cluster rooted at `root` in this sweep.
    fn waiting_at(&self, root: usize) -> Option<f32> {
        let (sweep, time) = self.waiting[root];
        (sweep == self.sweep).then_some(time)
    }

    /// An approach of the group of `pair` at `time` (s) waits for the next sweep.
    fn defer(&mut self, pair: Option<(usize, usize)>, time: f32, bodies: &[SolverBody]) {
        let Some((a, b)) = pair else { return };
        for i in [a, b] {
            if bodies[i].motion != Motion::Dynamic {
                continue;
            }
            let root = self.root(i);
            let earliest = self.waiting_at(root).map_or(time, |t| t.min(time));
            self.waiting[root] = (self.sweep, earliest);
        }
    }

    /// The group of `pair`, approaching at `time`, must wait: a cluster of one of its bodies
    /// has an approach waiting from before `time - simultaneous`.
    fn waits(&mut self, pair: Option<(usize, usize)>, time: f32, simultaneous: f32) -> bool {
        let Some((a, b)) = pair else { return false };
        [a, b].into_iter().any(|i| {
            let root = self.root(i);
            self.waiting_at(root)
                .is_some_and(|t| time > t + simultaneous)
        })
    }
}

/// Impacts of groups sharing a body whose times of impact differ by at most this fraction of
/// the step are one event, resolved together (a ball striking two resting balls placed
/// symmetrically strikes both at once; resolving one first gives an asymmetric answer).
/// 1e-4 of a 60 Hz step is 1.7 us, far below what a step resolves, and far above the f32
/// rounding of a time of impact (about 1e-7 of the step).
const SIMULTANEOUS: f32 = 1e-4;

/// An inelastic impact event (every contact of its groups `e = 0`) takes in the touching
/// inelastic groups (see [`joins`]) of its bodies, and theirs in turn, nearest first, until it
/// has this many rows (with [`Propagation::join_touching`]); up to [`DENSE_ROWS`] rows it is
/// solved exactly ([`lcp`]).
///
/// Why: a touching contact with `e = 0` holds, whether it is struck or pressed. Left out of the
/// event, a heavy body landing on a light one on the floor stopped only the pair: both then
/// moved down at `M / (M + m)` of the approach, the light body's floor contact stopped it in its
/// own event, the heavy one struck it again, and so on, a factor `M / (M + m)` a sweep (the
/// mixed pour's landings, ratios to 100:1, hit the bound of 64 sweeps). With the floor contact
/// in the event, both stop at once. Only inelastic events and contacts: with restitution, the
/// order of the impacts is the physics (Newton's cradle; a ball dropped on a box resting on the
/// ground gives the box its momentum, which the ground then takes, and does not rebound as from
/// the ground), which is what propagation resolves. 64 rows: 16 box manifolds; the events'
/// cost grows with the cube of the rows that push (a 4,000-sphere pour's landings cost 1.4 times
/// the bound-limited sweeps with 64, 1.7 times with 128).
const JOINED_ROWS: usize = 64;

/// An event whose rows have friction is solved in at most this many rounds: the normal block,
/// then each row that pushed in the round stops its tangential slip within the Coulomb disk of
/// that round's impulse (see [`ContactConstraint::apply_stick_impulse`]), and, if that set rows
/// approaching again (friction at one contact presses on the others through the bodies'
/// turning and through oblique normals), the block again from no impulse, with targets
/// `min(target, -max(v_n, 0))` at the velocities after the friction. The last round is the
/// normal block alone, so friction never ends an event with a row approaching.
///
/// Each application takes energy out or none: the friction by its own bound; a later block,
/// since a row that pushes ends at its target `v'` from a velocity `v` with `v + v' <=
/// min(v, 0) <= 0` (its energy change `sum lambda (v + v') / 2`, as for the first block). The
/// tangential impulses of the rounds sum to at most `mu` times the normal ones (each round
/// stays within its own disk), so the event stays within Coulomb's cone. Why in the event:
/// friction applied once after the block, the approaches it left became new impacts of the
/// pass, a sweep each, and the mixed pour (friction 0.5, ratios to 100:1) hit the bound of 64
/// sweeps at step 48; without friction in the event at all, a light body was squeezed out
/// sideways between two heavy ones at 13.2 m/s (its free-fall bound 12.3 m/s), which Coulomb
/// friction at its contacts resists.
///
/// Which rows: under the hybrid method ([`Propagation::join_touching`]) all, its touching rows
/// being holds inside an impact; under the propagation method, whose pass is also its resting
/// solve, only rows that did not touch at the step's start. There a resting contact is an
/// impact every step, one body pair at a time, and friction at it couples a stack into one
/// column that rocks on its base, the tilt growing 2-fold in 3 steps (two 1 mm dice at
/// 60 Hz, 1 m dice under 1000 g by scaling: they toppled into each other at 30, 60 and
/// 120 Hz, and so did two and three 1 cm dice at 30 Hz); that is, propagation's resting
/// contacts stay frictionless, as before.
const EVENT_FRICTION_ROUNDS: u32 = 4;

/// Events of at most this many solving rows are solved exactly ([`lcp`]); larger ones (many
/// simultaneous impacts) by Gauss-Seidel on the block.
const DENSE_ROWS: usize = 256;

/// The group (one body pair's rows) joins an impact event of one of its bodies as touching:
/// every row is inelastic and one of them touches ([`touches`]).
fn joins(rows: &[ContactConstraint], touch: f32) -> bool {
    rows.iter().all(|c| c.restitution == 0.0) && rows.iter().any(|c| touches(c, touch))
}

/// The row of a joined group takes part in the event: it can push, and it touches at the
/// start of the step (separated by at most `touch`, the resting phase's slop), or has pushed at
/// an impact of this pass. A speculative row is not held: it meets later, in its own event at
/// its own time. (Not the group's `met`: that a tilted manifold met at one corner does not
/// close the gap of the others.) Why the slop: the corners of a resting face are at separations
/// of either sign by f32 rounding (1e-7 m); taking only those at or below zero, a column under
/// propagation held its upper part on two corners of one edge, turned it about that edge
/// (0.2 rad/s) and toppled.
fn touches(c: &ContactConstraint, touch: f32) -> bool {
    c.normal_mass > 0.0 && (c.separation <= touch || c.total_impulse > 0.0)
}

/// A group waiting in a sweep's queue at its time of impact (ordered by time, then index).
#[derive(Clone, Copy, Debug)]
struct Queued {
    time: f32,
    group: usize,
}

impl PartialEq for Queued {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Queued {}

impl PartialOrd for Queued {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Queued {
    fn cmp(&self, other: &Self) -> Ordering {
        self.time
            .total_cmp(&other.time)
            .then(self.group.cmp(&other.group))
    }
}

/// For each dynamic body, the groups that touch it (compressed rows).
struct GroupsOfBody {
    start: Vec<u32>,
    groups: Vec<u32>,
}

impl GroupsOfBody {
    fn new(bodies: &[SolverBody], pairs: &[Option<(usize, usize)>]) -> Self {
        let dynamic = |i: usize| bodies[i].motion == Motion::Dynamic;
        let mut start = vec![0u32; bodies.len() + 1];
        for &(a, b) in pairs.iter().flatten() {
            for i in [a, b].into_iter().filter(|&i| dynamic(i)) {
                start[i + 1] += 1;
            }
        }
        for i in 0..bodies.len() {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut groups = vec![0u32; start[bodies.len()] as usize];
        for (k, (a, b)) in pairs
            .iter()
            .enumerate()
            .filter_map(|(k, p)| p.map(|p| (k, p)))
        {
            for i in [a, b].into_iter().filter(|&i| dynamic(i)) {
                groups[fill[i] as usize] = k as u32;
                fill[i] += 1;
            }
        }
        GroupsOfBody { start, groups }
    }

    fn of(&self, body: usize) -> &[u32] {
        &self.groups[self.start[body] as usize..self.start[body + 1] as usize]
    }
}

/// Either body of the pair was struck earlier in this pass: the group is part of a chain of
/// impacts.
#[inline]
fn chained(pair: Option<(usize, usize)>, stamp: &[u32]) -> bool {
    pair.is_some_and(|(a, b)| stamp[a] > 0 || stamp[b] > 0)
}

/// The contact approaches faster than the threshold and, if it is speculative, closes within
/// the step. `met`: its gap closed at an earlier impact of this pass. `chain`: one of its
/// bodies was struck in this pass, so a contact with restitution counts from
/// [`Propagation::chain_threshold`]: the restitution threshold exists to keep resting bodies
/// from hopping under gravity, and an impact passed on along a chain is not that.
#[inline]
fn approaching(
    c: &ContactConstraint,
    bodies: &[SolverBody],
    params: &Propagation,
    met: bool,
    chain: bool,
) -> bool {
    if c.normal_mass == 0.0 {
        return false;
    }
    let vn = c.normal_velocity(bodies);
    let gn = pass_gravity(c, bodies, params);
    vn < -threshold(c, params, chain) && closes_within(gap(c, met), vn, gn, params)
}

/// The approach speed above which `c` counts as approaching (see [`approaching`]).
#[inline]
fn threshold(c: &ContactConstraint, params: &Propagation, chain: bool) -> f32 {
    if chain && c.restitution > 0.0 {
        params.chain_threshold.min(params.threshold)
    } else {
        params.threshold
    }
}

/// The group's time of impact (see [`group_time`]) if it approaches: one of its contacts is
/// [`approaching`] at the start of the step, and still approaches as fast at that time, with
/// its anchors where [`resolve_event`] solves it ([`at_time`]).
///
/// Why both: the queue and the event must agree. Taken at the start of the step only, a
/// contact of a body spinning fast (a 0.5 m capsule at 16 rad/s after earlier impacts of the
/// step) approached at 1.46 m/s at its anchors, but at its anchors moved to its time of impact,
/// 0.015 s later, it separated at 0.76 m/s: the event found nothing to push, or pushed it to
/// rest there, the contact still approached at the start of the step, and it was picked up
/// again every sweep with the same velocities until the sweep bound (the mixed pour's first
/// landing, all 45 events of its 63rd sweep). An event leaves each of its contacts at or above
/// its target at that time, which is not approaching, so a resolved group is only picked up
/// again when another impact changes its bodies.
fn approach_time(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    group: &Range<usize>,
    params: &Propagation,
    met: bool,
    chain: bool,
) -> Option<f32> {
    let rows = &contacts[group.clone()];
    if !rows
        .iter()
        .any(|c| approaching(c, bodies, params, met, chain))
    {
        return None;
    }
    let time = group_time(bodies, contacts, group, params, met);
    if time <= 0.0 {
        return Some(time);
    }
    rows.iter()
        .any(|c| {
            approaching(c, bodies, params, met, chain)
                && at_time(c, bodies, time).normal_velocity(bodies) < -threshold(c, params, chain)
        })
        .then_some(time)
}

/// The contact with its anchors moved to where its two bodies meet at `toi` into the step (see
/// [`resolve_event`]), its normal row prepared for them.
fn at_time(c: &ContactConstraint, bodies: &[SolverBody], toi: f32) -> ContactConstraint {
    let mut row = *c;
    if toi > 0.0 {
        let (a, b) = (&bodies[c.body_a], &bodies[c.body_b]);
        let inverse = a.inverse_mass + b.inverse_mass;
        let (w_a, w_b) = if inverse > 0.0 {
            (a.inverse_mass / inverse, b.inverse_mass / inverse)
        } else {
            (0.5, 0.5)
        };
        let u_a = a.linear_velocity + a.angular_velocity.cross(row.anchor_a);
        let u_b = b.linear_velocity + b.angular_velocity.cross(row.anchor_b);
        let meet = (w_a * u_a + w_b * u_b) * toi;
        row.anchor_a += meet - a.linear_velocity * toi;
        row.anchor_b += meet - b.linear_velocity * toi;
        row.prepare_normal_row(a, b);
    }
    row
}

/// The gap the contact has to close: its separation at the start of the step, or none once it
/// met at an impact of this pass.
#[inline]
fn gap(c: &ContactConstraint, met: bool) -> f32 {
    if met {
        c.separation.min(0.0)
    } else {
        c.separation
    }
}
/// The gap `s` closes within the step at normal velocity `vn` and normal acceleration `gn`, as
/// the substepped integration will move the bodies.
#[inline]
fn closes_within(s: f32, vn: f32, gn: f32, params: &Propagation) -> bool {
    let dt = params.dt;
    let discrete = if gn < 0.0 {
        1.0 + 1.0 / params.substeps.max(1) as f32
    } else {
        1.0
    };
    s <= 0.0 || s + vn * dt + 0.5 * gn * dt * dt * discrete < 0.0
}

/// The earliest `t >= 0` with `s + vn t + gn t^2 / 2 = 0` (for `s > 0`, `vn < 0`), or 0 when
/// the gap is already closed.
#[inline]
pub(super) fn time_of_impact(s: f32, vn: f32, gn: f32) -> f32 {
    if s <= 0.0 {
        return 0.0;
    }
    if gn.abs() < 1e-12 {
        return s / -vn;
    }
    // Stable root of gn/2 t^2 + vn t + s = 0: t = 2 s / (-vn + sqrt(vn^2 - 2 gn s)).
    let disc = (vn * vn - 2.0 * gn * s).max(0.0);
    2.0 * s / (-vn + disc.sqrt())
}

/// Relative acceleration of the pair along the normal due to gravity, `(g_B - g_A) . n`, with
/// gravity acting on dynamic bodies only; with `extra`, each dynamic body's
/// [`extra_acceleration`](SolverBody::extra_acceleration) is added to its gravity (see
/// [`SolverBody::acceleration`]).
#[inline]
pub(super) fn relative_gravity(
    c: &ContactConstraint,
    bodies: &[SolverBody],
    gravity: Vec3,
    extra: bool,
) -> f32 {
    let (a, b) = (&bodies[c.body_a], &bodies[c.body_b]);
    if extra && (a.extra_acceleration != Vec3::ZERO || b.extra_acceleration != Vec3::ZERO) {
        return (b.acceleration(gravity) - a.acceleration(gravity)).dot(c.normal);
    }
    if gravity == Vec3::ZERO {
        return 0.0;
    }
    let g = |i: usize| {
        if bodies[i].motion == Motion::Dynamic {
            gravity
        } else {
            Vec3::ZERO
        }
    };
    (g(c.body_b) - g(c.body_a)).dot(c.normal)
}

/// The pair's relative acceleration along the normal that is integrated after the pass,
/// `params.gravity` with the bodies' extra accelerations when they come after it too.
#[inline]
fn pass_gravity(c: &ContactConstraint, bodies: &[SolverBody], params: &Propagation) -> f32 {
    relative_gravity(c, bodies, params.gravity, !params.accelerations_integrated)
}

/// When the group's impact happens within the step: its earliest closing point's time of
/// impact, not before either body's latest impact (see [`propagate`]).
fn group_time(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    group: &Range<usize>,
    params: &Propagation,
    met: bool,
) -> f32 {
    let rows = &contacts[group.clone()];
    let (ia, ib) = (rows[0].body_a, rows[0].body_b);
    let gn = pass_gravity(&rows[0], bodies, params);
    let geometric = rows
        .iter()
        .filter_map(|c| {
            let vn = c.normal_velocity(bodies);
            let s = gap(c, met);
            (c.normal_mass > 0.0 && vn < 0.0 && closes_within(s, vn, gn, params))
                .then(|| time_of_impact(s, vn, gn))
        })
        .fold(f32::INFINITY, f32::min);
    bodies[ia]
        .impact_time
        .max(bodies[ib].impact_time)
        .max(geometric.min(params.dt))
}

/// Buffers of [`resolve_event`], kept across events of a pass.
#[derive(Default)]
struct EventScratch {
    /// Copies of the event's rows, anchors moved to the time of impact.
    rows: Vec<ContactConstraint>,
    /// Per row: its index in the contact slice, its restitution target (NaN: not closing, it
    /// takes no part) and its accumulated impulse of this resolution.
    state: Vec<(usize, f32, f32)>,
    /// Velocities of the event's bodies before it: `(body, v, w)`.
    before: Vec<(usize, Vec3, Vec3)>,
    /// Per body, its index in `before`, or `u32::MAX`.
    slot: Vec<u32>,
    /// The exact solve of the block.
    dense: DenseSolve,
    /// Per row, its target in f64 (NaN: it takes no part).
    targets: Vec<f64>,
    /// Per row, its impulse in the block solve of the current round (see
    /// [`EVENT_FRICTION_ROUNDS`]).
    round: Vec<f32>,
    /// The rows that pushed in a round, as (body a, body b, row), sorted by pair.
    pairs: Vec<(usize, usize, usize)>,
}

impl EventScratch {
    /// The last event changed the velocities of `body`, one of its bodies.
    fn changed(&self, body: usize, bodies: &[SolverBody]) -> bool {
        let (_, v, w) = self.before[self.slot[body] as usize];
        bodies[body].linear_velocity != v || bodies[body].angular_velocity != w
    }
}

/// Resolves one impact event: the rows of `event`'s groups, solved together as one block at
/// time `toi` into the step.
///
/// Each row's anchors are moved to where its two bodies meet at `toi`: each body's material
/// point has moved by its velocity times `t`, and the two surface points meet at one common
/// point, so that the equal and opposite impulses act at the same place (with anchors from the
/// start of the step they would act at two points `t (u_B - u_A)` apart, a spurious torque).
/// The common point is the mean of the two material points weighted by inverse mass,
/// `(w_A u_A + w_B u_B) t` from the start, `w = (1/m) / (1/m_A + 1/m_B)`: the midpoint for equal masses,
/// and the moving body's own point against a fixed one. The latter matters: a wall's closest
/// point at the start of the step is not the point that gets hit, and a ball sliding along the
/// wall as it closes in (a fast ball falling under gravity) would otherwise be struck off its
/// line of centres and set spinning (at 100 m/s, 0.1 s of gravity, that cost 10% of the normal
/// impulse).
///
/// Each closing row's target is `-e v_n - (1 + e) g_n t` (see [`propagate`]), with `v_n` taken
/// before the event, and the accumulated impulses (clamped at >= 0) are the exact solution of
/// the event's block ([`lcp`]), or beyond [`DENSE_ROWS`] rows (or should that solve fail)
/// found by Gauss-Seidel on it; a single row is solved in one pass, `j = -(1+e) v_n / K`. The
/// exact block solution never adds energy: with `v'_i = -e v_i` on every row that pushes and
/// `lambda_i = 0` on the others, the energy change `sum lambda_i (v_i + v'_i) / 2 =
/// sum lambda_i (1 - e) v_i / 2` is at most 0, since `v_i < 0`. A joined touching row (see
/// [`JOINED_ROWS`]) has the target `-max(v_n, 0) - max(s, 0) / (dt - t)`: it may not approach,
/// or if it separated, not faster than it separated, or if it is apart by `s` (within the
/// touch distance), not faster than closes the gap by the end of the step; its term
/// `lambda_i (v_i + v'_i) / 2` is then at most `lambda_i min(v_i, 0) / 2 <= 0` as well.
///
/// When the velocities already include the step's gravity (`params.integrated_gravity`, the
/// propagation method), only the approach the row had when it met is bounced: with `g_n` the
/// pair's relative gravity along the normal (pulling them together, `g_n < 0`), the row met at
/// `v_n - g_n (dt - t)` and gravity then acts on for `dt - t`, so the target is
/// `-e (v_n - g_n (dt - t)) + g_n (dt - t)`, and never below 0: a row whose bounce gravity
/// would undo within the step rests. (Without integrated gravity the target is `-e v_n` as it
/// always was, bit for bit: `v_n`, taken at the anchors moved to the time of impact, may be
/// positive there, and the hybrid method's impacts are left exactly as they were.) A resting contact, whose whole approach is the step's
/// `g dt`, is then inelastic whatever its restitution. (Bouncing `v_n` itself bounced the
/// step's gravity too: an e = 1 box resting on the ground hopped 3 cm, and in the energy
/// property test a 4 g capsule gained 5-20% of its energy per bounce, seed 111.) A pull apart
/// (`g_n > 0`) is left out of the target, which can only lower it.
#[allow(clippy::too_many_arguments)]
fn resolve_event(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    groups: &[Range<usize>],
    event: &[usize],
    met: &[bool],
    joined: &[bool],
    toi: f32,
    params: &Propagation,
    scratch: &mut EventScratch,
) {
    let EventScratch {
        rows,
        state,
        before,
        slot,
        dense,
        targets,
        round,
        pairs,
    } = scratch;
    rows.clear();
    state.clear();
    for &(i, _, _) in before.iter() {
        slot[i] = u32::MAX;
    }
    before.clear();
    targets.clear();
    for &g in event {
        let range = groups[g].clone();
        let first = &contacts[range.start];
        let (ia, ib) = (first.body_a, first.body_b);
        for i in [ia, ib] {
            if slot[i] == u32::MAX {
                slot[i] = before.len() as u32;
                before.push((i, bodies[i].linear_velocity, bodies[i].angular_velocity));
            }
        }
        let gn = pass_gravity(first, bodies, params);
        let integrated = relative_gravity(
            first,
            bodies,
            params.integrated_gravity,
            params.accelerations_integrated,
        );
        for index in range {
            let start = &contacts[index];
            if joined[g] {
                // A touching inelastic row: it may not approach after the event, or if it
                // separated, not faster than it separated (so that it never adds energy).
                let row = at_time(start, bodies, toi);
                let (target, exact) = if touches(start, params.touch) {
                    let vn = lcp::normal_velocity(&row, bodies);
                    let rest = (params.dt - toi) as f64;
                    let gap = if start.total_impulse > 0.0 || rest <= 0.0 {
                        0.0
                    } else {
                        start.separation.max(0.0) as f64 / rest
                    };
                    let t = -(vn.max(0.0)) - gap;
                    (t as f32, t)
                } else {
                    (f32::NAN, f64::NAN)
                };
                rows.push(row);
                state.push((index, target, 0.0));
                targets.push(exact);
                continue;
            }
            let vn = start.normal_velocity(bodies);
            let closing = start.normal_mass > 0.0
                && vn < 0.0
                && closes_within(gap(start, met[g]), vn, gn, params);
            let row = at_time(start, bodies, toi);
            // The target in f64 for the exact solve (the same formula).
            targets.push(if closing {
                let vn = lcp::normal_velocity(&row, bodies);
                let (e, toi, gn) = (row.restitution as f64, toi as f64, gn as f64);
                let after = integrated.min(0.0) as f64 * (params.dt as f64 - toi);
                let bounce = if after < 0.0 {
                    (-e * (vn - after).min(0.0) + after).max(0.0)
                } else {
                    -e * vn
                };
                bounce - (1.0 + e) * gn * toi
            } else {
                f64::NAN
            });
            // Points that are not closing within the step take no part (NaN marks them).
            let target = if closing {
                let vn = row.normal_velocity(bodies);
                let after = integrated.min(0.0) * (params.dt - toi);
                let bounce = if after < 0.0 {
                    (-row.restitution * (vn - after).min(0.0) + after).max(0.0)
                } else {
                    -row.restitution * vn
                };
                bounce - (1.0 + row.restitution) * gn * toi
            } else {
                f32::NAN
            };
            rows.push(row);
            state.push((index, target, 0.0));
        }
    }

    // The block's impulses (see `solve_block`); then, where rows have friction, rounds of
    // friction and normal holds (see `EVENT_FRICTION_ROUNDS`).
    for round_count in 1..=EVENT_FRICTION_ROUNDS {
        solve_block(rows, state, targets, round, bodies, dense, params);
        for (entry, &j) in state.iter_mut().zip(round.iter()) {
            entry.2 += j;
        }
        // The last round ends with the normal block: friction never leaves a row approaching.
        if round_count == EVENT_FRICTION_ROUNDS {
            break;
        }
        // Friction by body pair (an event's rows of one pair are one group under the hybrid
        // method, a group each under propagation), in the pairs' order.
        pairs.clear();
        pairs.extend(
            rows.iter()
                .zip(round.iter())
                .enumerate()
                .filter(|(i, (row, j))| {
                    **j > 0.0
                        && row.friction > 0.0
                        && (params.join_touching || !touches(&contacts[state[*i].0], params.touch))
                })
                .map(|(i, (row, _))| (row.body_a, row.body_b, i)),
        );
        pairs.sort_unstable();
        let mut slipping = false;
        for pair in pairs.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
            let pair = pair.iter().map(|&(_, _, i)| (&rows[i], round[i]));
            if let Some((centre, load)) = manifold_centre(pair, bodies) {
                centre.apply_stick_impulse(bodies, centre.friction * load);
                slipping = true;
            }
        }
        if !slipping {
            break;
        }
        // The next round holds what friction set approaching, at targets that can only take
        // energy out: `min(target, -max(v_n, 0))` (see `EVENT_FRICTION_ROUNDS`).
        let mut approaching = false;
        for ((row, entry), exact) in rows.iter().zip(state.iter_mut()).zip(targets.iter_mut()) {
            if entry.1.is_nan() {
                continue;
            }
            let vn = row.normal_velocity(bodies);
            entry.1 = entry.1.min(-vn.max(0.0));
            *exact = exact.min(-lcp::normal_velocity(row, bodies).max(0.0));
            approaching |= vn < entry.1 - params.velocity_tolerance;
        }
        if !approaching {
            break;
        }
    }
    let mut joined_rows = event
        .iter()
        .flat_map(|&g| groups[g].clone().map(move |_| joined[g]));
    for &(index, _, accumulated) in state.iter() {
        let joined = joined_rows.next().expect("a flag a row");
        if accumulated > 0.0 {
            let c = &mut contacts[index];
            c.total_impulse += accumulated;
            // A touching row that only held is not an impact.
            c.impact |= !joined;
        }
    }
    for &(i, v, w) in before.iter() {
        owe_offset(&mut bodies[i], v, w, toi);
    }
}

/// The friction row of one body pair's rows in an event (with the round's normal impulses):
/// the row that pushed hardest, moved to the centre of the normal impulses (their
/// impulse-weighted mean anchor on each body), with its tangent rows prepared there, and the
/// round's total normal impulse, its Coulomb load; `None` if the pair has no friction or did
/// not push.
///
/// Why the centre and not each point: a manifold's normal impulses are not unique (four
/// corners on a face hold a body with any of many splits; the exact solve returns one at a
/// vertex, two corners), but their resultant and its line of action are (they stop the same
/// body velocities). Friction limited corner by corner by such a split pushes unevenly and
/// turns the body: a 1 mm die resting on another at 30 Hz (friction 0.5) tilted from f32
/// rounding, 2-fold a step, until one corner took a step's fall alone (243 rad/s) and the
/// pair fell apart. At the centre, the load and its point are the resultant's.
fn manifold_centre<'a>(
    pair: impl Iterator<Item = (&'a ContactConstraint, f32)> + Clone,
    bodies: &[SolverBody],
) -> Option<(ContactConstraint, f32)> {
    let (hardest, most) = pair.clone().max_by(|x, y| x.1.total_cmp(&y.1))?;
    if most.is_nan() || most <= 0.0 || hardest.friction.is_nan() || hardest.friction <= 0.0 {
        return None;
    }
    let (mut load, mut anchor_a, mut anchor_b) = (0.0, Vec3::ZERO, Vec3::ZERO);
    for (row, j) in pair.filter(|&(_, j)| j > 0.0) {
        load += j;
        anchor_a += j * row.anchor_a;
        anchor_b += j * row.anchor_b;
    }
    let mut centre = *hardest;
    centre.anchor_a = anchor_a / load;
    centre.anchor_b = anchor_b / load;
    centre.prepare_tangent_rows(&bodies[centre.body_a], &bodies[centre.body_b]);
    Some((centre, load))
}

/// Solves the normal rows of an event's block towards their targets (`state`'s, and `targets`
/// in f64 for the exact solve; NaN: the row takes no part), from no impulse: the exact
/// solution of the block ([`lcp`]) up to [`DENSE_ROWS`] rows, or Gauss-Seidel on it (should
/// the exact solve fail, or beyond), where a single row is solved in one pass,
/// `j = (target - v_n) / K`. Applies the impulses (clamped >= 0) and leaves them in `impulses`,
/// one a row.
fn solve_block(
    rows: &[ContactConstraint],
    state: &[(usize, f32, f32)],
    targets: &[f64],
    impulses: &mut Vec<f32>,
    bodies: &mut [SolverBody],
    dense: &mut DenseSolve,
    params: &Propagation,
) {
    impulses.clear();
    impulses.resize(rows.len(), 0.0);
    let solving = state.iter().filter(|(_, t, _)| !t.is_nan()).count();
    let mut iterations = if solving == 1 {
        1
    } else {
        params.max_block_iterations.max(1)
    };
    if solving > 1 && solving <= DENSE_ROWS {
        dense.clear();
        for (row, &target) in rows.iter().zip(targets.iter()) {
            if !target.is_nan() {
                dense.push(row, bodies, target);
            }
        }
        if let Some(solved) = dense.solve() {
            let mut solved = solved.iter();
            for ((row, &target), accumulated) in
                rows.iter().zip(targets.iter()).zip(impulses.iter_mut())
            {
                if target.is_nan() {
                    continue;
                }
                let j = *solved.next().expect("one impulse a solving row") as f32;
                if j > 0.0 {
                    *accumulated = j;
                    row.apply_normal_impulse(bodies, j);
                }
            }
            iterations = 0;
        }
    }
    for _ in 0..iterations {
        let mut largest_change = 0.0f32;
        for ((c, (_, target, _)), accumulated) in
            rows.iter().zip(state.iter()).zip(impulses.iter_mut())
        {
            if target.is_nan() {
                continue;
            }
            let vn = c.normal_velocity(bodies);
            let new = (*accumulated + row_impulse(c.normal_mass, vn, *target)).max(0.0);
            let delta = new - *accumulated;
            if delta != 0.0 {
                *accumulated = new;
                c.apply_normal_impulse(bodies, delta);
                largest_change = largest_change.max(delta.abs() / c.normal_mass);
            }
        }
        if largest_change <= params.velocity_tolerance {
            break;
        }
    }
}

/// Records that `body` moved at `(v, w)` until `toi` and at its current velocity after.
fn owe_offset(body: &mut SolverBody, v: Vec3, w: Vec3, toi: f32) {
    if body.inverse_mass == 0.0 && body.inverse_inertia == bevy::math::Mat3::ZERO {
        return;
    }
    body.impact_offset -= (body.linear_velocity - v) * toi;
    body.impact_rotation -= (body.angular_velocity - w) * toi;
    body.impact_time = toi;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::solver::contact::prepare_contacts;
    use bevy::math::{BVec3, Mat3, Quat};

    fn ball(x: f32, v: f32) -> SolverBody {
        SolverBody::new(Motion::Dynamic, Vec3::new(x, 0.0, 0.0), Quat::IDENTITY)
            .with_mass(
                1.0,
                Mat3::from_diagonal(Vec3::splat(10.0)),
                true,
                BVec3::FALSE,
            )
            .with_velocity(Vec3::new(v, 0.0, 0.0), Vec3::ZERO)
    }

    fn params() -> Propagation {
        Propagation {
            threshold: 0.0,
            chain_threshold: 0.0,
            max_sweeps: 100,
            dt: 1.0 / 60.0,
            gravity: Vec3::ZERO,
            integrated_gravity: Vec3::ZERO,
            accelerations_integrated: false,
            substeps: 1,
            max_block_iterations: 64,
            velocity_tolerance: 1e-6,
            join_touching: true,
            touch: 0.005,
            wait_in_cluster: true,
        }
    }

    /// Two unit cubes stacked on static ground (centres at 0.5 and 1.5 m), both falling at
    /// 1 m/s, touching each other and the ground, with the upper cube's speculative contact
    /// with the ground 1 m below it first; one group a contact.
    fn touching_stack() -> (Vec<SolverBody>, Vec<ContactConstraint>, Vec<Range<usize>>) {
        let cube = |y: f32| {
            SolverBody::new(Motion::Dynamic, Vec3::new(0.0, y, 0.0), Quat::IDENTITY)
                .with_mass(
                    1.0,
                    Mat3::from_diagonal(Vec3::splat(6.0)),
                    true,
                    BVec3::FALSE,
                )
                .with_velocity(Vec3::new(0.0, -1.0, 0.0), Vec3::ZERO)
        };
        let bodies = vec![
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            cube(0.5),
            cube(1.5),
        ];
        let at = |y: f32| Vec3::new(0.0, y, 0.0);
        let mut contacts = vec![
            ContactConstraint::new(0, 2, at(0.5), Vec3::Y, 1.0, 0.0, 0.0),
            ContactConstraint::new(1, 2, at(1.0), Vec3::Y, 0.0, 0.0, 0.0),
            ContactConstraint::new(0, 1, at(0.0), Vec3::Y, 0.0, 0.0, 0.0),
        ];
        prepare_contacts(&bodies, &mut contacts);
        let groups = (0..3).map(|i| i..i + 1).collect();
        (bodies, contacts, groups)
    }

    /// Two unit cubes stacked on static ground, both falling at 1 m/s onto it, with the upper
    /// one's contact with the ground through the lower one (a speculative contact 1 m below it)
    /// listed first. The lower cube meets the ground at once and stops, then the upper one meets
    /// it: both stop, e = 0, and neither is owed any position (neither moved freely), and the
    /// speculative contact takes no impulse. Resolved in storage order instead, the upper cube
    /// met the ground at its free-fall time of impact (1 s into a 2 s step) and was owed -1 m,
    /// the whole gap, which put it inside the lower cube. Velocities within 2e-6 m/s: twice the
    /// threshold at which the collapse of e = 0 contacts stops; offsets exactly 0 (every event
    /// at time 0), 1e-6 allowed.
    #[test]
    fn impacts_in_time_order_through_a_touching_stack() {
        let (mut bodies, mut contacts, groups) = touching_stack();
        // A threshold above zero ended the inelastic collapse (each round passed half the
        // approach back and forth) after about 20 rounds, before the touching contact between
        // the cubes joined the ground's impact event (which now stops both at once).
        let params = Propagation {
            dt: 2.0,
            threshold: 1e-6,
            chain_threshold: 1e-6,
            ..params()
        };
        let report = propagate(&mut bodies, &mut contacts, &groups, &params);
        assert!(!report.bound_hit);
        for i in [1, 2] {
            let b = &bodies[i];
            assert!(
                b.linear_velocity.length() <= 2e-6,
                "{i}: {}",
                b.linear_velocity
            );
            assert!(b.impact_offset.length() <= 1e-6, "{i}: {}", b.impact_offset);
        }
        assert_eq!(contacts[0].total_impulse, 0.0);
    }

    /// The propagation method's pass (no touching contacts joined to events) on the stack of
    /// `impacts_in_time_order_through_a_touching_stack`, upper cube's speculative contact with
    /// the ground first: the ground stops the lower cube, the cubes' contact leaves both at
    /// half the speed, and the lower cube's ground contact approaches again after it was
    /// resolved, so it waits for the next sweep (inelastic collapse, a factor 2 a sweep). The
    /// upper cube's ground contact (time of impact 2 s at 0.5 m/s, within the 4 s step) waits
    /// with it, being in the same cluster of touching cubes, and never comes: the collapse
    /// stops both cubes first. Answer: both at rest (within 4e-6 m/s, twice the 1e-6 threshold
    /// at which the collapse stops, each halving leaving at most that much), owed no position
    /// (every event at time 0; exactly 0, 1e-6 allowed), and the speculative contact takes no
    /// impulse. Without the wait (asserted, so the scene does catch it), the upper cube met the
    /// ground at 2 s in the first sweep and was owed the whole 1 m gap, inside the lower cube.
    #[test]
    fn later_impact_waits_for_a_deferred_one_of_its_cluster() {
        let run = |wait: bool| {
            let (mut bodies, mut contacts, groups) = touching_stack();
            let params = Propagation {
                dt: 4.0,
                threshold: 1e-6,
                chain_threshold: 1e-6,
                join_touching: false,
                wait_in_cluster: wait,
                ..params()
            };
            let report = propagate(&mut bodies, &mut contacts, &groups, &params);
            (bodies, contacts, report)
        };
        let (bodies, contacts, report) = run(true);
        assert!(!report.bound_hit);
        for b in &bodies[1..] {
            assert!(b.linear_velocity.length() <= 4e-6, "{}", b.linear_velocity);
            assert!(b.impact_offset.length() <= 1e-6, "{}", b.impact_offset);
        }
        assert_eq!(contacts[0].total_impulse, 0.0);
        let (bodies, _, _) = run(false);
        assert!(
            (bodies[2].impact_offset.y + 1.0).abs() <= 1e-5,
            "without the wait: {}",
            bodies[2].impact_offset
        );
    }

    /// Newton's cradle of five touching balls, e = 1: only the last ball leaves, at 1 m/s, in
    /// either contact order (velocities exact to 1e-6, f32 rounding of a few impulses).
    #[test]
    fn cradle_in_either_order() {
        for reversed in [false, true] {
            let mut bodies: Vec<_> = (0..5)
                .map(|i| ball(i as f32, if i == 0 { 1.0 } else { 0.0 }))
                .collect();
            let mut contacts: Vec<_> = (0..4)
                .map(|i| {
                    ContactConstraint::new(
                        i,
                        i + 1,
                        Vec3::new(i as f32 + 0.5, 0.0, 0.0),
                        Vec3::X,
                        0.0,
                        1.0,
                        0.0,
                    )
                })
                .collect();
            if reversed {
                contacts.reverse();
            }
            prepare_contacts(&bodies, &mut contacts);
            let groups: Vec<_> = (0..4).map(|i| i..i + 1).collect();
            let report = propagate(&mut bodies, &mut contacts, &groups, &params());
            for (i, b) in bodies.iter().enumerate() {
                let expected = if i == 4 { 1.0 } else { 0.0 };
                assert!(
                    (b.linear_velocity.x - expected).abs() <= 1e-6,
                    "ball {i}: {}",
                    b.linear_velocity.x
                );
            }
            assert!(!report.bound_hit);
        }
    }

    /// A unit cube of `mass` kg at height `y` (inertia `mass / 6` about each axis).
    fn cube(y: f32, mass: f32, vy: f32) -> SolverBody {
        SolverBody::new(Motion::Dynamic, Vec3::new(0.0, y, 0.0), Quat::IDENTITY)
            .with_mass(
                1.0 / mass,
                Mat3::from_diagonal(Vec3::splat(6.0 / mass)),
                true,
                BVec3::FALSE,
            )
            .with_velocity(Vec3::new(0.0, vy, 0.0), Vec3::ZERO)
    }

    /// The four corners of a unit face at height `y`, normal +y from `a` to `b`, touching.
    fn face(a: usize, b: usize, y: f32) -> Vec<ContactConstraint> {
        [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
            .iter()
            .map(|&(x, z)| ContactConstraint::new(a, b, Vec3::new(x, y, z), Vec3::Y, 0.0, 0.0, 0.0))
            .collect()
    }

    /// The hybrid method's thresholds: impacts above 0.5 m/s, chains of restitution from
    /// 1e-4 m/s; and, as the hybrid, no waiting in clusters.
    fn hybrid_params() -> Propagation {
        Propagation {
            threshold: 0.5,
            chain_threshold: 1e-4,
            wait_in_cluster: false,
            ..params()
        }
    }

    /// A heavy cube (`M` kg) landing flat at 2 m/s, e = 0, on a 1 kg cube resting on static
    /// ground, for `M` = 10, 100 and 1000. Worked out by hand: the light cube cannot move down,
    /// so the inelastic impact stops both, in one event and one sweep. The impulses: the upper
    /// face takes the heavy cube's momentum, `2 M` N s, and so does the ground (the light cube's
    /// momentum is unchanged, zero); the kinetic energy `M v^2 / 2 = 2 M` J is all lost. Only
    /// the upper face's rows are impacts: the ground's only held.
    ///
    /// Before the ground's contact joined the event, each sweep stopped the pair (both then
    /// moving at `M / (M + 1)` of the approach) and then the light cube on the ground: a factor
    /// `M / (M + 1)` a sweep, 24 sweeps at 10:1 to fall below the 0.5 m/s threshold, 231 at
    /// 100:1 and 2,300 at 1000:1 (the bound, 100 here, was hit).
    ///
    /// Tolerances: velocities within `1e-5 + 2e-6 M` m/s: the light cube receives velocity
    /// changes of `2 M` m/s from above and below that cancel, whose f32 rounding is 1.2e-7
    /// of them a step, a few steps over (at 1000:1 it ends at 1.5e-4 m/s); the impulses within
    /// 1e-5 relative (f32 sums of four rows).
    #[test]
    fn heavy_on_light_on_ground_stops_in_one_sweep() {
        for heavy in [10.0f32, 100.0, 1000.0] {
            let mut bodies = vec![
                SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
                cube(0.5, 1.0, 0.0),
                cube(1.5, heavy, -2.0),
            ];
            let mut contacts = face(0, 1, 0.0);
            contacts.extend(face(1, 2, 1.0));
            prepare_contacts(&bodies, &mut contacts);
            let groups = [0..4, 4..8];
            let report = propagate(&mut bodies, &mut contacts, &groups, &hybrid_params());
            assert_eq!((report.sweeps, report.resolutions), (1, 1), "{heavy}");
            assert!(!report.bound_hit);
            let tolerance = 1e-5 + 2e-6 * heavy;
            for b in &bodies[1..] {
                assert!(
                    b.linear_velocity.length() <= tolerance,
                    "{heavy}: {}",
                    b.linear_velocity
                );
                assert!(
                    b.angular_velocity.length() <= tolerance,
                    "{heavy}: {}",
                    b.angular_velocity
                );
            }
            let impulse =
                |range: Range<usize>| contacts[range].iter().map(|c| c.total_impulse).sum::<f32>();
            for (range, name) in [(0..4, "ground"), (4..8, "upper face")] {
                let j = impulse(range);
                assert!(
                    (j - 2.0 * heavy).abs() <= 1e-5 * 2.0 * heavy,
                    "{heavy} {name}: {j}"
                );
            }
            assert!(contacts[4..8].iter().all(|c| c.impact));
            assert!(contacts[0..4].iter().all(|c| !c.impact));
        }
    }

    /// The queue and the event agree on what approaches. A unit cube (1 kg) spinning at
    /// 2 rad/s about z, at rest otherwise, with a corner 0.5 m above static ground (anchor
    /// `r = (0.5, -0.5, 0)`): at the start of the step the corner approaches at
    /// `(w x r) . y = -1` m/s, so its gap closes at t = 0.5 s of a 1 s step. The event solves it
    /// at its anchor moved to that time, `r + (w x r) t = (0, -1, 0)`, where it moves at
    /// `(w x r') . y = 0`: not approaching. One sweep, nothing resolved, the cube unchanged.
    /// (Before, the event pushed nothing, the corner still approached at its start anchor, and
    /// it was picked up again every sweep until the bound.)
    #[test]
    fn approach_is_judged_where_the_event_solves_it() {
        let spinning = SolverBody::new(Motion::Dynamic, Vec3::new(0.0, 1.0, 0.0), Quat::IDENTITY)
            .with_mass(
                1.0,
                Mat3::from_diagonal(Vec3::splat(6.0)),
                true,
                BVec3::FALSE,
            )
            .with_velocity(Vec3::ZERO, Vec3::new(0.0, 0.0, -2.0));
        let mut bodies = vec![
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            spinning,
        ];
        let corner = Vec3::new(0.5, 0.5, 0.0);
        let mut contacts = [ContactConstraint::new(0, 1, corner, Vec3::Y, 0.5, 0.0, 0.0)];
        prepare_contacts(&bodies, &mut contacts);
        assert!((contacts[0].normal_velocity(&bodies) + 1.0).abs() <= 1e-6);
        let params = Propagation {
            dt: 1.0,
            ..hybrid_params()
        };
        let report = propagate(
            &mut bodies,
            &mut contacts,
            std::slice::from_ref(&(0..1)),
            &params,
        );
        assert_eq!((report.sweeps, report.resolutions), (1, 0));
        assert!(!report.bound_hit);
        assert_eq!(bodies[1].angular_velocity, Vec3::new(0.0, 0.0, -2.0));
        assert_eq!(bodies[1].linear_velocity, Vec3::ZERO);
    }

    /// A speculative impact is placed at its time of impact: a ball 0.05 m from a wall at
    /// 6 m/s (t = 1/120 s into a 1/60 s step), e = 1, ends the step 0.05 m from the wall again
    /// after integration, as the exact motion does.
    #[test]
    fn speculative_impact_happens_at_time_of_impact() {
        let mut bodies = vec![
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            ball(0.55, -6.0),
        ];
        let mut contacts = vec![ContactConstraint::new(
            0,
            1,
            Vec3::new(0.025, 0.0, 0.0),
            Vec3::X,
            0.05,
            1.0,
            0.0,
        )];
        prepare_contacts(&bodies, &mut contacts);
        let report = propagate(
            &mut bodies,
            &mut contacts,
            std::slice::from_ref(&(0..1)),
            &params(),
        );
        // One impact, nothing else touched: one sweep, and no second one that finds nothing.
        assert_eq!((report.sweeps, report.resolutions), (1, 1));
        crate::dynamics::solver::body::integrate_positions(&mut bodies, Vec3::ZERO, 1.0 / 60.0);
        assert!((bodies[1].linear_velocity.x - 6.0).abs() <= 1e-5);
        // Exact: 0.05 m to the wall at 6 m/s, then 1/120 s back out at 6 m/s: x = 0.55.
        assert!(
            (bodies[1].position.x - 0.55).abs() <= 1e-5,
            "{}",
            bodies[1].position.x
        );
    }
}
