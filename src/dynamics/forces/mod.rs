//! External forces, impulses, accelerations, gravity scale, damping and speed caps of dynamic
//! bodies, with avian3d 0.7's names and meanings.
//!
//! | type | formula | what it changes | unit |
//! |---|---|---|---|
//! | force `F` | `a = F / m` | velocity, over the step: `dv = F / m dt` | N |
//! | torque `tau` | `alpha = I^-1 tau` | angular velocity, over the step: `dw = I^-1 tau dt` | N m |
//! | acceleration `a` | | velocity, over the step: `dv = a dt` | m/s^2 |
//! | impulse `J` | | velocity, at once: `dv = J / m`, `dw = I^-1 (r x J)` | N s |
//!
//! Constant forces persist from step to step: [`ConstantForce`], [`ConstantTorque`],
//! [`ConstantLinearAcceleration`], [`ConstantAngularAcceleration`] (world frame) and
//! [`ConstantLocalForce`], [`ConstantLocalTorque`] (body frame). One-off forces, torques and
//! impulses go through the [`Forces`] query data: a force applied with
//! [`apply_force`](ForcesItem::apply_force) acts on the next physics step only (it is collected
//! in [`AccumulatedForces`] and cleared when that step reads it); an impulse changes the
//! velocity components at once, through the same [`ImpulseBody::apply_impulse`] that
//! applies a contact impulse.
//!
//! # How a step applies them
//!
//! Linear accelerations are integrated by the solver with gravity, substep by substep; the
//! rest is applied around the solve, per body and only for bodies that have it (see
//! [`BodyMotion`]):
//!
//! 1. before the solve (prepare stage): `a`, the sum of `F / m`, the accelerations and
//!    `(s - 1) g` for a [`GravityScale`] `s` (its components along locked translation axes
//!    dropped), becomes the solver body's
//!    [`extra_acceleration`](SolverBody::extra_acceleration); `w += alpha dt` with
//!    `alpha = I^-1 tau` (world inverse inertia at the start of the step); then damping,
//!    `v /= 1 + c dt`; then the locked translation components of `v` are zeroed.
//! 2. in the solve: every method's substep adds `(g + a) h` to the velocity where it adds
//!    gravity's `g h`, and a body no contact touches flies on the exact parabola of `g + a`
//!    ([`integrate_velocities`](crate::dynamics::solver::integrate_velocities),
//!    [`integrate_positions`](crate::dynamics::solver::integrate_positions)). So `a` is
//!    gravity's exact counterpart: `GravityScale(0.0)` cancels gravity in every substep (a
//!    free body keeps its velocity bit for bit, and a body on the floor does not creep), and a
//!    resting contact sees `(s g) h` a substep as its approach, as under gravity alone.
//! 3. after the solve (solve stage): translation locks put the locked coordinates of the centre
//!    of mass back, and the speed caps scale down a velocity above them.
//!
//! Angular accelerations stay a velocity change `alpha dt` at the start of the step: symplectic
//! Euler over the whole step, turning the body `alpha dt^2 (n - 1) / 2n` farther in a step of
//! `n` substeps than per-substep integration would (the closed form is in `tests/forces.rs`).
//! Nothing angular cancels against it, as gravity cancels a linear `a`, so that difference
//! does not accumulate into a drift.
//!
//! Damping is `v /= 1 + c dt` (the implicit Euler step of `dv/dt = -c v`, as Box2D v3 and
//! avian): it decays for every `c dt >= 0` without reversing the velocity (the explicit
//! `v *= 1 - c dt` reverses it above `c dt = 1`), matches `exp(-c dt)` to `O((c dt)^2)`,
//! and after `n` steps without other forces gives exactly `v0 / (1 + c dt)^n`. Applied before
//! the step's accelerations, a constant linear acceleration `a` (or gravity) gives the terminal
//! velocity `a (1 + c dt) / c`; a constant angular acceleration, applied before the damping,
//! `alpha / c`.
//!
//! Bodies without any of these components are untouched: nothing is stored for them and their
//! results are bit-identical to those of a world without the components.
//!
//! # Examples
//!
//! ```
//! use bevy::prelude::*;
//! use impact3d::prelude::*;
//!
//! fn setup(mut commands: Commands) {
//!     commands.spawn((
//!         RigidBody::Dynamic,
//!         Collider::sphere(0.5),
//!         ConstantForce(Vec3::new(0.0, 0.0, 10.0)), // 10 N along z, every step
//!         GravityScale(0.5),
//!         LinearDamping(0.2),
//!     ));
//! }
//!
//! fn thrust(mut bodies: Query<Forces>) {
//!     for mut forces in &mut bodies {
//!         forces.apply_force(Vec3::Y * 20.0); // the next step only
//!         forces.apply_linear_impulse_at_point(Vec3::X, forces.center_of_mass() + Vec3::Y);
//!     }
//! }
//! # bevy::ecs::system::assert_is_system(setup);
//! # bevy::ecs::system::assert_is_system(thrust);
//! ```

