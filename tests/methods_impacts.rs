//! Impact scenes (cases 8 to 10 of `SCENES.md`) under every solver method: what each method
//! gets right, and, with numbers, how it fails.
//!
//! Exact answers come from the event-by-event analysis of `SCENES.md`, from the LCP that every
//! simultaneous method converges to, and from conservation laws. A method's failure is pinned
//! to the value it gives today, with a band wide enough for harmless changes (rounding, the
//! order contacts are listed in) but narrow enough that a different failure mode shows.
//! All scenes run at 60 Hz with sleeping off; velocities are read after the step that holds
//! the impact (the first step) or once all contacts have separated.

mod methods_common;

use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes;
use methods_common::*;

/// Case 8 with `n` balls and `config`: (velocities after the first step, after 30 more steps).
fn cradle(n: usize, config: SolverConfig) -> (Vec<f32>, Vec<f32>, App, Vec<Entity>) {
    let mut app = app_with(60.0, config);
    let balls = scenes::cradle(app.world_mut(), n, 1.0, 1.0);
    app.update();
    let first = vx(&app, &balls);
    scenes::run_steps(&mut app, 30);
    let last = vx(&app, &balls);
    (first, last, app, balls)
}

/// The LCP answer of an `n`-ball cradle struck at 1 m/s with restitution only on the struck
/// contact (the others do not approach before the solve, so their target is zero): all
/// contacts active gives `v_0 = (2 - n) / n` and `v_i = 2 / n` for the rest, with impulses
/// `2 (n - i) / n >= 0`. Its energy is exactly 1/2: `((n-2)^2 + 4 (n-1)) / (2 n^2) = 1/2`.
fn cradle_lcp(n: usize) -> Vec<f32> {
    (0..n)
        .map(|i| {
            if i == 0 {
                (2.0 - n as f32) / n as f32
            } else {
                2.0 / n as f32
            }
        })
        .collect()
}

/// Case 8: propagation and the default send only the last ball, at 1 m/s, for 3 and 5 balls.
/// Tolerance 1e-5: each two-body impact is the closed form, so only f32 rounding remains.
/// Energy (1/2 J) and momentum (1 kg m/s) are conserved to the same tolerance. Propagation
/// needs at most `n - 1` sweeps whatever the contact order (one per ball the momentum has to
/// cross, plus the final check, which the first sweep shares when the order is favourable).
#[test]
fn cradle_propagation_and_default_send_only_the_last_ball() {
    for method in [SolverMethod::Hybrid, SolverMethod::Propagation] {
        for n in [3, 5] {
            let mut app = app(60.0, method);
            let balls = scenes::cradle(app.world_mut(), n, 1.0, 1.0);
            app.update();
            let s = stats(&app);
            let mut expected = vec![0.0; n];
            expected[n - 1] = 1.0;
            assert_close(
                &format!("{method:?} {n} balls"),
                &vx(&app, &balls),
                &expected,
                1e-5,
            );
            assert!((kinetic_energy(&app, &balls) - 0.5).abs() <= 1e-5);
            assert!((momentum(&app, &balls) - Vec3::X).length() <= 1e-5);
            assert!((s.propagation_sweeps as usize) < n, "{method:?} {n}: {s:?}");
            assert!(!s.propagation_bound_hit);
            scenes::run_steps(&mut app, 30);
            assert_close(
                &format!("{method:?} {n} later"),
                &vx(&app, &balls),
                &expected,
                1e-5,
            );
        }
    }
}

