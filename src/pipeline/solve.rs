//! The solve: the chosen method over the packed bodies and rows, continuous collision for the
//! methods that need it, and the impulses stored back into the manifolds, with the step's
//! impacts and touching transitions.

use bevy::prelude::*;
use parry3d::math::Pose;
use parry3d::query::cast_shapes_nonlinear;
use parry3d::shape::{Ball, Shape, SharedShape};

use crate::collision::ContactPairs;
use crate::collision::narrow_phase::StepMotion;
use crate::collision::parts::PartContact;
use crate::dynamics::SolverStats;
use crate::dynamics::solver::{self, Motion};
use crate::schedule::{PhysicsSchedule, PhysicsSystems};

use super::narrow_phase::{Turning, mixed};
use super::{
    CandidatePairs, ColliderPair, ContactRows, PhysicsState, StepEvents, init_stage_state,
};

/// Steps between two warnings that propagation hit its sweep bound: at most one a second at
/// 60 Hz, so a scene that hits the bound every step does not flood the log.
const BOUND_WARNING_INTERVAL: u32 = 60;

/// Adds [`solve_contacts`] to [`PhysicsSystems::Solve`].
pub struct SolvePlugin;

impl Plugin for SolvePlugin {
    fn build(&self, app: &mut App) {
        init_stage_state(app).add_systems(
            PhysicsSchedule,
            solve_contacts.in_set(PhysicsSystems::Solve),
        );
    }
}

/// Continuous collision after the solve (as Box2D v3's `b2SolveContinuous`): a dynamic body
/// whose solved motion over the step is longer than the contact margin is swept from its start
/// pose to its end pose against each of its broad-phase pairs (parry's nonlinear shape cast).
/// If it would first touch one more than `linear_slop` before the end of its sweep, it is put
/// back at the pose of that first touch, keeping its velocities: the next step's contact
/// resolves them. A body already touching at the start, or paired with a turning kinematic
/// body, is swept by its centre of mass alone (a point), so that at least its centre never
/// passes through. Bodies the solver stopped in time, slow bodies and resting contacts are
/// untouched.
///
/// Why: the solvers resolve each contact with the geometry of the start of the step. A body
/// that turns through several radians within the step (a box at 1e3 rad/s: 2.7 turns per
/// step at 60 Hz) meets the wall in a pose the start geometry does not describe, and every
/// method but the hybrid one, which resolves impacts one at a time at their time of impact,
/// let such a body through.
fn stop_at_first_impact(
    state: &mut PhysicsState,
    candidates: &CandidatePairs,
    rewind: &mut Rewind,
) {
    let dt = state.dt;
    let Rewind { first, poses } = rewind;
    first_impacts(state, candidates, first);
    poses.clear();
    poses.extend(
        first
            .iter()
            .enumerate()
            .filter(|&(_, &t)| t < dt)
            .map(|(i, &t)| (i, solved_motion(state, i).0.pose_at(t))),
    );
    put_back(state, poses);
}

/// [`stop_at_first_impact`]'s buffers, kept between steps so that a steady step allocates
/// nothing: each body's first impact time and the poses bodies are put back at.
#[derive(Default)]
pub struct Rewind {
    first: Vec<f32>,
    poses: Vec<(usize, Pose)>,
}

/// The solved motion of each body as a rigid motion from its start pose: the centre of
/// mass moves in a straight line to where the solve put it, and the body turns at its
/// solved angular velocity (or along the shortest arc to its end rotation, for turns under
/// a radian, which then reproduces the end pose exactly).
///
/// Returns it with the length of the body's sweep, m (its centre's path and its turn times its
/// radius).
fn solved_motion(state: &PhysicsState, i: usize) -> (StepMotion, f32) {
    let dt = state.dt;
    let body = &state.bodies[i];
    let start = state.poses[i];
    let com0 = start.transform_point(state.local_com[i]);
    let linear = (body.position - com0) / dt;
    let turn = (body.rotation * start.rotation.inverse()).to_scaled_axis();
    let angular = if turn.length() < 1.0 && body.angular_velocity.length() * dt < 1.0 {
        turn / dt
    } else {
        body.angular_velocity
    };
    let sweep = (body.position - com0).length() + angular.length() * dt * state.radius[i];
    (
        StepMotion {
            pose: start,
            local_center: state.local_com[i],
            linear,
            angular,
            spin_reach: 0.0,
        },
        sweep,
    )
}

/// Whether body `i` is an awake dynamic body whose solved motion sweeps farther than the
/// contact margin.
fn sweeps_fast(state: &PhysicsState, i: usize) -> bool {
    let margin = state.settings.narrow.contact_margin;
    state.bodies[i].motion == Motion::Dynamic
        && state.asleep[i].is_none()
        && solved_motion(state, i).1 > margin
}

