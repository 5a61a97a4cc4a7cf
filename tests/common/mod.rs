//! Shared helpers for the whole-app tests: app builders and fixtures, component getters and a
//! per-thread log capture.
#![allow(dead_code)]

use std::cell::RefCell;

use bevy::app::Plugins;
use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, Pour, PourBodies};

/// A headless app at 60 Hz (see [`scenes::headless_app`]) with the ground ([`scenes::ground`])
/// and then `bundle` spawned: the app and the entity of `bundle`.
pub fn on_ground(bundle: impl Bundle) -> (App, Entity) {
    let mut app = scenes::headless_app(60.0);
    scenes::ground(app.world_mut());
    let entity = app.world_mut().spawn(bundle).id();
    (app, entity)
}

/// Spawns a static body with `collider` at `transform`.
pub fn spawn_static(world: &mut World, collider: Collider, transform: Transform) -> Entity {
    world.spawn((RigidBody::Static, collider, transform)).id()
}

/// A triangle mesh of one quadrilateral: the triangles `[0, 2, 1]` and `[0, 3, 2]` of `corners`
/// (with corners at (-x, -z), (+x, -z), (+x, +z), (-x, +z), it faces up).
pub fn quad(corners: [Vec3; 4]) -> Collider {
    Collider::trimesh(corners.to_vec(), vec![[0, 2, 1], [0, 3, 2]])
}

/// A headless app at 60 Hz built from `plugins` (see [`scenes::headless_app_with`]), sleeping
/// off, with 300 mixed bodies (spheres, boxes, capsules, hulls) poured into a walled box with
/// friction 0.5 (`Pour::walled_box`): many contact pairs a step. The app and the bodies, in
/// spawn order.
pub fn mixed_pour<M>(plugins: impl Plugins<M>) -> (App, Vec<Entity>) {
    let mut app = scenes::headless_app_with(60.0, plugins);
    app.insert_resource(SleepConfig {
        enabled: false,
        ..default()
    });
    let spawned = scenes::pour_into(
        app.world_mut(),
        &Pour::walled_box(300, PourBodies::Mixed, 1.0, 0.5),
    );
    (app, spawned.bodies)
}

/// Translation of `entity`.
pub fn position(app: &App, entity: Entity) -> Vec3 {
    app.world().get::<Transform>(entity).unwrap().translation
}

/// Rotation of `entity`.
pub fn rotation(app: &App, entity: Entity) -> Quat {
    app.world().get::<Transform>(entity).unwrap().rotation
}

/// Linear velocity of `entity`.
pub fn velocity(app: &App, entity: Entity) -> Vec3 {
    app.world().get::<LinearVelocity>(entity).unwrap().0
}

/// Angular velocity of `entity`.
pub fn spin(app: &App, entity: Entity) -> Vec3 {
    app.world().get::<AngularVelocity>(entity).unwrap().0
}

/// Mass of a dynamic `entity`, kg.
pub fn mass(app: &App, entity: Entity) -> f32 {
    1.0 / app
        .world()
        .get::<ComputedMass>(entity)
        .unwrap()
        .inverse_mass
}

/// World inertia tensor of a dynamic `entity`, kg m^2.
pub fn world_inertia(app: &App, entity: Entity) -> Mat3 {
    let computed = app.world().get::<ComputedMass>(entity).unwrap();
    let r = Mat3::from_quat(rotation(app, entity));
    r * computed.local_inverse_inertia.inverse() * r.transpose()
}

/// Total linear momentum, angular momentum about the origin, and kinetic energy of `bodies`.
pub fn totals(app: &App, bodies: &[Entity]) -> (Vec3, Vec3, f32) {
    let (mut p, mut l, mut ke) = (Vec3::ZERO, Vec3::ZERO, 0.0);
    for &e in bodies {
        let (m, x, v, w) = (
            mass(app, e),
            position(app, e),
            velocity(app, e),
            spin(app, e),
        );
        let inertia = world_inertia(app, e);
        p += m * v;
        l += x.cross(m * v) + inertia * w;
        ke += 0.5 * m * v.length_squared() + 0.5 * w.dot(inertia * w);
    }
    (p, l, ke)
}

