//! The load each manifold carries, which sets its stiffness in the resting phase.

use super::*;
use crate::dynamics::solver::refill;

/// Sets each supported block's [`Block::load`]: the mass of its upper body plus everything that
/// presses on that body, shared equally among the body's supports; what a block passes on
/// through its support ([`Block::passes_on`]: the held part of its load, all of it where the
/// support is held wholly) does not press on the support (its warm start leaves it out, see
/// [`held_warm_start`]), so it counts only for the supports' levers. `blocks`
/// must be in `shock_order`'s order (ascending lower level), so that walking it backwards
/// visits every block a body supports before the blocks that support it.
///
/// Why: a soft manifold sinks by `W K / (2 pi f)^2` under a load `W`, `K` being its inverse
/// effective mass in the soft step. With `K` the manifold's own, the weight piles up: a column
/// of `N` cubes sinks by about `g N^2 / (2 pi f)^2` (11 cm for 20 cubes at 30 Hz), and a light
/// box under a 1000 times heavier one by 28 cm, deep enough for the contact normals to turn
/// and squeeze it out. Setting `K = 1 / load` (never softer than the manifold's own `K`) makes
/// every supporting contact sink by the same `g / (2 pi f)^2`, 0.28 mm at 30 Hz, whatever rests
/// on it: 5.5 mm for the 20-cube column, 0.28 mm under the 1000:1 pair. (With the loads passed
/// on, each block of a column with friction bears its upper cube only, and its own impulse is
/// that cube's weight: the same sink.) Only the
/// regularisation changes, and with the support held fixed the stiffer block still converges
/// in one pass: its only free body is the supported one.
pub(super) fn carried_loads(
    bodies: &[SolverBody],
    contacts: &[ContactConstraint],
    blocks: &mut [Block],
    scratch: &mut LoadScratch,
) {
    let LoadScratch {
        load,
        borne,
        moment,
        supports,
    } = scratch;
    let mass = |i: usize| {
        let b = &bodies[i];
        if b.motion == Motion::Dynamic && b.inverse_mass > 0.0 {
            1.0 / b.inverse_mass
        } else {
            0.0
        }
    };
    load.clear();
    load.extend((0..bodies.len()).map(mass));
    borne.clear();
    borne.extend_from_slice(load);
    // The mass-weighted sum of the positions of what each body carries (itself included), for
    // each block's lever.
    moment.clear();
    moment.extend(bodies.iter().enumerate().map(|(i, b)| mass(i) * b.position));
    // Only touching blocks share the load; a speculative one (not touching) is given the whole
    // load of its upper body, as if it were its only support, and passes none on.
    refill(supports, bodies.len(), 0);
    for block in blocks.iter().filter(|b| b.touching) {
        if let Some(upper) = block.upper(contacts) {
            supports[upper] += 1;
        }
    }
    for block in blocks.iter_mut().rev() {
        if let Some((upper, lower)) = block.pair(contacts) {
            if load[upper] > 0.0 {
                let center = moment[upper] / load[upper];
                (block.lever, block.spread) = lever(&contacts[block.range.clone()], upper, center);
            }
            if !block.touching {
                block.load = borne[upper];
                continue;
            }
            let fraction = 1.0 / supports[upper] as f32;
            let share = load[upper] * fraction;
            block.load = borne[upper] * fraction;
            if bodies[lower].motion == Motion::Dynamic {
                // What a block passes on, its support's supports take (all of it where it is
                // held wholly); the support bears the rest.
                borne[lower] += if block.passes_on {
                    (1.0 - block.hold.min(1.0)) * block.load
                } else {
                    block.load
                };
                load[lower] += share;
                let carried = moment[upper] * fraction;
                moment[lower] += carried;
            }
        }
    }
}

/// [`carried_loads`]' buffers, kept between steps (their contents rebuilt at every call).
#[derive(Clone, Debug, Default)]
pub(super) struct LoadScratch {
    /// The mass each body carries, itself included.
    load: Vec<f32>,
    /// The part of it that presses on the body (see [`Block::load`]).
    borne: Vec<f32>,
    /// The mass-weighted sum of the positions of what each body carries.
    moment: Vec<Vec3>,
    /// Each body's touching supports.
    supports: Vec<u32>,
}

/// A manifold's [`Block::lever`] and [`Block::spread`]: how high the centre of mass `center`
/// of what it carries stands above the manifold's centroid, along its normal towards the
/// supported body `upper`, m (0 if below); and the mean square distance of its points from
/// that centroid over two, m^2 (the second moment about one axis of a rectangle's corners).
pub(super) fn lever(rows: &[ContactConstraint], upper: usize, center: Vec3) -> (f32, f32) {
    let c = &rows[0];
    let up = if c.body_b == upper {
        c.normal
    } else {
        -c.normal
    };
    let n = rows.len() as f32;
    let centroid = rows.iter().map(|r| r.point).sum::<Vec3>() / n;
    let spread = rows
        .iter()
        .map(|r| (r.point - centroid).length_squared())
        .sum::<f32>()
        / (2.0 * n);
    ((center - centroid).dot(up).max(0.0), spread)
}
