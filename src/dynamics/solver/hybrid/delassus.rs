//! A manifold block iterated in the space of its rows' normal velocities, through its Delassus
//! matrix, for the blocks that iterate long (see [`solve_block`]).

use super::*;

/// The most rows of a block iterated through its Delassus matrix (a box's face manifold has 4;
/// a larger block is iterated on the bodies).
pub(super) const DELASSUS_ROWS: usize = 8;

/// One block's rows in the space of their normal velocities: the same Gauss-Seidel updates as
/// [`solve_block`]'s loop over the bodies, each row's velocity kept up to date through the
/// matrix `A` (`A[i][j]`: the change of row `i`'s normal velocity per unit impulse on row `j`,
/// through the block's [`Response`]) and the bodies changed once, at the end, by each row's
/// whole change of impulse.
///
/// Why: a manifold with friction and a rigid tilt is solved to 1e-7 m/s (see
/// [`manifold_sweep`]), 4.3 passes over its 4 rows on average in a settled pile of 1,000 cubes
/// and up to the bound of 64 in some solves. On the bodies each row update read both bodies'
/// velocities, divided by its diagonal and wrote the velocities back, a chain of dependent
/// steps the next row waited for; here a row update is a multiply-add on its own velocity,
/// a multiplication by its diagonal's reciprocal (computed once a block solve) and one
/// multiply-add across the block's velocities. `A` costs about one pass over the bodies to
/// build. The pile's step: 7.0-7.8 -> 6.3-6.8 ms (2026-12-07, four paired runs; the same
/// iterations dividing each time: no faster than on the bodies). The results differ from the
/// loop over the bodies by rounding, and by the projection of the biases (see
/// [`project_biases`], which costs about what its fewer passes save); the runs that turn on
/// rounding (the columns pinned as failing, see [`manifold_sweep`]) move either way.
pub(super) struct Delassus {
    /// Each row's normal velocity, m/s.
    vn: [f32; DELASSUS_ROWS],
    /// `a[j][i] = A[i][j]`, 1/kg: row `j`'s impulse's change of every row's velocity, one
    /// array, so that a row's update changes them all at once (rows past the block's are 0).
    a: [[f32; DELASSUS_ROWS]; DELASSUS_ROWS],
    /// Each row's change of impulse not yet applied to the bodies, N s.
    applied: [f32; DELASSUS_ROWS],
}

/// A row taking part in a [`Delassus`] block's passes: its index, bias, coupling to the soft
/// points' total (`c`, or 0 for a rigid row), `K_ii` and `1 / (K_ii + c)`.
#[derive(Clone, Copy, Default)]
struct Part {
    row: usize,
    bias: f32,
    coupling: f32,
    k: f32,
    inverse: f32,
}

impl Delassus {
    /// The block `group` (at most [`DELASSUS_ROWS`] rows, all on the same two bodies) at the
    /// bodies' velocities now, its bodies responding by `response`.
    pub(super) fn new(
        bodies: &[SolverBody],
        group: &[ContactConstraint],
        response: &Response,
    ) -> Self {
        debug_assert!(group.len() <= DELASSUS_ROWS);
        let mut d = Delassus {
            vn: [0.0; DELASSUS_ROWS],
            a: [[0.0; DELASSUS_ROWS]; DELASSUS_ROWS],
            applied: [0.0; DELASSUS_ROWS],
        };
        let Some(c0) = group.first() else {
            return d;
        };
        let (ima, imb) = (
            bodies[c0.body_a].inverse_mass,
            bodies[c0.body_b].inverse_mass,
        );
        for (j, cj) in group.iter().enumerate() {
            d.vn[j] = cj.normal_velocity(bodies);
            // As `apply_response` moves the bodies for an impulse of 1 on row `j`: B by
            // `+1/m_B dir_B` and `+f_B I_B^-1 (r_B x n)`, A by the opposite.
            let linear = ima * response.a.direction_for(cj.normal)
                + imb * response.b.direction_for(cj.normal);
            let turns = |side: &Side, ang: Vec3| match side.turn(cj.angular) {
                f if f > 0.0 => f * ang,
                _ => Vec3::ZERO,
            };
            let (wa, wb) = (turns(&response.a, cj.ang_a), turns(&response.b, cj.ang_b));
            for (i, ci) in group.iter().enumerate() {
                let mut change = linear.dot(ci.normal);
                if ci.angular {
                    change += wb.dot(ci.rn_b) + wa.dot(ci.rn_a);
                }
                d.a[j][i] = change;
            }
        }
        d
    }

