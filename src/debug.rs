//! Debug drawing with Bevy's gizmos (cargo feature `debug`): collider wireframes coloured by
//! state, bounding boxes, contact points and normals, impacts, velocities and sleeping islands.
//!
//! It needs Bevy's `GizmoPlugin` (part of `DefaultPlugins`) but not the render stack: without
//! one, the lines are recorded into `GizmoAsset`s and nothing is drawn, which is how the tests
//! check it.
//!
//! # Examples
//!
//! ```no_run
//! use bevy::prelude::*;
//! use impact3d::prelude::*;
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, PhysicsPlugins::default(), PhysicsDebugPlugin))
//!     .insert_resource(PhysicsGizmos { aabbs: true, ..default() })
//!     .run();
//! ```
//!
//! The geometry is plain functions that append line segments (`[start, end]`, world frame) to
//! a `Vec`: [`shape_segments`], [`box_segments`], [`arrow_segments`], [`cross_segments`]. The
//! systems gather what to draw and hand each segment to `Gizmos::line`, so what a scene draws
//! is exactly the segments these functions produce.

use std::f32::consts::TAU;

use bevy::color::palettes::css;
use bevy::gizmos::config::GizmoConfigGroup;
use bevy::gizmos::gizmos::Gizmos;
use bevy::gizmos::{AppGizmoBuilder, GizmoPlugin};
use bevy::prelude::*;
use parry3d::math::Pose;
use parry3d::shape::Shape;

use crate::collision::narrow_phase::TOUCH_DISTANCE;
use crate::collision::{Collider, ContactPairs};
use crate::dynamics::validation::PhysicsLengthUnit;
use crate::dynamics::{AngularVelocity, LinearVelocity, Quarantined, RigidBody, Sleeping};
use crate::messages::Impact;

/// The gizmo group impact3d draws in; its `GizmoConfig` (line width, depth bias, on/off for
/// all layers) is in Bevy's `GizmoConfigStore`.
#[derive(Default, Reflect, GizmoConfigGroup)]
pub struct PhysicsGizmoGroup;

/// What [`PhysicsDebugPlugin`] draws, in which colours and at which sizes. Every layer can be
/// switched on and off at run time.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct PhysicsGizmos {
    /// Collider wireframes, coloured by the body's state. Default true.
    pub colliders: bool,
    /// Bounding boxes of bounded colliders. Default false.
    pub aabbs: bool,
    /// Contact points (a small cross) and normals (from the first body of the pair to the
    /// second) closer than [`TOUCH_DISTANCE`]. Default true.
    pub contacts: bool,
    /// Each `Impact` as an arrow along its normal, `impulse_scale x j` long, fading out over
    /// `impact_fade`. Default true.
    pub impacts: bool,
    /// Linear and angular velocity arrows of moving bodies. Default false.
    pub velocities: bool,
    /// A line from each sleeping body to the body its island is named after. Default false.
    pub islands: bool,
    /// Awake dynamic body. Default orange.
    pub dynamic_color: Color,
    /// Sleeping body. Default slate grey.
    pub sleeping_color: Color,
    /// Static body (or a collider without `RigidBody`). Default dark grey.
    pub static_color: Color,
    /// Kinematic body. Default violet.
    pub kinematic_color: Color,
    /// `Quarantined` body. Default red.
    pub quarantined_color: Color,
    /// Bounding boxes. Default yellow.
    pub aabb_color: Color,
    /// Contact points. Default cyan.
    pub contact_color: Color,
    /// Contact normals. Default light green.
    pub normal_color: Color,
    /// Impact arrows (their alpha fades). Default magenta.
    pub impact_color: Color,
    /// Linear velocity arrows. Default light blue.
    pub velocity_color: Color,
    /// Angular velocity arrows. Default gold.
    pub angular_velocity_color: Color,
    /// Island lines. Default white.
    pub island_color: Color,
    /// Length of a contact normal, m. Default 0.3.
    pub normal_length: f32,
    /// Half size of a contact point's cross, m. Default 0.04.
    pub contact_size: f32,
    /// Impact arrow length per unit of impulse, m / (N s). Default 0.5.
    pub impulse_scale: f32,
    /// Longest impact arrow, m. Default 2.
    pub max_impact_length: f32,
    /// How long an impact arrow stays, fading, s. Default 1.
    pub impact_fade: f32,
    /// Velocity arrow length per unit of speed, s (m per m/s, m per rad/s). Default 0.1.
    pub velocity_scale: f32,
    /// Half side of the square patch drawn for a half-space, m. Default 10.
    pub half_space_size: f32,
    /// Grid lines per direction on a half-space patch (at least 2). Default 11.
    pub half_space_lines: u32,
    /// Segments of a full circle in sphere and capsule wireframes (even, at least 4). Default
    /// 24.
    pub circle_segments: u32,
}