use bevy::ecs::query::QueryData;
use bevy::prelude::*;

use crate::dynamics::mass::ComputedMass;
use crate::dynamics::rigid_body::{AngularVelocity, LinearVelocity, LockedAxes, RigidBody};
use crate::dynamics::solver::SolverBody;
use crate::impulse::ImpulseBody;

/// A force applied at the centre of mass every step, world frame, N. Acts on dynamic bodies.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct ConstantForce(pub Vec3);

impl ConstantForce {
    /// The force `(x, y, z)`, N.
    pub const fn new(x: f32, y: f32, z: f32) -> Self {
        ConstantForce(Vec3::new(x, y, z))
    }
}

/// A torque applied every step, world frame, N m. Acts on dynamic bodies.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct ConstantTorque(pub Vec3);

impl ConstantTorque {
    /// The torque `(x, y, z)`, N m.
    pub const fn new(x: f32, y: f32, z: f32) -> Self {
        ConstantTorque(Vec3::new(x, y, z))
    }
}

/// A force applied at the centre of mass every step, in the body's frame (turned by its
/// rotation at the start of each step), N.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct ConstantLocalForce(pub Vec3);

/// A torque applied every step, in the body's frame (turned by its rotation at the start of
/// each step), N m.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct ConstantLocalTorque(pub Vec3);

/// A linear acceleration applied every step whatever the mass, world frame, m/s^2 (a
/// per-body gravity on top of [`Gravity`](crate::dynamics::Gravity)).
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct ConstantLinearAcceleration(pub Vec3);

impl ConstantLinearAcceleration {
    /// The acceleration `(x, y, z)`, m/s^2.
    pub const fn new(x: f32, y: f32, z: f32) -> Self {
        ConstantLinearAcceleration(Vec3::new(x, y, z))
    }
}

/// An angular acceleration applied every step whatever the inertia, world frame, rad/s^2.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct ConstantAngularAcceleration(pub Vec3);

/// Multiplies [`Gravity`](crate::dynamics::Gravity) for this body: 0 floats, 2 falls twice as
/// fast, -1 falls up. Without it the scale is 1. Must be finite.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct GravityScale(pub f32);

impl Default for GravityScale {
    fn default() -> Self {
        GravityScale(1.0)
    }
}

/// Linear damping coefficient `c`, 1/s: each step `v /= 1 + c dt` (see the
/// [module docs](self) for why this form). Must be finite and `>= 0`; default 0.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct LinearDamping(pub f32);

/// Angular damping coefficient `c`, 1/s: each step `w /= 1 + c dt`. Must be finite and `>= 0`;
/// default 0.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct AngularDamping(pub f32);

/// Caps the body's linear speed, m/s: after each step a faster velocity is scaled down to this
/// length (direction kept). Only bodies with the component are capped. Must not be NaN or
/// negative (infinity is no cap).
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct MaxLinearSpeed(pub f32);

impl Default for MaxLinearSpeed {
    fn default() -> Self {
        MaxLinearSpeed(f32::INFINITY)
    }
}

/// Caps the body's angular speed, rad/s, as [`MaxLinearSpeed`] caps its linear speed.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Deref, DerefMut)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct MaxAngularSpeed(pub f32);

impl Default for MaxAngularSpeed {
    fn default() -> Self {
        MaxAngularSpeed(f32::INFINITY)
    }
}

/// The one-off forces, torques and accelerations applied through [`Forces`] since the last
/// physics step, world frame. The next step applies them and clears them. Required by
/// [`RigidBody`].
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct AccumulatedForces {
    /// Sum of the forces, N.
    pub force: Vec3,
    /// Sum of the torques (with those of forces applied away from the centre of mass), N m.
    pub torque: Vec3,
    /// Sum of the linear accelerations, m/s^2.
    pub linear_acceleration: Vec3,
    /// Sum of the angular accelerations, rad/s^2.
    pub angular_acceleration: Vec3,
}

/// Query data to apply forces, torques, accelerations and impulses to a body: use
/// `Query<Forces>` and call the methods of [`ForcesItem`]. Forces and accelerations act on the
/// next physics step only; impulses change [`LinearVelocity`] and [`AngularVelocity`] at once
/// (and so wake a sleeping body, as any change of velocity does; a force wakes it when the
/// step reads it). Only dynamic bodies respond; a body spawned in this frame has no mass yet
/// (its [`ComputedMass`] is derived by the next step), so an impulse on it does nothing. A
/// force applied in `Update` acts on the first fixed step after it only, however many run in
/// the frame: apply continuous forces in `FixedUpdate`, or use [`ConstantForce`].
#[derive(QueryData)]
#[query_data(mutable)]
pub struct Forces {
    body: &'static RigidBody,
    transform: &'static Transform,
    computed: &'static ComputedMass,
    locked: Option<&'static LockedAxes>,
    linear_velocity: &'static mut LinearVelocity,
    angular_velocity: &'static mut AngularVelocity,
    accumulated: &'static mut AccumulatedForces,
}

