//! Velocity projection onto several contact planes: the closest motion to a wanted one that
//! moves into none of them.

use bevy::prelude::*;

use super::config::MoveAndSlideConfig;

/// The motion closest to `v` (in length of the difference) that moves into none of the planes
/// of `normals`: the point of the cone `{u : u . n >= 0 for every n}` nearest `v`.
///
/// With no plane in the way `v` is returned as it is; against one plane its component along
/// the normal is removed (slide along a wall); in the crease of two planes it keeps only its
/// component along their line (slide along the corner of a wall and the floor); in a corner of
/// three or more independent planes nothing is left.
///
/// # How
///
/// The nearest point `u*` of a convex cone satisfies `u* = v + sum(l_i n_i)` with `l_i >= 0`
/// and `l_i (u* . n_i) = 0` (Karush-Kuhn-Tucker): `u*` is the orthogonal projection of `v` on
/// the subspace `{u . n_i = 0}` of its active planes. In 3D that subspace is all of space (no
/// active plane: `v`), a plane (`v - (v . n) n`), a line (`(v . d) d` with `d` along
/// `n_i x n_j`) or the origin. So `u*` is one of those few candidates, and being feasible and
/// the nearest feasible point, it is the nearest feasible candidate. The candidates are tried in
/// that order and the first nearest kept, so the answer is deterministic. `O(n^3)` for `n`
/// planes (pairs, each checked against all), meant for the few planes of a character's
/// surroundings (avian3d's `max_planes` is 20). A normal that is zero or not finite is
/// skipped.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::character::project_velocity;
///
/// // Into a wall facing -x at 45 degrees: the tangential part is kept.
/// let v = Vec3::new(1.0, 0.0, 1.0);
/// assert_eq!(project_velocity(v, &[Dir3::NEG_X]), Vec3::new(0.0, 0.0, 1.0));
/// // Into the crease of that wall and a ceiling: only the motion along the crease is left.
/// let u = project_velocity(Vec3::new(1.0, 1.0, 1.0), &[Dir3::NEG_X, Dir3::NEG_Y]);
/// assert_eq!(u, Vec3::new(0.0, 0.0, 1.0));
/// ```
pub fn project_velocity(v: Vec3, normals: &[Dir3]) -> Vec3 {
    let normals: Vec<Vec3> = normals
        .iter()
        .map(|n| n.as_vec3())
        .filter(|n| n.is_finite() && n.length_squared() > 0.5)
        .collect();
    // A candidate counts as moving into no plane within a few ulps of `|v|`.
    let tolerance = -1e-5 * v.length();
    let feasible = |u: Vec3| normals.iter().all(|n| u.dot(*n) >= tolerance);
    if !v.is_finite() || feasible(v) {
        return v;
    }
    let mut best = Vec3::ZERO;
    let mut best_distance = v.length_squared();
    let mut consider = |u: Vec3| {
        let distance = (v - u).length_squared();
        if distance < best_distance && feasible(u) {
            best = u;
            best_distance = distance;
        }
    };
    for n in &normals {
        consider(v - v.dot(*n) * *n);
    }
    for (i, a) in normals.iter().enumerate() {
        for b in &normals[i + 1..] {
            let line = a.cross(*b);
            // Nearly parallel planes: their crease is the plane, already a candidate.
            if line.length_squared() > 1e-10 {
                let d = line.normalize();
                consider(v.dot(d) * d);
            }
        }
    }
    best
}

/// Adds the plane of `normal` to `planes`, unless one within the similarity threshold is
/// there already (then the one more against `velocity` is kept) or there are
/// `max_planes` already.
pub(crate) fn add_plane(
    planes: &mut Vec<Dir3>,
    normal: Vec3,
    velocity: Vec3,
    config: &MoveAndSlideConfig,
) {
    let Ok(normal) = Dir3::new(normal) else {
        return;
    };
    for existing in planes.iter_mut() {
        if normal.dot(existing.as_vec3()) >= config.plane_similarity_dot_threshold {
            if normal.dot(velocity) < existing.dot(velocity) {
                *existing = normal;
            }
            return;
        }
    }
    if planes.len() < config.max_planes {
        planes.push(normal);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The projection of `v` on the cone by Dykstra's alternating projections onto the
    /// half-spaces, in f64: an independent method, converging to the same point.
    fn dykstra(v: Vec3, normals: &[Dir3]) -> Vec3 {
        let n: Vec<bevy::math::DVec3> = normals.iter().map(|n| n.as_vec3().as_dvec3()).collect();
        let mut x = v.as_dvec3();
        let mut corrections = vec![bevy::math::DVec3::ZERO; n.len()];
        for _ in 0..20_000 {
            for (k, n) in n.iter().enumerate() {
                let y = x + corrections[k];
                let along = y.dot(*n);
                let projected = if along < 0.0 { y - along * *n } else { y };
                corrections[k] = y - projected;
                x = projected;
            }
        }
        x.as_vec3()
    }

    #[test]
    fn matches_alternating_projections_on_random_plane_sets() {
        // A small linear congruential generator: the same sets on every run.
        let mut seed = 0x2545_f491_u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 33) as f32 / (1u64 << 31) as f32) * 2.0 - 1.0
        };
        for case in 0..500 {
            let count = 1 + case % 5;
            let normals: Vec<Dir3> = (0..count)
                .filter_map(|_| Dir3::new(Vec3::new(next(), next(), next())).ok())
                .collect();
            let v = Vec3::new(next(), next(), next()) * 3.0;
            let ours = project_velocity(v, &normals);
            let reference = dykstra(v, &normals);
            // Dykstra converges linearly, slowly where planes meet at small angles: 1e-3 of
            // |v| (at most 5e-3) is what 20,000 sweeps reach on every one of these sets.
            assert!(
                (ours - reference).length() <= 1e-3 * v.length().max(1.0),
                "case {case}: {ours} against {reference} for v = {v}, normals {normals:?}"
            );
            for n in &normals {
                assert!(ours.dot(n.as_vec3()) >= -1e-5 * v.length(), "case {case}");
            }
        }
    }

    #[test]
    fn closed_form_cases() {
        let v = Vec3::new(2.0, -1.0, 0.5);
        assert_eq!(project_velocity(v, &[]), v);
        // Moving away from the plane: unchanged.
        assert_eq!(project_velocity(v, &[Dir3::X]), v);
        // Floor: the downward part goes.
        assert_eq!(project_velocity(v, &[Dir3::Y]), Vec3::new(2.0, 0.0, 0.5));
        // Floor and a wall facing -x: only z is left.
        assert_eq!(
            project_velocity(v, &[Dir3::Y, Dir3::NEG_X]),
            Vec3::new(0.0, 0.0, 0.5)
        );
        // A corner of three walls: nothing.
        let corner = [Dir3::Y, Dir3::NEG_X, Dir3::NEG_Z];
        assert_eq!(project_velocity(v, &corner), Vec3::ZERO);
        // Two opposite planes: the motion between them.
        assert_eq!(
            project_velocity(v, &[Dir3::Y, Dir3::NEG_Y]),
            Vec3::new(2.0, 0.0, 0.5)
        );
        // A V crease opening upward (two walls at 45 degrees), pushed into it: along the line.
        let a = Dir3::new(Vec3::new(1.0, 1.0, 0.0)).unwrap();
        let b = Dir3::new(Vec3::new(-1.0, 1.0, 0.0)).unwrap();
        let u = project_velocity(Vec3::new(0.0, -1.0, 1.0), &[a, b]);
        assert!((u - Vec3::Z).length() < 1e-6, "{u}");
    }
}