    /// [`solve_block`]'s passes over the rows of a block with a rigid tilt (`rows` their
    /// parts, `diagonal` a row's `K_ii`, `coupling` the soft plane's `c`, `total` the soft
    /// points' impulse, `tolerance` and `first_row` as there, `max_push_out` the push-out's
    /// cap): each row's residual is `v_n + b + c * total` (`v_n + b` for a rigid row) over
    /// `K_ii + c` (`K_ii`), its bias projected first (see [`project_biases`]). Returns what
    /// `solve_block` does.
    pub(super) fn iterate(
        &mut self,
        group: &mut [ContactConstraint],
        rows: &[BlockRow],
        diagonal: impl Fn(&ContactConstraint) -> f32,
        (coupling, mut total): (f32, f32),
        (tolerance, first_row, max_iterations): (f32, Option<usize>, u32),
        max_push_out: f32,
    ) -> (bool, f32, bool) {
        let mut parts = [Part::default(); DELASSUS_ROWS];
        let mut count = 0;
        let mut impulse = [0.0f32; DELASSUS_ROWS];
        let mut most = [0.0f32; DELASSUS_ROWS];
        for (i, (c, row)) in group.iter().zip(rows).enumerate() {
            impulse[i] = c.normal_impulse;
            most[i] = c.max_normal_impulse;
            let Some((bias, soft)) = *row else { continue };
            let k = diagonal(c);
            if k <= 0.0 {
                continue;
            }
            let coupling = if soft { coupling } else { 0.0 };
            parts[count] = Part {
                row: i,
                bias,
                coupling,
                k,
                inverse: 1.0 / (k + coupling),
            };
            count += 1;
        }
        project_biases(group, &mut parts[..count], max_push_out);
        let mut first = 0.0f32;
        let mut changed = false;
        let mut converged = false;
        for iteration in 0..max_iterations {
            let mut last_changed = None;
            let mut largest = 0.0f32;
            for part in &parts[..count] {
                let i = part.row;
                let residual = self.vn[i] + part.bias + part.coupling * total;
                let new = (impulse[i] - residual * part.inverse).max(0.0);
                let delta = new - impulse[i];
                if delta != 0.0 {
                    impulse[i] = new;
                    self.applied[i] += delta;
                    let column = &self.a[i];
                    for (v, a) in self.vn.iter_mut().zip(column) {
                        *v += a * delta;
                    }
                    if part.coupling != 0.0 {
                        total += delta;
                    }
                    largest = largest.max(delta.abs() * part.k);
                    last_changed = Some(i);
                    changed = true;
                }
                most[i] = most[i].max(new);
            }
            if iteration == 0 {
                first = largest;
            }
            if last_changed <= first_row {
                converged = true;
                break;
            }
            if largest <= tolerance {
                break;
            }
        }
        for ((c, &impulse), &most) in group.iter_mut().zip(&impulse).zip(&most) {
            c.normal_impulse = impulse;
            c.max_normal_impulse = most;
        }
        (converged, first, changed)
    }

    /// Applies each row's whole change of impulse to the bodies.
    pub(super) fn apply(
        &self,
        bodies: &mut [SolverBody],
        group: &[ContactConstraint],
        response: &Response,
    ) {
        let Some(c0) = group.first() else {
            return;
        };
        let mut v = PairVelocities::load(bodies, c0.body_a, c0.body_b);
        for (c, &delta) in group.iter().zip(&self.applied) {
            if delta != 0.0 {
                apply_response(c, &mut v, delta, response);
            }
        }
        v.store(bodies, c0.body_a, c0.body_b);
    }
}

