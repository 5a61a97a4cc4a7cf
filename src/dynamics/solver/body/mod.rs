//! Solver bodies: the packed per-body state the solver stages read and write.

use bevy::math::{BVec3, DMat3, DVec3, Mat3, Quat, Vec3};

use crate::dynamics::mass::lock_axes;

/// How a solver body responds to the step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    /// Gravity and contacts move it.
    Dynamic,
    /// Moves at its velocity; contacts see it as infinitely heavy.
    Kinematic,
    /// Never moves.
    Static,
}

/// One body as the solver sees it, gathered from the ECS once per step. Static and kinematic
/// bodies have `inverse_mass = 0` and `inverse_inertia = 0`, so impulses leave them unchanged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolverBody {
    /// Centre of mass, world frame, m.
    pub position: Vec3,
    /// Orientation.
    pub rotation: Quat,
    /// m/s.
    pub linear_velocity: Vec3,
    /// rad/s, world frame.
    pub angular_velocity: Vec3,
    /// 1/kg.
    pub inverse_mass: f32,
    /// World inverse inertia at `rotation`, 1/(kg m^2).
    pub inverse_inertia: Mat3,
    /// Body-frame inverse inertia, kept to follow the body as it turns within a step.
    pub local_inverse_inertia: Mat3,
    /// World axes about which rotation is locked.
    pub locked_rotation: BVec3,
    /// The inertia is the same about every axis, so it never changes with rotation.
    pub isotropic: bool,
    /// Dynamic, kinematic or static.
    pub motion: Motion,
    /// Displacement of the centre of mass since the start of the step, m.
    pub delta_position: Vec3,
    /// Rotation since the start of the step.
    pub delta_rotation: Quat,
    /// Position correction owed to impacts resolved at their time of impact within the step:
    /// the body moved at its old velocity until then, so `-(v' - v) t` is added once, m.
    pub impact_offset: Vec3,
    /// The angular counterpart of `impact_offset` (a rotation vector), rad.
    pub impact_rotation: Vec3,
    /// Time within the step, s, at which the body's latest impact happened.
    pub impact_time: f32,
    /// No contact touches the body this step: it flies on the exact parabola under gravity
    /// instead of the symplectic Euler step (see [`integrate_positions`]).
    pub ballistic: bool,
    /// Linear acceleration of a dynamic body beyond gravity, world frame, m/s^2: its forces
    /// over its mass, its own accelerations, and `(s - 1) g` for a gravity scale `s` (see
    /// [`forces`](crate::dynamics::forces)). Integrated with gravity substep by substep,
    /// `v += (g + a) h`, and in free flight on the parabola of `g + a`. Zero for a body
    /// without any, which then takes exactly the arithmetic of gravity alone.
    pub extra_acceleration: Vec3,
}

impl SolverBody {
    /// A body with the given pose and velocities; mass terms are zero (fixed) until set.
    pub fn new(motion: Motion, position: Vec3, rotation: Quat) -> Self {
        SolverBody {
            position,
            rotation,
            linear_velocity: Vec3::ZERO,
            angular_velocity: Vec3::ZERO,
            inverse_mass: 0.0,
            inverse_inertia: Mat3::ZERO,
            local_inverse_inertia: Mat3::ZERO,
            locked_rotation: BVec3::FALSE,
            isotropic: true,
            motion,
            delta_position: Vec3::ZERO,
            delta_rotation: Quat::IDENTITY,
            impact_offset: Vec3::ZERO,
            impact_rotation: Vec3::ZERO,
            impact_time: 0.0,
            ballistic: false,
            extra_acceleration: Vec3::ZERO,
        }
    }

    /// Sets mass terms from a body-frame inverse inertia (dynamic bodies only).
    pub fn with_mass(
        mut self,
        inverse_mass: f32,
        local_inverse_inertia: Mat3,
        isotropic: bool,
        locked_rotation: BVec3,
    ) -> Self {
        self.set_mass(
            inverse_mass,
            local_inverse_inertia,
            isotropic,
            locked_rotation,
        );
        self
    }

    /// [`with_mass`](Self::with_mass) in place: the prepare stage sets the bodies in their
    /// array (a body is large; each builder call by value copied it).
    pub fn set_mass(
        &mut self,
        inverse_mass: f32,
        local_inverse_inertia: Mat3,
        isotropic: bool,
        locked_rotation: BVec3,
    ) {
        if self.motion == Motion::Dynamic {
            self.inverse_mass = inverse_mass;
            self.local_inverse_inertia = local_inverse_inertia;
            self.isotropic = isotropic;
            self.locked_rotation = locked_rotation;
            self.inverse_inertia = self.world_inverse_inertia(self.rotation);
        }
    }

