//! When each group meets its impact: approach tests, times of impact within the step, the
//! queue of groups by time, and the clusters of touching bodies whose impacts wait together.

use std::cmp::Ordering;
use std::ops::Range;

use bevy::math::Vec3;

use super::super::body::{Motion, SolverBody};
use super::super::contact::ContactConstraint;
use super::super::rows::CompressedRows;
use super::Propagation;
use crate::dynamics::solver::refill;

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
#[derive(Default)]
pub(super) struct Clusters {
    /// Union-find parent of each body (dynamic bodies only take part).
    parent: Vec<u32>,
    /// Per cluster root: the sweep and the earliest time, s, of an approach waiting in it.
    waiting: Vec<(u32, f32)>,
    /// The current sweep's number.
    sweep: u32,
}

impl Clusters {
    /// The clusters at the start of a pass: bodies joined by the groups that touch (the
    /// buffers' earlier contents dropped, their memory kept).
    pub(super) fn reset(
        &mut self,
        bodies: &[SolverBody],
        contacts: &[ContactConstraint],
        groups: &[Range<usize>],
        pairs: &[Option<(usize, usize)>],
        touch: f32,
    ) {
        self.parent.clear();
        self.parent.extend(0..bodies.len() as u32);
        refill(&mut self.waiting, bodies.len(), (0, 0.0));
        self.sweep = 0;
        for (range, &pair) in groups.iter().zip(pairs) {
            if let Some((a, b)) = pair
                && contacts[range.clone()].iter().any(|c| touches(c, touch))
            {
                self.join(a, b, bodies);
            }
        }
    }

    pub(super) fn root(&mut self, mut i: usize) -> usize {
        while self.parent[i] as usize != i {
            let up = self.parent[self.parent[i] as usize];
            self.parent[i] = up;
            i = up as usize;
        }
        i
    }

