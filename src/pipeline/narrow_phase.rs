//! The narrow phase: parry3d's persistent contact manifolds per candidate pair, and one
//! contact row per point, warm-started from the impulse that point carried from the last step.

use std::ops::Range;

use bevy::prelude::*;
use bevy::tasks::{ComputeTaskPool, ParallelSliceMut, TaskPool};
use parry3d::math::Pose;
use parry3d::shape::SharedShape;

use crate::collision::ContactPairs;
use crate::collision::narrow_phase::ContactPair;
use crate::collision::narrow_phase::{
    ContactImpulse, Meeting, StepMotion, binary_unit, face_normal_toward, time_of_impact,
};
use crate::dynamics::CoefficientCombine;
use crate::dynamics::solver::{ContactConstraint, Motion, SolverBody};
use crate::schedule::{PhysicsSchedule, PhysicsSystems};

use super::{CandidatePairs, ContactRows, PhysicsState, StepEvents, init_stage_state};

/// Adds [`update_narrow_phase`] to [`PhysicsSystems::NarrowPhase`].
pub struct NarrowPhasePlugin;

impl Plugin for NarrowPhasePlugin {
    fn build(&self, app: &mut App) {
        init_stage_state(app).add_systems(
            PhysicsSchedule,
            update_narrow_phase.in_set(PhysicsSystems::NarrowPhase),
        );
    }
}

