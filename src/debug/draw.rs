//! The drawing systems: each gathers what to draw, turns it into segments and hands them to
//! the gizmos.

use bevy::gizmos::gizmos::Gizmos;
use bevy::prelude::*;
use parry3d::math::Pose;
use parry3d::shape::SharedShape;

use super::{BodyState, DebugRender, ImpactTrails, PhysicsGizmoGroup, PhysicsGizmos};
use super::{arrow_segments, box_segments, cross_segments, shape_segments};
use crate::collision::collider::scaled_shape;
use crate::collision::{Collider, ColliderOf, ContactPairs, NarrowPhaseConfig};
use crate::dynamics::validation::PhysicsLengthUnit;
use crate::dynamics::{AngularVelocity, LinearVelocity, Quarantined, RigidBody, Sleeping};
use crate::messages::Impact;

/// The pose of a `Transform` (scale ignored, as the physics does).
fn pose_of(t: &Transform) -> Pose {
    Pose::from_parts(t.translation, t.rotation.normalize())
}

/// Hands every segment of `segments` to the gizmos in `color` and empties it.
fn flush(gizmos: &mut Gizmos<PhysicsGizmoGroup>, segments: &mut Vec<[Vec3; 2]>, color: Color) {
    for [a, b] in segments.drain(..) {
        gizmos.line(a, b, color);
    }
}

/// The components the collider and bounding-box layers read.
type BodyQuery<'a> = (
    &'a Collider,
    &'a Transform,
    Option<&'a GlobalTransform>,
    Has<ChildOf>,
    Option<&'a ColliderOf>,
    Option<&'a DebugRender>,
);

/// The components a collider's colour comes from, on its body.
type StateQuery<'a> = (Option<&'a RigidBody>, Has<Sleeping>, Has<Quarantined>);

/// A collider's shape as the physics sees it, in the world: at its `Transform` for a top-level
/// entity, at its `GlobalTransform` for a child (a part of its parent's body), and scaled by
/// that transform's scale as [`scaled_shape`] scales it (unscaled where it cannot be).
fn world_shape(
    collider: &Collider,
    transform: &Transform,
    global: Option<&GlobalTransform>,
    child: bool,
) -> (SharedShape, Pose) {
    let (scale, rotation, translation) = match global {
        Some(global) if child => global.to_scale_rotation_translation(),
        _ => (transform.scale, transform.rotation, transform.translation),
    };
    let shape = scaled_shape(collider.shape(), scale)
        .map_or_else(|_| collider.shape().clone(), |(shape, _)| shape);
    (shape, Pose::from_parts(translation, rotation.normalize()))
}

/// Draws each collider's wireframe ([`shape_segments`]) in the colour of its [`BodyState`] or
/// its [`DebugRender::color`].
///
/// Each collider is drawn where the physics has it: a child collider at its world pose, each
/// collider scaled by its scale (see `world_shape`), and a child collider in its body's colour.
pub fn draw_colliders(
    mut gizmos: Gizmos<PhysicsGizmoGroup>,
    config: Res<PhysicsGizmos>,
    colliders: Query<(Entity, BodyQuery)>,
    states: Query<StateQuery>,
    mut segments: Local<Vec<[Vec3; 2]>>,
) {
    for (entity, (collider, transform, global, child, part_of, render)) in &colliders {
        let render = render.copied().unwrap_or_default();
        if !render.collider.unwrap_or(config.colliders) {
            continue;
        }
        let color = render.color.unwrap_or_else(|| {
            let body = part_of.map_or(entity, |c| c.body);
            let (kind, sleeping, quarantined) = states.get(body).unwrap_or((None, false, false));
            BodyState::of(kind, sleeping, quarantined).color(&config)
        });
        let (shape, pose) = world_shape(collider, transform, global, child);
        shape_segments(shape.as_ref(), &pose, &config, &mut segments);
        flush(&mut gizmos, &mut segments, color);
    }
}

/// Draws the world bounding box of each bounded collider (12 segments each; half-spaces have
/// none).
pub fn draw_aabbs(
    mut gizmos: Gizmos<PhysicsGizmoGroup>,
    config: Res<PhysicsGizmos>,
    bodies: Query<BodyQuery>,
    mut segments: Local<Vec<[Vec3; 2]>>,
) {
    for (collider, transform, global, child, _, render) in &bodies {
        if !render.and_then(|r| r.aabb).unwrap_or(config.aabbs)
            || collider.shape().as_halfspace().is_some()
        {
            continue;
        }
        let (shape, pose) = world_shape(collider, transform, global, child);
        let aabb = shape.compute_aabb(&pose);
        box_segments(aabb.mins, aabb.maxs, &Pose::identity(), &mut segments);
        flush(&mut gizmos, &mut segments, config.aabb_color);
    }
}