impl Default for PhysicsGizmos {
    fn default() -> Self {
        PhysicsGizmos {
            colliders: true,
            aabbs: false,
            contacts: true,
            impacts: true,
            velocities: false,
            islands: false,
            dynamic_color: css::ORANGE.into(),
            sleeping_color: css::SLATE_GRAY.into(),
            static_color: css::DIM_GRAY.into(),
            kinematic_color: css::VIOLET.into(),
            quarantined_color: css::RED.into(),
            aabb_color: css::YELLOW.into(),
            contact_color: css::AQUA.into(),
            normal_color: css::LIGHT_GREEN.into(),
            impact_color: css::MAGENTA.into(),
            velocity_color: css::LIGHT_BLUE.into(),
            angular_velocity_color: css::GOLD.into(),
            island_color: css::WHITE.into(),
            normal_length: 0.3,
            contact_size: 0.04,
            impulse_scale: 0.5,
            max_impact_length: 2.0,
            impact_fade: 1.0,
            velocity_scale: 0.1,
            half_space_size: 10.0,
            half_space_lines: 11,
            circle_segments: 24,
        }
    }
}

/// Per-body override of [`PhysicsGizmos`]: each `Some` replaces the global setting for this
/// body. `DebugRender::default()` changes nothing.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct DebugRender {
    /// Draw this body's collider.
    pub collider: Option<bool>,
    /// Draw this body's bounding box.
    pub aabb: Option<bool>,
    /// Draw this body's velocity arrows.
    pub velocity: Option<bool>,
    /// Colour of this body's collider, whatever its state.
    pub color: Option<Color>,
}

impl DebugRender {
    /// Nothing drawn for this body.
    pub fn hidden() -> Self {
        DebugRender {
            collider: Some(false),
            aabb: Some(false),
            velocity: Some(false),
            color: None,
        }
    }

    /// The collider drawn in `color`.
    pub fn colored(color: impl Into<Color>) -> Self {
        DebugRender {
            collider: Some(true),
            color: Some(color.into()),
            ..default()
        }
    }
}

/// Impacts still being drawn, with their age in s.
#[derive(Resource, Default, Debug)]
pub struct ImpactTrails(pub Vec<(Impact, f32)>);

/// The systems of [`PhysicsDebugPlugin`], in `PostUpdate`.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PhysicsDebugSystems;

/// Draws the physics with gizmos (see [`crate::debug`]). Adds Bevy's `GizmoPlugin` if the app
/// has none.
pub struct PhysicsDebugPlugin;

impl Plugin for PhysicsDebugPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<GizmoPlugin>() {
            app.add_plugins(GizmoPlugin);
        }
        app.init_gizmo_group::<PhysicsGizmoGroup>()
            .init_resource::<PhysicsGizmos>()
            .init_resource::<ImpactTrails>()
            .add_systems(
                PostUpdate,
                (
                    draw_colliders,
                    draw_aabbs,
                    draw_contacts,
                    update_impact_trails,
                    draw_impacts,
                    draw_velocities,
                    draw_islands,
                )
                    .chain()
                    .in_set(PhysicsDebugSystems),
            );
    }
}

