//! What counts as valid input: the magnitude bounds every body is checked against before it
//! enters a step, the per-step validation of the settings resources, and the one helper that
//! names an entity in a log line.
//!
//! # Why bounds on finite values
//!
//! A finite but absurd value is as bad as a NaN: `LinearVelocity(1e30)` times a step of 1/60 s
//! is a reach of 1.7e28 m, whose square (as parry's distance queries form it) is infinite, and
//! `Mass(3e38)` times any velocity overflows an impulse. Such a body must be stopped before the
//! solve, or the overflow reaches every body it shares a contact with. The bounds below keep
//! every product the step forms finite in `f32` (largest 3.4e38), with margin to spare:
//!
//! | product | worst case within the bounds |
//! |---|---|
//! | kinetic energy `m v^2` | `1e12 kg * (1e6 m/s)^2 = 1e24` |
//! | momentum `m v`, an impulse | `1e18 N s` |
//! | angular momentum `I w` (`I <= m R^2`) | `1e12 * (1e6 m)^2 * 1e6 rad/s = 1e30` |
//! | squared distances `|x|^2`, `(v dt)^2` | `(2e7 m)^2 = 4e14` |
//! | `x * m v` (angular momentum about the origin) | `1e7 * 1e18 = 1e25` |
//!
//! and they are wide enough for anything a game or a simulation does in `f32`: beyond 1e7 m
//! from the origin `f32` positions are 1 m apart, far coarser than any contact margin; 1e6 m/s is
//! 300 times a rifle bullet; 1e-9 kg is a 0.1 mm grain of sand.

use bevy::prelude::*;

use super::rigid_body::Gravity;
use super::sleep::SleepConfig;
use super::solver::SolverConfig;
use crate::collision::NarrowPhaseConfig;

/// Largest coordinate of a body's position (each axis, absolute), m. Beyond it a body is
/// quarantined. See the [module docs](self) for why.
pub const MAX_COORDINATE: f32 = 1e7;
/// Largest linear speed of a body, m/s.
pub const MAX_LINEAR_SPEED: f32 = 1e6;
/// Largest angular speed of a body, rad/s.
pub const MAX_ANGULAR_SPEED: f32 = 1e6;
/// Smallest mass of a dynamic body, kg.
pub const MIN_MASS: f32 = 1e-9;
/// Largest mass of a dynamic body, kg.
pub const MAX_MASS: f32 = 1e12;
/// Largest entry of a body's inverse inertia tensor, 1/(kg m^2): a 1e-9 kg body of 1 um
/// radius has about 1e21; beyond 1e24 an angular impulse response `I^-1 (r x n) j` can overflow.
pub const MAX_INVERSE_INERTIA: f32 = 1e24;
/// Largest size (radius, half extent, vertex coordinate) of a collider, m.
pub const MAX_LENGTH: f32 = 1e6;
/// Largest gravity, m/s^2: with the largest step, `|g| dt` stays within [`MAX_LINEAR_SPEED`].
pub const MAX_GRAVITY: f32 = 1e6;
/// Largest linear acceleration of a body beyond gravity (forces over mass, accelerations,
/// gravity scale), m/s^2: with the largest step, `a dt` stays within [`MAX_LINEAR_SPEED`].
pub const MAX_ACCELERATION: f32 = 1e6;
/// Largest angular acceleration of a body (torques through the inverse inertia, angular
/// accelerations), rad/s^2: with the largest step, `alpha dt` stays within
/// [`MAX_ANGULAR_SPEED`].
pub const MAX_ANGULAR_ACCELERATION: f32 = 1e6;
/// Largest step length, s.
pub const MAX_DT: f32 = 1.0;
/// The step length used when the time source has never given a valid one: Bevy's default
/// fixed step, 1/64 s.
pub const DEFAULT_DT: f32 = 1.0 / 64.0;

/// The world's length unit, m: how long "one" is for the plugin's absolute lengths and speeds.
/// [`NarrowPhaseConfig`]'s `contact_margin` and `touch_distance`, the linear slop and every
/// speed threshold ([`SolverConfig`]'s `velocity_tolerance`, `restitution_threshold`,
/// `max_push_out_speed` and [`SleepConfig::linear_threshold`]) are multiplied by it, and
/// contacts are generated with the shapes scaled to the power of two nearest it (see
/// [`ContactPair::update`](crate::collision::narrow_phase::ContactPair::update)). Default 1 (a
/// world of objects around a metre); set it to the size of a typical object, e.g.
/// `PhysicsLengthUnit(1e-3)` for a world of millimetre dice (as avian's `PhysicsLengthUnit`).
/// Valid: finite, in `[1e-6, 1e6]`; an invalid value is logged once and the last good one is
/// used.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// let mut app = App::new();
/// app.add_plugins((MinimalPlugins, PhysicsPlugins::default()))
///     .insert_resource(PhysicsLengthUnit(1e-3));
/// ```
#[derive(Resource, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Resource, Debug, Default, PartialEq)]
pub struct PhysicsLengthUnit(pub f32);

