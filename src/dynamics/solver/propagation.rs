//! Propagation: each approaching contact (or manifold) resolved as an isolated impact with the
//! impulse formula, on the current velocities, sweeping until nothing approaches.
//!
//! This is the method that gets Newton's cradle right: resolving one two-body impact at a time
//! lets momentum travel down the row ball by ball, which is what the real event sequence does.
//! Any simultaneous method (sequential impulses to convergence, Jacobi, an exact LCP) solves all
//! contacts of the row as one block instead. Its weakness is the opposite case: inelastic
//! collapse, where `e = 0` contacts in a stack keep re-approaching by smaller and smaller
//! amounts, so the sweeps are bounded.

use std::ops::Range;

use bevy::math::Vec3;

use super::body::{Motion, SolverBody, pair_mut};
use super::contact::ContactConstraint;

/// What a propagation pass did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PropagationReport {
    /// Sweeps over the groups, the last one finding nothing to resolve (or hitting the bound).
    pub sweeps: u32,
    /// Group resolutions performed.
    pub resolutions: u32,
    /// The sweep bound was hit while contacts still approached.
    pub bound_hit: bool,
}

/// Parameters of a propagation pass.
#[derive(Clone, Copy, Debug)]
pub struct Propagation {
    /// A contact counts as approaching when `v_n < -threshold`, m/s.
    pub threshold: f32,
    /// At most this many sweeps.
    pub max_sweeps: u32,
    /// Step length, s: a speculative contact (separation s > 0) only takes part when it would
    /// close within the step, and its impact is placed at its time of impact.
    pub dt: f32,
    /// Gravity, m/s^2, when it is integrated *after* this pass over the same step (the hybrid
    /// method); zero when velocities already include it. See [`propagate`].
    pub gravity: Vec3,
    /// Substeps the later integration uses (1 when there is none): semi-implicit Euler over
    /// `n` substeps moves a body `g dt^2 (1 + 1/n) / 2` under gravity, a little more than the
    /// exact `g dt^2 / 2`, and the closing test uses that larger figure.
    pub substeps: u32,
    /// Largest block iterations for a group of several contacts (a manifold).
    pub max_block_iterations: u32,
    /// A group's block solve stops when no contact's velocity changes by more than this, m/s.
    pub velocity_tolerance: f32,
}

/// Resolves approaching groups of contacts as impacts until none approaches.
///
/// Each `groups` range is one unit of propagation: a single contact (textbook propagation), or
/// all points of one body pair's manifold, which are then solved together as a small block so
/// that a box landing flat on four corners rebounds without spin. Within a group, the
/// restitution target of each approaching point is `-e v_n`, with `v_n` taken when the group
/// is picked up; with one point this is exactly `j = -(1+e) v_n / K`.
///
/// An impact at a speculative contact happens at the time `t` into the step when the gap
/// closes, or later if one of the bodies was hit later in this step; each body is owed
/// `-(v' - v) t` of position so that, after integration, it moved at its old velocity until `t`
/// and at its new one after.
///
/// When gravity `g` is integrated after this pass (`params.gravity`), the pair's relative
/// acceleration along the normal, `g_n`, is part of the event: the gap closes when
/// `s + v_n t + g_n t^2 / 2 = 0`, the approach speed at impact is `v_n + g_n t`, and the target
/// normal velocity just after the impact is `-e (v_n + g_n t)`. Expressed before gravity (which
/// the later integration adds for the whole step), that target is `-e v_n - (1 + e) g_n t`;
/// the position owed is still `-(v' - v) t`, since the gravity terms cancel.
pub fn propagate(
    bodies: &mut [SolverBody],
    contacts: &mut [ContactConstraint],
    groups: &[Range<usize>],
    params: &Propagation,
) -> PropagationReport {
    let mut report = PropagationReport::default();
    let mut scratch: Vec<(f32, f32)> = Vec::new();
    let mut rows: Vec<ContactConstraint> = Vec::new();
    // Only a group one of whose bodies changed velocity since the group was last checked can
    // have started to approach: `stamp` is, per body, the number of the resolution that last
    // changed it, and `checked` per group the resolution count when it was last found not
    // approaching (or resolved). The pass stops as soon as no group needs a check, so an
    // island of one impact costs one sweep, not a second one that finds nothing.
    let mut stamp = vec![0u32; bodies.len()];
    let mut checked = vec![0u32; groups.len()];
    let mut resolutions = 0u32;
    // The body pair of each group (the groups are single contacts or one pair's manifold).
    let pairs: Vec<Option<(usize, usize)>> = groups
        .iter()
        .map(|g| {
            contacts
                .get(g.start)
                .filter(|_| !g.is_empty())
                .map(|c| (c.body_a, c.body_b))
        })
        .collect();
    let needs_check = |k: usize, stamp: &[u32], checked: &[u32], sweeps: u32| {
        pairs[k].is_some_and(|(a, b)| sweeps == 0 || stamp[a].max(stamp[b]) > checked[k])
    };
    loop {
        let pending = (0..groups.len()).any(|k| needs_check(k, &stamp, &checked, report.sweeps));
        if !pending {
            break;
        }
        if report.sweeps == params.max_sweeps {
            report.bound_hit = groups.iter().any(|g| {
                contacts[g.clone()]
                    .iter()
                    .any(|c| approaching(c, bodies, params))
            });
            break;
        }
        report.sweeps += 1;
        for (k, group) in groups.iter().enumerate() {
            if !needs_check(k, &stamp, &checked, report.sweeps - 1) {
                continue;
            }
            let group_contacts = &mut contacts[group.clone()];
            if !group_contacts
                .iter()
                .any(|c| approaching(c, bodies, params))
            {
                checked[k] = resolutions;
                continue;
            }
            resolve_group(bodies, group_contacts, params, &mut scratch, &mut rows);
            report.resolutions += 1;
            resolutions += 1;
            let (a, b) = (group_contacts[0].body_a, group_contacts[0].body_b);
            for i in [a, b] {
                if bodies[i].motion == Motion::Dynamic {
                    stamp[i] = resolutions;
                }
            }
            // A block stopped by its iteration bound may still approach: check it again.
            let settled = !group_contacts
                .iter()
                .any(|c| approaching(c, bodies, params));
            checked[k] = if settled {
                resolutions
            } else {
                resolutions - 1
            };
        }
    }
    report
}

