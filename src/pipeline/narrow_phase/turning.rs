//! A kinematic body that turns, in a pair with a dynamic body: its contacts carried with it to
//! the end of the step.

use bevy::prelude::*;
use parry3d::math::Pose;

use super::super::PhysicsState;
use crate::collision::narrow_phase::StepMotion;
use crate::dynamics::solver::{ContactConstraint, Motion, SolverBody};

/// A kinematic body that turns, in a pair with a dynamic body, and its prescribed motion over
/// the step: the contacts of the pair are carried with it to the end of the step (see
/// [`Turning::carry`]).
#[derive(Clone, Copy)]
pub(in crate::pipeline) struct Turning {
    /// +1 when the kinematic body is the pair's first body (the normal points away from it),
    /// -1 when it is the second.
    pub(super) sign: f32,
    /// The kinematic body's motion over the step, from its start pose.
    pub(super) motion: StepMotion,
    /// Its pose at the end of the step.
    pub(super) end: Pose,
    /// The dynamic body's sphere, if it is one: its centre at the start of the step and its
    /// radius.
    pub(super) ball: Option<(Vec3, f32)>,
}

/// A contact point on a face of the turning kinematic body: the point on that face when the
/// contact was built, and the dynamic body's contact point at the start of the step.
pub(super) struct Face {
    pub(super) on_kinematic: Vec3,
    pub(super) on_dynamic: Vec3,
}

impl Turning {
    /// The turning kinematic body of the pair `(ia, ib)` (not a sphere, whose contact normal
    /// does not turn with it) and its motion, if the other body is dynamic.
    pub(super) fn of(state: &PhysicsState, ia: usize, ib: usize) -> Option<Turning> {
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
    pub(in crate::pipeline) fn sides(
        state: &PhysicsState,
        ia: usize,
        ib: usize,
    ) -> Option<(usize, usize, f32)> {
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
    pub(super) fn face(
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
    pub(super) fn at_end(&self, p: Vec3, pose: &Pose) -> Vec3 {
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
    pub(super) fn carry(
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