impl Default for PhysicsLengthUnit {
    fn default() -> Self {
        PhysicsLengthUnit(1.0)
    }
}

impl PhysicsLengthUnit {
    /// The unit, or `last_good` with a message when it is not finite or outside
    /// `[1e-6, 1e6]` m.
    pub fn validated(&self, last_good: f32) -> (f32, Option<String>) {
        if (1e-6..=1e6).contains(&self.0) {
            (self.0, None)
        } else {
            (
                last_good,
                Some(format!(
                    "PhysicsLengthUnit = {:?} m is invalid (expected in [1e-6, 1e6]); using {last_good:?}",
                    self.0
                )),
            )
        }
    }
}

/// The entity as log lines name it: `body "crate 3" (12v0)` when it has a [`Name`], else
/// `body 12v0`.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::dynamics::validation::body_label;
///
/// let e = Entity::from_raw_u32(12).unwrap();
/// assert_eq!(body_label(e, Some(&Name::new("crate 3"))), "body \"crate 3\" (12v0)");
/// assert_eq!(body_label(e, None), "body 12v0");
/// ```
pub fn body_label(entity: Entity, name: Option<&Name>) -> String {
    match name {
        Some(name) => format!("body {:?} ({entity})", name.as_str()),
        None => format!("body {entity}"),
    }
}

/// `x <= max`, false for NaN: the check every bound here makes.
#[inline]
pub fn within(x: f32, max: f32) -> bool {
    x <= max
}

/// Checks a vector's length against `max`; NaN and infinite lengths fail.
#[inline]
pub(crate) fn check_length(what: &str, v: Vec3, max: f32) -> Result<(), String> {
    let len = v.length();
    if len <= max {
        Ok(())
    } else {
        Err(length_error(what, [v.x, v.y, v.z], len, max))
    }
}

/// The error of [`check_length`], out of line and given the coordinates one by one: formatting
/// `v` in place (or handing it over whole) made the check copy it to the stack in two parts
/// and read it back across both, which stalled every check.
#[cold]
#[inline(never)]
fn length_error(what: &str, [x, y, z]: [f32; 3], len: f32, max: f32) -> String {
    let v = Vec3::new(x, y, z);
    format!("{what} {v} (|{what}| = {len:?}) is not finite or above {max:e}")
}

/// Checks that `value` is finite and within `range`, pushing an error naming `field` and the
/// value and returning the fallback when it is not.
fn field<T: PartialOrd + Copy + std::fmt::Debug>(
    errors: &mut Vec<String>,
    name: &str,
    value: T,
    fallback: T,
    ok: impl Fn(T) -> bool,
    expected: &str,
) -> T {
    if ok(value) {
        value
    } else {
        errors.push(format!(
            "{name} = {value:?} is invalid (expected {expected}); using {fallback:?}"
        ));
        fallback
    }
}

fn finite_in(lo: f32, hi: f32) -> impl Fn(f32) -> bool {
    move |v: f32| v.is_finite() && v >= lo && v <= hi
}