/// The time, s into the step, at which each fast body first touches one of its pairs more than
/// `linear_slop` before the end of its sweep (`dt` where it does not), into `first`; empty when
/// no pair has a fast body.
fn first_impacts(state: &PhysicsState, candidates: &CandidatePairs, first: &mut Vec<f32>) {
    let dt = state.dt;
    let slop = state.settings.config.linear_slop;
    let n = state.bodies.len();
    let motion = |i: usize| solved_motion(state, i);
    let fast = |i: usize| sweeps_fast(state, i);
    first.clear();
    for (k, &(ia, ib)) in candidates.indices.iter().enumerate() {
        // A detect-only pair (a sensor) never stops a body: it has no contact to resolve.
        if candidates.dormant[k] || candidates.detect_only[k] || !(fast(ia) || fast(ib)) {
            continue;
        }
        if first.is_empty() {
            first.resize(n, dt);
        }
        let (ma, sweep_a) = motion(ia);
        let (mb, sweep_b) = motion(ib);
        let Some(t) = first_touch(state, ia, ib, &ma, &mb) else {
            continue;
        };
        for (i, sweep) in [(ia, sweep_a), (ib, sweep_b)] {
            if fast(i) && (1.0 - t / dt) * sweep > slop {
                first[i] = first[i].min(t);
            }
        }
    }
}

/// When bodies `ia` and `ib`, moving as `ma` and `mb`, first touch within the step, s: their
/// shapes swept against each other, or the fast body's centre when they touch at the start or
/// the pair is carried by a turning kinematic body.
fn first_touch(
    state: &PhysicsState,
    ia: usize,
    ib: usize,
    ma: &StepMotion,
    mb: &StepMotion,
) -> Option<f32> {
    let dt = state.dt;
    let (sa, sb) = (state.shapes[ia].as_ref(), state.shapes[ib].as_ref());
    let hit = |a: &StepMotion, sa: &dyn Shape, b: &StepMotion, sb: &dyn Shape| {
        let (a, b) = (a.nonlinear(), b.nonlinear());
        cast_shapes_nonlinear(&a, sa, &b, sb, 0.0, dt, false)
            .ok()
            .flatten()
            .map(|h| h.time_of_impact)
    };
    // A pair of a dynamic body and a turning kinematic body (see `Turning`) is solved with
    // the kinematic body's prescribed motion (its faces' contacts carried to its end-of-step
    // pose, its other anchors turned exactly), not with the start geometry this rewind makes
    // up for. Their straight solved paths can still graze mid-step (a ball pushed by a
    // kinematic bar turning at 6 rad/s, its path a chord of the face's arc, dips about 1 mm
    // into it), which a sweep of the whole shapes takes for a first impact: the ball was put
    // back where it started while the bar moved on, and the bar sank 9.9 cm into it under
    // the soft step. Such a pair is swept by the fast body's centre, as a pair touching at
    // the start.
    let carried = Turning::sides(state, ia, ib).is_some();
    if mixed(state, ia) || mixed(state, ib) {
        return if carried {
            None
        } else {
            first_touch_of_parts(state, (ia, ib), (ma, mb), hit)
        };
    }
    match hit(ma, sa, mb, sb) {
        Some(t) if t > 0.0 && !carried => Some(t),
        Some(_) => {
            // Touching at the start, or carried: sweep the fast body's centre (a point)
            // instead.
            let point = Ball::new(0.0);
            let centre = |m: &StepMotion| StepMotion {
                pose: Pose::from_parts(m.pose.transform_point(m.local_center), m.pose.rotation),
                local_center: Vec3::ZERO,
                ..*m
            };
            if sweeps_fast(state, ia) {
                hit(&centre(ma), &point, mb, sb).filter(|&t| t > 0.0)
            } else {
                hit(ma, sa, &centre(mb), &point).filter(|&t| t > 0.0)
            }
        }
        None => None,
    }
}