/// The contact approaches faster than the threshold and, if it is speculative, closes within
/// the step.
#[inline]
fn approaching(c: &ContactConstraint, bodies: &[SolverBody], params: &Propagation) -> bool {
    if c.normal_mass == 0.0 {
        return false;
    }
    let vn = c.normal_velocity(bodies);
    let gn = relative_gravity(c, bodies, params.gravity);
    vn < -params.threshold && closes_within(c.separation, vn, gn, params)
}

/// The gap `s` closes within the step at normal velocity `vn` and normal acceleration `gn`, as
/// the substepped integration will move the bodies.
#[inline]
fn closes_within(s: f32, vn: f32, gn: f32, params: &Propagation) -> bool {
    let dt = params.dt;
    let discrete = if gn < 0.0 {
        1.0 + 1.0 / params.substeps.max(1) as f32
    } else {
        1.0
    };
    s <= 0.0 || s + vn * dt + 0.5 * gn * dt * dt * discrete < 0.0
}

/// The earliest `t >= 0` with `s + vn t + gn t^2 / 2 = 0` (for `s > 0`, `vn < 0`), or 0 when
/// the gap is already closed.
#[inline]
fn time_of_impact(s: f32, vn: f32, gn: f32) -> f32 {
    if s <= 0.0 {
        return 0.0;
    }
    if gn.abs() < 1e-12 {
        return s / -vn;
    }
    // Stable root of gn/2 t^2 + vn t + s = 0: t = 2 s / (-vn + sqrt(vn^2 - 2 gn s)).
    let disc = (vn * vn - 2.0 * gn * s).max(0.0);
    2.0 * s / (-vn + disc.sqrt())
}

/// Relative acceleration of the pair along the normal due to gravity, `(g_B - g_A) . n`, with
/// gravity acting on dynamic bodies only.
#[inline]
fn relative_gravity(c: &ContactConstraint, bodies: &[SolverBody], gravity: Vec3) -> f32 {
    if gravity == Vec3::ZERO {
        return 0.0;
    }
    let g = |i: usize| {
        if bodies[i].motion == Motion::Dynamic {
            gravity
        } else {
            Vec3::ZERO
        }
    };
    (g(c.body_b) - g(c.body_a)).dot(c.normal)
}

