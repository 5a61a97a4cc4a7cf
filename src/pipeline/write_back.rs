//! Write back: poses and velocities to the components; a non-finite result quarantines its
//! body instead.

use bevy::prelude::*;

use crate::dynamics::solver::Motion;
use crate::dynamics::validation::body_label;
use crate::dynamics::{AngularVelocity, LinearVelocity, Quarantined};
use crate::schedule::{PhysicsSchedule, PhysicsSystems};

use super::{PhysicsState, init_stage_state};

/// Adds [`write_back`] to [`PhysicsSystems::WriteBack`].
pub struct WriteBackPlugin;

impl Plugin for WriteBackPlugin {
    fn build(&self, app: &mut App) {
        init_stage_state(app).add_systems(
            PhysicsSchedule,
            write_back.in_set(PhysicsSystems::WriteBack),
        );
    }
}

/// The components [`write_back`] writes, and the name its log lines give.
type WriteBackData = (
    &'static mut Transform,
    Option<&'static mut LinearVelocity>,
    Option<&'static mut AngularVelocity>,
    Option<&'static Name>,
);

/// Writes poses and velocities of moving bodies back to their components. A body whose result
/// is not finite (finite input that overflowed) is not written: it is quarantined instead, so
/// no NaN ever reaches a component. A top-level body's `Transform` is its world pose; a body
/// with a parent gets the local `Transform` that puts it at the solved world pose (its scale is
/// left as it is).
pub fn write_back(
    mut commands: Commands,
    state: Res<PhysicsState>,
    mut query: Query<WriteBackData>,
) {
    for ((&entity, body), &local_com) in state
        .entities
        .iter()
        .zip(&state.bodies)
        .zip(&state.local_com)
    {
        if body.motion == Motion::Static {
            continue;
        }
        let finite = body.position.is_finite()
            && body.rotation.is_finite()
            && body.linear_velocity.is_finite()
            && body.angular_velocity.is_finite();
        if !finite {
            let reason = "the step produced a non-finite state (input too large?)".to_string();
            let name = query.get(entity).ok().and_then(|(_, _, _, name)| name);
            log::error!(
                "impact3d: {} is left out of the physics step: {reason}",
                body_label(entity, name)
            );
            commands.entity(entity).insert(Quarantined { reason });
            continue;
        }
        let Ok((mut transform, linear, angular, _)) = query.get_mut(entity) else {
            continue;
        };
        let translation = body.position - body.rotation * local_com;
        // A body with a parent: the local pose that puts it at the solved world pose under its
        // parent's world pose at the start of the step (see `local_pose`).
        let (translation, rotation) = match state.hierarchy.parent_frame(entity) {
            Some(frame) => local_pose(&frame, translation, body.rotation),
            None => (translation, body.rotation),
        };
        if transform.translation != translation || transform.rotation != rotation {
            transform.translation = translation;
            transform.rotation = rotation;
        }
        if body.motion == Motion::Dynamic {
            if let Some(mut v) = linear {
                v.set_if_neq(LinearVelocity(body.linear_velocity));
            }
            if let Some(mut w) = angular {
                w.set_if_neq(AngularVelocity(body.angular_velocity));
            }
        }
    }
}

/// The local translation and rotation that place a child at world `translation`, `rotation`
/// under a parent whose world transform is `frame`: `frame^-1 * world`, the inverse of Bevy's
/// `parent * local` (`t = t_p + R_p (s_p * t_l)`, `R = R_p R_l`). Exact up to rounding for a
/// parent of uniform scale; under a non-uniformly scaled and turned parent a turning child is
/// sheared, which a `Transform` cannot hold, and only its translation is exact.
pub fn local_pose(frame: &Transform, translation: Vec3, rotation: Quat) -> (Vec3, Quat) {
    let inverse = frame.rotation.inverse();
    let local_translation = (inverse * (translation - frame.translation)) / frame.scale;
    let local_rotation = (inverse * rotation).normalize();
    (local_translation, local_rotation)
}