impl SolverConfig {
    /// This configuration with every invalid field replaced by `last_good`'s, and one message
    /// per replaced field naming it and its value. The pipeline calls it every step, so the
    /// solver only ever sees valid settings; `last_good` must itself be valid (start from
    /// `SolverConfig::default()`).
    ///
    /// Valid: `substeps` and `max_substeps` 1..=256, `max_turn_per_substep` > 0 (infinite
    /// allowed), `iterations` 1..=10,000, `relax_iterations` 0..=10,000,
    /// `max_propagation_sweeps` and `max_block_iterations` 1..=100,000 (larger counts are no
    /// longer settings but hangs); `velocity_tolerance`, `restitution_threshold`,
    /// `max_push_out_speed`, `contact_damping_ratio`, `linear_slop` finite and >= 0;
    /// `contact_hertz` finite and > 0; `baumgarte` in [0, 1]. Speeds are also bounded by
    /// [`MAX_LINEAR_SPEED`] and lengths by [`MAX_LENGTH`].
    ///
    /// # Examples
    ///
    /// ```
    /// use impact3d::prelude::*;
    ///
    /// let bad = SolverConfig { linear_slop: f32::NAN, ..default() };
    /// let (valid, errors) = bad.validated(&SolverConfig::default());
    /// assert_eq!(valid, SolverConfig::default());
    /// assert_eq!(errors.len(), 1);
    /// assert!(errors[0].contains("linear_slop = NaN"));
    /// # use bevy::prelude::default;
    /// ```
    pub fn validated(&self, last_good: &SolverConfig) -> (SolverConfig, Vec<String>) {
        // Long on purpose: one entry per field of `SolverConfig`, each with its bounds: a table,
        // not a sequence of steps.
        let mut e = Vec::new();
        let g = last_good;
        let count = |lo: u32, hi: u32| move |v: u32| (lo..=hi).contains(&v);
        let speed = finite_in(0.0, MAX_LINEAR_SPEED);
        let valid = SolverConfig {
            method: self.method,
            substeps: field(
                &mut e,
                "SolverConfig::substeps",
                self.substeps,
                g.substeps,
                count(1, 256),
                "1..=256",
            ),
            max_turn_per_substep: field(
                &mut e,
                "SolverConfig::max_turn_per_substep",
                self.max_turn_per_substep,
                g.max_turn_per_substep,
                |v: f32| v > 0.0,
                "> 0 rad (infinite: never split)",
            ),
            max_substeps: field(
                &mut e,
                "SolverConfig::max_substeps",
                self.max_substeps,
                g.max_substeps,
                count(1, 256),
                "1..=256",
            ),
            iterations: field(
                &mut e,
                "SolverConfig::iterations",
                self.iterations,
                g.iterations,
                count(1, 10_000),
                "1..=10000",
            ),
            relax_iterations: field(
                &mut e,
                "SolverConfig::relax_iterations",
                self.relax_iterations,
                g.relax_iterations,
                count(0, 10_000),
                "0..=10000",
            ),
            velocity_tolerance: field(
                &mut e,
                "SolverConfig::velocity_tolerance",
                self.velocity_tolerance,
                g.velocity_tolerance,
                &speed,
                "finite, >= 0, <= 1e6 m/s",
            ),
            restitution_threshold: field(
                &mut e,
                "SolverConfig::restitution_threshold",
                self.restitution_threshold,
                g.restitution_threshold,
                &speed,
                "finite, >= 0, <= 1e6 m/s",
            ),
            max_propagation_sweeps: field(
                &mut e,
                "SolverConfig::max_propagation_sweeps",
                self.max_propagation_sweeps,
                g.max_propagation_sweeps,
                count(1, 100_000),
                "1..=100000",
            ),
            max_block_iterations: field(
                &mut e,
                "SolverConfig::max_block_iterations",
                self.max_block_iterations,
                g.max_block_iterations,
                count(1, 100_000),
                "1..=100000",
            ),
            contact_hertz: field(
                &mut e,
                "SolverConfig::contact_hertz",
                self.contact_hertz,
                g.contact_hertz,
                |v: f32| v.is_finite() && v > 0.0 && v <= 1e9,
                "finite, > 0 Hz",
            ),
            contact_damping_ratio: field(
                &mut e,
                "SolverConfig::contact_damping_ratio",
                self.contact_damping_ratio,
                g.contact_damping_ratio,
                finite_in(0.0, 1e9),
                "finite, >= 0",
            ),
            max_push_out_speed: field(
                &mut e,
                "SolverConfig::max_push_out_speed",
                self.max_push_out_speed,
                g.max_push_out_speed,
                &speed,
                "finite, >= 0, <= 1e6 m/s",
            ),
            baumgarte: field(
                &mut e,
                "SolverConfig::baumgarte",
                self.baumgarte,
                g.baumgarte,
                finite_in(0.0, 1.0),
                "in [0, 1]",
            ),
            linear_slop: field(
                &mut e,
                "SolverConfig::linear_slop",
                self.linear_slop,
                g.linear_slop,
                finite_in(0.0, MAX_LENGTH),
                "finite, >= 0 m",
            ),
            warm_start: self.warm_start,
            mass_splitting: self.mass_splitting,
            friction_model: self.friction_model,
            impact_messages: self.impact_messages,
        };
        (valid, e)
    }
}