fn resolve_group(
    bodies: &mut [SolverBody],
    group: &mut [ContactConstraint],
    params: &Propagation,
    scratch: &mut Vec<(f32, f32)>,
    rows: &mut Vec<ContactConstraint>,
) {
    let (ia, ib) = (group[0].body_a, group[0].body_b);
    let (v_a, w_a, v_b, w_b) = (
        bodies[ia].linear_velocity,
        bodies[ia].angular_velocity,
        bodies[ib].linear_velocity,
        bodies[ib].angular_velocity,
    );
    // Time of impact within the step: the earliest closing speculative point, not before either
    // body's latest impact.
    let mut toi = bodies[ia].impact_time.max(bodies[ib].impact_time);
    let mut geometric = f32::INFINITY;
    // Per point: (normal velocity at preparation of this resolution, accumulated impulse).
    let gn = relative_gravity(&group[0], bodies, params.gravity);
    scratch.clear();
    for c in group.iter() {
        let vn = c.normal_velocity(bodies);
        let closing =
            c.normal_mass > 0.0 && vn < 0.0 && closes_within(c.separation, vn, gn, params);
        // Points that are not closing within the step take no part (NaN marks them).
        scratch.push((if closing { vn } else { f32::NAN }, 0.0));
        if closing {
            geometric = geometric.min(time_of_impact(c.separation, vn, gn));
        }
    }
    toi = toi.max(geometric.min(params.dt));

    // Solve copies of the rows with their anchors where the contact is at the time of impact:
    // each body's material point has moved by its velocity times t, and the two surface points
    // meet at one common point, so that the equal and opposite impulses act at the same place
    // (with anchors from the start of the step they would act at two points `t (u_B - u_A)`
    // apart, a spurious torque). The common point is the mean of the two material points
    // weighted by inverse mass, `(w_A u_A + w_B u_B) t` from the start, `w = (1/m) / (1/m_A +
    // 1/m_B)`: the midpoint for equal masses, and the moving body's own point against a fixed
    // one. The latter matters: a wall's closest point at the start of the step is not the point
    // that gets hit, and a ball sliding along the wall as it closes in (a fast ball falling
    // under gravity) would otherwise be struck off its line of centres and set spinning (at
    // 100 m/s, 0.1 s of gravity, that cost 10% of the normal impulse).
    rows.clear();
    rows.extend_from_slice(group);
    if toi > 0.0 {
        let (a, b) = (&bodies[ia], &bodies[ib]);
        let inverse = a.inverse_mass + b.inverse_mass;
        let (w_a, w_b) = if inverse > 0.0 {
            (a.inverse_mass / inverse, b.inverse_mass / inverse)
        } else {
            (0.5, 0.5)
        };
        for row in rows.iter_mut() {
            let u_a = a.linear_velocity + a.angular_velocity.cross(row.anchor_a);
            let u_b = b.linear_velocity + b.angular_velocity.cross(row.anchor_b);
            let meet = (w_a * u_a + w_b * u_b) * toi;
            row.anchor_a += meet - a.linear_velocity * toi;
            row.anchor_b += meet - b.linear_velocity * toi;
            row.prepare_normal_row(a, b);
        }
    }
    // Restitution targets, before gravity: -e v_n - (1 + e) g_n t (see `propagate`).
    for (row, (target, _)) in rows.iter().zip(scratch.iter_mut()) {
        if !target.is_nan() {
            let vn = row.normal_velocity(bodies);
            *target = -row.restitution * vn - (1.0 + row.restitution) * gn * toi;
        }
    }

    // Accumulated impulses of this resolution, clamped >= 0: Gauss-Seidel on the small block,
    // where a single point converges in one pass.
    let single = scratch.iter().filter(|(t, _)| !t.is_nan()).count() == 1;
    let iterations = if single {
        1
    } else {
        params.max_block_iterations.max(1)
    };
    for _ in 0..iterations {
        let mut largest_change = 0.0f32;
        for (c, (target, accumulated)) in rows.iter().zip(scratch.iter_mut()) {
            if target.is_nan() {
                continue;
            }
            let vn = c.normal_velocity(bodies);
            let new = (*accumulated - c.normal_mass * (vn - *target)).max(0.0);
            let delta = new - *accumulated;
            if delta != 0.0 {
                *accumulated = new;
                c.apply_normal_impulse(bodies, delta);
                largest_change = largest_change.max(delta.abs() / c.normal_mass);
            }
        }
        if largest_change <= params.velocity_tolerance {
            break;
        }
    }
    for (c, &(_, accumulated)) in group.iter_mut().zip(scratch.iter()) {
        if accumulated > 0.0 {
            c.total_impulse += accumulated;
            c.impact = true;
        }
    }

    let (a, b) = pair_mut(bodies, ia, ib);
    owe_offset(a, v_a, w_a, toi);
    owe_offset(b, v_b, w_b, toi);
}

