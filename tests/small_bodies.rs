//! Small bodies: margins, slops and speed thresholds are lengths, scaled by the world's
//! `PhysicsLengthUnit`, so millimetre dice rest.

mod common;

use bevy::prelude::*;
use common::*;
use impact3d::dynamics::validation::PhysicsLengthUnit;
use impact3d::prelude::*;
use impact3d::scenes::{self, headless_app};

/// Half extent of a 1 mm die, m.
const H: f32 = 0.0005;

/// A headless app at 60 Hz, sleeping off, with `method`, the length unit `unit` (the default
/// without), the ground, and dice of half extent `half` (density 1 g/cm^3) and friction
/// `friction` at `spots`.
fn dice_app(
    method: SolverMethod,
    unit: Option<f32>,
    half: f32,
    spots: &[Vec3],
    friction: f32,
) -> (App, Vec<Entity>) {
    let mut app = headless_app(60.0);
    app.insert_resource(SolverConfig::for_method(method));
    app.insert_resource(SleepConfig {
        enabled: false,
        ..default()
    });
    if let Some(unit) = unit {
        app.insert_resource(PhysicsLengthUnit(unit));
    }
    scenes::ground(app.world_mut());
    let dice = spots
        .iter()
        .map(|&p| {
            app.world_mut()
                .spawn((
                    RigidBody::Dynamic,
                    Collider::cuboid(half, half, half),
                    Friction(friction),
                    Transform::from_translation(p),
                ))
                .id()
        })
        .collect();
    (app, dice)
}

/// Largest displacement over 5 s of frictionless 1 mm dice (1 g/cm^3: 1e-6 kg each) resting
/// on the ground at `spots`, sleeping off, with the given length unit.
fn dice_drift(method: SolverMethod, unit: Option<f32>, spots: &[Vec3]) -> f32 {
    let (mut app, dice) = dice_app(method, unit, H, spots, 0.0);
    let mut drift = 0.0f32;
    for _ in 0..300 {
        app.update();
        for (&d, &p) in dice.iter().zip(spots) {
            drift = drift.max(position(&app, d).distance(p));
        }
    }
    drift
}

/// The soft sink of one supporting contact of the default method, `g / (2 pi f)^2` with
/// `f` = 30 Hz: 0.276 mm. A frequency, not a length, so the length unit does not scale it: at
/// 1 mm it is 28% of a die.
fn soft_sink() -> f32 {
    9.81 / (2.0 * std::f32::consts::PI * 30.0).powi(2)
}

/// What a run of stacked dice did.
struct Run {
    /// Final centre of each die, bottom first.
    end: Vec<Vec3>,
    /// Largest sideways (xz) distance of any die from its spawn point over the run.
    sideways: f32,
    /// Smallest height of the top die's centre over the die below it, over the run.
    top_gap: f32,
}

/// Dice of half extent `half` (density 1 g/cm^3) at `spots`, bottom first, on the ground,
/// sleeping off, 60 Hz, 5 s.
fn run_dice(method: SolverMethod, unit: f32, half: f32, spots: &[Vec3], friction: f32) -> Run {
    let (mut app, dice) = dice_app(method, Some(unit), half, spots, friction);
    let (mut sideways, mut top_gap) = (0.0f32, f32::INFINITY);
    let n = dice.len();
    for _ in 0..300 {
        app.update();
        for (&d, &p) in dice.iter().zip(spots) {
            let q = position(&app, d);
            sideways = sideways.max(Vec2::new(q.x - p.x, q.z - p.z).length());
        }
        if n >= 2 {
            top_gap = top_gap.min(position(&app, dice[n - 1]).y - position(&app, dice[n - 2]).y);
        }
    }
    Run {
        end: dice.iter().map(|&d| position(&app, d)).collect(),
        sideways,
        top_gap,
    }
}

/// `n` dice of half extent `half` stacked face to face on the ground.
fn column(n: usize, half: f32) -> Vec<Vec3> {
    (0..n)
        .map(|k| Vec3::new(0.0, (2 * k + 1) as f32 * half, 0.0))
        .collect()
}

