//! The narrow phase: parry3d's persistent contact manifolds per candidate pair, and one
//! contact row per point, warm-started from the impulse that point carried from the last step.

use std::ops::Range;

use bevy::prelude::*;
use bevy::tasks::{ComputeTaskPool, ParallelSliceMut, TaskPool};
use parry3d::shape::SharedShape;

use crate::collision::narrow_phase::{ContactPair, StepMotion, UnitShapes, binary_unit};
use crate::collision::parts::PartContact;
use crate::collision::{ContactPairs, NarrowPhaseConfig};
use crate::dynamics::CoefficientCombine;
use crate::dynamics::solver::{ContactConstraint, Motion, SolverBody};
use crate::schedule::{PhysicsSchedule, PhysicsSystems};

use super::{
    CandidatePairs, ColliderPair, ContactRows, PhysicsState, StepEvents, init_stage_state,
};

mod geometry;
mod normals;
mod parts;
mod turning;

use geometry::{Geometry, pair_geometry};
pub use normals::{FACE_NORMAL_ANGLE, lighter_face_normal};
pub(super) use parts::mixed;
use parts::{ManifoldPart, ManifoldParts, manifold_parts};
pub(super) use turning::Turning;

/// Adds [`update_narrow_phase`] to [`PhysicsSystems::NarrowPhase`], and the narrow phase's
/// settings [`NarrowPhaseConfig`] (initialised to its default unless already inserted).
pub struct NarrowPhasePlugin;