/// Case 8: sequential impulses converge to the LCP answer, (-1/3, 2/3, 2/3) for 3 balls,
/// within 1e-3 with the usual 10 iterations (the tolerance; measured error 7e-6).
/// Momentum and energy are conserved (within 1e-5 and 1e-4): conservation cannot tell this
/// wrong answer from the right one. With 5 balls 10 iterations are not enough: the struck ball
/// leaves at -0.588 instead of -0.6 (pinned within 0.005), and 200 iterations reach the LCP
/// answer (-0.6, 0.4, 0.4, 0.4, 0.4) within 1e-3.
#[test]
fn cradle_sequential_impulses_converge_to_the_lcp_answer() {
    let si = SolverMethod::SequentialImpulses;
    let (first, last, app, balls) = cradle(3, SolverConfig::for_method(si));
    assert_close("SI 3 balls", &first, &cradle_lcp(3), 1e-3);
    assert_close("SI 3 balls later", &last, &cradle_lcp(3), 1e-3);
    assert!((momentum(&app, &balls) - Vec3::X).length() <= 1e-5);
    assert!((kinetic_energy(&app, &balls) - 0.5).abs() <= 1e-4);

    let (first, _, _, _) = cradle(5, SolverConfig::for_method(si));
    assert_in(
        "SI 5 balls, 10 iterations, ball 0",
        first[0],
        -0.593,
        -0.583,
    );
    assert!(
        (first[0] - -0.6).abs() > 5e-3,
        "10 iterations are not converged: {first:?}"
    );

    let (first, _, app, balls) = cradle(5, with_iterations(si, 200));
    assert_close("SI 5 balls, 200 iterations", &first, &cradle_lcp(5), 1e-3);
    assert!((kinetic_energy(&app, &balls) - 0.5).abs() <= 1e-3);
}

/// Case 8: one sequential-impulse iteration depends on the order of the rows. Solving the
/// struck contact first gives `SCENES.md`'s (0, 0.5, 0.5) and loses half the energy (0.25 J of
/// 0.5): ball 0 rebounds elastically onto ball 1, whose row with ball 2 has no restitution
/// target (it did not approach before the solve) and shares the momentum inelastically.
/// Solving it last (the order the broad phase gives the builder's scene) gives (0, 1, 0): the
/// row between balls 1 and 2 finds nothing approaching, and the struck row then passes all the
/// momentum to ball 1, which is left overlapping ball 2 for the next step. Spawning the balls
/// in reverse order swaps the row order.
/// Tolerance 1e-5: two exact row solves.
#[test]
fn cradle_one_sequential_iteration_depends_on_row_order() {
    let config = with_iterations(SolverMethod::SequentialImpulses, 1);
    let (first, last, app, balls) = cradle(3, config.clone());
    assert_close(
        "SI 1 iteration, builder order",
        &first,
        &[0.0, 1.0, 0.0],
        1e-5,
    );
    // An impact's impulse is not warm-started into the next step (it does not recur), so the
    // next step's single iteration passes ball 1's momentum on to ball 2: the balls end at
    // (0, 0, 1) with 0.5 J, the exact cradle. (Warm-starting the struck row's 1 N s on top of
    // the new state, which one iteration could not take back, ended at (-0.25, -0.25, 1.5),
    // 1.1875 J from 0.5 J: 138% energy added.)
    assert_close(
        "SI 1 iteration, builder order, later",
        &last,
        &[0.0, 0.0, 1.0],
        1e-4,
    );
    assert!((kinetic_energy(&app, &balls) - 0.5).abs() <= 1e-4);
    assert!((momentum(&app, &balls) - Vec3::X).length() <= 1e-5);

    let mut app = app_with(60.0, config);
    app.world_mut().insert_resource(Gravity(Vec3::ZERO));
    let mut balls: Vec<Entity> = (0..3)
        .rev()
        .map(|i| {
            let v = if i == 0 { Vec3::X } else { Vec3::ZERO };
            let ball = scenes::ball(0.5, 1.0, Vec3::new(i as f32, 0.0, 0.0), v);
            app.world_mut().spawn((ball, Restitution(1.0))).id()
        })
        .collect();
    balls.reverse();
    app.update();
    assert_close(
        "SI 1 iteration, reversed",
        &vx(&app, &balls),
        &[0.0, 0.5, 0.5],
        1e-5,
    );
    assert!((kinetic_energy(&app, &balls) - 0.25).abs() <= 1e-5);
    assert!((momentum(&app, &balls) - Vec3::X).length() <= 1e-5);
}