/// Where each die of a resting column ends, bottom first: every contact below die `k` sinks by
/// `sink`, so die `k` ends `(k + 1) sink` below its spawn height `(2k + 1) half`.
fn settled(n: usize, half: f32, sink: f32) -> Vec<f32> {
    (0..n)
        .map(|k| (2 * k + 1) as f32 * half - (k + 1) as f32 * sink)
        .collect()
}

/// Checks a run against the settled heights (within `tolerance`, m) and the sideways bound (m).
fn check(run: &Run, expected: &[f32], tolerance: f32, sideways: f32, what: &str) {
    for (k, (p, &y)) in run.end.iter().zip(expected).enumerate() {
        assert!(
            (p.y - y).abs() <= tolerance,
            "{what}: die {k} ends at {} m, expected {y} m",
            p.y
        );
    }
    assert!(
        run.sideways <= sideways,
        "{what}: dice moved {} m sideways",
        run.sideways
    );
}

/// Issue 9: two 1 mm dice (1e-6 kg each), one on the other, rest with `PhysicsLengthUnit(1e-3)`,
/// frictionless and with friction 0.5, under the default method and Jacobi.
///
/// The answers: the default's contacts are soft and load-scaled, so each sinks by
/// [`soft_sink`] (0.276 mm) whatever it carries: the lower die ends at `H - s`, the upper one at
/// `3H - 2s` = 0.948 mm, 0.55 mm below `3H`. That sink is a frequency's (30 Hz), not a length,
/// so it is not scaled with the unit, and the upper die cannot end within 0.1 mm of `3H` under
/// the default. Jacobi's Baumgarte leaves each contact at the linear slop (5 um at this
/// unit), so its upper die ends at `3H - 2 slop` = 1.490 mm. Measured (2026-12-01): the
/// default's heights match to 5e-10 m, Jacobi's to 3e-8 m; sideways 6.1 um for the default
/// frictionless (f32 rounding: it drifts at about 1.2 um/s), 0.3 nm with friction, 0 for
/// Jacobi.
/// Tolerances: 10 um (1% of a die) on heights for rounding and what settling remains at 5 s,
/// 2 um for Jacobi, whose rest is exact to its slop; 20 um sideways (2% of a die), three
/// times the drift measured.
///
/// Before (measured, same scene): the default's upper die ended 1.22 mm lower, inside the lower
/// die, and slid apart. Two causes, both fixed: its speculative contact with the ground through
/// the lower die (the step's fall `g dt^2` = 2.7 mm reaches the ground) was resolved by the
/// impact phase at its free-fall time of impact, before the lower die's contact stopped them
/// (it was placed 1 mm down), and the resting phase took that speculative manifold as a
/// support (a 5 mm, unscaled, touching distance), giving the upper die the lower one's level,
/// so the pair was solved without shock propagation or the load it carries. The other methods
/// are pinned in `millimetre_stacks_other_methods`.
#[test]
fn millimetre_dice_rest_with_length_unit() {
    let (unit, slop) = (1e-3, 0.005 * 1e-3);
    let stacked = column(2, H);
    for friction in [0.0, 0.5] {
        let run = run_dice(SolverMethod::Hybrid, unit, H, &stacked, friction);
        let what = format!("Hybrid, friction {friction}");
        check(&run, &settled(2, H, soft_sink()), 1e-5, 2e-5, &what);
        let run = run_dice(SolverMethod::Jacobi, unit, H, &stacked, friction);
        let what = format!("Jacobi, friction {friction}");
        check(&run, &settled(2, H, slop), 2e-6, 2e-5, &what);
    }
    let without = dice_drift(SolverMethod::Hybrid, None, &stacked);
    assert!(
        without > 0.05,
        "the unit is what holds them: without it {without} m"
    );
}