/// Projects the biases of a block's penetrating rows (`parts` with a soft bias
/// `max(bias_rate s, -max_push_out)` of `s <= 0`, short of that cap) onto the normal velocity
/// fields that a rigid motion of the two bodies can give over their points: the functions
/// affine in the points' coordinates across the normal (each row's normal velocity is
/// `n . (v_B - v_A) + w_B . (r_B x n) - w_A . (r_A x n)`, affine in the point's position),
/// least squares. With fewer than four such rows nothing changes: three points (not in a
/// line) take any biases. The other rows keep theirs: a point apart (`s > 0`, bias `s/h`) or
/// pushed out at the cap is not on the same line of `s` as the rest, and spreading its bias
/// over the others would push them for it.
///
/// Why: a face manifold has four points and its rigid tilt three degrees of freedom, so its
/// equations `v_i + b_i + c sum(lambda) = 0` have a solution only where the biases `b_i` are
/// such a field. The biases come from the points' separations, which are one plane's up to
/// the rounding of the positions (about 1e-7 m for bodies metres from the origin, 5e-7 m/s of
/// bias): five times the 1e-7 m/s to which these blocks are solved. Unprojected, 1 % of the
/// block solves of a settled pile of 1,000 cubes found no solution and ran to the bound of 64
/// passes, moving load around the manifold's twist (two diagonal corners taking it from the
/// other two) at each pass; projected, none did, and the passes fell from 4.2 to 3.7 a solve
/// on average. Of 42 columns of 18-30 cubes with friction at 30 and 60 Hz, one (30 cubes,
/// friction 0.7, 30 Hz) drifted 45 mm in 20 s; projected, all stand within 0.01 mm. A real
/// tilt of the face (its corners at different depths) is such a field and is pushed out as
/// before.
fn project_biases(group: &[ContactConstraint], parts: &mut [Part], max_push_out: f32) {
    let mut rows = [0usize; DELASSUS_ROWS];
    let mut n = 0;
    for (j, p) in parts.iter().enumerate() {
        if p.coupling != 0.0 && p.bias <= 0.0 && p.bias > -max_push_out {
            rows[n] = j;
            n += 1;
        }
    }
    if n < 4 {
        return;
    }
    let rows = &rows[..n];
    let point = |j: usize| group[parts[j].row].point;
    let m = n as f32;
    let centroid = rows.iter().map(|&j| point(j)).sum::<Vec3>() / m;
    // An orthonormal basis (over the rows) of the affine fields: the constant, then each
    // tangent coordinate less its part along the ones before; a coordinate that is nearly all
    // such a part (the points in a line) adds nothing.
    let mut basis = [[0.0f32; DELASSUS_ROWS]; 3];
    basis[0][..n].fill(1.0 / m.sqrt());
    let mut size = 1;
    for t in group[parts[rows[0]].row].tangents {
        let mut e = [0.0f32; DELASSUS_ROWS];
        for (x, &j) in e.iter_mut().zip(rows) {
            *x = (point(j) - centroid).dot(t);
        }
        let raw = e.iter().map(|x| x * x).sum::<f32>().sqrt();
        for b in &basis[..size] {
            let d: f32 = e.iter().zip(b).map(|(x, y)| x * y).sum();
            for (x, y) in e.iter_mut().zip(b) {
                *x -= d * y;
            }
        }
        let norm = e.iter().map(|x| x * x).sum::<f32>().sqrt();
        if norm > 1e-3 * raw && norm > 0.0 {
            for x in &mut e {
                *x /= norm;
            }
            basis[size] = e;
            size += 1;
        }
    }
    let mut bias = [0.0f32; DELASSUS_ROWS];
    for (b, &j) in bias.iter_mut().zip(rows) {
        *b = parts[j].bias;
    }
    let mut fitted = [0.0f32; DELASSUS_ROWS];
    for b in &basis[..size] {
        let d: f32 = bias.iter().zip(b).map(|(x, y)| x * y).sum();
        for (f, y) in fitted.iter_mut().zip(b) {
            *f += d * y;
        }
    }
    for (&j, f) in rows.iter().zip(fitted) {
        parts[j].bias = f;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::solver::contact::prepare_contacts;

    /// Four soft rows at the corners of a 1 m face (in order round the square), their biases.
    fn face(biases: [f32; 4]) -> (Vec<ContactConstraint>, Vec<Part>) {
        let bodies = [
            SolverBody::new(Motion::Static, Vec3::ZERO, Quat::IDENTITY),
            SolverBody::new(Motion::Dynamic, Vec3::Y, Quat::IDENTITY),
        ];
        let corners = [(0.5, 0.5), (0.5, -0.5), (-0.5, -0.5), (-0.5, 0.5)];
        let mut group: Vec<_> = corners
            .iter()
            .map(|&(x, z)| {
                ContactConstraint::new(0, 1, Vec3::new(x, 0.5, z), Vec3::Y, 0.0, 0.0, 0.5)
            })
            .collect();
        prepare_contacts(&bodies, &mut group);
        let parts = biases
            .iter()
            .enumerate()
            .map(|(row, &bias)| Part {
                row,
                bias,
                coupling: 1.0,
                k: 1.0,
                inverse: 0.5,
            })
            .collect();
        (group, parts)
    }

    fn projected(biases: [f32; 4]) -> [f32; 4] {
        let (group, mut parts) = face(biases);
        project_biases(&group, &mut parts, 3.0);
        [0, 1, 2, 3].map(|j| parts[j].bias)
    }

    /// The projection is least squares onto the affine fields over the four corners of a
    /// square, whose one other mode is the twist `(+1, -1, +1, -1)`: an affine field (a tilt
    /// of the face, the corners at -1, -2, -3, -2 mm/s) is kept as it is, and a twist added to
    /// it is taken out whole, to f32 rounding (1e-9 m/s on biases of 1e-3).
    #[test]
    fn biases_lose_the_twist_and_keep_the_tilt() {
        let tilt = [-1e-3, -2e-3, -3e-3, -2e-3];
        for (a, b) in projected(tilt).iter().zip(tilt) {
            assert!((a - b).abs() <= 1e-9, "{a} vs {b}");
        }
        let twist = 5e-7;
        let twisted = [0, 1, 2, 3].map(|j| tilt[j] + if j % 2 == 0 { twist } else { -twist });
        for (a, b) in projected(twisted).iter().zip(tilt) {
            assert!((a - b).abs() <= 1e-9, "{a} vs {b}");
        }
    }

    /// Rows that are not on the penetrating branch keep their biases, and so do the others
    /// then: a corner apart (`s/h` = 0.24 m/s for 1 mm at 240 Hz) or one pushed out at the
    /// 3 m/s cap leaves three rows, which take any biases.
    #[test]
    fn a_corner_apart_or_at_the_cap_is_left_alone() {
        for odd in [0.24, -3.0] {
            let biases = [-1e-3, -1e-3, -1e-3, odd];
            assert_eq!(projected(biases), biases);
        }
    }
}