/// Case 8: Jacobi with mass splitting (20 iterations) also converges to the LCP answer for 3
/// balls within 1e-3 (measured error 3e-4), conserving momentum within 1e-5. With 5 balls it
/// is far from converged after 20 iterations: the balls leave at (-0.52, 0.45, 0.40, 0.35,
/// 0.32) (each pinned within 0.01), and once the last contacts have separated 15% of the
/// energy is gone (0.426 J left, pinned within 0.01).
#[test]
fn cradle_jacobi_converges_slowly_to_the_lcp_answer() {
    let (first, _, app, balls) = cradle(3, SolverConfig::for_method(SolverMethod::Jacobi));
    assert_close("Jacobi 3 balls", &first, &cradle_lcp(3), 1e-3);
    assert!((momentum(&app, &balls) - Vec3::X).length() <= 1e-5);

    let (first, _, app, balls) = cradle(5, SolverConfig::for_method(SolverMethod::Jacobi));
    assert_close(
        "Jacobi 5 balls",
        &first,
        &[-0.522, 0.454, 0.400, 0.346, 0.322],
        0.01,
    );
    assert!((momentum(&app, &balls) - Vec3::X).length() <= 1e-5);
    assert_in(
        "Jacobi 5 balls energy",
        kinetic_energy(&app, &balls),
        0.416,
        0.436,
    );
}

/// Case 8: the soft step gives neither the physical nor the LCP answer. Its restitution pass
/// acts only on contacts that approached faster than the threshold when the step was prepared
/// (the struck one), so the rest of the row is inelastic: with 3 balls the first leaves at
/// -0.198 and the others end together at 0.599 after a second step's contact, 24% of the
/// energy lost (0.378 J left); with 5 balls the first leaves at -0.377 and 0.312 J is left.
/// Pinned within 0.005 (velocities) and 0.005 J; momentum is conserved within 1e-5.
#[test]
fn cradle_soft_step_is_inelastic_past_the_struck_ball() {
    let soft = SolverMethod::SoftStep;
    let (first, last, app, balls) = cradle(3, SolverConfig::for_method(soft));
    assert_in("soft 3 balls, ball 0", first[0], -0.203, -0.193);
    assert_close("soft 3 balls later", &last, &[-0.198, 0.599, 0.599], 0.005);
    assert_in(
        "soft 3 balls energy",
        kinetic_energy(&app, &balls),
        0.373,
        0.383,
    );
    assert!((momentum(&app, &balls) - Vec3::X).length() <= 1e-5);

    let (first, _, app, balls) = cradle(5, SolverConfig::for_method(soft));
    assert_in("soft 5 balls, ball 0", first[0], -0.382, -0.372);
    assert_in(
        "soft 5 balls energy",
        kinetic_energy(&app, &balls),
        0.307,
        0.317,
    );
    assert!((momentum(&app, &balls) - Vec3::X).length() <= 1e-5);
}

/// Case 9 with restitution `e` and `config`: (linear velocity, angular velocity, energy) after
/// the first step, and the stats of that step.
fn flat_box(e: f32, config: SolverConfig) -> (Vec3, Vec3, f32, SolverStats) {
    let mut app = app_with(60.0, config);
    let (_, b) = scenes::box_landing_flat(app.world_mut(), e);
    app.update();
    (
        velocity(&app, b),
        spin(&app, b),
        kinetic_energy(&app, &[b]),
        stats(&app),
    )
}

/// Case 9: the default rebounds at `e` m/s with no spin, for e in {0, 0.5, 1}. Tolerances:
/// velocity within 1e-4 m/s and spin below 1e-4 rad/s, the block solve's velocity tolerance
/// (1e-4 m/s at the corners, about 1 m from the centre); energy `e^2 / 2` within 1e-4 J. The
/// impact costs one propagation sweep: the manifold is one block, and nothing else moved.
#[test]
fn box_flat_default_rebounds_without_spin() {
    for e in [0.0, 0.5, 1.0] {
        let (v, w, ke, s) = flat_box(e, SolverConfig::default());
        assert!(
            (v - Vec3::new(0.0, e, 0.0)).length() <= 1e-4,
            "e={e}: v {v}"
        );
        assert!(w.length() <= 1e-4, "e={e}: spin {w}");
        assert!((ke - 0.5 * e * e).abs() <= 1e-4, "e={e}: energy {ke}");
        assert_eq!(s.propagation_sweeps, 1, "e={e}: {s:?}");
        assert_eq!(s.impacts, 4, "all four corners take part");
    }
}

