//! The settings of move and slide ([`MoveAndSlideConfig`], [`DepenetrationConfig`]) and of a
//! walking character ([`CharacterConfig`]), with their checks.

use bevy::prelude::*;

use crate::collision::Collider;
use crate::dynamics::validation::{MAX_LENGTH, MAX_MASS};

/// Cosine of 5 degrees: [`MoveAndSlideConfig::plane_similarity_dot_threshold`]'s default.
#[allow(clippy::excessive_precision)]
pub const COS_5_DEGREES: f32 = 0.99619469809;

/// The most iterations a setting may ask for: more is taken for a mistake (a loop that long
/// would stall the frame), and rejected.
pub const MAX_ITERATIONS: usize = 10_000;

/// How [`MoveAndSlide::move_and_slide`](super::MoveAndSlide::move_and_slide) runs (avian3d
/// 0.7's type: the same fields, meanings and defaults). Lengths are in units of the
/// [`PhysicsLengthUnit`](crate::dynamics::PhysicsLengthUnit) (metres by default), as in avian3d.
#[derive(Clone, Debug, PartialEq, Reflect)]
#[reflect(Debug, PartialEq, Default)]
pub struct MoveAndSlideConfig {
    /// Casts per move: each moves the shape as far as it can go and turns the rest of the
    /// motion along what it hit. Default 4.
    pub move_and_slide_iterations: usize,
    /// Passes of the depenetration before and after the move; 0 turns it off. Default 16.
    pub depenetration_iterations: usize,
    /// Depenetration stops when the summed remaining overlap of a pass is below this, length
    /// units. Default 1e-4.
    pub max_depenetration_error: f32,
    /// A contact deeper than this is not pushed out of (it is taken for a wrong contact, which
    /// would push the shape through something), length units. Default 0.5.
    pub penetration_rejection_threshold: f32,
    /// The gap kept between the shape and everything else, length units. Default 0.01.
    pub skin_width: f32,
    /// Planes the motion never goes into, besides the ones hit (e.g. the ground a character
    /// stands on). Default none.
    pub planes: Vec<Dir3>,
    /// Two planes whose normals' dot product is at least this count as one (the more blocking
    /// one is kept). Default [`COS_5_DEGREES`].
    pub plane_similarity_dot_threshold: f32,
    /// At most this many planes are used per iteration. Default 20.
    pub max_planes: usize,
}

impl Default for MoveAndSlideConfig {
    fn default() -> Self {
        let depenetration = DepenetrationConfig::default();
        MoveAndSlideConfig {
            move_and_slide_iterations: 4,
            depenetration_iterations: depenetration.depenetration_iterations,
            max_depenetration_error: depenetration.max_depenetration_error,
            penetration_rejection_threshold: depenetration.penetration_rejection_threshold,
            skin_width: depenetration.skin_width,
            planes: Vec::new(),
            plane_similarity_dot_threshold: COS_5_DEGREES,
            max_planes: 20,
        }
    }
}

impl MoveAndSlideConfig {
    /// `Ok` if every field is usable, else what is wrong: iteration counts above
    /// [`MAX_ITERATIONS`], lengths that are negative, NaN or above 1e6 (the rejection threshold
    /// may be infinite: no rejection), a similarity threshold outside [-1, 1], planes that are
    /// not finite unit vectors.
    pub fn validate(&self) -> Result<(), String> {
        DepenetrationConfig::from(self).validate()?;
        check_iterations("move_and_slide_iterations", self.move_and_slide_iterations)?;
        let t = self.plane_similarity_dot_threshold;
        if !(-1.0..=1.0).contains(&t) {
            return Err(format!(
                "plane_similarity_dot_threshold = {t} is not in [-1, 1]"
            ));
        }
        for plane in &self.planes {
            let n = plane.as_vec3();
            if !n.is_finite() || (n.length_squared() - 1.0).abs() > 1e-3 {
                return Err(format!("plane normal {n} is not a finite unit vector"));
            }
        }
        Ok(())
    }
}

