//! Friction of a manifold as a whole ([`FrictionModel::Manifold`]): a friction pair at the
//! centroid of its points and a twist row about its normal.

use super::*;
use crate::dynamics::solver::contact::{TangentPlane, solve_plane};

/// A manifold's friction rows for [`FrictionModel::Manifold`], derived once a step (and again
/// after a substep for a body whose inertia turned, as the point rows are, see
/// [`refresh_inertia`](crate::dynamics::solver::contact::refresh_inertia)).
///
/// The pair acts at the centroid `c` of the points, along the manifold's two tangents, bounded
/// together by `mu` times the manifold's normal impulse (the Coulomb disc of the manifold's
/// resultant), and is solved as a point's pair is (`solve_friction`: the two rows in turn
/// while they stick, else `disc_solve` with the 2 x 2 `K_t` of the centroid); the twist row is an angular impulse about the normal, bounded by that times the
/// points' mean distance from `c` (the moment of a uniform pressure's friction over a disc of
/// that mean radius), solved with `1/K`, `K = n . I_A^-1 n + n . I_B^-1 n`, and clamped. Each
/// update is the exact minimiser of the kinetic energy over its bound, so it removes energy or
/// none, as a point's does.
///
/// Why: a face's four points carry eight friction rows per point model, each waiting on the
/// one before through the two bodies' velocities; the manifold's resultant and twist are the
/// only two things friction acts on that the points' normal rows do not already fix, and three
/// rows carry them. The price is Coulomb's law on the resultant instead of at each point: a
/// box that slides while it also spins about the normal has its friction force and twist each
/// bounded on its own, not together (Rapier's simplified model makes the same choice).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ManifoldFriction {
    /// Whether the manifold is solved this way: two or more points, with friction.
    pub ready: bool,
    /// The points' centroid, world frame (the start of the step's).
    center: Vec3,
    /// The centroid from each body's centre of mass.
    arms: [Vec3; 2],
    /// `I_A^-1 (r_A x t_k)` for the two tangents, then `I_A^-1 n` for the twist.
    turn_a: [Vec3; 3],
    /// The same for body B.
    turn_b: [Vec3; 3],
    /// The pair's `K_t` at the centroid, `[k00, k01, k11]`, 1/kg.
    pair: [f32; 3],
    /// `1/K` of the twist row (0 where it has no effective mass), kg m^2.
    twist_mass: f32,
    /// The points' mean distance from the centroid in the tangent plane, m.
    radius: f32,
}

impl ManifoldFriction {
    /// The rows of the manifold `group` (rows of one body pair, one normal) on `bodies` as they
    /// are now; not `ready` for a single point or a manifold without friction.
    pub fn new(bodies: &[SolverBody], group: &[ContactConstraint]) -> Self {
        let mut rows = ManifoldFriction::default();
        let [first, ..] = group else {
            return rows;
        };
        if group.len() < 2 || first.friction <= 0.0 {
            return rows;
        }
        let n = first.normal;
        let count = group.len() as f32;
        rows.center = group.iter().map(|c| c.point).sum::<Vec3>() / count;
        for c in group {
            let d = in_plane(c.point - rows.center, n);
            rows.radius += d.length() / count;
        }
        let (a, b) = (&bodies[first.body_a], &bodies[first.body_b]);
        rows.arms = [rows.center - a.position, rows.center - b.position];
        rows.derive(a, b, first);
        rows.ready = true;
        rows
    }