/// Dice side by side (0.01 mm apart) and alone stay within 0.3 mm with the unit set (the soft
/// methods sink 0.28 mm, `g / (2 pi 30 Hz)^2`; sequential impulses 1e-8 m), Jacobi within 1 mm
/// (5.7e-4 m side by side; 3.3e-3 without the unit), under every method but propagation, which
/// has no position correction (it is pinned at its own scale in `methods_resting.rs`).
#[test]
fn millimetre_dice_side_by_side_and_alone() {
    let side = [Vec3::new(0.0, H, 0.0), Vec3::new(2.0 * H + 1e-5, H, 0.0)];
    let lone = [Vec3::new(0.0, H, 0.0), Vec3::new(0.003, H, 0.0)];
    for method in SolverMethod::ALL {
        if method == SolverMethod::Propagation {
            continue;
        }
        for (name, spots) in [("side by side", &side[..]), ("alone", &lone[..])] {
            let drift = dice_drift(method, Some(1e-3), spots);
            let bound = if method == SolverMethod::Jacobi {
                1e-3
            } else {
                3e-4
            };
            assert!(drift < bound, "{method:?}: dice {name} moved {drift} m");
        }
    }
}

/// A column of three 1 mm dice under the default method, frictionless and with friction 0.5:
/// die `k` ends `(k + 1) s` below its spawn height, `s` the soft sink (the top one at
/// `5H - 3s` = 1.672 mm). Measured: heights within 1e-9 m, 2.8 um sideways frictionless.
/// Tolerances as for the pair (10 um on heights, 20 um sideways).
#[test]
fn three_millimetre_dice_stand() {
    for friction in [0.0, 0.5] {
        let run = run_dice(SolverMethod::Hybrid, 1e-3, H, &column(3, H), friction);
        let what = format!("Hybrid, friction {friction}");
        check(&run, &settled(3, H, soft_sink()), 1e-5, 2e-5, &what);
    }
}

/// The pair at 1 cm (half extent 5 mm, 1e-3 kg each) with `PhysicsLengthUnit(1e-2)`: the
/// default's upper die ends at `3H - 2s` = 14.45 mm (the sink is the same 0.276 mm), Jacobi's
/// at `3H - 2 slop` = 14.90 mm (slop 0.05 mm at this unit). Measured: within 1.2e-8 m
/// (default) and 3e-8 m (Jacobi); sideways 4.9 um frictionless under the default. Tolerances: 10 um on
/// heights, 5 um for Jacobi; 0.2 mm sideways (2% of a die, as at 1 mm).
#[test]
fn centimetre_dice_rest_with_length_unit() {
    let half = 0.005;
    for friction in [0.0, 0.5] {
        let run = run_dice(SolverMethod::Hybrid, 1e-2, half, &column(2, half), friction);
        let what = format!("Hybrid, friction {friction}");
        check(&run, &settled(2, half, soft_sink()), 1e-5, 2e-4, &what);
        let run = run_dice(SolverMethod::Jacobi, 1e-2, half, &column(2, half), friction);
        let what = format!("Jacobi, friction {friction}");
        check(&run, &settled(2, half, 0.005 * 1e-2), 5e-6, 2e-4, &what);
    }
}

/// A 1 mm die dropped from 5 mm (its lowest face 5 mm above the other's top; it lands at
/// `sqrt(2 g 5 mm)` = 0.31 m/s, 5 mm per step) onto a resting die, under Jacobi: it never
/// passes into it (its centre stays above the lower die's top face, `H` over the lower
/// centre; measured lowest 0.76 mm: unconverged, Jacobi lets it 0.24 mm in at the landing)
/// and ends resting at `3H - 2 slop` (measured within 0.7 um; tolerance 2 um, as for the
/// pair). The default method: `millimetre_die_dropped_on_another_default`.
#[test]
fn millimetre_die_dropped_on_another() {
    let mut spots = column(2, H);
    spots[1].y += 0.005;
    for friction in [0.0, 0.5] {
        let run = run_dice(SolverMethod::Jacobi, 1e-3, H, &spots, friction);
        let what = format!("Jacobi, friction {friction}");
        assert!(
            run.top_gap > H,
            "{what}: passed into it ({} m)",
            run.top_gap
        );
        check(&run, &settled(2, H, 0.005 * 1e-3), 2e-6, 2e-5, &what);
    }
}