/// How [`MoveAndSlide::depenetrate`](super::MoveAndSlide::depenetrate) runs (avian3d 0.7's
/// type; its fields are those of [`MoveAndSlideConfig`] of the same names, and a
/// `MoveAndSlideConfig` converts into it).
#[derive(Clone, Debug, PartialEq, Reflect)]
#[reflect(Debug, PartialEq, Default)]
pub struct DepenetrationConfig {
    /// Passes over the contacts; 0 turns depenetration off. Default 16.
    pub depenetration_iterations: usize,
    /// Stop when a pass's summed remaining overlap is below this, length units. Default 1e-4.
    pub max_depenetration_error: f32,
    /// Contacts deeper than this are ignored, length units. Default 0.5.
    pub penetration_rejection_threshold: f32,
    /// The gap to make between the shape and everything else, length units. Default 0.01.
    pub skin_width: f32,
}

impl Default for DepenetrationConfig {
    fn default() -> Self {
        DepenetrationConfig {
            depenetration_iterations: 16,
            max_depenetration_error: 1e-4,
            penetration_rejection_threshold: 0.5,
            skin_width: 0.01,
        }
    }
}

impl From<&MoveAndSlideConfig> for DepenetrationConfig {
    fn from(config: &MoveAndSlideConfig) -> Self {
        DepenetrationConfig {
            depenetration_iterations: config.depenetration_iterations,
            max_depenetration_error: config.max_depenetration_error,
            penetration_rejection_threshold: config.penetration_rejection_threshold,
            skin_width: config.skin_width,
        }
    }
}

impl DepenetrationConfig {
    /// `Ok` if every field is usable (see [`MoveAndSlideConfig::validate`]).
    pub fn validate(&self) -> Result<(), String> {
        check_iterations("depenetration_iterations", self.depenetration_iterations)?;
        check_length("skin_width", self.skin_width)?;
        check_length("max_depenetration_error", self.max_depenetration_error)?;
        let rejection = self.penetration_rejection_threshold;
        if rejection != f32::INFINITY {
            check_length("penetration_rejection_threshold", rejection)?;
        }
        Ok(())
    }
}

/// How a walking character moves ([`MoveAndSlide::move_character`](super::MoveAndSlide::move_character)
/// and [`KinematicCharacter`](super::KinematicCharacter)): move and slide, plus what Rapier's
/// `KinematicCharacterController` adds: stepping up ledges, a steepest climbable slope,
/// snapping to the ground, and ground detection. Lengths in metres, angles in radians.
///
/// # Examples
///
/// ```
/// use impact3d::character::CharacterConfig;
///
/// let config = CharacterConfig {
///     max_step_height: 0.35,
///     max_slope_angle: 45f32.to_radians(),
///     ..Default::default()
/// };
/// assert!(config.validate().is_ok());
/// assert!(CharacterConfig { snap_to_ground: f32::NAN, ..config.clone() }.validate().is_err());
/// assert!(CharacterConfig { push_mass: Some(0.0), ..config.clone() }.validate().is_err());
/// assert!(CharacterConfig { push_mass: Some(80.0), ..config }.validate().is_ok());
/// ```
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component, Debug, PartialEq, Default)]
pub struct CharacterConfig {
    /// Which way is up: steps are climbed and slopes measured along it, snapping pulls against
    /// it. Default `Dir3::Y`.
    pub up: Dir3,
    /// The steepest ground the character walks on, rad, in [0, pi/2]: a surface whose normal is
    /// farther than this from `up` is a wall to it (it slides along or down it, never up).
    /// Default 45 degrees.
    pub max_slope_angle: f32,
    /// The highest ledge the character steps up onto, m; 0 turns stepping off. Default 0.25.
    pub max_step_height: f32,
    /// The free depth a ledge must offer beyond its edge for the character to step onto it, m.
    /// Default 0.05.
    pub min_step_width: f32,
    /// While on the ground and not moving up, the character is pulled down onto ground at most
    /// this far below it (down a ramp or a step), m; 0 turns snapping off. Default 0.2.
    pub snap_to_ground: f32,
    /// The move and slide underneath (skin width, iterations, depenetration). Default: avian3d's
    /// defaults with 8 iterations (a step up takes one).
    pub move_and_slide: MoveAndSlideConfig,
    /// The mass the character pushes dynamic bodies with, kg, in (0, 1e12]: each dynamic body
    /// its move runs into takes the impulse of an inelastic impact (`e = 0`) with a body of
    /// this mass moving at the character's velocity, by the seed formula at the point and
    /// normal of the hit (the character's own rotation left out, and nothing pushes it back:
    /// it is kinematic). `None`: it pushes nothing; it slides along dynamic bodies as along
    /// static ones (the solver's contacts still push out what it overlaps). Default `None`.
    pub push_mass: Option<f32>,
}