/// Draws each contact point closer than [`NarrowPhaseConfig::touch_distance`] (in the world's
/// [`PhysicsLengthUnit`], as the physics step counts touching) as a cross and its normal as a
/// line (4 segments a point), at the bodies' current poses.
pub fn draw_contacts(
    mut gizmos: Gizmos<PhysicsGizmoGroup>,
    config: Res<PhysicsGizmos>,
    pairs: Option<Res<ContactPairs>>,
    unit: Option<Res<PhysicsLengthUnit>>,
    narrow: Option<Res<NarrowPhaseConfig>>,
    transforms: Query<&Transform>,
) {
    let Some(pairs) = pairs.filter(|_| config.contacts) else {
        return;
    };
    // An invalid unit or touch distance is logged by the physics step, which then uses the last
    // good one; here the default stands in for it.
    let default = NarrowPhaseConfig::default();
    let touch = narrow.map_or(default.touch_distance, |n| {
        n.validated(&default).0.touch_distance
    }) * unit.map_or(1.0, |u| u.validated(1.0).0);
    let mut segments = Vec::new();
    for pair in pairs.iter().filter(|p| !p.manifolds.is_empty()) {
        let (Ok(ta), Ok(tb)) = (transforms.get(pair.a), transforms.get(pair.b)) else {
            continue;
        };
        let (pa, pb) = (pose_of(ta), pose_of(tb));
        for (_, _, point, normal, dist) in pair.world_points(&pa, &pb) {
            if dist > touch {
                continue;
            }
            cross_segments(point, config.contact_size, &mut segments);
            flush(&mut gizmos, &mut segments, config.contact_color);
            gizmos.line(
                point,
                point + config.normal_length * normal,
                config.normal_color,
            );
        }
    }
}

/// Adds the frame's `Impact` messages to [`ImpactTrails`] and ages them, dropping those older
/// than [`PhysicsGizmos::impact_fade`].
pub fn update_impact_trails(
    time: Res<Time>,
    config: Res<PhysicsGizmos>,
    mut trails: ResMut<ImpactTrails>,
    mut impacts: MessageReader<Impact>,
) {
    let dt = time.delta_secs();
    for (_, age) in trails.0.iter_mut() {
        *age += dt;
    }
    trails.0.retain(|(_, age)| *age < config.impact_fade);
    trails.0.extend(impacts.read().map(|&i| (i, 0.0)));
}

/// Draws each recent impact as an arrow at its point along its normal (towards `b`),
/// `impulse_scale x j` long (at most `max_impact_length`), its alpha falling from 1 to 0 over
/// `impact_fade` s.
pub fn draw_impacts(
    mut gizmos: Gizmos<PhysicsGizmoGroup>,
    config: Res<PhysicsGizmos>,
    trails: Res<ImpactTrails>,
    mut segments: Local<Vec<[Vec3; 2]>>,
) {
    if !config.impacts {
        return;
    }
    for (impact, age) in &trails.0 {
        let length = (config.impulse_scale * impact.impulse.abs()).min(config.max_impact_length);
        let alpha = (1.0 - age / config.impact_fade.max(f32::EPSILON)).clamp(0.0, 1.0);
        arrow_segments(impact.point, length * impact.normal, &mut segments);
        flush(
            &mut gizmos,
            &mut segments,
            config.impact_color.with_alpha(alpha),
        );
    }
}

/// The components the velocity layer reads.
type VelocityQuery<'a> = (
    &'a Transform,
    &'a RigidBody,
    Option<&'a LinearVelocity>,
    Option<&'a AngularVelocity>,
    Has<Sleeping>,
    Option<&'a DebugRender>,
);

/// Draws the linear and angular velocity of each awake, non-static body as arrows from its
/// origin, `velocity_scale` long per m/s or rad/s (3 segments each, none when zero).
pub fn draw_velocities(
    mut gizmos: Gizmos<PhysicsGizmoGroup>,
    config: Res<PhysicsGizmos>,
    bodies: Query<VelocityQuery>,
    mut segments: Local<Vec<[Vec3; 2]>>,
) {
    for (transform, body, linear, angular, sleeping, render) in &bodies {
        let wanted = render.and_then(|r| r.velocity).unwrap_or(config.velocities);
        if !wanted || sleeping || body.is_static() {
            continue;
        }
        let at = transform.translation;
        if let Some(v) = linear {
            arrow_segments(at, config.velocity_scale * v.0, &mut segments);
            flush(&mut gizmos, &mut segments, config.velocity_color);
        }
        if let Some(w) = angular {
            arrow_segments(at, config.velocity_scale * w.0, &mut segments);
            flush(&mut gizmos, &mut segments, config.angular_velocity_color);
        }
    }
}

/// Draws a line from each sleeping body to the body its island is named after (none for that
/// body itself).
pub fn draw_islands(
    mut gizmos: Gizmos<PhysicsGizmoGroup>,
    config: Res<PhysicsGizmos>,
    sleepers: Query<(Entity, &Transform, &Sleeping)>,
    transforms: Query<&Transform>,
) {
    if !config.islands {
        return;
    }
    for (entity, transform, marker) in &sleepers {
        if marker.island == entity || marker.island == Entity::PLACEHOLDER {
            continue;
        }
        if let Ok(root) = transforms.get(marker.island) {
            gizmos.line(transform.translation, root.translation, config.island_color);
        }
    }
}