    /// Sets the velocities.
    pub fn with_velocity(mut self, linear: Vec3, angular: Vec3) -> Self {
        self.set_velocity(linear, angular);
        self
    }

    /// [`with_velocity`](Self::with_velocity) in place.
    pub fn set_velocity(&mut self, linear: Vec3, angular: Vec3) {
        self.linear_velocity = linear;
        self.angular_velocity = if self.motion == Motion::Static {
            Vec3::ZERO
        } else {
            angular
        };
        if self.motion == Motion::Static {
            self.linear_velocity = Vec3::ZERO;
        }
    }

    fn world_inverse_inertia(&self, rotation: Quat) -> Mat3 {
        let world = if self.isotropic {
            self.local_inverse_inertia
        } else {
            let r = Mat3::from_quat(rotation);
            r * self.local_inverse_inertia * r.transpose()
        };
        lock_axes(world, self.locked_rotation)
    }

    /// The body's linear acceleration under `gravity`, m/s^2: `g + a` for a dynamic body (`g`
    /// itself, bit for bit, when its [`extra_acceleration`](Self::extra_acceleration) `a` is
    /// zero), zero for kinematic and static bodies.
    #[inline]
    pub fn acceleration(&self, gravity: Vec3) -> Vec3 {
        match self.motion {
            Motion::Dynamic if self.extra_acceleration == Vec3::ZERO => gravity,
            Motion::Dynamic => gravity + self.extra_acceleration,
            _ => Vec3::ZERO,
        }
    }
}

/// Adds gravity over `h` seconds to every dynamic body, `v += g h` (`v += (g + a) h` for a
/// body with an [`extra_acceleration`](SolverBody::extra_acceleration) `a`), and the
/// gyroscopic torque `-w x (I w)` to those whose inertia is not isotropic (see
/// [`gyroscopic_step`]).
pub fn integrate_velocities(bodies: &mut [SolverBody], gravity: Vec3, h: f32) {
    let dv = gravity * h;
    for body in bodies.iter_mut().filter(|b| b.motion == Motion::Dynamic) {
        if body.extra_acceleration == Vec3::ZERO {
            body.linear_velocity += dv;
        } else {
            body.linear_velocity += (gravity + body.extra_acceleration) * h;
        }
        if !body.isotropic && !body.locked_rotation.any() && body.angular_velocity != Vec3::ZERO {
            body.angular_velocity = gyroscopic_step(body, h);
        }
    }
}

