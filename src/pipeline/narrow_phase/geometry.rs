//! The manifold pass: each candidate pair's manifolds updated for the step, at the start poses
//! or, for a fast-turning body, at the time-of-impact poses.

use parry3d::shape::SharedShape;

use super::super::{CandidatePairs, PhysicsState};
use super::parts::{forget_sensor_points, mixed};
use crate::collision::narrow_phase::{ContactPair, Meeting, StepMotion, time_of_impact};

/// Turn in one step, rad, beyond which a body's contact is generated at the time-of-impact
/// poses rather than at the start pose (see [`pair_geometry`]): a quarter radian (14 degrees),
/// past which the start pose's first-order turn of the anchors drifts from the true rotation.
const FAR_TURN: f32 = 0.25;

/// What the manifold pass found for one candidate pair (see [`pair_geometry`]).
pub(super) enum Geometry {
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
pub(super) fn pair_geometry(
    state: &PhysicsState,
    candidates: &CandidatePairs,
    scaled: Option<&(SharedShape, SharedShape)>,
    unit: f32,
    pair_index: usize,
    pair: &mut ContactPair,
) -> Geometry {
    // Long on purpose: a pair's kinds (dormant, detected only, meeting at a time of impact,
    // resting) end it early one after the other, sharing the poses, shapes and unit; a split
    // would hand all of them on.
    let narrow = &state.settings.narrow;
    let (ia, ib) = candidates.indices[pair_index];
    pair.detect_only = candidates.detect_only[pair_index];
    if candidates.dormant[pair_index] {
        return Geometry::None;
    }
    pair.compound = state.parts[ia].is_some() || state.parts[ib].is_some();
    if pair.compound {
        forget_sensor_points(state, (ia, ib), pair);
    }
    let margin = narrow.contact_margin;
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
        let touch = narrow.touch_distance;
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
                && state.bodies[i].angular_velocity.length() * state.dt > FAR_TURN
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
            // (Not for a body whose colliders pair differently: its first meeting may be a
            // sensor's, or a collider's that does not interact.)
            Meeting::At(t)
                if t > 0.0
                    && (turns_far(ia) || turns_far(ib))
                    && !(mixed(state, ia) || mixed(state, ib)) =>
            {
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