/// Case 9 under propagation: the four corners reach the ground at the same time of impact, so
/// they are one impact event, solved together (see `resolve_event` in the solver's
/// propagation module), and the box rebounds at `e` x 1 m/s with no spin, as under the default,
/// whatever the order of the corners. Before simultaneous impacts were grouped, one corner was
/// resolved at a time: 0.86 rad/s of spin and a rebound of 0.94 m/s for e = 1. Tolerances as
/// for the default above.
#[test]
fn box_flat_propagation_resolves_corners_together() {
    for e in [0.5, 1.0] {
        let config = SolverConfig::for_method(SolverMethod::Propagation);
        let (v, w, ke, _) = flat_box(e, config);
        assert!(
            (v - Vec3::new(0.0, e, 0.0)).length() <= 1e-4,
            "e={e}: v {v}"
        );
        assert!(w.length() <= 1e-4, "e={e}: spin {w}");
        assert!((ke - 0.5 * e * e).abs() <= 1e-4, "e={e}: energy {ke}");
    }
}

/// Case 9: one sequential-impulse iteration (1 substep) spins the box at 1.34 rad/s for e = 1
/// (pinned within 0.05), and it rises at only 0.44 m/s; `SCENES.md`'s "about 1 rad/s". (1.26
/// and 0.49 before restitution kept its energy ledger: the corners solved after the first now
/// bounce only with what the box's landing gave the island's account, see
/// `RestitutionLedger`.) The spin
/// falls with every iteration and first drops below 1e-3 rad/s at 5 iterations (SCENES.md:
/// "about 8"); converged, the rebound is 1 m/s within 1e-4. With e = 0.5 one iteration gives
/// 0.97 rad/s (0.95 before; pinned within 0.90-1.00).
#[test]
fn box_flat_sequential_impulses_spin_until_converged() {
    let si = SolverMethod::SequentialImpulses;
    let spins: Vec<f32> = (1..=8)
        .map(|it| {
            flat_box(
                1.0,
                SolverConfig {
                    substeps: 1,
                    ..with_iterations(si, it)
                },
            )
            .1
            .length()
        })
        .collect();
    assert_in("SI 1 iteration spin", spins[0], 1.29, 1.39);
    let (v, _, _, _) = flat_box(
        1.0,
        SolverConfig {
            substeps: 1,
            ..with_iterations(si, 1)
        },
    );
    assert_in("SI 1 iteration rebound", v.y, 0.39, 0.49);
    for pair in spins.windows(2) {
        assert!(
            pair[1] < pair[0] || pair[1] < 1e-5,
            "spin falls with iterations: {spins:?}"
        );
    }
    let below = spins.iter().position(|&w| w < 1e-3).map(|i| i + 1);
    assert_eq!(below, Some(5), "iterations to spin < 1e-3: {spins:?}");
    let (v, w, ke, _) = flat_box(1.0, SolverConfig::for_method(si));
    assert!(
        (v.y - 1.0).abs() <= 1e-4 && w.length() <= 1e-4,
        "converged: {v} {w}"
    );
    assert!((ke - 0.5).abs() <= 1e-4);
    let (_, w, _, _) = flat_box(
        0.5,
        SolverConfig {
            substeps: 1,
            ..with_iterations(si, 1)
        },
    );
    assert_in("SI 1 iteration e=0.5 spin", w.length(), 0.90, 1.00);
}

/// Case 9: the soft step's restitution pass is repeated until the corners agree (Box2D v3
/// makes a single Gauss-Seidel pass, which left the box rising at 0.74 m/s for e = 1 and
/// spinning at 0.63 rad/s, 26% of the energy lost), so for e = 1 the box rises at 1 m/s with
/// no spin (within 1e-4, as the default); for e = 0 it comes to rest (|v| below 1e-3 m/s
/// after 10 steps).
#[test]
fn box_flat_soft_step_restitution_pass_converges() {
    let config = SolverConfig::for_method(SolverMethod::SoftStep);
    let (v, w, _, _) = flat_box(1.0, config.clone());
    assert!((v - Vec3::Y).length() <= 1e-4, "soft e=1 rebound {v}");
    assert!(w.length() <= 1e-4, "soft e=1 spin {w}");
    let mut app = app_with(60.0, config);
    let (_, b) = scenes::box_landing_flat(app.world_mut(), 0.0);
    scenes::run_steps(&mut app, 10);
    assert!(velocity(&app, b).length() < 1e-3 && spin(&app, b).length() < 1e-3);
}