/// Drains the messages of type `M` written since the last call (the app's reader cursor is
/// kept in a local `MessageCursor`).
pub fn drain<M: Message + Clone>(
    app: &mut App,
    cursor: &mut bevy::ecs::message::MessageCursor<M>,
) -> Vec<M> {
    let messages = app.world().resource::<Messages<M>>();
    cursor.read(messages).cloned().collect()
}

thread_local! {
    static LOGS: RefCell<Vec<(log::Level, String)>> = const { RefCell::new(Vec::new()) };
}

struct Capture;

impl log::Log for Capture {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }
    fn log(&self, record: &log::Record) {
        LOGS.with(|logs| {
            logs.borrow_mut()
                .push((record.level(), record.args().to_string()))
        });
    }
    fn flush(&self) {}
}

static CAPTURE: Capture = Capture;

/// Captures `log` records on the calling thread (the app runs its schedules on the test's own
/// thread, so each test sees only its own records).
pub fn capture_logs() {
    let _ = log::set_logger(&CAPTURE);
    log::set_max_level(log::LevelFilter::Info);
    LOGS.with(|logs| logs.borrow_mut().clear());
}

/// The records captured on this thread so far, drained.
pub fn take_logs() -> Vec<(log::Level, String)> {
    LOGS.with(|logs| std::mem::take(&mut *logs.borrow_mut()))
}

/// Mechanical state of a dynamic body, read from its components in f64.
#[derive(Clone, Copy, Debug)]
pub struct BodyState {
    /// kg.
    pub mass: f64,
    /// Centre of mass, world frame, m: `translation + rotation * local_center_of_mass`.
    pub center: bevy::math::DVec3,
    /// m/s.
    pub velocity: bevy::math::DVec3,
    /// Linear kinetic energy plus rotational kinetic energy `w.I_world w / 2`, J.
    pub kinetic: f64,
    /// `|I_world w|`, kg m^2/s.
    pub spin_momentum: f64,
}

/// The mechanical state of dynamic `entity` from `ComputedMass`, `Transform` and velocities.
/// The rotational energy is evaluated in the body frame, `w_b.I_b w_b / 2` with
/// `w_b = R^T w`, in f64, so that the reading itself adds only the f32 rounding of the stored
/// state.
pub fn body_state(app: &App, entity: Entity) -> BodyState {
    let world = app.world();
    let computed = world.get::<ComputedMass>(entity).unwrap();
    let transform = world.get::<Transform>(entity).unwrap();
    let (v, w) = (
        world.get::<LinearVelocity>(entity).unwrap().0,
        world.get::<AngularVelocity>(entity).unwrap().0,
    );
    state_of(computed, transform.translation, transform.rotation, v, w)
}

/// [`body_state`] from explicit values (for a body whose `ComputedMass` is not yet derived).
pub fn state_of(
    computed: &ComputedMass,
    translation: Vec3,
    rotation: Quat,
    v: Vec3,
    w: Vec3,
) -> BodyState {
    let q = rotation.as_dquat().normalize();
    let mass = 1.0 / computed.inverse_mass as f64;
    let inertia = computed.local_inverse_inertia.as_dmat3().inverse();
    let local_w = q.inverse() * w.as_dvec3();
    let velocity = v.as_dvec3();
    BodyState {
        mass,
        center: translation.as_dvec3() + q * computed.local_center_of_mass.as_dvec3(),
        velocity,
        kinetic: 0.5 * mass * velocity.length_squared() + 0.5 * local_w.dot(inertia * local_w),
        spin_momentum: (inertia * local_w).length(),
    }
}

/// Pose and velocities of `bodies` (translation, rotation, linear and angular velocity), as
/// raw bits, for bit-identical comparisons.
pub fn snapshot(app: &App, bodies: &[Entity]) -> Vec<[u32; 13]> {
    bodies
        .iter()
        .map(|&e| {
            let t = app.world().get::<Transform>(e).unwrap();
            let mut out = [0u32; 13];
            let values = t
                .translation
                .to_array()
                .into_iter()
                .chain(t.rotation.to_array())
                .chain(velocity(app, e).to_array())
                .chain(spin(app, e).to_array());
            for (o, x) in out.iter_mut().zip(values) {
                *o = x.to_bits();
            }
            out
        })
        .collect()
}
