//! Transform interpolation: smooth motion between fixed physics steps.
//!
//! Physics moves bodies in fixed steps (60 Hz by default); a screen refreshing at another rate
//! shows them stutter. An interpolated body is drawn, each frame, between its last two physics
//! poses at the fraction of the step that has elapsed (`Time<Fixed>::overstep_fraction`), so it
//! is shown up to one step behind the simulation, moving smoothly.
//!
//! Opt in per body with [`TransformInterpolation`], or for every dynamic and kinematic body with
//! [`InterpolationConfig::all`] (or `PhysicsPlugins::default().set(InterpolationPlugin { all:
//! true })`).
//!
//! How it keeps the simulation unchanged, frame by frame:
//!
//! 1. Before the fixed-step loop ([`restore_physics_poses`]), each interpolated `Transform` gets
//!    back the exact pose the physics wrote last, so the step reads what it would have read
//!    without interpolation (a test checks that poses and velocities are bit-identical).
//! 2. After each physics step ([`record_physics_poses`]), the pose the step wrote becomes the
//!    end of the interval and the previous one its start.
//! 3. After the fixed-step loop ([`interpolate_transforms`]), `Transform` is set between the two.
//!
//! A `Transform` that differs from what step 1 or 3 wrote last was changed by the user (a
//! teleport): it is kept, and interpolation restarts from it. Sleeping bodies are left alone:
//! their `Transform` keeps the pose physics wrote when they fell asleep, so interpolation never
//! marks it changed and never wakes them (a sleeper wakes when its `Transform` changes after it
//! fell asleep). A body falling asleep is shown at its final physics pose at once; it moved less
//! than `SleepConfig::linear_threshold` times one step in its last step.

use bevy::prelude::*;

use crate::dynamics::{RigidBody, Sleeping};
use crate::schedule::{PhysicsSchedule, PhysicsSystems, PhysicsTime};

/// Draws this body between its last two physics poses, so it moves smoothly whatever the frame
/// rate. Static bodies never move and are not interpolated. See [`crate::interpolation`].
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Debug, Default, PartialEq)]
#[require(InterpolationState)]
pub struct TransformInterpolation;

/// Interpolates every dynamic and kinematic body, not only those with
/// [`TransformInterpolation`], when `all` is true. Default false.
#[derive(Resource, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Resource, Debug, Default, PartialEq)]
pub struct InterpolationConfig {
    /// Interpolate every non-static body. Default false.
    pub all: bool,
}

/// The poses an interpolated body is drawn between, kept by the plugin (read-only for users).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct InterpolationState {
    /// The pose before the last physics step: translation m, rotation.
    pub start: (Vec3, Quat),
    /// The pose the last physics step wrote.
    pub end: (Vec3, Quat),
    /// The pose last written to `Transform` by interpolation or restore; a `Transform` that
    /// differs from it was changed by the user.
    pub written: (Vec3, Quat),
    /// False until the first physics step after the body started interpolating.
    pub valid: bool,
}

impl InterpolationState {
    /// Standing still at `pose` (a pose the user set: interpolation restarts from it).
    pub fn at(pose: (Vec3, Quat)) -> Self {
        InterpolationState {
            start: pose,
            end: pose,
            written: pose,
            valid: true,
        }
    }
}

/// Transform interpolation (part of [`PhysicsPlugins`](crate::PhysicsPlugins)). With `all`
/// false (the default) only bodies with [`TransformInterpolation`] are interpolated.
#[derive(Default)]
pub struct InterpolationPlugin {
    /// Initial value of [`InterpolationConfig::all`].
    pub all: bool,
}

impl Plugin for InterpolationPlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(InterpolationConfig { all: self.all })
            .register_type::<TransformInterpolation>()
            .register_type::<InterpolationConfig>()
            .add_systems(
                RunFixedMainLoop,
                (
                    restore_physics_poses.in_set(RunFixedMainLoopSystems::BeforeFixedMainLoop),
                    interpolate_transforms.in_set(RunFixedMainLoopSystems::AfterFixedMainLoop),
                ),
            )
            .add_systems(
                PhysicsSchedule,
                record_physics_poses.after(PhysicsSystems::WriteBack),
            );
    }
}

/// A `Transform`'s pose as a pair.
fn pose(t: &Transform) -> (Vec3, Quat) {
    (t.translation, t.rotation)
}

/// The pose a fraction `alpha` in `[0, 1]` of the way from `start` to `end`: translation by
/// linear interpolation, rotation by normalised linear interpolation along the shorter arc
/// (exact at both ends, indistinguishable from slerp for the rotation of one step).
pub fn lerp_pose(start: (Vec3, Quat), end: (Vec3, Quat), alpha: f32) -> (Vec3, Quat) {
    if alpha >= 1.0 {
        return end;
    }
    if alpha <= 0.0 {
        return start;
    }
    let translation = start.0.lerp(end.0, alpha);
    // `Quat::lerp` takes the shorter arc and normalises.
    let rotation = start.1.lerp(end.1, alpha);
    (translation, rotation)
}