/// For [`first_touch`], a pair with a body whose colliders pair differently (a sensor among
/// them, or layers that differ): when the subshapes of colliders whose contacts are solved
/// first touch, s, each pair of them swept on its own (`hit`, with the bodies' motions carried
/// to the subshape's pose); those touching at the start (resting, or the solve's to resolve)
/// do not count. A sensor or a collider that does not interact never stops the body.
fn first_touch_of_parts(
    state: &PhysicsState,
    (ia, ib): (usize, usize),
    (ma, mb): (&StepMotion, &StepMotion),
    hit: impl Fn(&StepMotion, &dyn Shape, &StepMotion, &dyn Shape) -> Option<f32>,
) -> Option<f32> {
    let leaves = |k: usize, m: &StepMotion| -> Vec<(u32, StepMotion, SharedShape)> {
        let shape = &state.shapes[k];
        match shape.as_compound().filter(|_| state.parts[k].is_some()) {
            Some(compound) => compound
                .shapes()
                .iter()
                .enumerate()
                .map(|(i, (pose, leaf))| {
                    let motion = StepMotion {
                        pose: m.pose * *pose,
                        local_center: pose.inverse().transform_point(m.local_center),
                        ..*m
                    };
                    (i as u32, motion, leaf.clone())
                })
                .collect(),
            None => vec![(0, *m, shape.clone())],
        }
    };
    let (leaves_a, leaves_b) = (leaves(ia, ma), leaves(ib, mb));
    let mut first: Option<f32> = None;
    for (la, motion_a, shape_a) in &leaves_a {
        let part_a = state.part_of(ia, *la);
        for (lb, motion_b, shape_b) in &leaves_b {
            let part_b = state.part_of(ib, *lb);
            if !matches!(part_a.contact(&part_b), PartContact::Solved { .. }) {
                continue;
            }
            if let Some(t) = hit(motion_a, shape_a.as_ref(), motion_b, shape_b.as_ref())
                && t > 0.0
            {
                first = Some(first.map_or(t, |f| f.min(t)));
            }
        }
    }
    first
}

/// Puts each body of `poses` back at its pose, keeping its energy from rising (see
/// [`stop_at_first_impact`]).
fn put_back(state: &mut PhysicsState, poses: &[(usize, Pose)]) {
    let gravity = state.settings.gravity.0;
    for &(i, pose) in poses {
        let body = &mut state.bodies[i];
        let position = pose.transform_point(state.local_com[i]);
        // Moved back along its path, the body may stand higher than where the solve left it:
        // the potential energy it gains, `-m g . dx`, is taken from its kinetic energy (its
        // speed is scaled down), so the correction never adds energy. Without this, bodies
        // rewound after falling fast gained up to 22% of a world's energy in a step (the
        // energy property test).
        // (Under its own acceleration, gravity with its extra acceleration, if it has one.)
        let g = if body.extra_acceleration == Vec3::ZERO {
            gravity
        } else {
            gravity + body.extra_acceleration
        };
        let gained = -g.dot(position - body.position) / body.inverse_mass;
        let kinetic = 0.5 * body.linear_velocity.length_squared() / body.inverse_mass;
        if gained > 0.0 && kinetic > 0.0 {
            body.linear_velocity *= ((kinetic - gained).max(0.0) / kinetic).sqrt();
        }
        // Turned back, the body keeps its spin in its own frame, so that its rotational energy
        // `w . I w / 2` is what the solve left. (Turning it under a fixed world spin changes
        // that energy when the inertia is not isotropic: a 2 kg hull that an e = 1 impact on the
        // trimesh had set spinning gained 130 J, 29% of its world's energy, in one rewind:
        // the energy property test, propagation, seed 107.)
        let rotation = pose.rotation.normalize();
        if !body.isotropic && !body.locked_rotation.any() {
            let back = rotation * body.rotation.inverse();
            body.angular_velocity = back * body.angular_velocity;
        }
        body.position = position;
        body.rotation = rotation;
    }
}

