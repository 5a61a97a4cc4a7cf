//! [`KinematicCharacter`]: a component that walks its entity at a velocity every physics step,
//! and the [`CharacterPlugin`] that runs it.

use bevy::ecs::entity::EntityHashMap;
use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;

use super::MoveAndSlide;
use super::config::{CharacterConfig, DepenetrationConfig, MoveAndSlideConfig};
use super::walk::{CharacterHit, CharacterOutput};
use crate::collision::{Collider, ColliderOf, CollisionLayers};
use crate::dynamics::RigidBody;
use crate::dynamics::forces::Forces;
use crate::dynamics::validation::MAX_LINEAR_SPEED;
use crate::impulse::ImpulseBody;
use crate::schedule::{PhysicsSystems, PhysicsTime};
use crate::spatial_query::SpatialQueryFilter;

/// A character moved by [`MoveAndSlide::move_character`] every physics step, at `velocity`,
/// as its [`CharacterConfig`] says: it slides along walls, steps up ledges, walks up walkable
/// slopes and not steeper ones, keeps to the ground going down, and reports in its
/// [`CharacterOutput`] whether it stands on the ground. Needs a [`Collider`] (a capsule is
/// usual) and the [`CharacterPlugin`].
///
/// It is a [`RigidBody::Kinematic`] body (required): contacts do not move it, it moves only
/// through its `Transform`, which the plugin sets, before each physics step
/// ([`CharacterSystems`]), against the colliders as the previous step left them; with
/// [`CharacterConfig::push_mass`] it pushes the dynamic bodies it runs into. Its
/// `Transform` must be its world pose (no parent) with scale 1; its
/// [`CollisionLayers`]' filters say what it collides with. Nothing pulls it down: add gravity
/// to `velocity` yourself (and drop it while [`CharacterOutput::grounded`]), as with Rapier's
/// `KinematicCharacterController`.
///
/// Bad input (a velocity that is not finite or faster than 1e6 m/s, an invalid
/// [`CharacterConfig`], no or an invalid collider, a `Transform` that is not finite or is
/// scaled) moves nothing and is logged once as an error naming the entity (by its `Name`), and
/// again only after it has been valid. Nothing panics.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// let mut app = impact3d::scenes::headless_app(60.0);
/// app.add_plugins(CharacterPlugin::default());
/// let world = app.world_mut();
/// world.spawn((RigidBody::Static, Collider::half_space(Vec3::Y)));
/// // A 0.2 m step 1 m ahead.
/// world.spawn((RigidBody::Static, Collider::cuboid(1.0, 0.1, 1.0), Transform::from_xyz(2.0, 0.1, 0.0)));
/// let player = world
///     .spawn((
///         Name::new("player"),
///         KinematicCharacter { velocity: Vec3::new(2.0, 0.0, 0.0) },
///         Collider::capsule(0.3, 0.5),
///         // Feet 1 cm (the skin) above the ground.
///         Transform::from_xyz(0.0, 0.81, 0.0),
///     ))
///     .id();
/// impact3d::scenes::run_steps(&mut app, 60);
/// let at = app.world().get::<Transform>(player).unwrap().translation;
/// let out = app.world().get::<CharacterOutput>(player).unwrap();
/// assert!(at.x > 1.5 && out.grounded);
/// assert!((at.y - (0.2 + 0.81)).abs() < 1e-3, "on the step: {at}");
/// ```
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component, Debug, PartialEq, Default)]
#[require(RigidBody::Kinematic, CharacterConfig, CharacterOutput)]
pub struct KinematicCharacter {
    /// The velocity it tries to move at, world frame, m/s. Default zero.
    pub velocity: Vec3,
}

/// Moves the [`KinematicCharacter`]s (not part of
/// [`PhysicsPlugins`](crate::PhysicsPlugins): add it beside them). They move in the schedule
/// physics steps in (`FixedPostUpdate` by default), in [`CharacterSystems`].
pub struct CharacterPlugin {
    /// The schedule physics is stepped in, where characters move.
    pub schedule: Interned<dyn ScheduleLabel>,
}

impl CharacterPlugin {
    /// Characters move in `schedule`, the schedule physics is stepped in.
    pub fn new(schedule: impl ScheduleLabel) -> Self {
        CharacterPlugin {
            schedule: schedule.intern(),
        }
    }
}

impl Default for CharacterPlugin {
    fn default() -> Self {
        Self::new(FixedPostUpdate)
    }
}

/// The [`KinematicCharacter`]s move, in the schedule physics is stepped in, after
/// [`PhysicsSystems::First`] (where game systems may set their velocities) and before
/// [`PhysicsSystems::StepSimulation`].
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CharacterSystems;