impl NarrowPhaseConfig {
    /// This configuration with every invalid field replaced by `last_good`'s, and one message
    /// per replaced field naming it and its value, exactly as [`SolverConfig::validated`]; the
    /// pipeline calls it every step. Valid: `contact_margin` and `touch_distance` finite, in
    /// [0, [`MAX_LENGTH`]] m.
    ///
    /// # Examples
    ///
    /// ```
    /// use impact3d::prelude::*;
    ///
    /// let bad = NarrowPhaseConfig { contact_margin: f32::NAN, ..default() };
    /// let (valid, errors) = bad.validated(&NarrowPhaseConfig::default());
    /// assert_eq!(valid, NarrowPhaseConfig::default());
    /// assert_eq!(errors.len(), 1);
    /// assert!(errors[0].contains("contact_margin = NaN"));
    /// # use bevy::prelude::default;
    /// ```
    pub fn validated(&self, last_good: &NarrowPhaseConfig) -> (NarrowPhaseConfig, Vec<String>) {
        let mut e = Vec::new();
        let g = last_good;
        let valid = NarrowPhaseConfig {
            contact_margin: field(
                &mut e,
                "NarrowPhaseConfig::contact_margin",
                self.contact_margin,
                g.contact_margin,
                finite_in(0.0, MAX_LENGTH),
                "finite, >= 0 m",
            ),
            speculative_contacts: self.speculative_contacts,
            touch_distance: field(
                &mut e,
                "NarrowPhaseConfig::touch_distance",
                self.touch_distance,
                g.touch_distance,
                finite_in(0.0, MAX_LENGTH),
                "finite, >= 0 m",
            ),
        };
        (valid, e)
    }
}

impl SleepConfig {
    /// This configuration with every invalid field replaced by `last_good`'s, and one message
    /// per replaced field. Valid: `linear_threshold` finite in [0, [`MAX_LINEAR_SPEED`]],
    /// `time_to_sleep` finite and >= 0.
    ///
    /// # Examples
    ///
    /// ```
    /// use impact3d::prelude::*;
    ///
    /// let bad = SleepConfig { time_to_sleep: -1.0, ..Default::default() };
    /// let (valid, errors) = bad.validated(&SleepConfig::default());
    /// assert_eq!(valid, SleepConfig::default());
    /// assert!(errors[0].contains("time_to_sleep = -1.0"));
    /// ```
    pub fn validated(&self, last_good: &SleepConfig) -> (SleepConfig, Vec<String>) {
        let mut e = Vec::new();
        let valid = SleepConfig {
            enabled: self.enabled,
            linear_threshold: field(
                &mut e,
                "SleepConfig::linear_threshold",
                self.linear_threshold,
                last_good.linear_threshold,
                finite_in(0.0, MAX_LINEAR_SPEED),
                "finite, >= 0 m/s",
            ),
            time_to_sleep: field(
                &mut e,
                "SleepConfig::time_to_sleep",
                self.time_to_sleep,
                last_good.time_to_sleep,
                finite_in(0.0, f32::MAX),
                "finite, >= 0 s",
            ),
        };
        (valid, e)
    }
}

impl Gravity {
    /// This gravity, or `last_good` with a message when it is not finite or longer than
    /// [`MAX_GRAVITY`].
    ///
    /// # Examples
    ///
    /// ```
    /// use bevy::prelude::*;
    /// use impact3d::prelude::*;
    ///
    /// let (g, errors) = Gravity(Vec3::NAN).validated(Gravity::default());
    /// assert_eq!(g, Gravity::default());
    /// assert_eq!(errors.len(), 1);
    /// ```
    pub fn validated(&self, last_good: Gravity) -> (Gravity, Vec<String>) {
        match check_length("Gravity", self.0, MAX_GRAVITY) {
            Ok(()) => (*self, Vec::new()),
            Err(why) => (
                last_good,
                vec![format!("{why} m/s^2; using {}", last_good.0)],
            ),
        }
    }
}

/// The step length `dt` (s), or `last_good` with a message when it is not in (0, [`MAX_DT`]].
///
/// # Examples
///
/// ```
/// use impact3d::dynamics::validation::validated_dt;
///
/// assert_eq!(validated_dt(0.5, 0.25), (0.5, None));
/// assert_eq!(validated_dt(0.0, 0.25).0, 0.25);
/// assert!(validated_dt(f32::NAN, 0.25).1.is_some());
/// ```
pub fn validated_dt(dt: f32, last_good: f32) -> (f32, Option<String>) {
    if dt > 0.0 && dt <= MAX_DT {
        (dt, None)
    } else {
        (
            last_good,
            Some(format!(
                "the step length dt = {dt} s is invalid (expected in (0, {MAX_DT}] s); using {last_good} s"
            )),
        )
    }
}

#[cfg(test)]
mod tests;