    /// The inertia-dependent terms, from the bodies' present world inverse inertia; the arms
    /// stay those of the start of the step (as the point rows' anchors do).
    fn derive(&mut self, a: &SolverBody, b: &SolverBody, first: &ContactConstraint) {
        let n = first.normal;
        let [arm_a, arm_b] = self.arms;
        let t = first.tangents;
        let cross = [
            [arm_a.cross(t[0]), arm_a.cross(t[1])],
            [arm_b.cross(t[0]), arm_b.cross(t[1])],
        ];
        #[allow(clippy::needless_range_loop)] // three arrays indexed alike
        for k in 0..2 {
            self.turn_a[k] = a.inverse_inertia * cross[0][k];
            self.turn_b[k] = b.inverse_inertia * cross[1][k];
        }
        // As a point's `K_t` (`prepare_tangent_rows`), at the centroid.
        let entry = |k: usize, l: usize, linear: f32| {
            linear + cross[0][k].dot(self.turn_a[l]) + cross[1][k].dot(self.turn_b[l])
        };
        let masses = a.inverse_mass + b.inverse_mass;
        self.pair = [
            entry(0, 0, masses),
            0.5 * (entry(0, 1, 0.0) + entry(1, 0, 0.0)),
            entry(1, 1, masses),
        ];
        self.turn_a[2] = a.inverse_inertia * n;
        self.turn_b[2] = b.inverse_inertia * n;
        let k_twist = n.dot(self.turn_a[2]) + n.dot(self.turn_b[2]);
        self.twist_mass = if k_twist > 0.0 && self.radius > 0.0 {
            1.0 / k_twist
        } else {
            0.0
        };
    }

    /// Re-derives the rows for the bodies' present inertia where one of them is dynamic and not
    /// isotropic (the rows [`refresh_inertia`](crate::dynamics::solver::contact::refresh_inertia)
    /// re-derives).
    pub fn refresh(&mut self, bodies: &[SolverBody], group: &[ContactConstraint]) {
        let first = &group[0];
        if self.ready && first.inertia_turns(bodies) {
            self.derive(&bodies[first.body_a], &bodies[first.body_b], first);
        }
    }

    /// One pass over the manifold's friction (the pair, then the twist) on its bodies'
    /// velocities `v`, bounded by the friction coefficient times the points' normal impulses
    /// plus `carried`, the load the manifold bears beyond them (see [`Transmitted`]). The manifold's resultant and twist are read from its points' impulses
    /// and handed back to them when they change: each point's tangent impulse `f / N` and its
    /// twist share `tau / N` ([`ContactConstraint::twist_impulse`], a pure torque about the
    /// normal), so that contact persistence carries them and the warm start applies exactly
    /// the wrench these rows read back, the resultant at the centroid and the twist about `n`.
    /// Returns whether any velocity changed.
    ///
    /// Why a share of its own: handed back as tangent impulses `(tau / S) n x d` at the points
    /// (`d` a point's offset from the centroid in the tangent plane, `S` the sum of `|d|^2`),
    /// the twist's warm start applied torques that no row reads and so none removes: a point's
    /// offset `e` along the normal turns its `n x d` into a tilt (`(tau / S) sum(e_i d_i)`), and
    /// a point gone by the next step leaves the others' shares a resultant. A 4 g
    /// hull under a 0.42 kg capsule in a pour of 0.1 m bodies with friction 1 at 30 Hz spun up
    /// to 350 rad/s in one step and left the box at 5.6 m/s; two more of the 60 mixed pours
    /// of `examples/family_probe` failed that way (none with the share).
    pub fn solve_in(
        &self,
        v: &mut PairVelocities,
        group: &mut [ContactConstraint],
        carried: f32,
    ) -> bool {
        let first = &group[0];
        let (n, tangents) = (first.normal, first.tangents);
        let mut load = carried;
        let mut force = [0.0f32; 2];
        let mut twist = 0.0f32;
        for c in group.iter() {
            load += c.normal_impulse.max(0.0);
            force[0] += c.tangent_impulse[0];
            force[1] += c.tangent_impulse[1];
            // A point's own twist share, plus the twist of its tangent impulse about the
            // centroid (none where the impulses are the resultant's even shares, as handed
            // back below; some where a point's own rows set them).
            let d = in_plane(c.point - self.center, n);
            let along = c.tangent_impulse[0] * tangents[0] + c.tangent_impulse[1] * tangents[1];
            twist += c.twist_impulse + d.cross(along).dot(n);
        }
        let limit = first.friction * load;
        if limit == 0.0 && force == [0.0; 2] && twist == 0.0 {
            return false;
        }
        let mut changed = self.solve_pair(v, &mut force, tangents, limit);
        let bound = limit * self.radius;
        let new = if self.twist_mass > 0.0 {
            let spin = (v.b.angular - v.a.angular).dot(n);
            (twist - spin * self.twist_mass).clamp(-bound, bound)
        } else {
            0.0
        };
        let delta = new - twist;
        if delta != 0.0 {
            twist = new;
            v.a.angular -= delta * self.turn_a[2];
            v.b.angular += delta * self.turn_b[2];
            changed = true;
        }
        if changed {
            let count = group.len() as f32;
            for c in group.iter_mut() {
                c.tangent_impulse = [force[0] / count, force[1] / count];
                c.twist_impulse = twist / count;
            }
        }
        changed
    }
}

