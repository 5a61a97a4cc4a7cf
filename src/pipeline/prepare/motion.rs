//! A dynamic body's motion beyond gravity and contacts: its forces, accelerations, gravity
//! scale, damping and speed caps, checked and gathered for the step; and what counts as a
//! push that wakes a sleeping body.

use bevy::ecs::change_detection::Tick;
use bevy::prelude::*;

use crate::dynamics::forces::{AccumulatedForces, BodyMotion};
use crate::dynamics::validation::{MAX_ACCELERATION, MAX_ANGULAR_ACCELERATION, check_length};

use super::query::{BodyDataItem, MotionDataItem};

/// Whether something pushed a sleeping body since it fell asleep (tick `since`): a one-off
/// force waits in its [`AccumulatedForces`], a constant force or gravity scale was set, or it
/// may no longer sleep ([`SleepingDisabled`](crate::dynamics::sleep::SleepingDisabled)). Its
/// island wakes.
pub(super) fn pushed_since(m: &MotionDataItem, since: Tick, now: Tick) -> bool {
    let set = [
        m.constant_force.as_ref().map(|c| c.last_changed()),
        m.constant_torque.as_ref().map(|c| c.last_changed()),
        m.constant_local_force.as_ref().map(|c| c.last_changed()),
        m.constant_local_torque.as_ref().map(|c| c.last_changed()),
        m.linear_acceleration.as_ref().map(|c| c.last_changed()),
        m.angular_acceleration.as_ref().map(|c| c.last_changed()),
        m.gravity_scale.as_ref().map(|c| c.last_changed()),
    ];
    m.sleeping_disabled
        || m.accumulated
            .as_ref()
            .is_some_and(|a| **a != AccumulatedForces::default())
        || set
            .into_iter()
            .flatten()
            .any(|tick| tick.is_newer_than(since, now))
}

/// Checks a dynamic body's forces, accelerations, gravity scale, damping and speed caps, and
/// gathers them (world frame) for the step: `None` when it has none of them, so the step
/// leaves it exactly as before. Errors name the component and the value.
pub(super) fn body_motion(
    item: &BodyDataItem,
    rotation: Quat,
    gravity: Vec3,
) -> Result<Option<BodyMotion>, String> {
    let m = &item.motion;
    if has_no_motion(item) {
        return Ok(None);
    }
    let rotation = rotation.normalize();
    let locked = item.locked.copied().unwrap_or_default();
    let Applied {
        force,
        torque,
        mut linear,
        mut angular,
    } = applied(m, rotation)?;
    if let Some(scale) = &m.gravity_scale {
        if !scale.0.is_finite() {
            return Err(format!("GravityScale {:?} is not finite", scale.0));
        }
        if scale.0 != 1.0 {
            linear += (scale.0 - 1.0) * gravity;
        }
    }
    let computed = item
        .computed
        .as_deref()
        .ok_or("dynamic body has no ComputedMass component")?;
    if force != Vec3::ZERO {
        linear += computed.inverse_mass * force;
    }
    if torque != Vec3::ZERO {
        angular += computed.world_inverse_inertia(rotation, locked.rotation) * torque;
    }
    angular = Vec3::select(locked.rotation, Vec3::ZERO, angular);
    check_length("linear acceleration", linear, MAX_ACCELERATION)?;
    check_length("angular acceleration", angular, MAX_ANGULAR_ACCELERATION)?;
    let damping = |what: &str, c: Option<f32>| match c {
        Some(c) if !(c.is_finite() && c >= 0.0) => {
            Err(format!("{what} {c:?} must be finite and >= 0"))
        }
        c => Ok(c.unwrap_or(0.0)),
    };
    let cap = |what: &str, c: Option<f32>| match c {
        Some(c) if c.is_nan() || c < 0.0 => Err(format!("{what} {c:?} must be >= 0")),
        c => Ok(c.unwrap_or(f32::INFINITY)),
    };
    let motion = BodyMotion {
        linear_acceleration: linear,
        angular_acceleration: angular,
        linear_damping: damping("LinearDamping", m.linear_damping.map(|c| c.0))?,
        angular_damping: damping("AngularDamping", m.angular_damping.map(|c| c.0))?,
        max_linear_speed: cap("MaxLinearSpeed", m.max_linear_speed.map(|c| c.0))?,
        max_angular_speed: cap("MaxAngularSpeed", m.max_angular_speed.map(|c| c.0))?,
        locked_translation: locked.translation,
    };
    Ok((!motion.is_none()).then_some(motion))
}

/// Whether a body has none of the components [`body_motion`] reads (its `AccumulatedForces`
/// empty) and no locked translation: its motion is none, as the full check would find, for the
/// price of a few loads (most bodies, every step).
fn has_no_motion(item: &BodyDataItem) -> bool {
    let m = &item.motion;
    m.constant_force.is_none()
        && m.constant_torque.is_none()
        && m.constant_local_force.is_none()
        && m.constant_local_torque.is_none()
        && m.linear_acceleration.is_none()
        && m.angular_acceleration.is_none()
        && m.gravity_scale.is_none()
        && m.linear_damping.is_none()
        && m.angular_damping.is_none()
        && m.max_linear_speed.is_none()
        && m.max_angular_speed.is_none()
        && m
            .accumulated
            .as_deref()
            .is_none_or(|a| *a == AccumulatedForces::default())
        && item.locked.is_none_or(|l| !l.translation.any())
        // The full check's error for a missing `ComputedMass` (met first in `validate`).
        && item.computed.is_some()
}

/// What is applied to a body, summed in the world frame: forces (N), torques (N m), linear
/// (m/s^2) and angular (rad/s^2) accelerations.
#[derive(Default)]
struct Applied {
    force: Vec3,
    torque: Vec3,
    linear: Vec3,
    angular: Vec3,
}

/// Sums a body's constant forces, torques and accelerations and those applied through
/// `Forces` for this step (the body-frame ones turned by `rotation`); an error names the first
/// that is not finite.
fn applied(m: &MotionDataItem, rotation: Quat) -> Result<Applied, String> {
    let finite = |what: &str, v: Vec3| {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(format!("{what} {v} is not finite"))
        }
    };
    let mut sum = Applied::default();
    if let Some(f) = &m.constant_force {
        sum.force += finite("ConstantForce", f.0)?;
    }
    if let Some(f) = &m.constant_local_force {
        sum.force += rotation * finite("ConstantLocalForce", f.0)?;
    }
    if let Some(t) = &m.constant_torque {
        sum.torque += finite("ConstantTorque", t.0)?;
    }
    if let Some(t) = &m.constant_local_torque {
        sum.torque += rotation * finite("ConstantLocalTorque", t.0)?;
    }
    if let Some(a) = &m.linear_acceleration {
        sum.linear += finite("ConstantLinearAcceleration", a.0)?;
    }
    if let Some(a) = &m.angular_acceleration {
        sum.angular += finite("ConstantAngularAcceleration", a.0)?;
    }
    if let Some(a) = &m.accumulated {
        sum.force += finite("the force applied through Forces", a.force)?;
        sum.torque += finite("the torque applied through Forces", a.torque)?;
        sum.linear += finite(
            "the linear acceleration applied through Forces",
            a.linear_acceleration,
        )?;
        sum.angular += finite(
            "the angular acceleration applied through Forces",
            a.angular_acceleration,
        )?;
    }
    Ok(sum)
}
