//! Unit tests of the input bounds and the settings validation.

use super::*;

const BAD: [f32; 5] = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1.0, 1e30];

/// A named float field of a config and how to set it.
type Field<C> = (&'static str, fn(&mut C, f32));

/// Sets each of `fields` of `last` to each bad value in turn and checks that `validated`
/// replaces the config by `last` with exactly one message naming `{kind}::{field} = {value}`.
fn each_bad_field_is_replaced<C: Clone + PartialEq + std::fmt::Debug>(
    last: &C,
    kind: &str,
    fields: &[Field<C>],
    validated: impl Fn(&C, &C) -> (C, Vec<String>),
) {
    for &(name, set) in fields {
        for bad in BAD {
            let mut c = last.clone();
            set(&mut c, bad);
            let (valid, errors) = validated(&c, last);
            assert_eq!(&valid, last, "{name} = {bad}");
            assert_eq!(errors.len(), 1, "{name} = {bad}: {errors:?}");
            assert!(
                errors[0].contains(&format!("{kind}::{name} = {bad:?}")),
                "{}",
                errors[0]
            );
        }
    }
}

/// Every float field of `SolverConfig` set to each bad value is replaced by the last good
/// value, with exactly one message naming the field and the value.
#[test]
fn solver_config_replaces_each_bad_float_field() {
    let last = SolverConfig {
        contact_hertz: 25.0,
        ..SolverConfig::default()
    };
    let fields: [Field<SolverConfig>; 7] = [
        ("velocity_tolerance", |c, v| c.velocity_tolerance = v),
        ("restitution_threshold", |c, v| c.restitution_threshold = v),
        ("contact_hertz", |c, v| c.contact_hertz = v),
        ("contact_damping_ratio", |c, v| c.contact_damping_ratio = v),
        ("max_push_out_speed", |c, v| c.max_push_out_speed = v),
        ("baumgarte", |c, v| c.baumgarte = v),
        ("linear_slop", |c, v| c.linear_slop = v),
    ];
    each_bad_field_is_replaced(&last, "SolverConfig", &fields, SolverConfig::validated);
    // Zero is valid for these and invalid for the stiffness.
    let mut c = last.clone();
    c.baumgarte = 0.0;
    assert!(c.validated(&last).1.is_empty());
    c.contact_hertz = 0.0;
    assert_eq!(c.validated(&last).1.len(), 1);
}

/// Every float field of `NarrowPhaseConfig` set to each bad value is replaced by the last good
/// value, with exactly one message naming the field and the value; zero is valid for both.
#[test]
fn narrow_phase_config_replaces_each_bad_float_field() {
    let last = NarrowPhaseConfig {
        contact_margin: 0.03,
        ..NarrowPhaseConfig::default()
    };
    let fields: [Field<NarrowPhaseConfig>; 2] = [
        ("contact_margin", |c, v| c.contact_margin = v),
        ("touch_distance", |c, v| c.touch_distance = v),
    ];
    each_bad_field_is_replaced(
        &last,
        "NarrowPhaseConfig",
        &fields,
        NarrowPhaseConfig::validated,
    );
    let mut c = last.clone();
    c.contact_margin = 0.0;
    c.touch_distance = 0.0;
    c.speculative_contacts = false;
    let (valid, errors) = c.validated(&last);
    assert!(errors.is_empty(), "{errors:?}");
    assert_eq!(valid, c);
}

/// `max_turn_per_substep` must be positive; infinite is valid (never split a step).
#[test]
fn solver_config_turn_per_substep() {
    let last = SolverConfig::default();
    for bad in [f32::NAN, f32::NEG_INFINITY, -1.0, 0.0] {
        let c = SolverConfig {
            max_turn_per_substep: bad,
            ..SolverConfig::default()
        };
        let (valid, errors) = c.validated(&last);
        assert_eq!(valid, last, "{bad}");
        assert_eq!(errors.len(), 1, "{bad}: {errors:?}");
        assert!(errors[0].contains(&format!("SolverConfig::max_turn_per_substep = {bad:?}")));
    }
    for good in [f32::INFINITY, 1e30, 1e-6, 0.25] {
        let c = SolverConfig {
            max_turn_per_substep: good,
            ..SolverConfig::default()
        };
        assert_eq!(c.validated(&last), (c.clone(), Vec::new()), "{good}");
    }
}

#[test]
fn solver_config_replaces_bad_counts() {
    let last = SolverConfig::default();
    let c = SolverConfig {
        substeps: 0,
        iterations: u32::MAX,
        max_propagation_sweeps: 0,
        max_block_iterations: 0,
        relax_iterations: 0,
        max_substeps: 257,
        ..SolverConfig::default()
    };
    let (valid, errors) = c.validated(&last);
    assert_eq!(errors.len(), 5, "{errors:?}");
    assert_eq!(
        valid,
        SolverConfig {
            relax_iterations: 0,
            ..last
        }
    );
    assert!(SolverConfig::default().validated(&last).1.is_empty());
}

#[test]
fn sleep_config_and_gravity_and_dt() {
    let last = SleepConfig {
        linear_threshold: 0.1,
        ..SleepConfig::default()
    };
    for bad in BAD {
        let c = SleepConfig {
            linear_threshold: bad,
            time_to_sleep: bad,
            enabled: false,
        };
        let (valid, errors) = c.validated(&last);
        // -1 and 1e30 for time_to_sleep: 1e30 s is valid (never sleep), -1 is not.
        let expected_time = if bad == 1e30 {
            1e30
        } else {
            last.time_to_sleep
        };
        assert_eq!(valid.linear_threshold, last.linear_threshold, "{bad}");
        assert_eq!(valid.time_to_sleep, expected_time, "{bad}");
        assert!(!valid.enabled);
        assert_eq!(errors.len(), if bad == 1e30 { 1 } else { 2 }, "{errors:?}");
        let g = Gravity(Vec3::new(0.0, bad, 0.0));
        let (valid, errors) = g.validated(Gravity(Vec3::X));
        if bad == -1.0 {
            assert_eq!((valid, errors.len()), (g, 0));
        } else {
            assert_eq!((valid, errors.len()), (Gravity(Vec3::X), 1), "{bad}");
            assert!(errors[0].contains("Gravity"));
        }
        let (dt, error) = validated_dt(bad, 0.01);
        assert_eq!(dt, 0.01);
        assert!(error.unwrap().contains(&format!("dt = {bad}")));
    }
    assert_eq!(validated_dt(0.0, 0.01).0, 0.01);
    assert_eq!(validated_dt(1.0 / 60.0, 0.01), (1.0 / 60.0, None));
}