impl ManifoldFriction {
    /// The slip of the centroid along `tangent`, on the velocities `v`.
    #[inline]
    fn slip(&self, v: &PairVelocities, tangent: Vec3) -> f32 {
        let [arm_a, arm_b] = self.arms;
        (v.b.linear + v.b.angular.cross(arm_b) - v.a.linear - v.a.angular.cross(arm_a)).dot(tangent)
    }

    /// Applies friction impulse `delta` along tangent `k` (`tangent`) at the centroid.
    #[inline]
    fn apply(&self, v: &mut PairVelocities, k: usize, tangent: Vec3, delta: f32) {
        v.a.linear -= v.a.inverse_mass * delta * tangent;
        v.a.angular -= delta * self.turn_a[k];
        v.b.linear += v.b.inverse_mass * delta * tangent;
        v.b.angular += delta * self.turn_b[k];
    }

    /// The pair at the centroid, as a point's pair is solved ([`solve_plane`]: the two rows in
    /// turn where they stay inside the disc of radius `limit`, else the point of the disc
    /// nearest stopping the slip). `force` is the resultant, updated. Returns whether any
    /// velocity changed.
    fn solve_pair(
        &self,
        v: &mut PairVelocities,
        force: &mut [f32; 2],
        tangents: [Vec3; 2],
        limit: f32,
    ) -> bool {
        solve_plane(
            &Centroid {
                rows: self,
                tangents,
            },
            v,
            force,
            limit,
        )
    }
}

/// A manifold's friction pair at its centroid, as a [`TangentPlane`].
struct Centroid<'a> {
    rows: &'a ManifoldFriction,
    tangents: [Vec3; 2],
}

impl TangentPlane for Centroid<'_> {
    #[inline]
    fn slip(&self, v: &PairVelocities, k: usize) -> f32 {
        self.rows.slip(v, self.tangents[k])
    }

    #[inline]
    fn apply(&self, v: &mut PairVelocities, k: usize, delta: f32) {
        self.rows.apply(v, k, self.tangents[k], delta);
    }

    #[inline]
    fn inverse_mass(&self) -> [f32; 3] {
        self.rows.pair
    }
}

/// `d` less its component along the unit normal `n`.
#[inline]
fn in_plane(d: Vec3, n: Vec3) -> Vec3 {
    d - d.dot(n) * n
}

/// Each block's [`ManifoldFriction`] into `rows` (one per block, in order), for
/// [`FrictionModel::Manifold`]; `rows` is emptied otherwise (every block then per point).
///
/// A block solved per point (one point, or no friction) drops the twist shares its points
/// carry (from a step when its manifold had more points). Why: no row of it reads them, so
/// the warm start would apply them every substep, step after step, and nothing would ever
/// change them.
pub(crate) fn manifold_frictions(
    model: FrictionModel,
    bodies: &[SolverBody],
    contacts: &mut [ContactConstraint],
    blocks: &[Block],
    rows: &mut Vec<ManifoldFriction>,
) {
    rows.clear();
    if model == FrictionModel::Manifold {
        for block in blocks {
            let group = &mut contacts[block.range.clone()];
            let friction = ManifoldFriction::new(bodies, group);
            if !friction.ready {
                for c in group.iter_mut() {
                    c.twist_impulse = 0.0;
                }
            }
            rows.push(friction);
        }
    }
}

#[cfg(test)]
mod tests;
