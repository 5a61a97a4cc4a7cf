//! The normal of a manifold whose lighter body a heavier dynamic body presses: taken from the
//! lighter body's own face, so that a light body pressed between heavy ones is not pushed out.

use bevy::prelude::*;

use super::super::PhysicsState;
use crate::collision::narrow_phase::face_normal_toward;

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