/// The default method's dropped die (as `millimetre_die_dropped_on_another`) lands on the lower
/// die (1.398 mm after the landing step) and stays on it: it never passes into it (its centre
/// stays above the lower die's top face) and both end at the heights of the stacked pair in
/// `millimetre_dice_rest_with_length_unit`, `H - s` and `3H - 2s`. Measured: heights within
/// 2e-9 m, lowest centre gap 0.724 mm (`2H - s`, the rest), 14 um sideways (frictionless,
/// f32 rounding). Tolerances as for the pair: 10 um on heights, 20 um sideways.
///
/// Before (measured): the die tipped off at step 8 through the lower die, and both ended on
/// the ground 11 mm apart. Two causes, both fixed:
/// - The resting phase's block solve held a point a hair apart (1e-10 m, rounding) as a rigid
///   speculative row while the manifold's other points sank at the soft rate: a hinge, and
///   the upper die turned 1.0e-2 rad about it in step 3 (the soft sink, 0.28 mm, is a quarter
///   of the die). Now the speculative points of a manifold that penetrates are points of the
///   same soft plane (`manifold_sweep`): 4e-8 rad at step 3.
/// - parry's face clipping drops every crossing of edges shorter than 1.9 cm (an absolute
///   `f32::EPSILON` on `|d1|^2 |d2|^2 - (d1 . d2)^2`), so the dice's manifold was two points on
///   a diagonal from step 4 (the other two corners are edge crossings when the faces are
///   offset by a hair): a hinge again, the die rocking about it, four- to sixfold per step
///   from step 6. Now contacts are generated with the shapes scaled to the power of two
///   nearest the length unit (`ContactPair::update`): four corners.
///
/// Either alone fails: without the first, the die tilted in step 3 levels on its full manifold,
/// but the manifold's normal, which parry's coherence keeps in the upper die's frame, is left
/// tilted (1.4e-3 rad at step 4) and the frictionless pair slides apart at 0.17 mm/s each;
/// without the second, the die tips off at step 12. The impact phase's resolution of the upper
/// die's speculative contact with the ground (step 8, before) came of the tipping: now no
/// impact is resolved in the whole run.
#[test]
fn millimetre_die_dropped_on_another_default() {
    let mut spots = column(2, H);
    spots[1].y += 0.005;
    let run = run_dice(SolverMethod::Hybrid, 1e-3, H, &spots, 0.0);
    assert!(run.top_gap > H, "passed into it ({} m)", run.top_gap);
    check(&run, &settled(2, H, soft_sink()), 1e-5, 2e-5, "Hybrid");
}