/// Updates the persistent contact pairs and builds one contact constraint per contact point,
/// carrying each point's impulses from the last step.
pub fn update_narrow_phase(
    mut state: ResMut<PhysicsState>,
    mut pairs: ResMut<ContactPairs>,
    candidates: Res<CandidatePairs>,
    mut rows: ResMut<ContactRows>,
    mut events: ResMut<StepEvents>,
) {
    let state = &mut *state;
    let rows = &mut *rows;
    events.ended.clear();
    events.started.clear();
    state.lost.clear();
    let (ended, lost) = (&mut events.ended, &mut state.lost);
    pairs.retain_candidates(&candidates.pairs, |p| {
        if p.touching {
            ended.push((p.a, p.b));
            // A sensor's touch held nothing up: losing it wakes no one.
            if !p.detect_only {
                lost.extend([p.a, p.b]);
            }
        }
    });
    rows.contacts.clear();
    rows.pair_ranges.clear();
    rows.keys.clear();
    rows.detected.clear();
    // The bodies a heavier dynamic body may press (see `lighter_face_normal`).
    let mut pressed = vec![false; state.bodies.len()];
    for (&(i, j), &detect_only) in candidates.indices.iter().zip(&candidates.detect_only) {
        let (a, b) = (&state.bodies[i], &state.bodies[j]);
        if !detect_only
            && a.motion == Motion::Dynamic
            && b.motion == Motion::Dynamic
            && a.inverse_mass != b.inverse_mass
        {
            pressed[if a.inverse_mass > b.inverse_mass {
                i
            } else {
                j
            }] = true;
        }
    }
    // Contacts are generated with the shapes scaled to the length unit (see
    // `ContactPair::update`); a pair with a shape parry cannot scale keeps metres.
    let unit = binary_unit(state.settings.length_unit);
    let mut unit_shapes = std::mem::take(&mut state.unit_shapes);
    let scaled: Vec<Option<(SharedShape, SharedShape)>> = if unit == 1.0 {
        Vec::new()
    } else {
        candidates
            .indices
            .iter()
            .map(|&(ia, ib)| {
                unit_shapes
                    .get(&state.shapes[ia], unit)
                    .zip(unit_shapes.get(&state.shapes[ib], unit))
            })
            .collect()
    };
    // The manifolds of every pair, independently of the others: in parallel on Bevy's compute
    // task pool, in chunks whose results come back in pair order, so the step is the same on
    // any number of threads.
    let state_ref: &PhysicsState = state;
    let candidates_ref: &CandidatePairs = &candidates;
    let scaled_ref = &scaled;
    let pool = ComputeTaskPool::get_or_init(TaskPool::default);
    let per_task = pairs_per_task(pairs.pairs_mut().len(), pool.thread_num());
    let geometry: Vec<Geometry> = pairs
        .pairs_mut()
        .par_chunk_map_mut(pool, per_task, |chunk, pairs| {
            pairs
                .iter_mut()
                .enumerate()
                .map(|(k, pair)| {
                    let pair_index = chunk * per_task + k;
                    pair_geometry(
                        state_ref,
                        candidates_ref,
                        scaled_ref.get(pair_index).and_then(Option::as_ref),
                        unit,
                        pair_index,
                        pair,
                    )
                })
                .collect::<Vec<_>>()
        })
        .into_iter()
        .flatten()
        .collect();
    for (pair_index, ((pair, &(ia, ib)), geometry)) in pairs
        .pairs_mut()
        .iter_mut()
        .zip(&candidates.indices)
        .zip(geometry)
        .enumerate()
    {
        let impact_time = match geometry {
            Geometry::None => continue,
            Geometry::Detected(touching) => {
                if touching {
                    rows.detected.push(pair_index as u32);
                }
                continue;
            }
            Geometry::Impact(t, motion_a, motion_b) => Some((t, motion_a, motion_b)),
            Geometry::Start => None,
        };
        let (pose_a, pose_b) = (&state.poses[ia], &state.poses[ib]);
        // Each coefficient by the pair's rule (`Max` unless a body asks for another).
        let (rules_a, rules_b) = (state.combine[ia], state.combine[ib]);
        let restitution = CoefficientCombine::of_pair(rules_a.restitution, rules_b.restitution)
            .mix(state.restitution[ia], state.restitution[ib]);
        let friction = CoefficientCombine::of_pair(rules_a.friction, rules_b.friction)
            .mix(state.friction[ia], state.friction[ib]);
        let turning = Turning::of(state, ia, ib);
        let start = rows.contacts.len();
        if let Some((t, motion_a, motion_b)) = impact_time {
            // A spinning body: the contact of its first point to meet the other is generated
            // at the time-of-impact poses (the start pose's normal and points would miss the
            // rotation), with its points mapped back to where they are at the start and a
            // separation that the approach velocity there closes exactly at the impact time.
            let (toi_a, toi_b) = (motion_a.pose_at(t), motion_b.pose_at(t));
            let (a, b) = (&state.bodies[ia], &state.bodies[ib]);
            // The point is moved back with the body that turns farther, so that its lever arm
            // is the one at impact (`p - x(t)`): the impulse then turns it as the impact does.
            let carrier = if state.spin_reach[ia] >= state.spin_reach[ib] {
                &motion_a
            } else {
                &motion_b
            };
            let shift = carrier.linear * t;
            for (m, k, impact_point, normal, dist) in pair.world_points(&toi_a, &toi_b) {
                let point = impact_point - shift;
                let point_velocity = |body: &SolverBody| {
                    body.linear_velocity + body.angular_velocity.cross(point - body.position)
                };
                let approach = (point_velocity(b) - point_velocity(a)).dot(normal);
                if approach >= 0.0 {
                    continue;
                }
                let separation = dist.max(0.0) - approach * t;
                let mut c = ContactConstraint::new(
                    ia,
                    ib,
                    point,
                    normal,
                    separation,
                    restitution,
                    friction,
                );
                if let Some(turning) = &turning {
                    let (toi_k, other) = if turning.sign > 0.0 {
                        (&toi_a, &motion_b)
                    } else {
                        (&toi_b, &motion_a)
                    };
                    let face = turning.face(pair.surface_points(m, k, &toi_a, &toi_b), |p| {
                        p - other.linear * t
                    });
                    turning.carry(&mut c, toi_k, face, &state.bodies, state.dt);
                }
                let carried = pair.manifolds[m].points[k].data;
                push_row(
                    &mut rows.contacts,
                    &mut rows.keys,
                    c,
                    carried,
                    (pair_index, m, k),
                );
            }
            close_pair_range(&rows.contacts, &mut rows.pair_ranges, start);
            continue;
        }
        let mut face = None;
        for (m, k, point, normal, dist) in pair.world_points(pose_a, pose_b) {
            let normal = match face {
                Some((manifold, n)) if manifold == m => n,
                _ => {
                    let n = lighter_face_normal(state, &pressed, ia, ib, normal);
                    face = Some((m, n));
                    n
                }
            };
            let mut c = ContactConstraint::new(ia, ib, point, normal, dist, restitution, friction);
            if let Some(turning) = &turning {
                let face = turning.face(pair.surface_points(m, k, pose_a, pose_b), |p| p);
                turning.carry(&mut c, &turning.motion.pose, face, &state.bodies, state.dt);
            }
            let carried = pair.manifolds[m].points[k].data;
            push_row(
                &mut rows.contacts,
                &mut rows.keys,
                c,
                carried,
                (pair_index, m, k),
            );
        }
        close_pair_range(&rows.contacts, &mut rows.pair_ranges, start);
    }
    unit_shapes.prune();
    state.unit_shapes = unit_shapes;
}