    /// Bodies `a` and `b` touch: their clusters are one (static and kinematic bodies join
    /// nothing, their velocities being given).
    pub(super) fn join(&mut self, a: usize, b: usize, bodies: &[SolverBody]) {
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

    pub(super) fn begin_sweep(&mut self) {
        self.sweep += 1;
    }

    /// The earliest waiting approach of the cluster rooted at `root` in this sweep.
    pub(super) fn waiting_at(&self, root: usize) -> Option<f32> {
        let (sweep, time) = self.waiting[root];
        (sweep == self.sweep).then_some(time)
    }

    /// An approach of the group of `pair` at `time` (s) waits for the next sweep.
    pub(super) fn defer(&mut self, pair: Option<(usize, usize)>, time: f32, bodies: &[SolverBody]) {
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
    pub(super) fn waits(
        &mut self,
        pair: Option<(usize, usize)>,
        time: f32,
        simultaneous: f32,
    ) -> bool {
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
pub(super) const SIMULTANEOUS: f32 = 1e-4;

/// A group struck at `now` whose last impact in the pass was at `last` (NaN: none) is struck
/// again at the same instant (within [`SIMULTANEOUS`] of the step `dt`). A group with
/// restitution below 1 that is struck again has spent its bounce and is inelastic for the
/// rest of the pass: its restitution counts as 0, it is
/// approaching only from the inelastic threshold (not the chain's), and it joins inelastic
/// events as a touching group, which are solved exactly as one block. Why: in a touching cluster with restitution (a pile
/// of balls with `e = 0.2`), an impact is passed back and forth between the same bodies at one
/// instant, each time smaller (inelastic collapse, McNamara and Young 1994): 400 spheres
/// poured into a box, 60 Hz, hit the bound of 64 sweeps in 24 steps, some groups resolved 50
/// times in one pass; 400 mixed bodies with `e = 0.2` in 148 steps. Event-driven simulations
/// of granular gases meet the same collapse and end it by changing the restitution of
/// collisions that follow too soon (the TC model, Luding and McNamara 1998); here they become
/// inelastic, the simultaneous answer, which never adds energy. Impacts at different
/// instants keep their restitution, however many there are (a ball rattling between two walls
/// within a step), and so does each contact of a chain struck once (Newton's cradle). So does
/// `e = 1`: each exchange keeps the energy, the approaches do not die away, and the exact
/// sequence is finite (a 1 kg ball between a wall and a 100 kg ball, touching, is struck 31
/// times at one instant, and the 100 kg ball leaves with all its energy).
#[inline]
pub(super) fn struck_again(last: f32, now: f32, dt: f32) -> bool {
    (now - last).abs() <= SIMULTANEOUS * dt
}

/// The group (one body pair's rows) joins an impact event of one of its bodies as touching:
/// every row is inelastic (or the group has spent its bounce, `spent`: see [`struck_again`])
/// and one of them touches ([`touches`]).
pub(super) fn joins(rows: &[ContactConstraint], touch: f32, spent: bool) -> bool {
    (spent || rows.iter().all(|c| c.restitution == 0.0)) && rows.iter().any(|c| touches(c, touch))
}

/// The row of a joined group takes part in the event: it can push, and it touches at the
/// start of the step (separated by at most `touch`, the resting phase's slop), or has pushed at
/// an impact of this pass. A speculative row is not held: it meets later, in its own event at
/// its own time. (Not the group's `met`: that a tilted manifold met at one corner does not
/// close the gap of the others.) Why the slop: the corners of a resting face are at separations
/// of either sign by f32 rounding (1e-7 m); taking only those at or below zero, a column under
/// propagation held its upper part on two corners of one edge, turned it about that edge
/// (0.2 rad/s) and toppled.
pub(super) fn touches(c: &ContactConstraint, touch: f32) -> bool {
    c.normal_mass > 0.0 && (c.separation <= touch || c.total_impulse > 0.0)
}

/// A group waiting in a sweep's queue at its time of impact (ordered by time, then index).
#[derive(Clone, Copy, Debug)]
pub(super) struct Queued {
    pub(super) time: f32,
    pub(super) group: usize,
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
#[derive(Default)]
pub(super) struct GroupsOfBody(CompressedRows);

impl GroupsOfBody {
    /// The groups of each body of `pairs` (the buffers' earlier contents dropped, their memory
    /// kept).
    pub(super) fn rebuild(&mut self, bodies: &[SolverBody], pairs: &[Option<(usize, usize)>]) {
        let dynamic = |i: usize| bodies[i].motion == Motion::Dynamic;
        self.0.build(
            bodies.len(),
            pairs
                .iter()
                .enumerate()
                .filter_map(|(k, p)| p.map(|(a, b)| (k as u32, [a, b])))
                .flat_map(move |(k, ends)| {
                    ends.into_iter()
                        .filter(move |&i| dynamic(i))
                        .map(move |i| (i, k))
                }),
        );
    }

    pub(super) fn of(&self, body: usize) -> &[u32] {
        self.0.row(body)
    }

    /// The groups of either body of `pair` (none for no pair), the first body's first.
    pub(super) fn of_pair(&self, pair: Option<(usize, usize)>) -> impl Iterator<Item = usize> {
        pair.into_iter()
            .flat_map(|(a, b)| [a, b])
            .flat_map(|body| self.of(body))
            .map(|&l| l as usize)
    }
}

/// Either body of the pair was struck earlier in this pass: the group is part of a chain of
/// impacts.
#[inline]
pub(super) fn chained(pair: Option<(usize, usize)>, stamp: &[u32]) -> bool {
    pair.is_some_and(|(a, b)| stamp[a] > 0 || stamp[b] > 0)
}

/// The contact approaches faster than the threshold and, if it is speculative, closes within
/// the step. `met`: its gap closed at an earlier impact of this pass. `chain`: one of its
/// bodies was struck in this pass, so a contact with restitution counts from
/// [`Propagation::chain_threshold`]: the restitution threshold exists to keep resting bodies
/// from hopping under gravity, and an impact passed on along a chain is not that.
#[inline]
pub(super) fn approaching(
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
pub(super) fn threshold(c: &ContactConstraint, params: &Propagation, chain: bool) -> f32 {
    if chain && c.restitution > 0.0 {
        params.chain_threshold.min(params.threshold)
    } else {
        params.threshold
    }
}

/// The group's time of impact (see [`group_time`]) if it approaches: one of its contacts is
/// [`approaching`] at the start of the step, and still approaches as fast at that time, with
/// its anchors where [`resolve_event`](super::event::resolve_event) solves it ([`at_time`]).
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
pub(super) fn approach_time(
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

/// The gap the contact has to close: its separation at the start of the step, or none once it
/// met at an impact of this pass.
#[inline]
pub(super) fn gap(c: &ContactConstraint, met: bool) -> f32 {
    if met {
        c.separation.min(0.0)
    } else {
        c.separation
    }
}
/// The gap `s` closes within the step at normal velocity `vn` and normal acceleration `gn`, as
/// the substepped integration will move the bodies.
#[inline]
pub(super) fn closes_within(s: f32, vn: f32, gn: f32, params: &Propagation) -> bool {
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
pub(in crate::dynamics::solver) fn time_of_impact(s: f32, vn: f32, gn: f32) -> f32 {
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
pub(in crate::dynamics::solver) fn relative_gravity(
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
pub(super) fn pass_gravity(
    c: &ContactConstraint,
    bodies: &[SolverBody],
    params: &Propagation,
) -> f32 {
    relative_gravity(c, bodies, params.gravity, !params.accelerations_integrated)
}

/// When the group's impact happens within the step: its earliest closing point's time of
/// impact, not before either body's latest impact (see [`propagate`](super::propagate)).
pub(super) fn group_time(
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

/// The contact with its anchors moved to where its two bodies meet at `toi` into the step (see
/// [`resolve_event`](super::event::resolve_event)), its normal row prepared for them.
pub(super) fn at_time(c: &ContactConstraint, bodies: &[SolverBody], toi: f32) -> ContactConstraint {
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