/// The angular velocity after `h` seconds of torque-free rotation: Euler's equations
/// `I dw/dt + w x (I w) = 0` in the body frame, integrated by the implicit midpoint rule
///
/// ```text
/// I (w1 - w0) + h wm x (I wm) = 0,   wm = (w0 + w1) / 2
/// ```
///
/// which conserves both invariants of torque-free rotation exactly, whatever `h`:
///
/// - kinetic energy: dot the equation with `wm`. `wm . (wm x I wm) = 0`, and, `I` being
///   symmetric, `wm . I (w1 - w0) = (w1 + w0) . I (w1 - w0) / 2 = (w1.I w1 - w0.I w0) / 2`, so
///   `w1.I w1 = w0.I w0`;
/// - the magnitude of angular momentum: dot it with `I wm`. `(I wm) . (wm x I wm) = 0`, and
///   `(I wm) . I (w1 - w0) = (I w1 + I w0) . (I w1 - I w0) / 2 = (|I w1|^2 - |I w0|^2) / 2`, so
///   `|I w1| = |I w0|`.
///
/// (The rotation update in [`integrate_positions`] turns the body about `w` itself, which
/// leaves the body-frame `w`, hence both invariants, unchanged.)
///
/// The equation is solved for `wm` by Newton's method on
/// `g(wm) = 2 I (wm - w0) + h wm x (I wm)`, Jacobian `2 I + h (skew(wm) I - skew(I wm))`,
/// from `wm = w0`, in f64, until a correction is below [`MIDPOINT_TOLERANCE`] of `|w0|`
/// (at most [`MIDPOINT_MAX_ITERATIONS`]; a body spinning about a principal axis stops after
/// one, its `w` unchanged bit for bit). Newton
/// converges from `w0` only while the step turns the body by little, so the step is split
/// into pieces of at most [`MIDPOINT_MAX_ANGLE`] rad of rotation, each a midpoint step (which
/// conserves the invariants as well), and a piece that still does not converge is split
/// again, up to [`MIDPOINT_MAX_PIECES`]; if even that fails, `w` is left unchanged (a free
/// body's energy is then trivially kept).
///
/// In f32 the result is then projected back onto the conserved energy: rounding the f64
/// answer to f32 moves `w.I w` by about 1e-7 relative either way, and when it comes out above
/// the energy at the start, `w` is scaled by `sqrt(E0 / E1)` (nudged down by one f32 rounding
/// step at a time until it is no longer above). That is the exact solution's own invariant
/// restored, not a clamp: the scale differs from 1 by a rounding error, and it lets the solver
/// guarantee that a free body's kinetic energy never rises.
///
/// The previous one-Newton-step implicit Euler (Catto, GDC 2015) was not converged at large
/// `h |w|`: a box spinning at 200 rad/s at 60 Hz with one substep gained energy (1.29x in 60
/// steps in issue 8, 14.6x in 300 steps in `tests/energy.rs`) and `|L|` drifted by up to
/// 99%; the explicit alternatives (holding `L = I w` fixed in the world and
/// re-deriving `w` after rotating, or adding `-h I^-1 (w x I w)`) pump energy into a thin body
/// spinning near its axis of largest inertia.
pub fn gyroscopic_step(body: &SolverBody, h: f32) -> Vec3 {
    let inertia = body.local_inverse_inertia.as_dmat3().inverse();
    let q = body.rotation.as_dquat().normalize();
    let w0_world = body.angular_velocity.as_dvec3();
    if !(inertia.is_finite() && q.is_finite() && w0_world.is_finite()) {
        return body.angular_velocity;
    }
    let energy = |w: DVec3| {
        let local = q.inverse() * w;
        local.dot(inertia * local)
    };
    let w0 = q.inverse() * w0_world;
    let Some(w1) = midpoint_rotation(inertia, w0, h as f64) else {
        return body.angular_velocity;
    };
    // Only the change goes back to the world frame, so that a body whose spin does not change
    // keeps its f32 velocity bit for bit.
    let target = energy(w0_world);
    let mut w = w0_world + q * (w1 - w0);
    let mut result = w.as_vec3();
    let mut e1 = energy(result.as_dvec3());
    if e1 > target && e1 > 0.0 {
        w *= (target / e1).sqrt();
        result = w.as_vec3();
        for _ in 0..8 {
            e1 = energy(result.as_dvec3());
            if e1 <= target {
                break;
            }
            w *= 1.0 - f32::EPSILON as f64;
            result = w.as_vec3();
        }
    }
    if result.is_finite() {
        result
    } else {
        body.angular_velocity
    }
}

/// Largest rotation, rad, of one piece of [`gyroscopic_step`]'s midpoint solve.
pub const MIDPOINT_MAX_ANGLE: f64 = 0.5;
/// Newton's method stops when a correction is below this fraction of `|w0|`: f64 rounding is
/// 1e-16, so this is reached in one more iteration once Newton converges quadratically.
pub const MIDPOINT_TOLERANCE: f64 = 1e-12;
/// Bound on Newton iterations per piece.
pub const MIDPOINT_MAX_ITERATIONS: u32 = 16;
/// Bound on the pieces a step is split into.
pub const MIDPOINT_MAX_PIECES: u32 = 4096;

/// Body-frame `w` after `h` s of torque-free rotation by the implicit midpoint rule (see
/// [`gyroscopic_step`]), or `None` if Newton's method did not converge.
fn midpoint_rotation(inertia: DMat3, w0: DVec3, h: f64) -> Option<DVec3> {
    let angle = h * w0.length();
    let mut pieces = ((angle / MIDPOINT_MAX_ANGLE).ceil() as u32).max(1);
    while pieces <= MIDPOINT_MAX_PIECES {
        let hp = h / pieces as f64;
        let mut w = w0;
        let mut converged = true;
        for _ in 0..pieces {
            match midpoint_piece(inertia, w, hp) {
                Some(w1) => w = w1,
                None => {
                    converged = false;
                    break;
                }
            }
        }
        if converged {
            return Some(w);
        }
        pieces *= 2;
    }
    None
}