/// Records that `body` moved at `(v, w)` until `toi` and at its current velocity after.
fn owe_offset(body: &mut SolverBody, v: Vec3, w: Vec3, toi: f32) {
    if body.inverse_mass == 0.0 && body.inverse_inertia == bevy::math::Mat3::ZERO {
        return;
    }
    body.impact_offset -= (body.linear_velocity - v) * toi;
    body.impact_rotation -= (body.angular_velocity - w) * toi;
    body.impact_time = toi;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::solver::contact::prepare_contacts;
    use bevy::math::{BVec3, Mat3, Quat};

    fn ball(x: f32, v: f32) -> SolverBody {
        SolverBody::new(Motion::Dynamic, Vec3::new(x, 0.0, 0.0), Quat::IDENTITY)
            .with_mass(
                1.0,
                Mat3::from_diagonal(Vec3::splat(10.0)),
                true,
                BVec3::FALSE,
            )
            .with_velocity(Vec3::new(v, 0.0, 0.0), Vec3::ZERO)
    }

    fn params() -> Propagation {
        Propagation {
            threshold: 0.0,
            max_sweeps: 100,
            dt: 1.0 / 60.0,
            gravity: Vec3::ZERO,
            substeps: 1,
            max_block_iterations: 64,
            velocity_tolerance: 1e-6,
        }
    }

    /// Newton's cradle of five touching balls, e = 1: only the last ball leaves, at 1 m/s, in
    /// either contact order (velocities exact to 1e-6, f32 rounding of a few impulses).
    #[test]
    fn cradle_in_either_order() {
        for reversed in [false, true] {
            let mut bodies: Vec<_> = (0..5)
                .map(|i| ball(i as f32, if i == 0 { 1.0 } else { 0.0 }))
                .collect();
            let mut contacts: Vec<_> = (0..4)
                .map(|i| {
                    ContactConstraint::new(
                        i,
                        i + 1,
                        Vec3::new(i as f32 + 0.5, 0.0, 0.0),
                        Vec3::X,
                        0.0,
                        1.0,
                        0.0,
                    )
                })
                .collect();
            if reversed {
                contacts.reverse();
            }
            prepare_contacts(&bodies, &mut contacts);
            let groups: Vec<_> = (0..4).map(|i| i..i + 1).collect();
            let report = propagate(&mut bodies, &mut contacts, &groups, &params());
            for (i, b) in bodies.iter().enumerate() {
                let expected = if i == 4 { 1.0 } else { 0.0 };
                assert!(
                    (b.linear_velocity.x - expected).abs() <= 1e-6,
                    "ball {i}: {}",
                    b.linear_velocity.x
                );
            }
            assert!(!report.bound_hit);
        }
    }

    /// A speculative impact is placed at its time of impact: a ball 0.05 m from a wall at
    /// 6 m/s (t = 1/120 s into a 1/60 s step), e = 1, ends the step 0.05 m from the wall again
    /// after integration, as the exact motion does.
    #[test]
    fn speculative_impact_happens_at_time_of_impact() {
        let mut bodies = vec![
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            ball(0.55, -6.0),
        ];
        let mut contacts = vec![ContactConstraint::new(
            0,
            1,
            Vec3::new(0.025, 0.0, 0.0),
            Vec3::X,
            0.05,
            1.0,
            0.0,
        )];
        prepare_contacts(&bodies, &mut contacts);
        let report = propagate(
            &mut bodies,
            &mut contacts,
            std::slice::from_ref(&(0..1)),
            &params(),
        );
        // One impact, nothing else touched: one sweep, and no second one that finds nothing.
        assert_eq!((report.sweeps, report.resolutions), (1, 1));
        crate::dynamics::solver::body::integrate_positions(&mut bodies, Vec3::ZERO, 1.0 / 60.0);
        assert!((bodies[1].linear_velocity.x - 6.0).abs() <= 1e-5);
        // Exact: 0.05 m to the wall at 6 m/s, then 1/120 s back out at 6 m/s: x = 0.55.
        assert!(
            (bodies[1].position.x - 0.55).abs() <= 1e-5,
            "{}",
            bodies[1].position.x
        );
    }
}