/// The step's touching transitions between colliders (see [`StepEvents::colliders_started`]):
/// a pair of bodies without child colliders is one pair of colliders, its bodies, and its
/// transitions are the pair's (those of `events.started`, and of `events.ended` from
/// `ended_before`, which [`ContactPairs::update_touching`] pushed); the colliders of a
/// compound pair touch when a row of theirs is within the touch distance or pushed in the step,
/// or when the narrow phase found them touching without rows (`rows.detected_parts`). A
/// dormant pair keeps its touching colliders.
fn update_colliders_touching(
    state: &PhysicsState,
    pairs: &mut ContactPairs,
    candidates: &CandidatePairs,
    rows: &ContactRows,
    events: &mut StepEvents,
    ended_before: usize,
) {
    let plain = |pairs: &ContactPairs, (a, b): (Entity, Entity)| {
        pairs.get(a, b).is_none_or(|p| !p.compound)
    };
    for i in 0..events.started.len() {
        let pair = events.started[i];
        if plain(pairs, pair) {
            events
                .colliders_started
                .push(ColliderPair::of_bodies(pair.0, pair.1));
        }
    }
    for i in ended_before..events.ended.len() {
        let pair = events.ended[i];
        if plain(pairs, pair) {
            events
                .colliders_ended
                .push(ColliderPair::of_bodies(pair.0, pair.1));
        }
    }
    if !pairs.candidates().iter().any(|p| p.compound) {
        return;
    }
    let touch = state.settings.narrow.touch_distance;
    let mut now: Vec<(u32, Entity, Entity)> = rows.detected_parts.clone();
    for (c, &(p, m, _)) in rows.contacts.iter().zip(&rows.keys) {
        let pair = &pairs.candidates()[p as usize];
        if pair.compound && (c.separation <= touch || c.total_impulse > 0.0) {
            let (ia, ib) = candidates.indices[p as usize];
            let manifold = &pair.manifolds[m as usize];
            now.push((
                p,
                state.part_of(ia, manifold.subshape1).collider,
                state.part_of(ib, manifold.subshape2).collider,
            ));
        }
    }
    now.sort_unstable();
    now.dedup();
    let mut next = 0;
    for (p, pair) in pairs.pairs_mut().iter_mut().enumerate() {
        let start = next;
        while next < now.len() && now[next].0 as usize == p {
            next += 1;
        }
        if !pair.compound || candidates.dormant[p] {
            continue;
        }
        let touching: Vec<(Entity, Entity)> =
            now[start..next].iter().map(|&(_, a, b)| (a, b)).collect();
        let bodies = (pair.a, pair.b);
        let event = |colliders| ColliderPair { colliders, bodies };
        for was in &pair.part_touching {
            if touching.binary_search(was).is_err() {
                events.colliders_ended.push(event(*was));
            }
        }
        for is in &touching {
            if pair.part_touching.binary_search(is).is_err() {
                events.colliders_started.push(event(*is));
            }
        }
        pair.part_touching = touching;
    }
}

/// Runs the solver over the packed arrays and stores the impulses back into the manifolds.
pub fn solve_contacts(
    mut stats: ResMut<SolverStats>,
    mut state: ResMut<PhysicsState>,
    mut pairs: ResMut<ContactPairs>,
    candidates: Res<CandidatePairs>,
    mut rows: ResMut<ContactRows>,
    mut events: ResMut<StepEvents>,
    mut rewind: Local<Rewind>,
) {
    let (rows, events) = (&mut *rows, &mut *events);
    let state = &mut *state;
    let config = &state.settings.config;
    *stats = solver::step_with_scratch(
        &mut state.bodies,
        &mut rows.contacts,
        &rows.pair_ranges,
        config,
        state.settings.gravity.0,
        state.dt,
        &mut state.solver_scratch,
    );
    // Translation locks and speed caps, for the bodies that have them (see
    // `crate::dynamics::forces`).
    for &(i, extra, start) in &state.motion {
        let body = &mut state.bodies[i];
        if body.motion == Motion::Dynamic {
            extra.end_step(body, start);
        }
    }
    // The hybrid method resolves impacts one at a time at their time of impact, on contacts
    // generated at the time-of-impact poses, so its bodies already stop where they first touch
    // (a box spinning at 1e3 rad/s stops at a thin wall without the rewind): only the other
    // methods, which solve every contact with the geometry of the start of the step, need it.
    // The rewind is not free: it moves bodies without the solver's knowledge, and in the
    // energy property test it was what raised the energy of 9 of the hybrid's 10 failing
    // worlds.
    if state.settings.config.method != solver::SolverMethod::Hybrid {
        stop_at_first_impact(state, &candidates, &mut rewind);
    }
    let config = &state.settings.config;
    state.steps_since_bound_warning = state.steps_since_bound_warning.saturating_add(1);
    if stats.propagation_bound_hit && state.steps_since_bound_warning >= BOUND_WARNING_INTERVAL {
        state.steps_since_bound_warning = 0;
        log::warn!(
            "impact3d: propagation stopped at its bound of {} sweeps with contacts still \
             approaching (raise SolverConfig::max_propagation_sweeps)",
            config.max_propagation_sweeps
        );
    }

    pairs.store_impulses(&rows.contacts, &rows.keys);
    let ended_before = events.ended.len();
    pairs.update_touching(
        &rows.contacts,
        &rows.keys,
        &rows.detected,
        &candidates.dormant,
        state.settings.narrow.touch_distance,
        &mut events.started,
        &mut events.ended,
    );
    update_colliders_touching(state, &mut pairs, &candidates, rows, events, ended_before);
    events.impacts.clear();
    events.impacts.extend(crate::messages::impacts(
        &pairs,
        &rows.contacts,
        &rows.keys,
        config.impact_messages,
    ));
}