/// Case 9: Jacobi solves the four corners from the same velocities, so the symmetric scene
/// stays symmetric (spin below 1e-5 rad/s for every e: only rounding), but with mass splitting
/// 20 iterations are not converged: for e = 1 the box rises at 0.94 m/s (pinned within 0.02)
/// instead of 1.
#[test]
fn box_flat_jacobi_is_symmetric_but_unconverged() {
    for e in [0.0, 0.5, 1.0] {
        let (_, w, _, _) = flat_box(e, SolverConfig::for_method(SolverMethod::Jacobi));
        assert!(w.length() <= 1e-5, "e={e}: spin {w}");
    }
    let (v, _, _, _) = flat_box(1.0, SolverConfig::for_method(SolverMethod::Jacobi));
    assert_in("Jacobi e=1 rebound", v.y, 0.92, 0.96);
}

/// Case 10, m1 = 3 m2, v0 = 1 m/s: (ball 1, ball 2) vertical velocities after the first step
/// and after 30 more, and the final energy.
fn cannon(config: SolverConfig) -> ([f32; 2], [f32; 2], f32) {
    let mut app = app_with(60.0, config);
    let (_, b1, b2) = scenes::galilean_cannon(app.world_mut(), 3.0, 1.0, 1.0);
    app.update();
    let first = [velocity(&app, b1).y, velocity(&app, b2).y];
    scenes::run_steps(&mut app, 30);
    let last = [velocity(&app, b1).y, velocity(&app, b2).y];
    (first, last, kinetic_energy(&app, &[b1, b2]))
}

/// Case 10: event by event, ball 1 (3 kg) stops dead and ball 2 (1 kg) leaves at
/// `(3 m1 - m2) v0 / (m1 + m2)` = 2 m/s, taking all 2 J of energy (it rises to 4 times the drop
/// height). Propagation and the default get it within 1e-5 (closed-form impacts), energy within
/// 1e-4 J.
#[test]
fn cannon_propagation_and_default_fire_the_top_ball() {
    for method in [SolverMethod::Hybrid, SolverMethod::Propagation] {
        let (first, last, ke) = cannon(SolverConfig::for_method(method));
        assert_close(&format!("{method:?}"), &first, &[0.0, 2.0], 1e-5);
        assert_close(&format!("{method:?} later"), &last, &[0.0, 2.0], 1e-5);
        assert!((ke - 2.0).abs() <= 1e-4, "{method:?}: energy {ke}");
    }
}

/// Case 10: a simultaneous solve treats the pair as one block and both balls rebound at
/// `e v0` = 1 m/s, conserving the 2 J of energy (so, again, conservation does not catch it).
/// Sequential impulses: within 1e-3 after the first step (measured 8e-6); Jacobi: within 3e-3
/// (20 iterations, measured 2.3e-3).
#[test]
fn cannon_simultaneous_methods_rebound_as_one_block() {
    let (first, last, ke) = cannon(SolverConfig::for_method(SolverMethod::SequentialImpulses));
    assert_close("SI", &first, &[1.0, 1.0], 1e-3);
    assert_close("SI later", &last, &[1.0, 1.0], 1e-3);
    assert!((ke - 2.0).abs() <= 2e-3, "SI energy {ke}");
    let (first, _, ke) = cannon(SolverConfig::for_method(SolverMethod::Jacobi));
    assert_close("Jacobi", &first, &[1.0, 1.0], 3e-3);
    assert!((ke - 2.0).abs() <= 1e-2, "Jacobi energy {ke}");
}

/// Case 10: the soft step gets neither answer. After the first step ball 2 still falls at
/// 0.108 m/s (its contact with ball 1 did not approach at preparation, so no restitution);
/// the balls end at (0.446, 1.554) m/s with 1.51 J of the 2 J left. Pinned within 0.01 m/s and
/// 0.01 J.
#[test]
fn cannon_soft_step_loses_a_quarter_of_the_energy() {
    let (first, last, ke) = cannon(SolverConfig::for_method(SolverMethod::SoftStep));
    assert_close("soft", &first, &[1.0, -0.108], 0.01);
    assert_close("soft later", &last, &[0.446, 1.554], 0.01);
    assert_in("soft energy", ke, 1.496, 1.516);
}