/// A body's state, for the colour of its collider.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BodyState {
    /// Dynamic and awake.
    Dynamic,
    /// Dynamic and sleeping.
    Sleeping,
    /// Static, or a collider without `RigidBody`.
    Static,
    /// Kinematic.
    Kinematic,
    /// Left out of the step for bad input.
    Quarantined,
}

impl BodyState {
    /// The state of a body from its components: quarantine first, then sleep, then its kind.
    pub fn of(body: Option<&RigidBody>, sleeping: bool, quarantined: bool) -> Self {
        match (
            quarantined,
            sleeping,
            body.copied().unwrap_or(RigidBody::Static),
        ) {
            (true, _, _) => BodyState::Quarantined,
            (false, _, RigidBody::Static) => BodyState::Static,
            (false, _, RigidBody::Kinematic) => BodyState::Kinematic,
            (false, true, RigidBody::Dynamic) => BodyState::Sleeping,
            (false, false, RigidBody::Dynamic) => BodyState::Dynamic,
        }
    }

    /// The configured colour of this state.
    pub fn color(self, config: &PhysicsGizmos) -> Color {
        match self {
            BodyState::Dynamic => config.dynamic_color,
            BodyState::Sleeping => config.sleeping_color,
            BodyState::Static => config.static_color,
            BodyState::Kinematic => config.kinematic_color,
            BodyState::Quarantined => config.quarantined_color,
        }
    }
}

/// The pose of a `Transform` (scale ignored, as the physics does).
fn pose_of(t: &Transform) -> Pose {
    Pose::from_parts(t.translation, t.rotation.normalize())
}

/// Appends the 12 edges of the box `[mins, maxs]` placed at `pose`.
pub fn box_segments(mins: Vec3, maxs: Vec3, pose: &Pose, out: &mut Vec<[Vec3; 2]>) {
    let corner = |i: usize| {
        let p = Vec3::new(
            if i & 1 == 0 { mins.x } else { maxs.x },
            if i & 2 == 0 { mins.y } else { maxs.y },
            if i & 4 == 0 { mins.z } else { maxs.z },
        );
        pose.transform_point(p)
    };
    for i in 0..8 {
        for bit in [1, 2, 4] {
            if i & bit == 0 {
                out.push([corner(i), corner(i | bit)]);
            }
        }
    }
}

/// Appends an arc of `segments` segments about `center` in the plane spanned by `u` and `v`
/// (orthonormal), radius `r`, from angle `from` to `to` (rad, from `u` towards `v`).
fn arc_segments(
    center: Vec3,
    u: Vec3,
    v: Vec3,
    r: f32,
    (from, to): (f32, f32),
    segments: u32,
    out: &mut Vec<[Vec3; 2]>,
) {
    let at = |k: u32| {
        let a = from + (to - from) * k as f32 / segments as f32;
        center + r * (a.cos() * u + a.sin() * v)
    };
    for k in 0..segments {
        out.push([at(k), at(k + 1)]);
    }
}