/// One implicit midpoint step of `h` s by Newton's method on `wm`.
fn midpoint_piece(inertia: DMat3, w0: DVec3, h: f64) -> Option<DVec3> {
    let scale = w0.length();
    let mut wm = w0;
    for _ in 0..MIDPOINT_MAX_ITERATIONS {
        let iwm = inertia * wm;
        let g = 2.0 * (inertia * (wm - w0)) + h * wm.cross(iwm);
        let jacobian = 2.0 * inertia + h * (skew64(wm) * inertia - skew64(iwm));
        let det = jacobian.determinant();
        if !(det.is_finite() && det.abs() > 0.0) {
            return None;
        }
        let correction = jacobian.inverse() * g;
        wm -= correction;
        if !wm.is_finite() {
            return None;
        }
        if correction.length() <= MIDPOINT_TOLERANCE * scale {
            return Some(2.0 * wm - w0);
        }
    }
    None
}

/// The matrix of `v x`, in f64.
fn skew64(v: DVec3) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(0.0, v.z, -v.y),
        DVec3::new(-v.z, 0.0, v.x),
        DVec3::new(v.y, -v.x, 0.0),
    )
}

/// Moves dynamic and kinematic bodies over `h` seconds (symplectic Euler: the velocities
/// already hold this substep's update), adds any position correction owed to impacts, and
/// tracks the displacement since the start of the step.
///
/// Symplectic Euler moves a body under gravity `g h^2 / 2` further per substep than the exact
/// parabola, which costs a bouncing ball about `v h` of apex height per bounce. A `ballistic`
/// body (no contact this step) is moved on the exact parabola, `x += v h - g h^2 / 2` with `v`
/// already including `g h`; bodies in contact keep symplectic Euler, whose velocity-level
/// solve is what keeps resting contact still. A body with an
/// [`extra_acceleration`](SolverBody::extra_acceleration) `a` flies on the parabola of `g + a`.
///
/// A dynamic body whose inertia is not isotropic has its world inverse inertia refreshed at the
/// new orientation (its gyroscopic torque is applied in [`integrate_velocities`]).
pub fn integrate_positions(bodies: &mut [SolverBody], gravity: Vec3, h: f32) {
    integrate_positions_owing(bodies, gravity, h, 1.0);
}

/// [`integrate_positions`] turning a body by only `share` (in `(0, 1]`) of the rotation owed to
/// its impacts, and leaving the rest owed: the soft substeps spread it over the substeps left in
/// the step (`1 / (n - k)` in substep `k` of `n`), so that a large owed turn does not turn a body
/// in one substep past what its contact rows, linear in its turn, describe (see
/// [`SolverConfig::max_turn_per_substep`](super::SolverConfig::max_turn_per_substep)). The owed
/// displacement is added whole in the first substep, as before: spread, its last part pushed a
/// landing cube into the ground in the step's last substep, after the rows could answer (the
/// three-cube column at 30 Hz x 4 sank 3.2 mm against its 1.3 mm bound).
pub fn integrate_positions_owing(bodies: &mut [SolverBody], gravity: Vec3, h: f32, share: f32) {
    let parabola = -0.5 * gravity * h * h;
    let owed = |v: &mut Vec3| {
        if share >= 1.0 {
            std::mem::take(v)
        } else {
            let part = *v * share;
            *v -= part;
            part
        }
    };
    for body in bodies.iter_mut().filter(|b| b.motion != Motion::Static) {
        let offset = std::mem::take(&mut body.impact_offset);
        let turn = owed(&mut body.impact_rotation);
        let mut dp = body.linear_velocity * h + offset;
        if body.ballistic {
            if body.extra_acceleration == Vec3::ZERO {
                dp += parabola;
            } else {
                dp += -0.5 * (gravity + body.extra_acceleration) * h * h;
            }
        }
        body.position += dp;
        body.delta_position += dp;

        // The rotation owed to an impact turns the body without a torque: its spin turns with
        // it, so that the spin in the body's frame, and with it the kinetic energy, is what the
        // impact left. (Turning the body under a fixed world spin changes `w . I w` for a body
        // whose inertia is not isotropic: a thin capsule whose spin an impact raised tenfold
        // gained 2 kJ, 22% of its world's energy, from this offset alone.)
        if turn != Vec3::ZERO
            && body.motion == Motion::Dynamic
            && !body.isotropic
            && !body.locked_rotation.any()
        {
            body.angular_velocity = Quat::from_scaled_axis(turn) * body.angular_velocity;
        }
        // The owed turn first, then the turn about the spin itself, which leaves the spin in
        // the body's frame unchanged: so neither changes `w . I w`. (One rotation by the sum
        // `w h + turn` is not their composition: at `|w h|` = 1.2 rad and a turn of 0.5 rad, a
        // capsule spinning at 165 rad/s gained 13 J, 1.7% of its world's energy, in one
        // bounce: the energy property test, sequential impulses, seed 21.)
        let spin = body.angular_velocity * h;
        if spin != Vec3::ZERO || turn != Vec3::ZERO {
            let dq = if turn == Vec3::ZERO {
                Quat::from_scaled_axis(spin)
            } else {
                Quat::from_scaled_axis(spin) * Quat::from_scaled_axis(turn)
            };
            body.rotation = (dq * body.rotation).normalize();
            body.delta_rotation = (dq * body.delta_rotation).normalize();
            if body.motion == Motion::Dynamic && !body.isotropic {
                body.inverse_inertia = body.world_inverse_inertia(body.rotation);
            }
        }
    }
}