/// Fewest candidate pairs per task of the narrow phase's parallel manifold pass.
const MIN_PAIRS_PER_TASK: usize = 64;

/// Tasks per thread of the compute pool the manifold pass is split into (a few, so that a
/// thread that finishes early takes another).
const TASKS_PER_THREAD: usize = 4;

/// Candidate pairs per task for `pairs` pairs on a pool of `threads` threads: the pairs split
/// into `TASKS_PER_THREAD` tasks per thread, but none smaller than [`MIN_PAIRS_PER_TASK`].
/// Each pair's result depends on that pair alone and comes back in pair order, so the split
/// changes nothing but the time.
///
/// Why bounded by the threads: Bevy's task pool without `multi_threaded` (this crate without
/// feature `parallel`) queues a scope's tasks in a fixed-capacity executor; with a task per 64
/// pairs, the pairs of a 1,000-sphere pour overflowed it, panicking inside the narrow phase
/// (the lab's test `one_thread_build_steps_thousands_of_pairs`).
fn pairs_per_task(pairs: usize, threads: usize) -> usize {
    pairs
        .div_ceil(threads.max(1) * TASKS_PER_THREAD)
        .max(MIN_PAIRS_PER_TASK)
}

/// What the manifold pass found for one candidate pair (see [`pair_geometry`]).
enum Geometry {
    /// Dormant, or no contact within the prediction: no rows.
    None,
    /// A detect-only pair (a sensor, or no dynamic body): touching or not; no rows.
    Detected(bool),
    /// The manifolds at the start poses.
    Start,
    /// A fast-turning body: the manifolds at the time-of-impact poses, `t` s into the step,
    /// with both bodies' motions.
    Impact(f32, StepMotion, StepMotion),
}