impl Default for CharacterConfig {
    fn default() -> Self {
        CharacterConfig {
            up: Dir3::Y,
            max_slope_angle: 45f32.to_radians(),
            max_step_height: 0.25,
            min_step_width: 0.05,
            snap_to_ground: 0.2,
            move_and_slide: MoveAndSlideConfig {
                move_and_slide_iterations: 8,
                ..default()
            },
            push_mass: None,
        }
    }
}

impl CharacterConfig {
    /// `Ok` if every field is usable, else what is wrong: `up` not a finite unit vector, the
    /// slope angle outside [0, pi/2], a length negative, NaN or above 1e6, a push mass not in
    /// (0, 1e12] kg, or a bad [`MoveAndSlideConfig`].
    pub fn validate(&self) -> Result<(), String> {
        let up = self.up.as_vec3();
        if !up.is_finite() || (up.length_squared() - 1.0).abs() > 1e-3 {
            return Err(format!("up = {up} is not a finite unit vector"));
        }
        let angle = self.max_slope_angle;
        if !(0.0..=std::f32::consts::FRAC_PI_2).contains(&angle) {
            return Err(format!("max_slope_angle = {angle} rad is not in [0, pi/2]"));
        }
        check_length("max_step_height", self.max_step_height)?;
        check_length("min_step_width", self.min_step_width)?;
        check_length("snap_to_ground", self.snap_to_ground)?;
        if let Some(mass) = self.push_mass
            && !(mass > 0.0 && mass <= MAX_MASS)
        {
            return Err(format!(
                "push_mass = {mass} kg is not a mass in (0, {MAX_MASS:e}]"
            ));
        }
        self.move_and_slide.validate()
    }
}

/// `Ok` if `value` is a length in [0, 1e6].
fn check_length(what: &str, value: f32) -> Result<(), String> {
    if (0.0..=MAX_LENGTH).contains(&value) {
        Ok(())
    } else {
        Err(format!(
            "{what} = {value} is not a length in [0, {MAX_LENGTH:e}]"
        ))
    }
}

/// `Ok` if `value` is at most [`MAX_ITERATIONS`].
fn check_iterations(what: &str, value: usize) -> Result<(), String> {
    if value <= MAX_ITERATIONS {
        Ok(())
    } else {
        Err(format!("{what} = {value} is above {MAX_ITERATIONS}"))
    }
}

/// `Ok` if the shape is valid and its position and rotation are finite (the rotation not zero).
pub(crate) fn check_input(shape: &Collider, position: Vec3, rotation: Quat) -> Result<(), String> {
    if let Some(error) = shape.error() {
        return Err(format!("its collider is invalid: {error}"));
    }
    check_vector("position", position)?;
    let norm = rotation.length_squared();
    if !(norm.is_finite() && norm >= 1e-12) {
        return Err(format!(
            "rotation {rotation} is not a finite, non-zero quaternion"
        ));
    }
    Ok(())
}

/// `Ok` if `v` is finite.
pub(crate) fn check_vector(what: &str, v: Vec3) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{what} {v} is not finite"))
    }
}