impl ForcesItem<'_, '_> {
    /// The body's centre of mass, world frame, m, from its `Transform`: for a top-level body
    /// the world pose. Known limit: for a body with a parent (see the README's Hierarchies and
    /// scale) it is the local pose, so a force at a point on such a body turns it about the
    /// wrong point; `apply_force` and the impulses without a point are unaffected.
    pub fn center_of_mass(&self) -> Vec3 {
        self.transform.translation
            + self.transform.rotation.normalize() * self.computed.local_center_of_mass
    }

    /// The body's linear velocity, m/s.
    pub fn linear_velocity(&self) -> Vec3 {
        self.linear_velocity.0
    }

    /// The body's angular velocity, rad/s.
    pub fn angular_velocity(&self) -> Vec3 {
        self.angular_velocity.0
    }

    /// Applies `force` (N, world frame) at the centre of mass for the next step.
    pub fn apply_force(&mut self, force: Vec3) {
        if force != Vec3::ZERO {
            self.accumulated.force += force;
        }
    }

    /// Applies `force` (N, world frame) at world point `point` for the next step: the force,
    /// and the torque `(point - centre of mass) x force` about the centre of mass now.
    pub fn apply_force_at_point(&mut self, force: Vec3, point: Vec3) {
        if force != Vec3::ZERO {
            let torque = (point - self.center_of_mass()).cross(force);
            self.accumulated.force += force;
            self.accumulated.torque += torque;
        }
    }

    /// Applies `torque` (N m, world frame) for the next step.
    pub fn apply_torque(&mut self, torque: Vec3) {
        if torque != Vec3::ZERO {
            self.accumulated.torque += torque;
        }
    }

    /// Applies the linear acceleration `acceleration` (m/s^2, world frame, whatever the mass)
    /// for the next step.
    pub fn apply_linear_acceleration(&mut self, acceleration: Vec3) {
        if acceleration != Vec3::ZERO {
            self.accumulated.linear_acceleration += acceleration;
        }
    }

    /// Applies the angular acceleration `acceleration` (rad/s^2, world frame, whatever the
    /// inertia) for the next step.
    pub fn apply_angular_acceleration(&mut self, acceleration: Vec3) {
        if acceleration != Vec3::ZERO {
            self.accumulated.angular_acceleration += acceleration;
        }
    }

    /// Applies the impulse `impulse` (N s, world frame) at the centre of mass: `dv = J / m` at
    /// once.
    pub fn apply_linear_impulse(&mut self, impulse: Vec3) {
        let point = self.center_of_mass();
        self.apply_linear_impulse_at_point(impulse, point);
    }

    /// Applies the impulse `impulse` (N s, world frame) at world point `point`, at once, as a
    /// contact impulse is applied ([`ImpulseBody::apply_impulse`]): `dv = J / m` and
    /// `dw = I^-1 (r x J)`, `r = point - centre of mass`, `I^-1` the world inverse inertia
    /// (with locked rotation axes zeroed). Locked translation components of `dv` are dropped.
    pub fn apply_linear_impulse_at_point(&mut self, impulse: Vec3, point: Vec3) {
        if impulse == Vec3::ZERO || !self.body.is_dynamic() {
            return;
        }
        let mut body = self.impulse_body();
        body.apply_impulse(point, impulse);
        self.set_velocities(body.linear_velocity, body.angular_velocity);
    }

    /// Applies the angular impulse `impulse` (N m s, world frame), at once:
    /// `dw = I^-1 impulse`.
    pub fn apply_angular_impulse(&mut self, impulse: Vec3) {
        if impulse == Vec3::ZERO || !self.body.is_dynamic() {
            return;
        }
        let body = self.impulse_body();
        let w = body.angular_velocity + body.inverse_inertia * impulse;
        self.set_velocities(body.linear_velocity, w);
    }

    /// Resolves an inelastic impact of `other` (a body this one does not push back, such as a
    /// kinematic character seen as a body of its mass) on this body at world `point` with unit
    /// `normal` from `other` to this body, by the seed formula with `e = 0`
    /// ([`resolve_impact`](crate::impulse::resolve_impact)): while they approach, this body
    /// takes `+j n` at the point. Returns `j`, N s (0 for a body that is not dynamic or does
    /// not approach).
    pub fn take_impact(&mut self, mut other: ImpulseBody, point: Vec3, normal: Vec3) -> f32 {
        if !self.body.is_dynamic() {
            return 0.0;
        }
        let mut body = self.impulse_body();
        let j = crate::impulse::resolve_impact(&mut other, &mut body, point, normal, 0.0);
        if j > 0.0 {
            self.set_velocities(body.linear_velocity, body.angular_velocity);
        }
        j
    }