/// The velocities of one body as a contact row reads and changes them, with its inverse mass:
/// a copy held in locals while the rows of one body pair are solved (see [`PairVelocities`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowBody {
    /// m/s.
    pub linear: Vec3,
    /// rad/s, world frame.
    pub angular: Vec3,
    /// 1/kg.
    pub inverse_mass: f32,
}

/// Bodies A and B of a run of rows that all join the same two bodies (a manifold), read once
/// before the rows are solved and written back once after.
///
/// Why: solved against the body slice, each row's update is stored and read back by the next
/// row (through the row's body indices, which the compiler cannot prove equal), a chain of
/// loads and stores the rows wait on; in locals the velocities stay in registers. The rows
/// perform the same operations in the same order either way, so the results are bit-identical.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairVelocities {
    /// Body A.
    pub a: RowBody,
    /// Body B.
    pub b: RowBody,
}

impl PairVelocities {
    /// Bodies `a` and `b`'s velocities and inverse masses.
    #[inline]
    pub fn load(bodies: &[SolverBody], a: usize, b: usize) -> Self {
        let side = |body: &SolverBody| RowBody {
            linear: body.linear_velocity,
            angular: body.angular_velocity,
            inverse_mass: body.inverse_mass,
        };
        PairVelocities {
            a: side(&bodies[a]),
            b: side(&bodies[b]),
        }
    }

    /// Writes the velocities back to bodies `a` and `b`.
    #[inline]
    pub fn store(&self, bodies: &mut [SolverBody], a: usize, b: usize) {
        let (body_a, body_b) = pair_mut(bodies, a, b);
        (body_a.linear_velocity, body_a.angular_velocity) = (self.a.linear, self.a.angular);
        (body_b.linear_velocity, body_b.angular_velocity) = (self.b.linear, self.b.angular);
    }
}

/// Returns mutable references to two distinct bodies (or per-body entries).
pub(crate) fn pair_mut<T>(bodies: &mut [T], a: usize, b: usize) -> (&mut T, &mut T) {
    debug_assert_ne!(a, b);
    if a < b {
        let (lo, hi) = bodies.split_at_mut(b);
        (&mut lo[a], &mut hi[0])
    } else {
        let (lo, hi) = bodies.split_at_mut(a);
        (&mut hi[0], &mut lo[b])
    }
}

/// Kinetic energy of the dynamic bodies, J (summed in f64): the solver tests' conservation
/// checks.
#[cfg(test)]
pub(crate) fn kinetic_energy(bodies: &[SolverBody]) -> f64 {
    bodies
        .iter()
        .filter(|b| b.motion == Motion::Dynamic)
        .map(|b| {
            let (v, w) = (b.linear_velocity.as_dvec3(), b.angular_velocity.as_dvec3());
            let inertia = b.inverse_inertia.as_dmat3().inverse();
            0.5 * v.length_squared() / b.inverse_mass as f64 + 0.5 * w.dot(inertia * w)
        })
        .sum()
}

/// A 1 kg cube of side 1 (`I^-1 = 6` about every axis) with its centre `height` above the
/// origin, moving at `v` and spinning at `w`: the solver tests' unit cube.
#[cfg(test)]
pub(crate) fn unit_cube(height: f32, v: Vec3, w: Vec3) -> SolverBody {
    SolverBody::new(Motion::Dynamic, Vec3::new(0.0, height, 0.0), Quat::IDENTITY)
        .with_mass(
            1.0,
            Mat3::from_diagonal(Vec3::splat(6.0)),
            true,
            BVec3::FALSE,
        )
        .with_velocity(v, w)
}

/// Static ground (body 0) and a [`unit_cube`] (body 1) with its centre `height` above it:
/// the solver tests' cube on the ground.
#[cfg(test)]
pub(crate) fn cube_over_ground(height: f32, v: Vec3, w: Vec3) -> [SolverBody; 2] {
    [
        SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
        unit_cube(height, v, w),
    ]
}

#[cfg(test)]
mod tests;
