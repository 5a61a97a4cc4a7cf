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
/// With `PhysicsLengthUnit(1e-3)` the pair stays within 2 mm (measured 1.25 mm: mostly the
/// soft contact's sink, which is set by the 30 Hz stiffness, not by a length, and a slow
/// frictionless slip), and Jacobi's within 2 mm too (1.3 mm). Dice side by side (0.01 mm
/// apart) and alone stay within 0.3 mm (the soft methods sink 0.28 mm, `g / (2 pi 30 Hz)^2`;
/// sequential impulses 1e-8 m), Jacobi within 1 mm (5.7e-4 m side by side; 3.3e-3 without
/// the unit), under every method but propagation, which has no position correction (it is pinned at its own scale in
/// `methods_resting.rs`).
///
/// Not fixed (measured with the unit set, stacked pair): sequential impulses 2.6 cm, soft step
/// 0.2 m, propagation 5 cm. Their resting contact holds a 1 mm stack no better at 60 Hz; see
/// the report of issue 9.
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