/// "An island of one impact and no resting contact costs one pass": a ball flying at 5 m/s
/// into a static wall (no gravity, e = 1) and two balls meeting head-on at 5 m/s each.
/// Propagation and the default use one sweep, and the default's resting phase none at all
/// (nothing can push after the impact); sequential impulses and Jacobi one iteration (a single
/// row is solved exactly in one pass, which the early-out detects). Each also gets the exact
/// answer: the ball returns at 5 m/s, the pair swaps velocities (within 1e-4). The soft step is
/// left out: it always runs its substeps' solve and relax passes (one each, 8 in all, see
/// `iterative_methods_stop_early_at_rest`), and meets the wall with its soft rows.
#[test]
fn one_impact_costs_one_pass() {
    for method in SolverMethod::ALL
        .into_iter()
        .filter(|&m| m != SolverMethod::SoftStep)
    {
        // Ball and wall.
        let mut app = methods_common::app(60.0, method);
        app.world_mut().insert_resource(Gravity(Vec3::ZERO));
        app.world_mut().spawn((
            RigidBody::Static,
            Collider::cuboid(0.5, 2.0, 2.0),
            Transform::from_xyz(0.5, 0.0, 0.0),
        ));
        let ball = app
            .world_mut()
            .spawn((
                scenes::ball(
                    0.1,
                    1.0,
                    Vec3::new(-0.15, 0.0, 0.0),
                    Vec3::new(5.0, 0.0, 0.0),
                ),
                Restitution(1.0),
            ))
            .id();
        let s = step_to_first_impact(&mut app);
        assert!(
            (velocity(&app, ball) - Vec3::new(-5.0, 0.0, 0.0)).length() <= 1e-4,
            "{method:?}: {}",
            velocity(&app, ball)
        );
        check_one_pass(method, s, "ball and wall");

        // Two balls.
        let mut app = methods_common::app(60.0, method);
        app.world_mut().insert_resource(Gravity(Vec3::ZERO));
        let a = app
            .world_mut()
            .spawn((
                scenes::ball(
                    0.5,
                    1.0,
                    Vec3::new(-0.55, 0.0, 0.0),
                    Vec3::new(5.0, 0.0, 0.0),
                ),
                Restitution(1.0),
            ))
            .id();
        let b = app
            .world_mut()
            .spawn((
                scenes::ball(
                    0.5,
                    1.0,
                    Vec3::new(0.55, 0.0, 0.0),
                    Vec3::new(-5.0, 0.0, 0.0),
                ),
                Restitution(1.0),
            ))
            .id();
        let s = step_to_first_impact(&mut app);
        assert_close(
            &format!("{method:?} pair"),
            &vx(&app, &[a, b]),
            &[-5.0, 5.0],
            1e-4,
        );
        check_one_pass(method, s, "two balls");
    }
}

/// Steps `app` until a step resolves an impact, at most 3 steps, and returns that step's
/// statistics (or the last step's, if none did).
fn step_to_first_impact(app: &mut App) -> SolverStats {
    for _ in 0..3 {
        app.update();
        if stats(app).impacts > 0 {
            break;
        }
    }
    stats(app)
}

#[track_caller]
fn check_one_pass(method: SolverMethod, s: SolverStats, scene: &str) {
    assert!(
        s.impacts > 0,
        "{method:?} {scene}: the impact happened: {s:?}"
    );
    match method {
        SolverMethod::Hybrid => {
            assert_eq!(
                (s.propagation_sweeps, s.iterations),
                (1, 0),
                "{scene}: {s:?}"
            )
        }
        SolverMethod::Propagation => assert_eq!(s.propagation_sweeps, 1, "{scene}: {s:?}"),
        _ => assert_eq!(s.iterations, 1, "{method:?} {scene}: {s:?}"),
    }
}

/// Within a sweep the propagation pass resolves impacts in time order, each group at most
/// once: a 5-ball cradle whose contacts the broad phase lists from the far end completes in one
/// sweep (the momentum crosses every ball), exact.
#[test]
fn cradle_completes_in_one_sweep() {
    let mut app = app_with(60.0, SolverConfig::for_method(SolverMethod::Propagation));
    let balls = scenes::cradle(app.world_mut(), 5, 1.0, 1.0);
    app.update();
    assert_close(
        "cradle",
        &vx(&app, &balls),
        &[0.0, 0.0, 0.0, 0.0, 1.0],
        1e-5,
    );
    assert_eq!(stats(&app).propagation_sweeps, 1, "{:?}", stats(&app));
}