/// Updates the manifolds of candidate pair `pair_index` (`pair`) for this step, from the
/// bodies' shapes (scaled to the length unit `unit` where `scaled` holds them), poses and
/// motion, and says which poses they are at. Reads nothing another pair writes: the pairs are
/// updated in parallel.
fn pair_geometry(
    state: &PhysicsState,
    candidates: &CandidatePairs,
    scaled: Option<&(SharedShape, SharedShape)>,
    unit: f32,
    pair_index: usize,
    pair: &mut ContactPair,
) -> Geometry {
    let config = &state.settings.config;
    let (ia, ib) = candidates.indices[pair_index];
    pair.detect_only = candidates.detect_only[pair_index];
    if candidates.dormant[pair_index] {
        return Geometry::None;
    }
    let margin = config.contact_margin;
    let reach = state.reach[ia] + state.reach[ib];
    let (pose_a, pose_b) = (&state.poses[ia], &state.poses[ib]);
    let (shape_a, shape_b) = (state.shapes[ia].as_ref(), state.shapes[ib].as_ref());
    let (unit_a, unit_b, pair_unit) = match scaled {
        Some((a, b)) => (a.as_ref(), b.as_ref(), unit),
        None => (shape_a, shape_b, 1.0),
    };
    if candidates.detect_only[pair_index] {
        // Detected, never solved (a sensor, or no dynamic body): the manifolds at the start
        // poses, within the margin, for the touching state; no rows. Computed afresh (see
        // `ContactPair::reset`): such pairs overlap deeply.
        pair.reset();
        if !pair.update(pose_a, unit_a, pose_b, unit_b, margin, pair_unit) {
            pair.manifolds.clear();
            return Geometry::None;
        }
        let touch = state.settings.touch_distance;
        return Geometry::Detected(
            pair.world_points(pose_a, pose_b)
                .any(|(_, _, _, _, dist)| dist <= touch),
        );
    }
    // Speculative contacts (a prediction wider than the margin) only for pairs that really
    // meet within the step: a near miss of fast bodies is a miss (no ghost collision).
    // Gravity bends a path by at most |g| dt^2 / 2 from the straight line the cast follows.
    let mut prediction = margin + reach;
    if reach > margin {
        let motion = |i: usize| StepMotion {
            pose: state.poses[i],
            local_center: state.local_com[i],
            linear: state.bodies[i].linear_velocity,
            angular: state.bodies[i].angular_velocity,
            spin_reach: state.spin_reach[i],
        };
        let bend = 0.5 * state.settings.gravity.0.length() * state.dt * state.dt;
        // The start pose's contact geometry (anchors turned to first order) holds for small
        // turns; past a quarter radian in the step (14 degrees: the first-order rotation of
        // a point is then 1% off in length, 12% off in direction at a full radian), and
        // where the turn carries a point beyond the margin, the contact is generated at the
        // time of impact instead.
        let turns_far = |i: usize| {
            state.spin_reach[i] > margin
                && state.bodies[i].angular_velocity.length() * state.dt > 0.25
        };
        match time_of_impact(
            shape_a,
            &motion(ia),
            shape_b,
            &motion(ib),
            state.dt,
            bend,
            margin,
        ) {
            Meeting::Miss => prediction = margin,
            Meeting::At(t) if t > 0.0 && (turns_far(ia) || turns_far(ib)) => {
                let (motion_a, motion_b) = (motion(ia), motion(ib));
                let (toi_a, toi_b) = (motion_a.pose_at(t), motion_b.pose_at(t));
                if !pair.update(&toi_a, unit_a, &toi_b, unit_b, margin, pair_unit) {
                    pair.manifolds.clear();
                    return Geometry::None;
                }
                return Geometry::Impact(t, motion_a, motion_b);
            }
            Meeting::At(_) | Meeting::Unknown => {}
        }
    }
    if !pair.update(pose_a, unit_a, pose_b, unit_b, prediction, pair_unit) {
        pair.manifolds.clear();
        return Geometry::None;
    }
    Geometry::Start
}

/// Largest angle, rad, between a manifold's normal and a face of its lighter body for that face
/// to give the normal (see [`lighter_face_normal`]): a thousandth of a radian, far above the
/// f32 rounding of a pose (1e-7) and the tilts a settling stack shows (1e-5 to 1e-4), far
/// below a real edge contact's.
pub const FACE_NORMAL_ANGLE: f32 = 1e-3;

/// The normal of a manifold whose lighter body a heavier dynamic body presses (`pressed`, by
/// body: it is the lighter body of a candidate pair with a heavier dynamic one), taken from
/// that lighter body's face where it has one within [`FACE_NORMAL_ANGLE`] of parry's normal
/// (which comes from whichever face its separating-axis test picked); otherwise parry's
/// normal. A static or kinematic body counts as the heavier.
///
/// Why: frictionless, a contact pushes sideways by its load times its normal's tilt. Two
/// nearly parallel faces give the same contact either way, but a light body pressed between
/// two heavy ones, each manifold's normal taken from a heavy body's face, is pushed sideways by
/// the load times the difference of two independent tilts: a watermelon seed. A 1 kg cube under
/// six 1000 kg cubes, their faces 1e-5 rad apart after the landing, slid out at 0.3 m/s and the
/// 100-cube 1000:1 column fell (and its resting phase then blew up: 234 m/s at step 116). With
/// all its normals from the light cube's own faces, which are exactly parallel, the sideways
/// pushes cancel but for its own weight times its tilt, and what is left of the tilts pushes
/// the heavy bodies, a thousand times less: the column stands (7.8e-4 m/s after 20 s). That
/// includes a pressed body's contact with the ground (the bottom cube of the column, under
/// 50 t, slid at 0.35 m/s with the ground's normal below and its own above). A body nothing
/// heavier presses keeps parry's normal: a box alone on a static floor would otherwise be
/// pushed sideways by its weight times its own small tilt (2.5e-3 m/s in 1.5 s sliding over a
/// trimesh under the soft step), where the floor's face is exact.
pub fn lighter_face_normal(
    state: &PhysicsState,
    pressed: &[bool],
    ia: usize,
    ib: usize,
    normal: Vec3,
) -> Vec3 {
    let (a, b) = (&state.bodies[ia], &state.bodies[ib]);
    if a.inverse_mass == b.inverse_mass {
        return normal;
    }
    // The lighter body's face toward the other: outward along `-n` for B, `+n` for A.
    let (light, outward) = if b.inverse_mass > a.inverse_mass {
        (ib, -normal)
    } else {
        (ia, normal)
    };
    if !pressed[light] {
        return normal;
    }
    let rotation = state.poses[light].rotation;
    match face_normal_toward(
        state.shapes[light].as_ref(),
        rotation,
        outward,
        FACE_NORMAL_ANGLE,
    ) {
        Some(face) if light == ib => -face,
        Some(face) => face,
        None => normal,
    }
}