impl Plugin for CharacterPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<KinematicCharacter>()
            .register_type::<CharacterConfig>()
            .register_type::<CharacterOutput>()
            .register_type::<CharacterHit>()
            .register_type::<MoveAndSlideConfig>()
            .register_type::<DepenetrationConfig>()
            .configure_sets(
                self.schedule,
                CharacterSystems
                    .after(PhysicsSystems::First)
                    .before(PhysicsSystems::StepSimulation),
            )
            .add_systems(
                self.schedule,
                move_kinematic_characters.in_set(CharacterSystems),
            );
    }
}

/// The components [`move_kinematic_characters`] reads and writes.
type CharacterData = (
    Entity,
    &'static KinematicCharacter,
    &'static CharacterConfig,
    Option<&'static Collider>,
    &'static mut Transform,
    &'static mut CharacterOutput,
    Option<&'static CollisionLayers>,
    Option<&'static Name>,
);

/// Moves every [`KinematicCharacter`] by its velocity times the step's length (the schedule's
/// `Time` delta times [`PhysicsTime`]'s speed; nothing moves while physics is paused), and
/// stores what happened in its [`CharacterOutput`]. Bad input is logged once per character.
pub fn move_kinematic_characters(
    mut characters: Query<CharacterData>,
    mut pushed: Query<Forces, Without<KinematicCharacter>>,
    colliders: Query<&ColliderOf>,
    move_and_slide: MoveAndSlide,
    time: Res<Time>,
    clock: Option<Res<PhysicsTime>>,
    mut reported: Local<EntityHashMap<String>>,
) {
    let clock = clock.map_or(PhysicsTime::default(), |c| *c);
    if !clock.is_running() {
        return;
    }
    // An invalid speed is logged by the step; characters keep to the game's clock meanwhile.
    let dt = time.delta_secs() * clock.validated_speed(1.0).0;
    let mut errors = EntityHashMap::default();
    for (entity, character, config, collider, mut transform, mut output, layers, name) in
        &mut characters
    {
        let moved = character_move(
            &move_and_slide,
            entity,
            character,
            config,
            collider,
            &transform,
            layers,
            dt,
        );
        match moved {
            Ok(out) => {
                if let Some(mass) = config.push_mass {
                    let character =
                        ImpulseBody::sphere_like(mass, transform.translation, character.velocity);
                    push_bodies(&mut pushed, &colliders, character, &out.hits);
                }
                if transform.translation != out.position {
                    transform.translation = out.position;
                }
                *output = out;
            }
            Err(error) => {
                if reported.get(&entity) != Some(&error) {
                    log::error!(
                        "impact3d: {} does not move: {error}",
                        character_label(entity, name)
                    );
                }
                errors.insert(entity, error);
                *output = CharacterOutput {
                    position: transform.translation,
                    ..default()
                };
            }
        }
    }
    *reported = errors;
}

/// Pushes each dynamic body among `hits` (the body of a hit child collider) as an inelastic
/// impact of `character` would (see [`CharacterConfig::push_mass`]), hit by hit: a body
/// hit again along the same normal is already moving away and takes nothing more.
fn push_bodies(
    pushed: &mut Query<Forces, Without<KinematicCharacter>>,
    colliders: &Query<&ColliderOf>,
    character: ImpulseBody,
    hits: &[CharacterHit],
) {
    for hit in hits {
        let body = colliders.get(hit.entity).map_or(hit.entity, |c| c.body);
        if let Ok(mut forces) = pushed.get_mut(body) {
            // The hit's normal points out of the body hit, towards the character.
            forces.take_impact(character, hit.point, -hit.normal);
        }
    }
}

/// One character's move, or why it cannot move.
#[allow(clippy::too_many_arguments)]
fn character_move(
    move_and_slide: &MoveAndSlide,
    entity: Entity,
    character: &KinematicCharacter,
    config: &CharacterConfig,
    collider: Option<&Collider>,
    transform: &Transform,
    layers: Option<&CollisionLayers>,
    dt: f32,
) -> Result<CharacterOutput, String> {
    let collider = collider.ok_or("it has no Collider")?;
    let scale = transform.scale;
    if !scale.is_finite() || (scale - Vec3::ONE).abs().max_element() > 1e-5 {
        return Err(format!(
            "its Transform scale {scale} is not 1 (a character's collider is cast unscaled)"
        ));
    }
    let velocity = character.velocity;
    if !(velocity.is_finite() && velocity.length() <= MAX_LINEAR_SPEED) {
        return Err(format!(
            "velocity {velocity} is not finite or is faster than {MAX_LINEAR_SPEED:e} m/s"
        ));
    }
    let mask = layers.copied().unwrap_or_default().filters;
    let filter = SpatialQueryFilter::from_mask(mask).with_excluded_entities([entity]);
    move_and_slide.move_character(
        collider,
        transform.translation,
        transform.rotation,
        velocity * dt,
        config,
        &filter,
    )
}

/// Names a character in a log line: `character "Name" (entity)`, or `character entity`.
fn character_label(entity: Entity, name: Option<&Name>) -> String {
    match name {
        Some(name) => format!("character {:?} ({entity})", name.as_str()),
        None => format!("character {entity}"),
    }
}