/// Pinned: the stacked 1 mm pair under the other methods, and three dice under Jacobi, as in
/// `millimetre_dice_rest_with_length_unit` (the expected heights: the rigid methods' at the
/// slop, soft step's at its sink). Measured (unit 1e-3, 60 Hz, 5 s), with contacts generated
/// in the length unit (`ContactPair::update`; before, in brackets, where it differed):
///
/// | method | frictionless | friction 0.5 |
/// |---|---|---|
/// | sequential impulses | upper die slides off, 107 mm (80 mm) | slides off, 2.4 mm (1.0 mm) |
/// | soft step | slides off, 0.16 m (0.20 m) | tumbles from the first step (3.4 rad/s); the lower die sinks 0.54 mm at most, Box2D's sink for the pair's load (`soft_contact_holds_its_load_under_the_push_out_cap`), the upper tumbles off, both end side by side at `H - s`, 1.1 mm sideways (before that fix: the lower die sank its height into the ground, the upper on it, 0.33 mm; before contacts in the unit: slides off, 0.84 mm) |
/// | propagation | heights right (within 0.4 um), but the pair rocks, 0.13 mm sideways at most, back on the stack at the end (before `dice_never_end_inside_each_other_propagation`'s fix: the upper die ended inside the lower, both centres at 0.5 mm) | the same (its resting contacts carry no friction, its impacts do: see `EVENT_FRICTION_ROUNDS` in `propagation/event.rs`) |
/// | Jacobi, three dice | sinks 1.2 mm in the first step and bounces, not at rest at 5 s | |
///
/// Not a length left unscaled: a step's fall `g dt^2` is 2.7 mm, 2.7 dice, at 60 Hz, so a
/// 1 mm die is a 1 m die under 1000 g. The 1 m pair with unit 1 and gravity 9810 m/s^2
/// reproduced the 1 mm run's first step exactly (measured before contacts were generated in
/// the unit) (sequential impulses: the upper die's spin
/// 3.48 rad/s from the unconverged 8-point manifold, in both) and fails the same way. And the
/// frictionless 1 m pair at 60 Hz, over the same number of its own time constants `sqrt(L / g)`
/// (158 s), slides off under sequential impulses (65 m; soft step at 30 Hz, 133 m): these methods'
/// frictionless stacks are unstable at every size (`stacks_fall_with_the_other_methods`), and
/// 5 s is 500 time constants of a 1 mm die but 16 of a 1 m one. 50 iterations (converged in the
/// first step) do not help sequential impulses; 960 Hz does not help (0.19 m, 0.14 m).
/// Propagation's rocking grows from f32 rounding of the collapse (spins of 3e-5 rad/s after a
/// step; three dice topple, `millimetre_dice_three_propagation_pinned`). The soft step's
/// tumbling: its single Gauss-Seidel pass leaves the corners' impulses unequal, a velocity
/// error set by the substep's `g h` (0.041 m/s), not by the size: after the first step the
/// dice have moved 1e-5 m sideways at 1 mm, 1 cm and 1 m alike, and the upper one spins at
/// 3.4e-3 rad/s at 1 m (its corners at 1.7 mm/s, 4% of `g h`) and 3.4 rad/s at 1 mm. Jacobi's first step, unconverged, leaves part of
/// `g dt` (0.16 m/s, 160 dice per second) unresolved and its push-out is capped at the scaled
/// 3 mm/s.
#[test]
#[ignore = "fails (issue 9): sequential impulses, soft step and propagation let the 1 mm pair slide apart, Jacobi bounces three dice; see doc"]
fn millimetre_stacks_other_methods() {
    let (unit, slop) = (1e-3, 0.005 * 1e-3);
    for friction in [0.0, 0.5] {
        for (method, sink) in [
            (SolverMethod::SequentialImpulses, slop),
            (SolverMethod::SoftStep, soft_sink()),
            (SolverMethod::Propagation, 0.0),
        ] {
            let run = run_dice(method, unit, H, &column(2, H), friction);
            let what = format!("{method:?}, friction {friction}");
            check(&run, &settled(2, H, sink), 2e-5, 2e-5, &what);
        }
    }
    let run = run_dice(SolverMethod::Jacobi, unit, H, &column(3, H), 0.0);
    check(&run, &settled(3, H, slop), 2e-6, 2e-5, "Jacobi, three dice");
}

/// How close a run of dice came to containment: each die holds a ball of radius `half` (its
/// inscribed sphere), and no point of another die or of the ground may enter that ball unless
/// they overlap. So over the run, the smallest distance, m, from a die's centre to another die
/// (the box, in that die's frame) and the smallest height of a die's centre over the ground:
/// both `half` for dice that never overlap, whatever their pose; less by the depth of any
/// overlap. A die inside another has its centre within `half` of it, or inside it (negative).
fn closest_approach(
    method: SolverMethod,
    unit: f32,
    half: f32,
    spots: &[Vec3],
    friction: f32,
    hz: f64,
) -> (f32, f32) {
    let (mut app, dice) = dice_app(method, Some(unit), half, spots, friction);
    app.insert_resource(Time::<Fixed>::from_hz(hz));
    let (mut to_die, mut to_ground) = (f32::INFINITY, f32::INFINITY);
    for _ in 0..(5.0 * hz) as u32 {
        app.update();
        for &d in &dice {
            let c = position(&app, d);
            to_ground = to_ground.min(c.y);
            for &other in dice.iter().filter(|&&o| o != d) {
                let local = rotation(&app, other).inverse() * (c - position(&app, other));
                let outside = (local.abs() - Vec3::splat(half)).max(Vec3::ZERO);
                let inside = (local.abs() - Vec3::splat(half)).max_element().min(0.0);
                to_die = to_die.min(outside.length() + inside);
            }
        }
    }
    (to_die, to_ground)
}

