//! [`MoveAndSlide::move_character`]: move and slide for a walking character, with steps,
//! slopes, snapping to the ground and ground detection.

use bevy::prelude::*;

use super::MoveAndSlide;
use super::config::{CharacterConfig, DepenetrationConfig};
use super::config::{check_input, check_vector};
use super::hits::MoveHitData;
use super::move_and_slide::MIN_MOVE;
use super::project::add_plane;
use super::project::project_velocity;
use crate::collision::Collider;
use crate::dynamics::validation::MAX_LENGTH;
use crate::spatial_query::SpatialQueryFilter;

/// What one move of a character did ([`MoveAndSlide::move_character`]); also the component
/// [`KinematicCharacter`](super::KinematicCharacter)s keep it in.
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component, Debug, PartialEq, Default)]
pub struct CharacterOutput {
    /// Where the character ended, world frame, m.
    pub position: Vec3,
    /// The translation asked for, m.
    pub desired_translation: Vec3,
    /// The translation done (`position` less the start), m.
    pub translation: Vec3,
    /// Whether the character ends standing on walkable ground (within a few skin widths below
    /// it, no steeper than [`CharacterConfig::max_slope_angle`], or the ledge it just stepped
    /// onto).
    pub grounded: bool,
    /// The normal of that ground (of the face under it where it stands on an edge); zero when
    /// not grounded.
    pub ground_normal: Vec3,
    /// The collider of that ground (a child collider's entity for a body with colliders on its
    /// children).
    pub ground_entity: Option<Entity>,
    /// How far the character stepped up onto ledges in this move, m.
    pub stepped_up: f32,
    /// How far it was pulled down onto the ground at the end of the move, m.
    pub snapped: f32,
    /// What its casts hit in this move, in order.
    pub hits: Vec<CharacterHit>,
}

/// A collider a character's move ran into.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Debug, PartialEq)]
pub struct CharacterHit {
    /// The collider hit (a child collider's entity for a body with colliders on its children).
    pub entity: Entity,
    /// The point hit on it, world frame.
    pub point: Vec3,
    /// Its outward normal there.
    pub normal: Vec3,
}

/// Ground under a character.
#[derive(Clone, Copy, Debug)]
struct Ground {
    entity: Entity,
    normal: Vec3,
}

impl MoveAndSlide<'_, '_> {
    /// Moves a character's `shape` from `position` (turned by `rotation`) by `translation`
    /// (m), walking as `config` says, among the colliders `filter` admits (exclude the
    /// character itself), and tells what happened.
    ///
    /// # Algorithm
    ///
    /// Depenetrate; find the ground under the start. Then cast and slide as
    /// [`move_and_slide`](Self::move_and_slide) does, with three changes. A hit that is not
    /// walkable ground, met while the character stood on the ground, is first tried as a step:
    /// room to rise `max_step_height` above, room to move at that height over the ledge's edge
    /// and `min_step_width` beyond it, and walkable ground found there by a cast down, no higher
    /// than the rise: then the character rises to that ground's height and walks on. A
    /// surface steeper than `max_slope_angle` that faces up is slid along as itself and as a
    /// vertical wall, so the motion may go along or down it but never up; a rounded shape
    /// resting on the edge of walkable ground (a ledge under a capsule's bottom) treats it as
    /// ground. After the last cast, a character that stood on the ground, did not step up and
    /// was not asked to move up is pulled down onto walkable ground within `snap_to_ground`.
    /// Depenetrate again, and look for ground under the end.
    ///
    /// # Errors
    ///
    /// A position, rotation or translation that is not finite (or a translation longer than
    /// 1e6 m), an invalid collider or a configuration that fails [`CharacterConfig::validate`]:
    /// nothing moves, and the message says what is wrong.
    pub fn move_character(
        &self,
        shape: &Collider,
        position: Vec3,
        rotation: Quat,
        translation: Vec3,
        config: &CharacterConfig,
        filter: &SpatialQueryFilter,
    ) -> Result<CharacterOutput, String> {
        check_input(shape, position, rotation)?;
        check_vector("translation", translation)?;
        if translation.length() > MAX_LENGTH {
            return Err(format!(
                "translation {translation} is longer than {MAX_LENGTH:e} m"
            ));
        }
        config.validate()?;
        let walk = Walk::new(self, shape, rotation.normalize(), config, filter);
        let depenetration = DepenetrationConfig::from(&config.move_and_slide);
        let mut p =
            position + self.depenetrate(shape, position, walk.rotation, &depenetration, filter);
        let on_ground = walk.ground(p).is_some();
        let mut out = CharacterOutput {
            desired_translation: translation,
            ..default()
        };
        let mut landing = None;
        let mut remaining = translation;
        for _ in 0..config.move_and_slide.move_and_slide_iterations {
            let Ok((direction, length)) = Dir3::new_and_length(remaining) else {
                break;
            };
            if length < MIN_MOVE * self.unit() {
                break;
            }
            let Some(hit) = walk.cast(p, remaining) else {
                p += remaining;
                break;
            };
            p += direction * hit.distance;
            remaining -= direction * hit.distance;
            out.hits.push(CharacterHit {
                entity: hit.entity,
                point: hit.point1,
                normal: hit.normal1,
            });
            if on_ground
                && !walk.walkable(hit.normal1)
                && let Some((height, ground)) = walk.step_up(p, &hit, remaining)
            {
                p += walk.up * height;
                out.stepped_up += height;
                landing = Some(ground);
                continue;
            }
            remaining = project_velocity(remaining, &walk.planes(p, &hit, remaining));
        }
        if on_ground
            && out.stepped_up == 0.0
            && translation.dot(walk.up) <= 0.0
            && let Some(distance) = walk.snap(p)
        {
            p -= walk.up * distance;
            out.snapped = distance;
        }
        p += self.depenetrate(shape, p, walk.rotation, &depenetration, filter);
        let ground = walk.ground(p).or(landing);
        out.position = p;
        out.translation = p - position;
        out.grounded = ground.is_some();
        out.ground_normal = ground.map_or(Vec3::ZERO, |g| g.normal);
        out.ground_entity = ground.map(|g| g.entity);
        Ok(out)
    }
}