impl Plugin for NarrowPhasePlugin {
    fn build(&self, app: &mut App) {
        init_stage_state(app)
            .init_resource::<NarrowPhaseConfig>()
            .register_type::<NarrowPhaseConfig>()
            .add_systems(
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
    mut scratch: Local<Scratch>,
) {
    let state = &mut *state;
    let rows = &mut *rows;
    let Scratch { pressed, geometry } = &mut *scratch;
    events.ended.clear();
    events.started.clear();
    events.colliders_ended.clear();
    events.colliders_started.clear();
    state.lost.clear();
    drop_ended_pairs(state, &mut pairs, &candidates, &mut events);
    rows.contacts.clear();
    rows.pair_ranges.clear();
    rows.keys.clear();
    rows.detected.clear();
    rows.detected_parts.clear();
    pressed_bodies(state, &candidates, pressed);
    // Contacts are generated with the shapes scaled to the length unit (see
    // `ContactPair::update`); a pair with a shape parry cannot scale keeps metres.
    let unit = binary_unit(state.settings.length_unit);
    let mut unit_shapes = std::mem::take(&mut state.unit_shapes);
    let scaled = unit_scaled_shapes(state, &candidates, &mut unit_shapes, unit);
    if let Some(split) = parallel_pairs(pairs.candidates().len()) {
        all_pair_geometry(
            state,
            &candidates,
            (&scaled, unit),
            &mut pairs,
            split,
            geometry,
        );
        for (pair_index, ((pair, &(ia, ib)), geometry)) in pairs
            .pairs_mut()
            .iter_mut()
            .zip(&candidates.indices)
            .zip(geometry.drain(..))
            .enumerate()
        {
            pair_rows(state, rows, pressed, pair, pair_index, (ia, ib), geometry);
        }
    } else {
        // On one thread each pair's rows are read off its manifolds right after they are
        // updated, while they are still in the cache: read in a second pass over thousands of
        // pairs, the manifolds' first load was 11 % of a settled pile's step (2,000 spheres).
        for (pair_index, (pair, &(ia, ib))) in pairs
            .pairs_mut()
            .iter_mut()
            .zip(&candidates.indices)
            .enumerate()
        {
            let scaled = scaled.get(pair_index).and_then(Option::as_ref);
            let geometry = pair_geometry(state, &candidates, scaled, unit, pair_index, pair);
            pair_rows(state, rows, pressed, pair, pair_index, (ia, ib), geometry);
        }
    }
    unit_shapes.prune();
    state.unit_shapes = unit_shapes;
}

/// The narrow phase's buffers, kept between steps so that a steady step allocates nothing.
#[derive(Default)]
pub struct Scratch {
    /// [`pressed_bodies`]'s flags.
    pressed: Vec<bool>,
    /// [`all_pair_geometry`]'s results.
    geometry: Vec<Geometry>,
}

/// Drops the pairs that are no longer candidates: each that was touching has ended, and unless
/// it only detected (a sensor's touch held nothing up) its bodies have lost a support.
fn drop_ended_pairs(
    state: &mut PhysicsState,
    pairs: &mut ContactPairs,
    candidates: &CandidatePairs,
    events: &mut StepEvents,
) {
    let (ended, lost) = (&mut events.ended, &mut state.lost);
    let colliders_ended = &mut events.colliders_ended;
    pairs.retain_candidates(&candidates.pairs, |p| {
        if p.compound {
            colliders_ended.extend(p.part_touching.iter().map(|&colliders| ColliderPair {
                colliders,
                bodies: (p.a, p.b),
            }));
        } else if p.touching {
            colliders_ended.push(ColliderPair::of_bodies(p.a, p.b));
        }
        if p.touching {
            ended.push((p.a, p.b));
            // A sensor's touch held nothing up: losing it wakes no one.
            if !p.detect_only {
                lost.extend([p.a, p.b]);
            }
        }
    });
}

/// The bodies a heavier dynamic body may press (see [`lighter_face_normal`]), into `pressed`.
fn pressed_bodies(state: &PhysicsState, candidates: &CandidatePairs, pressed: &mut Vec<bool>) {
    pressed.clear();
    pressed.resize(state.bodies.len(), false);
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
}

/// Each candidate pair's shapes scaled to the length unit `unit` (none at all when it is 1);
/// `None` for a pair with a shape parry cannot scale.
fn unit_scaled_shapes(
    state: &PhysicsState,
    candidates: &CandidatePairs,
    unit_shapes: &mut UnitShapes,
    unit: f32,
) -> Vec<Option<(SharedShape, SharedShape)>> {
    if unit == 1.0 {
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
    }
}

/// The manifolds of every pair, independently of the others, into `out` in pair order: in
/// parallel on Bevy's compute task pool (`split`: the pool and the pairs per task, from
/// [`parallel_pairs`]), in chunks whose results come back in pair order, so the step is the
/// same on any number of threads.
fn all_pair_geometry(
    state: &PhysicsState,
    candidates: &CandidatePairs,
    (scaled, unit): (&[Option<(SharedShape, SharedShape)>], f32),
    pairs: &mut ContactPairs,
    (pool, per_task): (&ComputeTaskPool, usize),
    out: &mut Vec<Geometry>,
) {
    out.clear();
    let chunks = pairs
        .pairs_mut()
        .par_chunk_map_mut(pool, per_task, |chunk, pairs| {
            pairs
                .iter_mut()
                .enumerate()
                .map(|(k, pair)| {
                    let pair_index = chunk * per_task + k;
                    let scaled = scaled.get(pair_index).and_then(Option::as_ref);
                    pair_geometry(state, candidates, scaled, unit, pair_index, pair)
                })
                .collect::<Vec<_>>()
        });
    out.extend(chunks.into_iter().flatten());
}

/// The contact rows of candidate pair `pair_index` (bodies `ia` and `ib`) from what the
/// manifold pass found for it: none for a pair without contact or one only detected (recorded
/// in `rows.detected` when touching); else a row per contact point, at the start poses or, for
/// a fast-turning body, from the time-of-impact poses ([`impact_rows`]).
///
/// A pair with a body made of child colliders (`pair.compound`) is sorted out manifold by
/// manifold, each on one collider of each body: its rows take that pair of colliders'
/// restitution and friction, a manifold between colliders whose layers do not interact has
/// none, and one on a sensor has none but counts for touching (in `rows.detected_parts`, and
/// its pair in `rows.detected`).
fn pair_rows(
    state: &PhysicsState,
    rows: &mut ContactRows,
    pressed: &[bool],
    pair: &ContactPair,
    pair_index: usize,
    (ia, ib): (usize, usize),
    geometry: Geometry,
) {
    let parts = pair.compound.then(|| manifold_parts(state, (ia, ib), pair));
    let impact_time = match geometry {
        Geometry::None => return,
        Geometry::Detected(touching) => {
            let touching = match &parts {
                Some(parts) => detected_parts(state, rows, pair, pair_index, (ia, ib), parts),
                None => touching,
            };
            if touching {
                rows.detected.push(pair_index as u32);
            }
            return;
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
    if let Some(impact) = impact_time {
        impact_rows(
            state,
            rows,
            pair,
            pair_index,
            (ia, ib),
            impact,
            (restitution, friction),
            (turning.as_ref(), parts.as_deref()),
        );
        close_pair_range(&rows.contacts, &mut rows.pair_ranges, start);
        return;
    }
    if let Some(parts) = &parts
        && detected_parts(state, rows, pair, pair_index, (ia, ib), parts)
    {
        rows.detected.push(pair_index as u32);
    }
    let mut face = None;
    // Internal iteration (`for_each`): a `for` loop over the manifolds' flattened points paid
    // `Flatten::next` on every point, 5 % of a 1,000-sphere pour's step.
    let points = pair.world_points(pose_a, pose_b);
    points.for_each(|(m, k, point, normal, dist)| {
        let Some((restitution, friction)) =
            part_material(parts.as_deref(), m, restitution, friction)
        else {
            return;
        };
        let normal = match face {
            Some((manifold, n)) if manifold == m => n,
            _ => {
                let n = lighter_face_normal(state, pressed, ia, ib, normal);
                face = Some((m, n));
                n
            }
        };
        let mut c = ContactConstraint::new(ia, ib, point, normal, dist, restitution, friction);
        if let Some(turning) = &turning {
            let face = turning.face(pair.surface_points(m, k, pose_a, pose_b), |p| p);
            turning.carry(&mut c, &turning.motion.pose, face, &state.bodies, state.dt);
        }
        push_row(rows, pair, c, (pair_index, m, k));
    });
    close_pair_range(&rows.contacts, &mut rows.pair_ranges, start);
}

/// The rows of pair `pair_index` (bodies `ia` and `ib`) whose bodies meet `t` s into the step,
/// for [`pair_rows`].
#[allow(clippy::too_many_arguments)]
fn impact_rows(
    state: &PhysicsState,
    rows: &mut ContactRows,
    pair: &ContactPair,
    pair_index: usize,
    (ia, ib): (usize, usize),
    (t, motion_a, motion_b): (f32, StepMotion, StepMotion),
    (restitution, friction): (f32, f32),
    (turning, parts): (Option<&Turning>, Option<&[ManifoldPart]>),
) {
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
        let Some((restitution, friction)) = part_material(parts, m, restitution, friction) else {
            continue;
        };
        let point = impact_point - shift;
        let point_velocity = |body: &SolverBody| {
            body.linear_velocity + body.angular_velocity.cross(point - body.position)
        };
        let approach = (point_velocity(b) - point_velocity(a)).dot(normal);
        if approach >= 0.0 {
            continue;
        }
        let separation = dist.max(0.0) - approach * t;
        let mut c =
            ContactConstraint::new(ia, ib, point, normal, separation, restitution, friction);
        if let Some(turning) = turning {
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
        push_row(rows, pair, c, (pair_index, m, k));
    }
}

/// The restitution and friction of the rows of manifold `m`: the pair's (`restitution`,
/// `friction`) for a pair without child colliders (`parts` is `None`), else those of the
/// manifold's colliders; `None` when the manifold has no rows (a sensor's, or between colliders
/// whose layers do not interact).
fn part_material(
    parts: Option<&[ManifoldPart]>,
    m: usize,
    restitution: f32,
    friction: f32,
) -> Option<(f32, f32)> {
    match parts {
        None => Some((restitution, friction)),
        Some(parts) => match parts[m].0 {
            PartContact::Solved {
                restitution,
                friction,
            } => Some((restitution, friction)),
            PartContact::Sensor | PartContact::Filtered => None,
        },
    }
}

/// Records in `rows.detected_parts` the colliders of compound pair `pair_index` that touch
/// without rows: those of each manifold with a point within the touch distance that only
/// detects (a sensor's, or any of a detect-only pair), none where the colliders' layers do not
/// interact. Returns whether any touch.
fn detected_parts(
    state: &PhysicsState,
    rows: &mut ContactRows,
    pair: &ContactPair,
    pair_index: usize,
    (ia, ib): (usize, usize),
    parts: &ManifoldParts,
) -> bool {
    let touch = state.settings.narrow.touch_distance;
    let (pose_a, pose_b) = (&state.poses[ia], &state.poses[ib]);
    let start = rows.detected_parts.len();
    let mut last = None;
    for (m, _, _, _, dist) in pair.world_points(pose_a, pose_b) {
        let (contact, a, b) = parts[m];
        let detects = match contact {
            PartContact::Filtered => false,
            PartContact::Sensor => true,
            PartContact::Solved { .. } => pair.detect_only,
        };
        if detects && dist <= touch && last != Some(m) {
            last = Some(m);
            rows.detected_parts.push((pair_index as u32, a, b));
        }
    }
    rows.detected_parts.len() > start
}

/// The compute task pool and the pairs per task when the manifold pass over `pairs` pairs runs
/// in parallel; `None` when it runs on this thread: without feature `parallel`, on a pool of
/// one thread (as Bevy's `Query::par_iter` does; its one worker and the waiting main thread
/// splitting the pairs bought nothing measurable: a 1,000-sphere pour took 4.2-5.4 ms a step
/// that way, 4.6-5.6 ms on one thread), or with pairs for one task only. (The pool's scope
/// also allocates for its tasks every step, which a one-thread build has no use for.)
fn parallel_pairs(pairs: usize) -> Option<(&'static ComputeTaskPool, usize)> {
    if !cfg!(feature = "parallel") {
        return None;
    }
    let pool = ComputeTaskPool::get_or_init(TaskPool::default);
    let per_task = pairs_per_task(pairs, pool.thread_num());
    (pool.thread_num() > 1 && per_task < pairs).then_some((pool, per_task))
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

/// Adds the contact row of point `k` of manifold `m` of `pair`, candidate pair `pair_index`
/// (the row's key), starting from the impulses that point carried from the last step (warm
/// starting).
fn push_row(
    rows: &mut ContactRows,
    pair: &ContactPair,
    mut row: ContactConstraint,
    (pair_index, m, k): (usize, usize, usize),
) {
    let carried = pair.manifolds[m].points[k].data;
    row.normal_impulse = carried.normal;
    row.tangent_impulse = carried.tangent;
    row.twist_impulse = carried.twist;
    rows.contacts.push(row);
    rows.keys.push((pair_index as u32, m as u32, k as u32));
}

/// Records the rows pushed since `start` as one body pair's range, if there are any.
fn close_pair_range(contacts: &[ContactConstraint], ranges: &mut Vec<Range<usize>>, start: usize) {
    if contacts.len() > start {
        ranges.push(start..contacts.len());
    }
}