    /// The body as the impulse formula sees it.
    fn impulse_body(&self) -> ImpulseBody {
        let locked = self.locked.copied().unwrap_or_default();
        ImpulseBody {
            inverse_mass: self.computed.inverse_mass,
            inverse_inertia: self
                .computed
                .world_inverse_inertia(self.transform.rotation.normalize(), locked.rotation),
            center_of_mass: self.center_of_mass(),
            linear_velocity: self.linear_velocity.0,
            angular_velocity: self.angular_velocity.0,
        }
    }

    /// Writes new velocities, keeping the locked translation components as they were.
    fn set_velocities(&mut self, v: Vec3, w: Vec3) {
        let locked = self.locked.map_or(BVec3::FALSE, |l| l.translation);
        let v = Vec3::select(locked, self.linear_velocity.0, v);
        self.linear_velocity.0 = v;
        self.angular_velocity.0 = w;
    }
}

/// What a dynamic body has beyond gravity and contacts in one step, gathered by the prepare
/// stage (world frame): the step's accelerations, damping, speed caps and translation locks.
/// Stored only for bodies that have one of them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyMotion {
    /// `F / m + a + (s - 1) g`, m/s^2.
    pub linear_acceleration: Vec3,
    /// `I^-1 tau + alpha`, rad/s^2 (locked rotation axes zeroed).
    pub angular_acceleration: Vec3,
    /// 1/s.
    pub linear_damping: f32,
    /// 1/s.
    pub angular_damping: f32,
    /// m/s; infinite when uncapped.
    pub max_linear_speed: f32,
    /// rad/s; infinite when uncapped.
    pub max_angular_speed: f32,
    /// Translation along these world axes is locked.
    pub locked_translation: BVec3,
}

impl Default for BodyMotion {
    fn default() -> Self {
        BodyMotion {
            linear_acceleration: Vec3::ZERO,
            angular_acceleration: Vec3::ZERO,
            linear_damping: 0.0,
            angular_damping: 0.0,
            max_linear_speed: f32::INFINITY,
            max_angular_speed: f32::INFINITY,
            locked_translation: BVec3::FALSE,
        }
    }
}

impl BodyMotion {
    /// Nothing beyond gravity and contacts: the step leaves the body alone.
    pub fn is_none(&self) -> bool {
        *self == BodyMotion::default()
    }

    /// Before the solve: the linear acceleration goes to the solver body's
    /// [`extra_acceleration`](SolverBody::extra_acceleration) (its components along locked
    /// translation axes dropped), which the solver integrates with gravity substep by substep;
    /// the angular velocity change `alpha dt`; then damping; then the locked translation
    /// components of the velocity zeroed (see the [module docs](self)).
    pub fn start_step(&self, body: &mut SolverBody, dt: f32) {
        let mut v = body.linear_velocity;
        let mut w = body.angular_velocity;
        if self.linear_acceleration != Vec3::ZERO {
            body.extra_acceleration = Vec3::select(
                self.locked_translation,
                Vec3::ZERO,
                self.linear_acceleration,
            );
        }
        if self.angular_acceleration != Vec3::ZERO {
            w += self.angular_acceleration * dt;
        }
        if self.linear_damping > 0.0 {
            v /= 1.0 + self.linear_damping * dt;
        }
        if self.angular_damping > 0.0 {
            w /= 1.0 + self.angular_damping * dt;
        }
        body.linear_velocity = Vec3::select(self.locked_translation, Vec3::ZERO, v);
        body.angular_velocity = w;
    }

    /// After the solve: locked coordinates of the centre of mass go back to `start` and their
    /// velocity components to zero, and speeds above the caps are scaled down to them.
    pub fn end_step(&self, body: &mut SolverBody, start: Vec3) {
        if self.locked_translation.any() {
            let position = Vec3::select(self.locked_translation, start, body.position);
            body.delta_position += position - body.position;
            body.position = position;
            body.linear_velocity =
                Vec3::select(self.locked_translation, Vec3::ZERO, body.linear_velocity);
        }
        body.linear_velocity = cap(body.linear_velocity, self.max_linear_speed);
        body.angular_velocity = cap(body.angular_velocity, self.max_angular_speed);
    }
}

/// `v` scaled down to length `max` if it is longer.
fn cap(v: Vec3, max: f32) -> Vec3 {
    let length = v.length();
    if length > max { v * (max / length) } else { v }
}

#[cfg(test)]
mod tests;