/// One move's settings, derived once.
struct Walk<'a, 'w, 's> {
    query: &'a MoveAndSlide<'w, 's>,
    shape: &'a Collider,
    rotation: Quat,
    config: &'a CharacterConfig,
    filter: &'a SpatialQueryFilter,
    up: Vec3,
    /// The skin, m (scaled by the length unit).
    skin: f32,
    /// `cos` of the steepest walkable slope, less a rounding allowance.
    cos_max: f32,
}

impl<'a, 'w, 's> Walk<'a, 'w, 's> {
    fn new(
        query: &'a MoveAndSlide<'w, 's>,
        shape: &'a Collider,
        rotation: Quat,
        config: &'a CharacterConfig,
        filter: &'a SpatialQueryFilter,
    ) -> Self {
        Walk {
            query,
            shape,
            rotation,
            config,
            filter,
            up: config.up.as_vec3(),
            skin: query.unit() * config.move_and_slide.skin_width,
            cos_max: config.max_slope_angle.cos() - 1e-5,
        }
    }

    /// [`MoveAndSlide::cast_move`] of the character from `p` along `motion`.
    fn cast(&self, p: Vec3, motion: Vec3) -> Option<MoveHitData> {
        self.query
            .cast_move(self.shape, p, self.rotation, motion, self.skin, self.filter)
    }

    /// Whether a surface of normal `n` is walkable ground.
    fn walkable(&self, n: Vec3) -> bool {
        n.dot(self.up) >= self.cos_max
    }

    /// The walkable ground within a few skins below the character at `p`: up to `skin / cos`
    /// of the steepest walkable slope (where the skin leaves a character on such a slope) plus
    /// one skin.
    fn ground(&self, p: Vec3) -> Option<Ground> {
        let reach = self.skin * (1.0 + 1.0 / self.cos_max.max(0.1));
        let hit = self.cast(p, -self.up * reach)?;
        if hit.collision_distance > reach {
            return None;
        }
        let normal = self.support_normal(&hit, p)?;
        Some(Ground {
            entity: hit.entity,
            normal,
        })
    }

    /// The normal of the walkable ground a hit below the character at `p` stands for: the
    /// hit's own normal if walkable, else the face under it where the hit is on the edge of
    /// walkable ground; `None` for a steep surface.
    fn support_normal(&self, hit: &MoveHitData, p: Vec3) -> Option<Vec3> {
        if self.walkable(hit.normal1) {
            return Some(hit.normal1);
        }
        if hit.normal1.dot(self.up) <= 1e-3 {
            return None;
        }
        self.face_beyond_edge(hit.point1, p)
    }

