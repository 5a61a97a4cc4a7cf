//! Unit tests of the dense solve of an impact event's contact rows.

use super::*;

/// A unit cube (1 kg, inertia 1/6 about each axis) landing flat on static ground at 1 m/s
/// while turning at 0.5 rad/s about x, e = 0: its four corners are redundant rows (`K` of
/// rank 3). Worked out by hand, with corners `r = (+-0.5, -0.5, +-0.5)` from the centre:
/// they approach at `-1 - 0.5 z` m/s; all push, and the cube stops, `v = w = 0`. The
/// impulses: `sum j = 1` N s (the momentum), `sum j z = 1/12` (the angular momentum about x,
/// `I w = 1/12`), `sum j x = 0`, so the corners at `z = 0.5` take `7/24` N s each and those at
/// `z = -0.5` `5/24` (equal across x by symmetry: the regularised problem's unique answer).
/// Tolerances: impulses within 1e-6 N s (the 1e-9 regularisation, f64 rounding); velocities
/// within 1e-6 (f32 rounding of applying impulses of order 0.3 to velocities of order 1).
#[test]
fn flat_box_corners_share_the_landing() {
    use crate::dynamics::solver::body::cube_over_ground;
    use crate::dynamics::solver::contact::prepare_contacts;
    use bevy::math::Vec3;
    let mut bodies = cube_over_ground(0.5, Vec3::new(0.0, -1.0, 0.0), Vec3::new(0.5, 0.0, 0.0));
    let corners = [(-0.5f32, -0.5f32), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)];
    let mut contacts = corners
        .map(|(x, z)| ContactConstraint::new(0, 1, Vec3::new(x, 0.0, z), Vec3::Y, 0.0, 0.0, 0.0));
    prepare_contacts(&bodies, &mut contacts);
    let mut solve = DenseSolve::default();
    solve.clear();
    for c in &contacts {
        solve.push(c, &bodies, 0.0);
    }
    let impulses = solve.solve().expect("a solution").to_vec();
    for (&(_, z), &j) in corners.iter().zip(&impulses) {
        let expected = if z > 0.0 { 7.0 / 24.0 } else { 5.0 / 24.0 };
        assert!((j - expected).abs() <= 1e-6, "corner at z = {z}: {j}");
    }
    for (c, &j) in contacts.iter().zip(&impulses) {
        c.apply_normal_impulse(&mut bodies, j as f32);
    }
    assert!(
        bodies[1].linear_velocity.length() <= 1e-6,
        "{}",
        bodies[1].linear_velocity
    );
    assert!(
        bodies[1].angular_velocity.length() <= 1e-6,
        "{}",
        bodies[1].angular_velocity
    );
}

/// A small deterministic generator (the same LCG as the scenes' jitter).
struct Lcg(u32);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(1664525).wrapping_add(1013904223);
        (self.0 >> 8) as f64 / (1u32 << 24) as f64 * 2.0 - 1.0
    }

    fn vector(&mut self) -> DVec3 {
        DVec3::new(self.next(), self.next(), self.next())
    }
}

/// The LCP's solution by trying every set of pushing rows: for a positive definite `K` it
/// is unique, so the one set whose equalities give `lambda >= 0` and `w >= 0` elsewhere.
fn brute_force(k: &[f64], q: &[f64]) -> Vec<f64> {
    let n = q.len();
    for set in 0u32..1 << n {
        let rows: Vec<usize> = (0..n).filter(|&i| set >> i & 1 == 1).collect();
        // Gaussian elimination on K_SS lambda_S = -q_S.
        let m = rows.len();
        let mut a: Vec<Vec<f64>> = rows
            .iter()
            .map(|&i| {
                let mut r: Vec<f64> = rows.iter().map(|&j| k[i * n + j]).collect();
                r.push(-q[i]);
                r
            })
            .collect();
        for c in 0..m {
            let p = (c..m)
                .max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))
                .unwrap();
            a.swap(c, p);
            let pivot = a[c].clone();
            for (r, row) in a.iter_mut().enumerate() {
                if r != c {
                    let f = row[c] / pivot[c];
                    for (x, p) in row.iter_mut().zip(&pivot).skip(c) {
                        *x -= f * p;
                    }
                }
            }
        }
        let mut lambda = vec![0.0; n];
        for (f, &i) in rows.iter().enumerate() {
            lambda[i] = a[f][m] / a[f][f];
        }
        let w: Vec<f64> = (0..n)
            .map(|i| q[i] + (0..n).map(|j| k[i * n + j] * lambda[j]).sum::<f64>())
            .collect();
        if lambda.iter().all(|&l| l >= -1e-9) && w.iter().all(|&w| w >= -1e-9) {
            return lambda;
        }
    }
    panic!("no solution");
}

/// Random events of up to 8 rows among 4 bodies (random masses, inertias, normals and
/// levers, body 0 fixed), random `q` (2,000 cases, 16 of which have a row leave the free
/// set on the way): the active-set solve matches the solution found by trying every set of
/// pushing rows (both on the same regularised `K`). Tolerance 1e-7
/// of the largest impulse: f64 rounding times the condition of these random `K` (up to
/// about 1e6), far below any difference between two active sets.
#[test]
fn matches_brute_force() {
    let mut rng = Lcg(12345);
    let mut solve = DenseSolve::default();
    for case in 0..2000 {
        let inverse_mass: Vec<f64> = (0..4)
            .map(|b| {
                if b == 0 {
                    0.0
                } else {
                    0.1 + rng.next().abs() * 10.0
                }
            })
            .collect();
        let inverse_inertia: Vec<DMat3> = (0..4)
            .map(|b| {
                if b == 0 {
                    DMat3::ZERO
                } else {
                    let a = DMat3::from_cols(rng.vector(), rng.vector(), rng.vector());
                    a * a.transpose() + DMat3::IDENTITY * 0.1
                }
            })
            .collect();
        let n = 1 + case % 8;
        solve.rows.clear();
        solve.q.clear();
        for _ in 0..n {
            let a = (rng.next().abs() * 4.0) as usize % 4;
            let b = (a + 1 + (rng.next().abs() * 3.0) as usize % 3) % 4;
            let n = rng.vector().normalize();
            let (rn_a, rn_b) = (rng.vector().cross(n), rng.vector().cross(n));
            solve.rows.push(Row {
                a,
                b,
                n,
                rn_a,
                rn_b,
                ang_a: inverse_inertia[a] * rn_a,
                ang_b: inverse_inertia[b] * rn_b,
                inverse_mass_a: inverse_mass[a],
                inverse_mass_b: inverse_mass[b],
            });
            solve.q.push(rng.next() * 3.0);
        }
        // The whole K, as the solve computes its columns.
        solve.computed.clear();
        solve.computed.resize(n, false);
        solve.k.resize(n * n, 0.0);
        for j in 0..n {
            solve.column(j);
        }
        let k = solve.k[..n * n].to_vec();
        let q = solve.q.clone();
        let expected = brute_force(&k, &q);
        let lambda = solve.solve().expect("a solution").to_vec();
        let scale = expected.iter().fold(1.0f64, |m, l| m.max(l.abs()));
        for i in 0..n {
            assert!(
                (lambda[i] - expected[i]).abs() <= 1e-7 * scale,
                "case {case} row {i}: {} vs {}",
                lambda[i],
                expected[i]
            );
        }
    }
}