/// Issue 9, propagation: stacked dice never end inside each other or the ground. The family:
/// 1 mm and 1 cm dice (length units 1e-3 and 1e-2), 30, 60 and 120 Hz, two and three dice,
/// friction 0 and 0.5, 5 s, but for three 1 mm dice (pinned in
/// `millimetre_dice_three_propagation_pinned`). Answer: a die's centre never comes nearer
/// than `H` to another die or the ground (see [`closest_approach`]) less what propagation,
/// which corrects no penetration, lets contacts close: its collapse of an inelastic stack
/// stops once no contact approaches faster than the velocity tolerance (1e-4 m/s times the
/// unit), so a contact may close at up to that speed for the whole run, 5e-4 times the unit
/// in 5 s; twice that allowed (1 um at 1 mm, 10 um at 1 cm, 0.2% of `H`), for the rounding
/// of the collapse's velocities. Measured: nearest 0.9990 H (three 1 cm dice, 60 Hz: 4.9 um
/// closed), 0.9992 H at 1 mm (0.37 um).
///
/// Before, at 1 mm, 30 and 60 Hz: both dice of the pair ended at 0.5 mm after the first
/// step, the upper inside the lower. The pass resolves each contact at most once a sweep: the
/// ground stopped the lower die, the pair's contact left both at half the speed, the lower
/// die's ground contact approached again and waited for the next sweep, and the upper die's
/// speculative contact with the ground through the lower die (a 1 mm gap, which the step's
/// fall `g dt^2`, 2.7 mm at 60 Hz, reaches) was resolved in the same sweep at its time of
/// impact, 12 ms, as if the lower die were gone: the upper die was placed on the ground. Now
/// an impact later than one that waits in its cluster of touching bodies waits too.
#[test]
fn dice_never_end_inside_each_other_propagation() {
    for (half, unit) in [(H, 1e-3), (0.005, 1e-2)] {
        for n in [2, 3] {
            if n == 3 && half == H {
                continue;
            }
            let allowed = 2.0 * 1e-4 * unit * 5.0;
            for hz in [30.0, 60.0, 120.0] {
                for friction in [0.0, 0.5] {
                    let spots = column(n, half);
                    let (to_die, to_ground) = closest_approach(
                        SolverMethod::Propagation,
                        unit,
                        half,
                        &spots,
                        friction,
                        hz,
                    );
                    let what = format!("{n} dice of {half} m, {hz} Hz, friction {friction}");
                    assert!(to_die >= half - allowed, "{what}: {to_die} m from a die");
                    assert!(to_ground >= half - allowed, "{what}: {to_ground} m high");
                }
            }
        }
    }
}

/// Pinned: three 1 mm dice stacked under propagation topple and end inside each other and the
/// ground (as the frictionless column of ten in `methods_resting.rs` topples, propagation's
/// impacts carry no friction). Measured (closest approach of a centre, as in
/// `dice_never_end_inside_each_other_propagation`, in `H`): 30 Hz -0.28 to a die, -16.6 to
/// the ground; 60 Hz -0.52, -0.20; 120 Hz 0.72, 0.9992. The stack stands for a while (the
/// collapse leaves it at rest each step to the velocity tolerance), but a tilt grows
/// (1.3-fold a step at 30 Hz from 1e-5 rad/s at 3 s, the lowest die sliding out), and the
/// toppling dice spin up to 300 rad/s and pass into the ground. At 120 Hz, where no contact
/// through a die is in the step's reach (`g dt^2` = 0.68 mm), it failed the same way before
/// the fix of `dice_never_end_inside_each_other_propagation` (0.37 H and 0.52 H deep, by
/// parry's contact query): not that cause.
#[test]
#[ignore = "fails (issue 9): three 1 mm dice under propagation topple and pass into each other; see doc"]
fn millimetre_dice_three_propagation_pinned() {
    let mut results = Vec::new();
    for hz in [30.0, 60.0, 120.0] {
        let (to_die, to_ground) =
            closest_approach(SolverMethod::Propagation, 1e-3, H, &column(3, H), 0.0, hz);
        results.push((hz, to_die, to_ground));
    }
    for (hz, to_die, to_ground) in results {
        assert!(
            to_die >= H - 1e-6 && to_ground >= H - 1e-6,
            "{hz} Hz: {to_die} {to_ground}"
        );
    }
}