/// Appends the wireframe of `shape` at `pose`:
///
/// | shape | segments |
/// |---|---|
/// | ball | three great circles, `3 n` (`n` = `circle_segments`) |
/// | cuboid | 12 edges |
/// | capsule | a ring at each end of the axis, 4 lines along it, two half circles over each cap: `4 n + 4` |
/// | cylinder | a ring at each end, 4 lines along its side: `2 n + 4` |
/// | cone | a ring at its base, 4 lines to its apex: `n + 4` |
/// | rounded box | its inner box and its outer bounding box: 24 |
/// | compound | each part's wireframe at its pose |
/// | convex polyhedron | its edges |
/// | triangle mesh, heightfield | their distinct triangle edges |
/// | half-space | a square grid of `half_space_lines` lines each way, `half_space_size` from the body origin: `2 x lines` |
/// | anything else | its local bounding box, 12 |
pub fn shape_segments(
    shape: &dyn Shape,
    pose: &Pose,
    config: &PhysicsGizmos,
    out: &mut Vec<[Vec3; 2]>,
) {
    let n = config.circle_segments.max(4) & !1;
    let rot = pose.rotation;
    let (x, y, z) = (rot * Vec3::X, rot * Vec3::Y, rot * Vec3::Z);
    let origin = pose.translation;
    if let Some(ball) = shape.as_ball() {
        let r = ball.radius;
        for (u, v) in [(x, y), (y, z), (z, x)] {
            arc_segments(origin, u, v, r, (0.0, TAU), n, out);
        }
    } else if let Some(cuboid) = shape.as_cuboid() {
        box_segments(-cuboid.half_extents, cuboid.half_extents, pose, out);
    } else if let Some(capsule) = shape.as_capsule() {
        let (a, b) = (
            pose.transform_point(capsule.segment.a),
            pose.transform_point(capsule.segment.b),
        );
        let r = capsule.radius;
        let axis = (b - a).try_normalize().unwrap_or(y);
        let (u, v) = axis.any_orthonormal_pair();
        for c in [a, b] {
            arc_segments(c, u, v, r, (0.0, TAU), n, out);
        }
        for side in [u, -u, v, -v] {
            out.push([a + r * side, b + r * side]);
        }
        for w in [u, v] {
            // Half circles from w through the axis tip to -w.
            arc_segments(b, w, axis, r, (0.0, TAU / 2.0), n / 2, out);
            arc_segments(a, w, -axis, r, (0.0, TAU / 2.0), n / 2, out);
        }
    } else if let Some(cylinder) = shape.as_cylinder() {
        let (r, hh) = (cylinder.radius, cylinder.half_height);
        let (top, bottom) = (origin + hh * y, origin - hh * y);
        for c in [top, bottom] {
            arc_segments(c, x, z, r, (0.0, TAU), n, out);
        }
        for side in [x, -x, z, -z] {
            out.push([bottom + r * side, top + r * side]);
        }
    } else if let Some(cone) = shape.as_cone() {
        let (r, hh) = (cone.radius, cone.half_height);
        let (apex, base) = (origin + hh * y, origin - hh * y);
        arc_segments(base, x, z, r, (0.0, TAU), n, out);
        for side in [x, -x, z, -z] {
            out.push([base + r * side, apex]);
        }
    } else if let Some(round) = shape.as_round_cuboid() {
        let h = round.inner_shape.half_extents;
        box_segments(-h, h, pose, out);
        let outer = h + Vec3::splat(round.border_radius);
        box_segments(-outer, outer, pose, out);
    } else if let Some(compound) = shape.as_compound() {
        for (part_pose, part) in compound.shapes() {
            shape_segments(part.as_ref(), &(pose * *part_pose), config, out);
        }
    } else if let Some(field) = shape.as_heightfield() {
        let mut edges: Vec<[Vec3; 2]> = Vec::new();
        for tri in field.triangles() {
            for (p, q) in [(tri.a, tri.b), (tri.b, tri.c), (tri.c, tri.a)] {
                let (p, q) = if p.to_array() <= q.to_array() {
                    (p, q)
                } else {
                    (q, p)
                };
                edges.push([p, q]);
            }
        }
        edges.sort_unstable_by(|e, f| {
            e[0].to_array()
                .partial_cmp(&f[0].to_array())
                .unwrap_or(std::cmp::Ordering::Equal)
                .then(
                    e[1].to_array()
                        .partial_cmp(&f[1].to_array())
                        .unwrap_or(std::cmp::Ordering::Equal),
                )
        });
        edges.dedup();
        for [p, q] in edges {
            out.push([pose.transform_point(p), pose.transform_point(q)]);
        }
    } else if let Some(hull) = shape.as_convex_polyhedron() {
        let points = hull.points();
        for edge in hull.edges() {
            let [i, j] = edge.vertices;
            out.push([
                pose.transform_point(points[i as usize]),
                pose.transform_point(points[j as usize]),
            ]);
        }
    } else if let Some(mesh) = shape.as_trimesh() {
        let vertices = mesh.vertices();
        let mut edges: Vec<(u32, u32)> = mesh
            .indices()
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .map(|(i, j)| (i.min(j), i.max(j)))
            .collect();
        edges.sort_unstable();
        edges.dedup();
        for (i, j) in edges {
            out.push([
                pose.transform_point(vertices[i as usize]),
                pose.transform_point(vertices[j as usize]),
            ]);
        }
    } else if let Some(half_space) = shape.as_halfspace() {
        let normal = rot * half_space.normal;
        let (u, v) = normal.any_orthonormal_pair();
        let (size, lines) = (config.half_space_size, config.half_space_lines.max(2));
        for k in 0..lines {
            let s = -size + 2.0 * size * k as f32 / (lines - 1) as f32;
            out.push([origin + s * u - size * v, origin + s * u + size * v]);
            out.push([origin + s * v - size * u, origin + s * v + size * u]);
        }
    } else {
        let aabb = shape.compute_local_aabb();
        box_segments(aabb.mins, aabb.maxs, pose, out);
    }
}