/// A kinematic body that turns, in a pair with a dynamic body, and its prescribed motion over
/// the step: the contacts of the pair are carried with it to the end of the step (see
/// [`Turning::carry`]).
#[derive(Clone, Copy)]
pub(super) struct Turning {
    /// +1 when the kinematic body is the pair's first body (the normal points away from it),
    /// -1 when it is the second.
    sign: f32,
    /// The kinematic body's motion over the step, from its start pose.
    motion: StepMotion,
    /// Its pose at the end of the step.
    end: Pose,
    /// The dynamic body's sphere, if it is one: its centre at the start of the step and its
    /// radius.
    ball: Option<(Vec3, f32)>,
}

/// A contact point on a face of the turning kinematic body: the point on that face when the
/// contact was built, and the dynamic body's contact point at the start of the step.
struct Face {
    on_kinematic: Vec3,
    on_dynamic: Vec3,
}

impl Turning {
    /// The turning kinematic body of the pair `(ia, ib)` (not a sphere, whose contact normal
    /// does not turn with it) and its motion, if the other body is dynamic.
    fn of(state: &PhysicsState, ia: usize, ib: usize) -> Option<Turning> {
        let (k, d, sign) = Turning::sides(state, ia, ib)?;
        let motion = StepMotion {
            pose: state.poses[k],
            local_center: state.local_com[k],
            linear: state.bodies[k].linear_velocity,
            angular: state.bodies[k].angular_velocity,
            spin_reach: state.spin_reach[k],
        };
        let ball = state.shapes[d]
            .as_ball()
            .map(|b| (state.poses[d].translation, b.radius));
        Some(Turning {
            sign,
            motion,
            end: motion.pose_at(state.dt),
            ball,
        })
    }

    /// `(kinematic body, dynamic body, sign)` of the pair `(ia, ib)` if it has a turning
    /// kinematic body (see [`Turning::of`]).
    pub(super) fn sides(state: &PhysicsState, ia: usize, ib: usize) -> Option<(usize, usize, f32)> {
        let turns = |k: usize, d: usize| {
            state.bodies[k].motion == Motion::Kinematic
                && state.bodies[k].angular_velocity != Vec3::ZERO
                && state.bodies[d].motion == Motion::Dynamic
                && state.shapes[k].as_ball().is_none()
        };
        if turns(ia, ib) {
            Some((ia, ib, 1.0))
        } else if turns(ib, ia) {
            Some((ib, ia, -1.0))
        } else {
            None
        }
    }

    /// The face point of a contact whose surface points are `points` (`(on a, on b)`, each with
    /// whether it lies on a face), if the kinematic body's point lies on one of its faces;
    /// `to_start` maps the dynamic body's point back to the start of the step.
    fn face(
        &self,
        ((on_a, face_a), (on_b, face_b)): ((Vec3, bool), (Vec3, bool)),
        to_start: impl Fn(Vec3) -> Vec3,
    ) -> Option<Face> {
        let (on_kinematic, face, on_dynamic) = if self.sign > 0.0 {
            (on_a, face_a, on_b)
        } else {
            (on_b, face_b, on_a)
        };
        face.then(|| Face {
            on_kinematic,
            on_dynamic: to_start(on_dynamic),
        })
    }