/// Writes `p` into `transform` only if it differs, so unchanged bodies stay unchanged.
fn write_pose(transform: &mut Mut<Transform>, p: (Vec3, Quat)) {
    if pose(transform) != p {
        transform.translation = p.0;
        transform.rotation = p.1;
    }
}

/// The components [`restore_physics_poses`] reads and writes.
type RestoreQuery<'a> = (
    Entity,
    &'a mut Transform,
    &'a mut InterpolationState,
    Option<&'a RigidBody>,
    Has<TransformInterpolation>,
    Has<Sleeping>,
);

/// Bodies that have no [`InterpolationState`] yet.
type MissingState = (Without<InterpolationState>, With<Transform>);

/// Before the fixed-step loop: gives each interpolated body back the pose the physics wrote
/// last, keeps a pose the user set instead (restarting interpolation from it), and adds or
/// removes [`InterpolationState`] as [`InterpolationConfig::all`] and
/// [`TransformInterpolation`] say.
pub fn restore_physics_poses(
    mut commands: Commands,
    config: Res<InterpolationConfig>,
    mut bodies: Query<RestoreQuery>,
    missing: Query<(Entity, &RigidBody), MissingState>,
) {
    for (entity, mut transform, mut state, body, marked, sleeping) in &mut bodies {
        let wanted = marked || (config.all && body.is_some_and(|b| !b.is_static()));
        if state.valid {
            if pose(&transform) != state.written {
                // The user moved the body: keep their pose, restart from it.
                *state = InterpolationState::at(pose(&transform));
            } else if !sleeping {
                let end = state.end;
                write_pose(&mut transform, end);
                state.written = end;
            }
        }
        if !wanted {
            commands.entity(entity).remove::<InterpolationState>();
        }
    }
    if config.all {
        for (entity, body) in &missing {
            if !body.is_static() {
                commands
                    .entity(entity)
                    .insert(InterpolationState::default());
            }
        }
    }
}

/// After each physics step: the pose the step wrote becomes the end of the interval, the
/// previous end its start.
pub fn record_physics_poses(mut bodies: Query<(&Transform, &mut InterpolationState)>) {
    for (transform, mut state) in &mut bodies {
        let p = pose(transform);
        if state.valid {
            state.start = state.end;
        } else {
            state.start = p;
            state.valid = true;
        }
        state.end = p;
        state.written = p;
    }
}

/// After the fixed-step loop: draws each awake interpolated body at the elapsed fraction of the
/// step between its last two physics poses. A sleeping body stays at its physics pose, and so
/// does every body while [`PhysicsTime`] is paused.
pub fn interpolate_transforms(
    time: Res<Time<Fixed>>,
    clock: Option<Res<PhysicsTime>>,
    mut bodies: Query<(&mut Transform, &mut InterpolationState, Has<Sleeping>)>,
) {
    // Paused, physics writes no new pose: every body is shown where it stopped.
    let alpha = if clock.is_some_and(|c| !c.is_running()) {
        1.0
    } else {
        time.overstep_fraction()
    };
    for (mut transform, mut state, sleeping) in &mut bodies {
        if !state.valid {
            continue;
        }
        if pose(&transform) != state.written {
            // Moved by the user since the step (or after a step with no restore): keep it.
            *state = InterpolationState::at(pose(&transform));
            continue;
        }
        if sleeping {
            state.start = state.end;
            continue;
        }
        let p = lerp_pose(state.start, state.end, alpha);
        write_pose(&mut transform, p);
        state.written = p;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both ends are returned exactly (bit for bit), and the midpoint of a translation is its
    /// mean; the midpoint of a 90 degree turn about y is the 45 degree turn (tolerance 1e-6,
    /// f32 rounding of a unit quaternion).
    #[test]
    fn lerp_pose_ends_and_middle() {
        let a = (Vec3::new(1.0, 2.0, 3.0), Quat::IDENTITY);
        let b = (
            Vec3::new(3.0, 2.0, -1.0),
            Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
        );
        assert_eq!(lerp_pose(a, b, 0.0), a);
        assert_eq!(lerp_pose(a, b, 1.0), b);
        let (t, r) = lerp_pose(a, b, 0.5);
        assert_eq!(t, Vec3::new(2.0, 2.0, 1.0));
        let expected = Quat::from_rotation_y(std::f32::consts::FRAC_PI_4);
        assert!(r.angle_between(expected) < 1e-6, "{r} vs {expected}");
    }
}