/// Appends an arrow from `from` along `vector`: the shaft and two head lines a fifth of its
/// length (3 segments). Nothing for a zero or non-finite vector.
pub fn arrow_segments(from: Vec3, vector: Vec3, out: &mut Vec<[Vec3; 2]>) {
    let length = vector.length();
    if !(length > 0.0 && length.is_finite() && from.is_finite()) {
        return;
    }
    let dir = vector / length;
    let tip = from + vector;
    let side = dir.any_orthonormal_vector();
    let head = 0.2 * length;
    out.push([from, tip]);
    out.push([tip, tip - head * dir + 0.5 * head * side]);
    out.push([tip, tip - head * dir - 0.5 * head * side]);
}

/// Appends a cross of half size `size` at `point`, one line per axis (3 segments).
pub fn cross_segments(point: Vec3, size: f32, out: &mut Vec<[Vec3; 2]>) {
    for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
        out.push([point - size * axis, point + size * axis]);
    }
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
    Option<&'a RigidBody>,
    Has<Sleeping>,
    Has<Quarantined>,
    Option<&'a DebugRender>,
);

/// Draws each collider's wireframe ([`shape_segments`]) in the colour of its [`BodyState`] or
/// its [`DebugRender::color`].
pub fn draw_colliders(
    mut gizmos: Gizmos<PhysicsGizmoGroup>,
    config: Res<PhysicsGizmos>,
    bodies: Query<BodyQuery>,
    mut segments: Local<Vec<[Vec3; 2]>>,
) {
    for (collider, transform, body, sleeping, quarantined, render) in &bodies {
        let render = render.copied().unwrap_or_default();
        if !render.collider.unwrap_or(config.colliders) {
            continue;
        }
        let color = render
            .color
            .unwrap_or_else(|| BodyState::of(body, sleeping, quarantined).color(&config));
        shape_segments(
            collider.shape().as_ref(),
            &pose_of(transform),
            &config,
            &mut segments,
        );
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
    for (collider, transform, _, _, _, render) in &bodies {
        if !render.and_then(|r| r.aabb).unwrap_or(config.aabbs)
            || collider.shape().as_halfspace().is_some()
        {
            continue;
        }
        let aabb = collider.shape().compute_aabb(&pose_of(transform));
        box_segments(aabb.mins, aabb.maxs, &Pose::identity(), &mut segments);
        flush(&mut gizmos, &mut segments, config.aabb_color);
    }
}

/// Draws each contact point closer than [`TOUCH_DISTANCE`] (in the world's
/// [`PhysicsLengthUnit`], as the physics step counts touching) as a cross and its normal as a
/// line (4 segments a point), at the bodies' current poses.
pub fn draw_contacts(
    mut gizmos: Gizmos<PhysicsGizmoGroup>,
    config: Res<PhysicsGizmos>,
    pairs: Option<Res<ContactPairs>>,
    unit: Option<Res<PhysicsLengthUnit>>,
    transforms: Query<&Transform>,
) {
    let Some(pairs) = pairs.filter(|_| config.contacts) else {
        return;
    };
    // An invalid unit is logged by the physics step, which then uses the last good one; here
    // the default stands in for it.
    let touch = TOUCH_DISTANCE * unit.map_or(1.0, |u| u.validated(1.0).0);
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