    /// Where the kinematic body's material point that is at `p` when the body is at `pose` is
    /// at the end of the step.
    fn at_end(&self, p: Vec3, pose: &Pose) -> Vec3 {
        self.end.transform_point(pose.inverse_transform_point(p))
    }

    /// Carries contact `c`, built with the kinematic body at `at`, with the kinematic body to
    /// the end of the step, so that every method's rows keep the dynamic body out of where the
    /// kinematic body will be rather than where it was.
    ///
    /// A point on a face of the kinematic body gets that face's plane at the end of the step:
    /// the normal turned with the body, and a separation that the rows' own model of the
    /// step (each anchor moved rigidly with its body, `current_separation`) brings at the end of
    /// the step to the dynamic point's distance from that plane, `s_end + d . n` for a
    /// displacement `d` of the dynamic point. (The face plane carried rigidly, the start
    /// separation of a point built at the start pose is unchanged: only the normal turns.) A
    /// sphere's point is moved to where its surface meets the turned normal, so that the row
    /// still passes through its centre. The row gets the [`drive`](ContactConstraint::drive)
    /// that makes it move the kinematic body's point by its exact displacement over the step.
    ///
    /// A point on an edge or a vertex of the kinematic body keeps its start geometry: its
    /// normal is the other body's face (or an edge pair's), which turns with the other body,
    /// not with the kinematic one. (Driving such a row with the kinematic point's exact
    /// displacement alone made things worse: a box spinning at 4 rad/s, its edge sliding along
    /// the face of a cube the push set turning, sank 3.5 mm into it instead of 2.1 under the
    /// hybrid method, 13.5 instead of 10.6 under propagation.)
    ///
    /// Why: with the start normal held for the whole step, the pushed body is kept out of a
    /// plane that no longer exists. A ball pushed along a bar turning at 10 rad/s slides out
    /// along it at several m/s, and the start plane lets it lag the turned face by that
    /// sliding times the turn, `v_r dt theta` (1.4 cm per step at 5 m/s, 0.17 rad): the bar
    /// sank 3.7-5.5 cm into it.
    fn carry(
        &self,
        c: &mut ContactConstraint,
        at: &Pose,
        face: Option<Face>,
        bodies: &[SolverBody],
        dt: f32,
    ) {
        let Some(face) = face else {
            return;
        };
        let start = &self.motion.pose;
        let normal = ((self.end.rotation * at.rotation.inverse()) * c.normal).normalize();
        let on_dynamic = match self.ball {
            Some((centre, radius)) => centre - self.sign * radius * normal,
            None => face.on_dynamic,
        };
        let end_separation =
            self.sign * (on_dynamic - self.at_end(face.on_kinematic, at)).dot(normal);
        // How far the kinematic body's point at `on_dynamic` moves along the normal in the step.
        let travel = (self.at_end(on_dynamic, start) - on_dynamic).dot(normal);
        c.normal = normal;
        c.point = on_dynamic;
        c.separation = end_separation + self.sign * travel;
        let body = if self.sign > 0.0 {
            &bodies[c.body_a]
        } else {
            &bodies[c.body_b]
        };
        let first_order = (body.linear_velocity
            + body.angular_velocity.cross(on_dynamic - body.position))
        .dot(normal);
        c.drive = self.sign * (first_order - travel / dt);
    }
}

/// Adds the contact row of point `k` of manifold `m` of candidate pair `pair` (the `key`),
/// starting from the impulses that point carried from the last step (warm starting).
fn push_row(
    contacts: &mut Vec<ContactConstraint>,
    keys: &mut Vec<(u32, u32, u32)>,
    mut row: ContactConstraint,
    carried: ContactImpulse,
    (pair, m, k): (usize, usize, usize),
) {
    row.normal_impulse = carried.normal;
    row.tangent_impulse = carried.tangent;
    contacts.push(row);
    keys.push((pair as u32, m as u32, k as u32));
}

/// Records the rows pushed since `start` as one body pair's range, if there are any.
fn close_pair_range(contacts: &[ContactConstraint], ranges: &mut Vec<Range<usize>>, start: usize) {
    if contacts.len() > start {
        ranges.push(start..contacts.len());
    }
}