/// The propagation sweep bound: a 100 kg ball at 1 m/s strikes a 1 kg ball resting against a
/// static wall, all touching, e = 1, no gravity. The light ball rattles between the heavy one
/// and the wall (Galilei's billiards: about `pi sqrt(M / m)` = 31 impacts), and each sweep
/// resolves each pair at most once, so it takes many sweeps. Bounded at k sweeps below that,
/// the step reports the bound hit (the pipeline logs a warning from it) after exactly k, and
/// energy is still conserved within 1e-5 relative (each resolution is a complete elastic
/// impact). With the default bound it completes: the heavy ball leaves the wall no slower than
/// the light one (no impact left to come), with all the energy.
#[test]
fn propagation_sweep_bound_is_reported() {
    let run = |bound: u32| {
        let config = SolverConfig {
            max_propagation_sweeps: bound,
            ..SolverConfig::for_method(SolverMethod::Propagation)
        };
        let mut app = app_with(60.0, config);
        app.insert_resource(Gravity(Vec3::ZERO));
        app.world_mut().spawn((
            RigidBody::Static,
            Collider::cuboid(0.5, 2.0, 2.0),
            Transform::from_xyz(1.0, 0.0, 0.0),
            Restitution(1.0),
        ));
        let balls = [
            app.world_mut()
                .spawn((
                    scenes::ball(0.5, 100.0, Vec3::new(-1.0, 0.0, 0.0), Vec3::X),
                    Restitution(1.0),
                ))
                .id(),
            app.world_mut()
                .spawn((
                    scenes::ball(0.5, 1.0, Vec3::ZERO, Vec3::ZERO),
                    Restitution(1.0),
                ))
                .id(),
        ];
        app.update();
        let energy = kinetic_energy(&app, &balls);
        (stats(&app), vx(&app, &balls), energy)
    };
    let (full, v, energy) = run(64);
    assert!(!full.propagation_bound_hit, "{full:?}");
    assert!(full.propagation_sweeps > 3, "{full:?}");
    assert!((energy - 50.0).abs() <= 50.0 * 1e-5, "energy {energy}");
    assert!(v[0] <= v[1] + 1e-5 && v[1] <= 1e-5, "{v:?}");
    for bound in [1u32, 2, 3] {
        let (s, _, energy) = run(bound);
        assert_eq!(
            (s.propagation_sweeps, s.propagation_bound_hit),
            (bound, true)
        );
        assert!(
            (energy - 50.0).abs() <= 50.0 * 1e-5,
            "bound {bound}: energy {energy}"
        );
    }
}

/// Iterative methods stop early and report it: on a box resting on the ground (after 2 s),
/// sequential impulses (10 iterations allowed) and Jacobi (20) use 1, since warm starting
/// leaves nothing to change; the default and the soft step use one solve and one relax pass
/// per substep, 8 in all.
#[test]
fn iterative_methods_stop_early_at_rest() {
    for (method, used) in [
        (SolverMethod::SequentialImpulses, 1),
        (SolverMethod::Jacobi, 1),
        (SolverMethod::Hybrid, 8),
        (SolverMethod::SoftStep, 8),
    ] {
        let mut app = methods_common::app(60.0, method);
        scenes::resting_box(app.world_mut(), 0.5);
        scenes::run_steps(&mut app, 120);
        assert_eq!(
            stats(&app).iterations,
            used,
            "{method:?}: {:?}",
            stats(&app)
        );
    }
}

/// Jacobi without mass splitting: on these small scenes (at most four rows per body) plain
/// Jacobi converges faster than with splitting, to the LCP answer for the 3-ball cradle within
/// 1e-4 and to the exact 1 m/s rebound of the flat box within 1e-4, still without spin (below
/// 1e-5 rad/s); mass splitting trades that speed for convergence on crowded bodies.
#[test]
fn jacobi_without_mass_splitting() {
    let config = SolverConfig {
        mass_splitting: false,
        ..SolverConfig::for_method(SolverMethod::Jacobi)
    };
    let (first, _, _, _) = cradle(3, config.clone());
    assert_close("Jacobi unsplit", &first, &cradle_lcp(3), 1e-4);
    let (v, w, _, _) = flat_box(1.0, config);
    assert!((v.y - 1.0).abs() <= 1e-4 && w.length() <= 1e-5, "{v} {w}");
}
