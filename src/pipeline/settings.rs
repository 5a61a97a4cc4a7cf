//! The step's settings: the settings resources validated against the last good values and
//! scaled to the world's length unit.

use super::PhysicsState;
use crate::collision::NarrowPhaseConfig;
use crate::dynamics::sleep::SleepConfig;
use crate::dynamics::validation::{DEFAULT_DT, PhysicsLengthUnit, validated_dt};
use crate::dynamics::{Gravity, SolverConfig};
use crate::schedule::PhysicsTime;

/// The validated settings of one step.
#[derive(Clone, Debug)]
pub(super) struct Settings {
    pub(super) config: SolverConfig,
    pub(super) narrow: NarrowPhaseConfig,
    pub(super) gravity: Gravity,
    pub(super) sleep: SleepConfig,
    pub(super) dt: f32,
    pub(super) length_unit: f32,
    /// [`PhysicsTime::relative_speed`](crate::schedule::PhysicsTime::relative_speed).
    pub(super) relative_speed: f32,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            config: SolverConfig::default(),
            narrow: NarrowPhaseConfig::default(),
            gravity: Gravity::default(),
            sleep: SleepConfig::default(),
            dt: DEFAULT_DT,
            length_unit: 1.0,
            relative_speed: 1.0,
        }
    }
}

/// Validates the settings resources and the step length (the schedule's delta times the
/// physics clock's relative speed) against the last good values (see
/// [`SolverConfig::validated`] and [`NarrowPhaseConfig::validated`]), logging each invalid value once, as an error naming the
/// field and the value, for as long as it stays.
#[allow(clippy::too_many_arguments)]
pub(super) fn validate_settings(
    state: &mut PhysicsState,
    config: &SolverConfig,
    narrow: &NarrowPhaseConfig,
    gravity: &Gravity,
    sleep: &SleepConfig,
    unit: &PhysicsLengthUnit,
    clock: &PhysicsTime,
    delta: f32,
) {
    let last = &state.last_good;
    let (relative_speed, speed_error) = clock.validated_speed(last.relative_speed);
    // Speed 1 leaves the delta as it is, bit for bit (`x * 1.0 == x` in IEEE arithmetic).
    let dt = delta * relative_speed;
    let (config, mut errors) = config.validated(&last.config);
    errors.extend(speed_error);
    let (narrow, e) = narrow.validated(&last.narrow);
    errors.extend(e);
    let (gravity, e) = gravity.validated(last.gravity);
    errors.extend(e);
    let (sleep, e) = sleep.validated(&last.sleep);
    errors.extend(e);
    let (dt, e) = validated_dt(dt, last.dt);
    errors.extend(e);
    let (unit, e) = unit.validated(last.length_unit);
    errors.extend(e);
    for error in &errors {
        if !state.settings_reported.contains(error) {
            log::error!("impact3d: invalid setting: {error}");
        }
    }
    state.settings_reported = errors;
    state.last_good = Settings {
        config,
        narrow,
        gravity,
        sleep,
        dt,
        length_unit: unit,
        relative_speed,
    };
    state.settings = state.last_good.scaled();
}

impl Settings {
    /// These settings with every length (m) and speed (m/s) multiplied by the length unit.
    pub(super) fn scaled(&self) -> Settings {
        let u = self.length_unit;
        let mut s = self.clone();
        s.narrow.contact_margin *= u;
        s.narrow.touch_distance *= u;
        let c = &mut s.config;
        c.linear_slop *= u;
        c.velocity_tolerance *= u;
        c.restitution_threshold *= u;
        c.max_push_out_speed *= u;
        s.sleep.linear_threshold *= u;
        s
    }
}