/// Issue 9, soft step: a soft contact holds its load whatever the push-out cap. A 1 m cube
/// (1 kg) rests on the ground under the soft step, 60 Hz, 4 substeps, with
/// `max_push_out_speed` 1 mm/s, below the 2.5 mm/s bias each corner's spring needs to carry
/// its quarter of the weight (`g / (omega a1)`, `a1 = 2 zeta + h omega`, 30 Hz): it ends
/// at the soft sink `g / (2 pi 30 Hz)^2` = 0.276 mm below its spawn height, as with the
/// default cap (`resting_box_iterative_methods_hold_still`); 3% allowed, as there (the
/// spring settles asymptotically). Measured: 0.2757 mm.
///
/// And the 1 mm pair (friction 0.5, unit 1e-3, 60 Hz, 5 s), whose lower die's corners each
/// carry twice their effective mass's weight (5 mm/s against a cap scaled to 3 mm/s): its
/// centre never sinks more than Box2D's sink for that load, `2 g / (2 pi 30 Hz)^2` =
/// 0.552 mm, plus 5% (the dice tumble, pinned in `millimetre_stacks_other_methods`, and a
/// corner's share of the load varies); measured 0.538 mm. That is more than the die's half
/// height: under the soft step (Box2D's stiffness, set by each contact's own effective mass,
/// a contact carrying `k` weights sinks `k` soft sinks) a 1 mm die under another rests with
/// its centre at the ground's level; the default scales the stiffness with the load.
///
/// Before: the soft row capped its bias, `bias_rate s`, at the push-out speed, so a row
/// whose load asks for more could not hold it at any depth: the cube sank 6.9 mm in 5 s
/// (about 1.4 mm/s, and kept sinking), and the lower die of the pair 1.04 mm, its whole
/// height and more. Now the cap bounds the speed the spring drives, which is zero at rest
/// (`Softness::row_impulse`).
#[test]
fn soft_contact_holds_its_load_under_the_push_out_cap() {
    let mut app = headless_app(60.0);
    app.insert_resource(SolverConfig {
        max_push_out_speed: 1e-3,
        ..SolverConfig::for_method(SolverMethod::SoftStep)
    });
    app.insert_resource(SleepConfig {
        enabled: false,
        ..default()
    });
    let (_, cube) = scenes::resting_box(app.world_mut(), 0.0);
    let start = position(&app, cube).y;
    for _ in 0..300 {
        app.update();
    }
    let sink = start - position(&app, cube).y;
    assert!(
        (sink - soft_sink()).abs() <= 0.03 * soft_sink(),
        "sank {sink} m, expected {}",
        soft_sink()
    );
    let (mut app, dice) = dice_app(SolverMethod::SoftStep, Some(1e-3), H, &column(2, H), 0.5);
    let mut lowest = f32::INFINITY;
    for _ in 0..300 {
        app.update();
        lowest = lowest.min(position(&app, dice[0]).y);
    }
    assert!(
        H - lowest <= 1.05 * 2.0 * soft_sink(),
        "the lower die sank {} m",
        H - lowest
    );
}

/// An invalid length unit is logged once and the last good one (here the default, 1) is used:
/// the run is the same as with the default.
#[test]
fn invalid_length_unit_falls_back() {
    for bad in [0.0, -1.0, f32::NAN, f32::INFINITY, 1e30] {
        capture_logs();
        let a = dice_drift(SolverMethod::Hybrid, Some(bad), &[Vec3::new(0.0, H, 0.0)]);
        let errors: Vec<_> = take_logs()
            .into_iter()
            .filter(|(l, _)| *l == log::Level::Error)
            .collect();
        assert_eq!(errors.len(), 1, "{bad}: {errors:?}");
        assert!(errors[0].1.contains("PhysicsLengthUnit"));
        let b = dice_drift(SolverMethod::Hybrid, None, &[Vec3::new(0.0, H, 0.0)]);
        assert_eq!(a, b, "{bad}");
    }
}
