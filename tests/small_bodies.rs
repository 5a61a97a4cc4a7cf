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

/// Largest displacement over 5 s of frictionless 1 mm dice (1 g/cm^3: 1e-6 kg each) resting
/// on the ground at `spots`, sleeping off, with the given length unit.
fn dice_drift(method: SolverMethod, unit: Option<f32>, spots: &[Vec3]) -> f32 {
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
    let dice: Vec<Entity> = spots
        .iter()
        .map(|&p| {
            app.world_mut()
                .spawn((
                    RigidBody::Dynamic,
                    Collider::cuboid(H, H, H),
                    Transform::from_translation(p),
                ))
                .id()
        })
        .collect();
    let mut drift = 0.0f32;
    for _ in 0..300 {
        app.update();
        for (&d, &p) in dice.iter().zip(spots) {
            drift = drift.max(position(&app, d).distance(p));
        }
    }
    drift
}

/// Regression (issue 9): two 1 mm dice, one on the other, slid 0.18 m apart in 5 s under the
/// default method, every margin and threshold being metres (a 2 cm contact margin is 20 dice).
/// With `PhysicsLengthUnit(1e-3)` the stacked pair's largest displacement stays under 2 mm
/// under Hybrid and Jacobi. Dice side by side (0.01 mm apart) and alone stay within 0.3 mm
/// (the soft methods sink 0.28 mm, `g / (2 pi 30 Hz)^2`; sequential impulses 1e-8 m), Jacobi
/// within 1 mm (5.7e-4 m side by side; 3.3e-3 without the unit), under every method but
/// propagation, which has no position correction (it is pinned at its own scale in
/// `methods_resting.rs`).
///
/// What the 2 mm bound does not say (measured at 60 Hz, unit set, frictionless, 2026-12-01): only
/// Jacobi's stack rests. Its lower die sinks 1 mm into the ground in the first step (unconverged,
/// it leaves part of `g dt` of approach, and the push-out is capped at the scaled 3 mm/s) and both
/// are back within 1e-5 m of their start by the end. Under the other methods the upper die ends
/// inside the lower one: Hybrid 1.22 mm lower (and the lower die 1.11 mm lower, through the
/// ground), Propagation and sequential impulses 1.0 mm, soft step 1.28 mm. Frictionless, the pair
/// then also slides apart: sequential impulses 8.0 cm, soft step 20.5 cm in 5 s (with
/// `Friction(0.5)`: 1.4 mm and 1.5 mm, still one inside the other); propagation stays at 1.0 mm.
/// Not a length left in metres: the same pair at 1 m with the unit at 1 moves 1e-6 of its size, and
/// raising the rate to 960 Hz does not help propagation, sequential impulses or soft step
/// (0.10-0.19 m). Likely causes, from the first steps' contacts (not yet confirmed by a fix): a
/// step's gravity reach `g dt^2` (2.7 mm at 60 Hz) is longer than a die, so the upper die gets a
/// speculative contact with the ground through the lower one (0.8 mm away after the first step),
/// which Hybrid's propagation pass takes as approaching (1.8 mm/s against the scaled 0.5 mm/s
/// threshold) and resolves at its free-fall time of impact (the support that would stop it is a
/// resting contact, which that pass does not see); and the frictionless tilt-and-slide of a stacked
/// pair grows at a rate set by `sqrt(g / L)` (500 of a 1 mm die's time constants in 5 s, 16 of a 1
/// m cube's). Not fixed; see the report of issue 9.
#[test]
fn millimetre_dice_rest_with_length_unit() {
    let stacked = [Vec3::new(0.0, H, 0.0), Vec3::new(0.0, 3.0 * H, 0.0)];
    let side = [Vec3::new(0.0, H, 0.0), Vec3::new(2.0 * H + 1e-5, H, 0.0)];
    let lone = [Vec3::new(0.0, H, 0.0), Vec3::new(0.003, H, 0.0)];
    let unit = Some(1e-3);
    for method in [SolverMethod::Hybrid, SolverMethod::Jacobi] {
        let drift = dice_drift(method, unit, &stacked);
        assert!(drift < 0.002, "{method:?}: stacked dice moved {drift} m");
    }
    let without = dice_drift(SolverMethod::Hybrid, None, &stacked);
    assert!(
        without > 0.05,
        "the unit is what holds them: without it {without} m"
    );
    for method in SolverMethod::ALL {
        if method == SolverMethod::Propagation {
            continue;
        }
        for (name, spots) in [("side by side", &side[..]), ("alone", &lone[..])] {
            let drift = dice_drift(method, unit, spots);
            let bound = if method == SolverMethod::Jacobi {
                1e-3
            } else {
                3e-4
            };
            assert!(drift < bound, "{method:?}: dice {name} moved {drift} m");
        }
    }
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