    /// The walkable face just beyond `point` as seen from the character's centre `center`,
    /// if any: a short ray down from a little past `point` (away from the centre) and above
    /// it, high enough to start above any walkable face through `point`. A curved shape
    /// resting on an edge touches it with a normal as steep as the curve there; this finds
    /// the face the edge belongs to.
    fn face_beyond_edge(&self, point: Vec3, center: Vec3) -> Option<Vec3> {
        let out = (point - center)
            .reject_from_normalized(self.up)
            .normalize_or_zero();
        if out == Vec3::ZERO {
            return None;
        }
        let aside = (2.0 * self.skin).max(1e-3 * self.query.unit());
        let above = aside * (1.0 + self.config.max_slope_angle.tan().min(10.0));
        let origin = point + out * aside + self.up * above;
        let hit = self.query.spatial_query.cast_ray_predicate(
            origin,
            -self.config.up,
            2.0 * above,
            true,
            self.filter,
            &|entity| !self.query.is_sensor(entity),
        )?;
        (hit.distance > 0.0 && self.walkable(hit.normal)).then_some(hit.normal)
    }

    /// The rise (m) that puts the character at `p` onto the ledge `hit` found, moving along
    /// `remaining`, with the ground it lands on; `None` if it is no step (see
    /// [`MoveAndSlide::move_character`]).
    fn step_up(&self, p: Vec3, hit: &MoveHitData, remaining: Vec3) -> Option<(f32, Ground)> {
        let max = self.config.max_step_height;
        let along = remaining.reject_from_normalized(self.up);
        let (direction, length) = Dir3::new_and_length(along).ok()?;
        if max <= 0.0 || length < MIN_MOVE * self.query.unit() {
            return None;
        }
        // Room above.
        let rise = self.cast(p, self.up * max).map_or(max, |c| c.distance);
        if rise <= 0.0 {
            return None;
        }
        // Room over the edge and `min_step_width` beyond it, at that height.
        let raised = p + self.up * rise;
        let reach = (hit.point1 - p).dot(*direction).max(0.0) + self.config.min_step_width;
        if self.cast(raised, direction * reach).is_some() {
            return None;
        }
        // Walkable ground there, higher than the character stands now.
        let land = self.cast(raised + direction * reach, -self.up * rise)?;
        let height = rise - land.distance;
        if !self.walkable(land.normal1) || height <= MIN_MOVE * self.query.unit() {
            return None;
        }
        let ground = Ground {
            entity: land.entity,
            normal: land.normal1,
        };
        Some((height, ground))
    }

    /// How far down the character at `p` goes to stand on walkable ground within
    /// `snap_to_ground` (keeping the skin), if there is such ground.
    fn snap(&self, p: Vec3) -> Option<f32> {
        let reach = self.config.snap_to_ground;
        if reach <= 0.0 {
            return None;
        }
        let hit = self.cast(p, -self.up * reach)?;
        self.support_normal(&hit, p)?;
        Some(hit.distance)
    }

    /// The planes the motion left slides along at `p` after `hit`: the configured ones, the
    /// hit's and those of the contacts within two skins, each as [`Self::add_surface`] says.
    fn planes(&self, p: Vec3, hit: &MoveHitData, remaining: Vec3) -> Vec<Dir3> {
        let mut planes = self.config.move_and_slide.planes.clone();
        self.add_surface(&mut planes, hit.normal1, hit.point1, p, remaining);
        self.query.intersections(
            self.shape,
            p,
            self.rotation,
            2.0 * self.skin,
            self.filter,
            |_, contact, normal| {
                self.add_surface(&mut planes, normal.as_vec3(), contact.point, p, remaining);
                true
            },
        );
        planes
    }

    /// Adds a surface of normal `n` touched at `point` to the sliding planes: walkable ground,
    /// walls and ceilings as their plane; a steep slope facing up as its plane and as a
    /// vertical wall (slide down or along, never up); the edge of walkable ground under a
    /// rounded shape as its plane (the shape rolls over it).
    fn add_surface(&self, planes: &mut Vec<Dir3>, n: Vec3, point: Vec3, p: Vec3, motion: Vec3) {
        let config = &self.config.move_and_slide;
        add_plane(planes, n, motion, config);
        let rising = n.dot(self.up);
        if self.walkable(n) || rising <= 1e-3 || self.face_beyond_edge(point, p).is_some() {
            return;
        }
        add_plane(planes, n - self.up * rising, motion, config);
    }
}
