//! The impact3d viewer: every scene of `impact3d::scenes` in a window, with debug drawing.
//!
//! ```sh
//! cargo run --release --example viewer --features viewer
//! cargo run --release --example viewer --features viewer -- --scene 11 --seconds 1 --screenshot shot.png
//! ```
//!
//! Keys: 1-9, 0 choose scenes 1-10, Shift + 1-5 scenes 11-15; Space pause, N one step, R reset;
//! M next solver method, - / = substeps; T interpolation on/off; C colliders, B bounding boxes,
//! K contacts, I impacts, V velocities, L islands, G all debug drawing; H the text overlay;
//! mouse drag or arrow keys orbit, scroll or W / S zoom; Esc quits.
//!
//! Flags: `--scene N` (1-based, as in the list), `--seconds S` (run S s of simulated time, then
//! exit; with `--screenshot PATH`, save a screenshot of the window to PATH first), `--pause`.
//! At exit with `--seconds`, frame and physics step times are printed.

use std::path::PathBuf;
use std::time::Instant;

use bevy::image::{ImageAddressMode, ImageLoaderSettings, ImageSampler, ImageSamplerDescriptor};
use bevy::input::mouse::{AccumulatedMouseMotion, AccumulatedMouseScroll};
use bevy::math::Affine2;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured, save_to_disk};
use bevy::window::WindowResolution;
use impact3d::debug::PhysicsGizmoGroup;
use impact3d::prelude::*;
use impact3d::scenes;

/// One selectable scene: its name, its builder, and where the camera looks from.
struct SceneEntry {
    name: &'static str,
    build: fn(&mut World),
    view: OrbitCamera,
}

const fn view(focus: Vec3, yaw: f32, pitch: f32, distance: f32) -> OrbitCamera {
    OrbitCamera {
        focus,
        yaw,
        pitch,
        distance,
    }
}

/// Every scene builder of `impact3d::scenes`, one line each; the list order is the key order.
const SCENES: &[SceneEntry] = &[
    SceneEntry {
        name: "box drop",
        build: |w| {
            scenes::box_drop(w);
        },
        view: view(Vec3::new(0.0, 1.0, 0.0), 0.5, 0.3, 8.0),
    },
    SceneEntry {
        name: "bouncing ball e=0.8",
        build: |w| {
            scenes::bouncing_ball(w, 1.0, 0.8);
        },
        view: view(Vec3::new(0.0, 0.5, 0.0), 0.5, 0.2, 4.0),
    },
    SceneEntry {
        name: "head-on 1:3 e=1",
        build: |w| {
            scenes::head_on(w, 1.0);
        },
        view: view(Vec3::new(0.5, 0.0, 0.0), 0.0, 0.3, 8.0),
    },
    SceneEntry {
        name: "oblique spinning e=0.8",
        build: |w| {
            scenes::oblique(w, 0.8);
        },
        view: view(Vec3::new(0.5, 0.3, 0.0), 0.0, 0.3, 8.0),
    },
    SceneEntry {
        name: "Newton's cradle x5",
        build: |w| {
            scenes::cradle(w, 5, 2.0, 1.0);
        },
        view: view(Vec3::new(2.0, 0.0, 0.0), 0.0, 0.3, 10.0),
    },
    SceneEntry {
        name: "box landing flat e=0.5",
        build: |w| {
            scenes::box_landing_flat(w, 0.5);
        },
        view: view(Vec3::new(0.0, 0.5, 0.0), 0.5, 0.3, 6.0),
    },
    SceneEntry {
        name: "Galilean cannon 3:1",
        build: |w| {
            scenes::galilean_cannon(w, 3.0, 1.0, 2.0);
        },
        view: view(Vec3::new(0.0, 1.5, 0.0), 0.5, 0.2, 8.0),
    },
    SceneEntry {
        name: "resting box e=1",
        build: |w| {
            scenes::resting_box(w, 1.0);
        },
        view: view(Vec3::new(0.0, 0.5, 0.0), 0.5, 0.3, 6.0),
    },
    SceneEntry {
        name: "heavy on light 1000:1",
        build: |w| {
            scenes::cube_on_cube(w, 1000.0);
        },
        view: view(Vec3::new(0.0, 1.0, 0.0), 0.5, 0.3, 7.0),
    },
    SceneEntry {
        name: "stack of 10",
        build: |w| {
            scenes::stack(w, 10);
        },
        view: view(Vec3::new(0.0, 5.0, 0.0), 0.5, 0.2, 20.0),
    },
    SceneEntry {
        name: "pyramid, base 10",
        build: |w| {
            scenes::pyramid(w, 10);
        },
        view: view(Vec3::new(0.0, 4.5, 0.0), 0.0, 0.25, 24.0),
    },
    SceneEntry {
        name: "stack of 20",
        build: |w| {
            scenes::stack(w, 20);
        },
        view: view(Vec3::new(0.0, 10.0, 0.0), 0.5, 0.2, 36.0),
    },
    SceneEntry {
        name: "fast thin wall",
        build: |w| {
            scenes::fast_thin_wall(w);
        },
        view: view(Vec3::new(-0.3, 0.0, 0.0), 0.9, 0.3, 5.0),
    },
    SceneEntry {
        name: "pour of 1000 spheres",
        build: |w| {
            scenes::pour(w, 1000);
        },
        view: view(Vec3::new(0.0, 3.0, 0.0), 0.6, 0.5, 30.0),
    },
    SceneEntry {
        name: "1000 spheres in free flight",
        build: |w| {
            scenes::sparse_flight(w, 1000);
        },
        view: view(Vec3::new(9.0, 9.0, 9.0), 0.6, 0.4, 45.0),
    },
];

/// The camera's orbit: it looks at `focus` from `distance` m, at `yaw` about y (0: from +z)
/// and `pitch` above the horizon, in rad.
#[derive(Resource, Clone, Copy, Debug)]
struct OrbitCamera {
    focus: Vec3,
    yaw: f32,
    pitch: f32,
    distance: f32,
}

impl OrbitCamera {
    fn transform(&self) -> Transform {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        let eye = self.focus + self.distance * Vec3::new(cp * sy, sp, cp * cy);
        Transform::from_translation(eye).looking_at(self.focus, Vec3::Y)
    }
}

/// The viewer's state: the scene shown, pause and single-step requests, and timings.
#[derive(Resource)]
struct Viewer {
    scene: usize,
    reset: bool,
    paused: bool,
    step_once: bool,
    overlay: bool,
    step_started: Option<Instant>,
    /// Wall time of the last physics step, ms, and a smoothed value.
    step_ms: f32,
    step_ms_smooth: f32,
    frame_ms_smooth: f32,
}

/// What the command line asked for.
#[derive(Resource, Default)]
struct RunArgs {
    seconds: Option<f32>,
    screenshot: Option<PathBuf>,
    requested: bool,
    frames: u32,
    /// Frame times after the warm-up, and physics step times, ms (for the report at exit).
    frame_ms: Vec<f32>,
    step_ms: Vec<f32>,
}

/// Marks everything a scene spawned (bodies); reset despawns it.
#[derive(Component)]
struct SceneBody;

/// The text overlay: the stats block (top left) and the scene list (top right).
#[derive(Component)]
struct Overlay {
    scene_list: bool,
}

/// Shared meshes and materials, so a pour of 1000 spheres uses one mesh.
#[derive(Resource, Default)]
struct MeshCache {
    meshes: Vec<(String, Handle<Mesh>)>,
    dynamic: Vec<Handle<StandardMaterial>>,
    fixed: Option<Handle<StandardMaterial>>,
    ground: Option<Handle<StandardMaterial>>,
}

fn parse_args() -> (usize, RunArgs, bool) {
    let mut args = std::env::args().skip(1);
    let (mut scene, mut run, mut paused) = (1, RunArgs::default(), false);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--scene" => scene = args.next().and_then(|s| s.parse().ok()).unwrap_or(1),
            "--seconds" => run.seconds = args.next().and_then(|s| s.parse().ok()),
            "--screenshot" => run.screenshot = args.next().map(PathBuf::from),
            "--pause" => paused = true,
            other => eprintln!("viewer: unknown argument {other}"),
        }
    }
    (scene.clamp(1, SCENES.len()) - 1, run, paused)
}

fn main() {
    let (scene, run, paused) = parse_args();
    App::new()
        .add_plugins((
            DefaultPlugins.set(WindowPlugin {
                primary_window: Some(Window {
                    title: "impact3d viewer".into(),
                    resolution: WindowResolution::new(1280, 720),
                    ..default()
                }),
                ..default()
            }),
            PhysicsPlugins::default().set(InterpolationPlugin { all: true }),
            PhysicsDebugPlugin,
        ))
        .insert_resource(ClearColor(Color::srgb(0.45, 0.62, 0.85)))
        .insert_resource(GlobalAmbientLight {
            brightness: 400.0,
            ..default()
        })
        .insert_resource(SCENES[scene].view)
        .insert_resource(Viewer {
            scene,
            reset: true,
            paused,
            step_once: false,
            overlay: true,
            step_started: None,
            step_ms: 0.0,
            step_ms_smooth: 0.0,
            frame_ms_smooth: 0.0,
        })
        .insert_resource(run)
        .init_resource::<MeshCache>()
        .add_systems(Startup, setup)
        .add_systems(
            FixedPostUpdate,
            (
                start_step_timer.before(impact3d::schedule::run_physics_schedule),
                stop_step_timer.after(impact3d::schedule::run_physics_schedule),
            ),
        )
        .add_systems(
            RunFixedMainLoop,
            single_step.in_set(RunFixedMainLoopSystems::FixedMainLoop),
        )
        .add_systems(
            Update,
            (
                keys,
                reset_scene,
                attach_meshes,
                orbit_camera,
                update_overlay,
                finish_run,
            )
                .chain(),
        )
        .run();
}

fn setup(
    mut commands: Commands,
    mut cache: ResMut<MeshCache>,
    assets: Res<AssetServer>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    camera: Res<OrbitCamera>,
) {
    commands.spawn((Camera3d::default(), camera.transform()));
    commands.spawn((
        DirectionalLight {
            illuminance: 8000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(4.0, 10.0, 6.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    for scene_list in [false, true] {
        let (left, right) = if scene_list {
            (Val::Auto, Val::Px(8.0))
        } else {
            (Val::Px(8.0), Val::Auto)
        };
        commands.spawn((
            Text::new(""),
            TextFont {
                font_size: FontSize::Px(13.0),
                ..default()
            },
            TextColor(Color::WHITE),
            Node {
                position_type: PositionType::Absolute,
                top: Val::Px(6.0),
                left,
                right,
                ..default()
            },
            Overlay { scene_list },
        ));
    }
    let texture = assets
        .load_builder()
        .with_settings(|s: &mut ImageLoaderSettings| {
            s.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor {
                address_mode_u: ImageAddressMode::Repeat,
                address_mode_v: ImageAddressMode::Repeat,
                ..ImageSamplerDescriptor::linear()
            });
        })
        .load("textures/ground.png");
    cache.ground = Some(materials.add(StandardMaterial {
        base_color_texture: Some(texture),
        uv_transform: Affine2::from_scale(Vec2::splat(8.0)),
        perceptual_roughness: 0.9,
        ..default()
    }));
    cache.fixed = Some(materials.add(StandardMaterial {
        base_color: Color::srgb(0.62, 0.62, 0.66),
        perceptual_roughness: 0.8,
        ..default()
    }));
    cache.dynamic = [
        Color::srgb(0.93, 0.45, 0.12),
        Color::srgb(0.88, 0.30, 0.15),
        Color::srgb(0.95, 0.60, 0.15),
    ]
    .into_iter()
    .map(|c| {
        materials.add(StandardMaterial {
            base_color: c,
            perceptual_roughness: 0.6,
            ..default()
        })
    })
    .collect();
}

/// What a reset despawns: bodies and the scene's visual floor.
type SceneEntity = Or<(With<Collider>, With<SceneBody>)>;

/// Despawns the scene's bodies and builds the chosen scene again.
fn reset_scene(
    mut commands: Commands,
    mut viewer: ResMut<Viewer>,
    bodies: Query<Entity, SceneEntity>,
) {
    if !viewer.reset {
        return;
    }
    viewer.reset = false;
    for e in &bodies {
        commands.entity(e).despawn();
    }
    let build = SCENES[viewer.scene].build;
    commands.queue(move |world: &mut World| {
        world.insert_resource(Gravity::default());
        world
            .resource_mut::<impact3d::debug::ImpactTrails>()
            .0
            .clear();
        build(world);
        // Scenes without a ground get a visual floor under their lowest body.
        let mut has_ground = false;
        let mut lowest = f32::INFINITY;
        let mut query = world.query::<(&Collider, &Transform)>();
        for (c, t) in query.iter(world) {
            if c.shape().as_halfspace().is_some() {
                has_ground = true;
            } else {
                let pose = parry3d::math::Pose::from_parts(t.translation, t.rotation);
                lowest = lowest.min(c.shape().compute_aabb(&pose).mins.y);
            }
        }
        if !has_ground && lowest.is_finite() {
            let floor = Transform::from_xyz(0.0, lowest - 1.0, 0.0);
            world.spawn((SceneBody, floor, Floor));
        }
    });
}

/// A visual floor (no collider).
#[derive(Component)]
struct Floor;

/// The mesh of a collider's shape, flat-shaded for polyhedra, and a key to share it.
fn collider_mesh(collider: &Collider) -> (String, Mesh) {
    let shape = collider.shape();
    if let Some(b) = shape.as_ball() {
        (
            format!("ball {}", b.radius),
            Sphere::new(b.radius).mesh().uv(32, 18),
        )
    } else if let Some(c) = shape.as_cuboid() {
        let h = c.half_extents;
        (
            format!("cuboid {h}"),
            Cuboid::new(2.0 * h.x, 2.0 * h.y, 2.0 * h.z).into(),
        )
    } else if let Some(c) = shape.as_capsule() {
        let length = (c.segment.b - c.segment.a).length();
        (
            format!("capsule {} {length}", c.radius),
            Capsule3d::new(c.radius, length).into(),
        )
    } else if let Some(h) = shape.as_halfspace() {
        let normal = Dir3::new(h.normal).unwrap_or(Dir3::Y);
        (
            "half-space".to_string(),
            Plane3d::new(*normal, Vec2::splat(60.0)).mesh().into(),
        )
    } else {
        let (vertices, indices) = if let Some(hull) = shape.as_convex_polyhedron() {
            hull.to_trimesh()
        } else if let Some(mesh) = shape.as_trimesh() {
            (mesh.vertices().to_vec(), mesh.indices().to_vec())
        } else {
            let aabb = shape.compute_local_aabb();
            let size = aabb.maxs - aabb.mins;
            return (format!("box {size}"), Cuboid::from_size(size).into());
        };
        let mut mesh = Mesh::new(PrimitiveTopology::TriangleList, default());
        let positions: Vec<[f32; 3]> = vertices.iter().map(|v| v.to_array()).collect();
        mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, positions);
        mesh.insert_indices(Indices::U32(indices.into_iter().flatten().collect()));
        mesh.duplicate_vertices();
        mesh.compute_flat_normals();
        (format!("mesh {:p}", collider.shape().as_ref()), mesh)
    }
}

/// Gives every new collider a mesh matching its shape.
fn attach_meshes(
    mut commands: Commands,
    mut cache: ResMut<MeshCache>,
    mut meshes: ResMut<Assets<Mesh>>,
    new: Query<(Entity, &Collider, Option<&RigidBody>), Without<Mesh3d>>,
    floors: Query<Entity, (With<Floor>, Without<Mesh3d>)>,
) {
    let cache = &mut *cache;
    for (entity, collider, body) in &new {
        let (key, mesh) = collider_mesh(collider);
        let handle = match cache.meshes.iter().find(|(k, _)| *k == key) {
            Some((_, h)) => h.clone(),
            None => {
                let h = meshes.add(mesh);
                cache.meshes.push((key.clone(), h.clone()));
                h
            }
        };
        let material = if key == "half-space" {
            cache.ground.clone()
        } else if body.is_some_and(|b| !b.is_static()) {
            Some(cache.dynamic[entity.index_u32() as usize % cache.dynamic.len()].clone())
        } else {
            cache.fixed.clone()
        };
        commands
            .entity(entity)
            .insert((Mesh3d(handle), MeshMaterial3d(material.unwrap_or_default())));
    }
    for entity in &floors {
        let mesh = meshes.add(Plane3d::new(Vec3::Y, Vec2::splat(60.0)).mesh());
        commands.entity(entity).insert((
            Mesh3d(mesh),
            MeshMaterial3d(cache.ground.clone().unwrap_or_default()),
        ));
    }
}

/// Keyboard control (see the module doc).
#[allow(clippy::too_many_arguments)]
fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut viewer: ResMut<Viewer>,
    mut camera: ResMut<OrbitCamera>,
    mut config: ResMut<SolverConfig>,
    mut gizmos: ResMut<PhysicsGizmos>,
    mut store: ResMut<GizmoConfigStore>,
    mut interpolation: ResMut<InterpolationConfig>,
    mut time: ResMut<Time<Virtual>>,
    mut exit: MessageWriter<AppExit>,
) {
    const DIGITS: [KeyCode; 10] = [
        KeyCode::Digit1,
        KeyCode::Digit2,
        KeyCode::Digit3,
        KeyCode::Digit4,
        KeyCode::Digit5,
        KeyCode::Digit6,
        KeyCode::Digit7,
        KeyCode::Digit8,
        KeyCode::Digit9,
        KeyCode::Digit0,
    ];
    let shift = input.any_pressed([KeyCode::ShiftLeft, KeyCode::ShiftRight]);
    for (i, key) in DIGITS.iter().enumerate() {
        let scene = i + if shift { 10 } else { 0 };
        if input.just_pressed(*key) && scene < SCENES.len() {
            viewer.scene = scene;
            viewer.reset = true;
            *camera = SCENES[scene].view;
        }
    }
    if input.just_pressed(KeyCode::KeyR) {
        viewer.reset = true;
    }
    if input.just_pressed(KeyCode::Space) {
        viewer.paused = !viewer.paused;
    }
    if input.just_pressed(KeyCode::KeyN) {
        viewer.paused = true;
        viewer.step_once = true;
    }
    if viewer.paused != time.is_paused() {
        if viewer.paused {
            time.pause();
        } else {
            time.unpause();
        }
    }
    if input.just_pressed(KeyCode::KeyM) {
        let all = SolverMethod::ALL;
        let next = all[(all.iter().position(|&m| m == config.method).unwrap_or(0) + 1) % all.len()];
        *config = SolverConfig::for_method(next);
    }
    if input.just_pressed(KeyCode::Minus) {
        config.substeps = config.substeps.saturating_sub(1).max(1);
    }
    if input.just_pressed(KeyCode::Equal) {
        config.substeps = (config.substeps + 1).min(64);
    }
    if input.just_pressed(KeyCode::KeyT) {
        interpolation.all = !interpolation.all;
    }
    let g = &mut *gizmos;
    for (key, layer) in [
        (KeyCode::KeyC, &mut g.colliders),
        (KeyCode::KeyB, &mut g.aabbs),
        (KeyCode::KeyK, &mut g.contacts),
        (KeyCode::KeyI, &mut g.impacts),
        (KeyCode::KeyV, &mut g.velocities),
        (KeyCode::KeyL, &mut g.islands),
    ] {
        if input.just_pressed(key) {
            *layer = !*layer;
        }
    }
    if input.just_pressed(KeyCode::KeyG) {
        let (config, _) = store.config_mut::<PhysicsGizmoGroup>();
        config.enabled = !config.enabled;
    }
    if input.just_pressed(KeyCode::KeyH) {
        viewer.overlay = !viewer.overlay;
    }
    if input.just_pressed(KeyCode::Escape) {
        exit.write(AppExit::Success);
    }
}

/// Orbit: mouse drag or arrow keys turn, the wheel or W / S zoom.
fn orbit_camera(
    mut orbit: ResMut<OrbitCamera>,
    buttons: Res<ButtonInput<MouseButton>>,
    input: Res<ButtonInput<KeyCode>>,
    motion: Res<AccumulatedMouseMotion>,
    scroll: Res<AccumulatedMouseScroll>,
    time: Res<Time<Real>>,
    mut cameras: Query<&mut Transform, With<Camera3d>>,
) {
    let dt = time.delta_secs();
    if buttons.pressed(MouseButton::Left) {
        orbit.yaw -= motion.delta.x * 0.005;
        orbit.pitch += motion.delta.y * 0.005;
    }
    let axis = |neg: KeyCode, pos: KeyCode| {
        input.pressed(pos) as i32 as f32 - input.pressed(neg) as i32 as f32
    };
    orbit.yaw += axis(KeyCode::ArrowLeft, KeyCode::ArrowRight) * 1.5 * dt;
    orbit.pitch += axis(KeyCode::ArrowDown, KeyCode::ArrowUp) * 1.0 * dt;
    orbit.pitch = orbit.pitch.clamp(-1.4, 1.4);
    let zoom = scroll.delta.y * 0.1 + axis(KeyCode::KeyS, KeyCode::KeyW) * dt;
    orbit.distance = (orbit.distance * (1.0 - zoom)).clamp(1.0, 200.0);
    for mut t in &mut cameras {
        *t = orbit.transform();
    }
}

/// One physics step while paused (key N), run where the fixed-step loop runs: after the
/// interpolated bodies got their physics pose back, before they are interpolated again.
fn single_step(world: &mut World) {
    let mut viewer = world.resource_mut::<Viewer>();
    if !viewer.step_once {
        return;
    }
    viewer.step_once = false;
    let step = world.resource::<Time<Fixed>>().timestep();
    let mut time = Time::<()>::default();
    time.advance_by(step);
    let saved = std::mem::replace(&mut *world.resource_mut::<Time>(), time);
    world.run_schedule(bevy::app::FixedMain);
    *world.resource_mut::<Time>() = saved;
}

fn start_step_timer(mut viewer: ResMut<Viewer>) {
    viewer.step_started = Some(Instant::now());
}

fn stop_step_timer(mut viewer: ResMut<Viewer>, mut run: ResMut<RunArgs>) {
    if let Some(start) = viewer.step_started.take() {
        let ms = start.elapsed().as_secs_f32() * 1e3;
        viewer.step_ms = ms;
        viewer.step_ms_smooth = 0.9 * viewer.step_ms_smooth + 0.1 * ms;
        if run.seconds.is_some() {
            run.step_ms.push(ms);
        }
    }
}

/// The text overlay: scenes, solver, timings, what the last step did, keys.
#[allow(clippy::too_many_arguments)]
fn update_overlay(
    mut viewer: ResMut<Viewer>,
    time: Res<Time<Real>>,
    config: Res<SolverConfig>,
    stats: Res<SolverStats>,
    gizmos: Res<PhysicsGizmos>,
    interpolation: Res<InterpolationConfig>,
    bodies: Query<(), With<RigidBody>>,
    sleeping: Query<(), With<Sleeping>>,
    mut overlay: Query<(&mut Text, &mut Visibility, &Overlay)>,
) {
    let frame_ms = time.delta_secs() * 1e3;
    viewer.frame_ms_smooth = 0.9 * viewer.frame_ms_smooth + 0.1 * frame_ms;
    let mut list = String::new();
    for (i, scene) in SCENES.iter().enumerate() {
        let key = match i {
            0..=8 => format!("{}", i + 1),
            9 => "0".to_string(),
            _ => format!("Shift+{}", (i - 9) % 10),
        };
        let mark = if i == viewer.scene { ">" } else { " " };
        list += &format!("{mark} {key:>7}  {}\n", scene.name);
    }
    let on = |b: bool| if b { "on" } else { "off" };
    let stats = format!(
        "{:?}, {} substeps, {} iterations{}   frame {:.1} ms, physics step {:.2} ms (last {:.2})\n\
         bodies {}, sleeping {}, contacts {}, impacts {}, iterations {}, sweeps {}{}\n\
         interpolation {} (T); colliders {} (C), boxes {} (B), contacts {} (K), impacts {} (I), \
         velocities {} (V), islands {} (L)\n\
         Space pause, N step, R reset, M method, -/= substeps, G gizmos, H hide, \
         drag/arrows orbit, W/S zoom",
        config.method,
        config.substeps,
        config.iterations,
        if viewer.paused { "  [paused]" } else { "" },
        viewer.frame_ms_smooth,
        viewer.step_ms_smooth,
        viewer.step_ms,
        bodies.iter().count(),
        sleeping.iter().count(),
        stats.contacts,
        stats.impacts,
        stats.iterations,
        stats.propagation_sweeps,
        if stats.propagation_bound_hit {
            " (bound hit)"
        } else {
            ""
        },
        on(interpolation.all),
        on(gizmos.colliders),
        on(gizmos.aabbs),
        on(gizmos.contacts),
        on(gizmos.impacts),
        on(gizmos.velocities),
        on(gizmos.islands),
    );
    for (mut text, mut visibility, overlay) in &mut overlay {
        *visibility = if viewer.overlay {
            Visibility::Inherited
        } else {
            Visibility::Hidden
        };
        let wanted = if overlay.scene_list { &list } else { &stats };
        if viewer.overlay && text.0 != *wanted {
            text.0 = wanted.clone();
        }
    }
}

/// With `--seconds`: after that much simulated time (and enough frames for the render
/// pipelines to be ready), takes the screenshot if asked and exits, printing the timings.
fn finish_run(
    mut commands: Commands,
    mut run: ResMut<RunArgs>,
    time: Res<Time<Virtual>>,
    real: Res<Time<Real>>,
    mut exit: MessageWriter<AppExit>,
) {
    let Some(seconds) = run.seconds else {
        return;
    };
    run.frames += 1;
    if time.elapsed_secs() > 0.5 {
        run.frame_ms.push(real.delta_secs() * 1e3);
    }
    if run.requested || time.elapsed_secs() < seconds || run.frames < 20 {
        return;
    }
    run.requested = true;
    report(&run);
    match run.screenshot.clone() {
        Some(path) => {
            commands
                .spawn(Screenshot::primary_window())
                .observe(save_to_disk(path))
                .observe(
                    |_: On<ScreenshotCaptured>, mut exit: MessageWriter<AppExit>| {
                        exit.write(AppExit::Success);
                    },
                );
        }
        None => {
            exit.write(AppExit::Success);
        }
    }
}

/// Prints frame and step time statistics of the run.
fn report(run: &RunArgs) {
    let stats = |v: &[f32]| {
        let mut s = v.to_vec();
        s.sort_by(f32::total_cmp);
        let mean = s.iter().sum::<f32>() / s.len().max(1) as f32;
        (s.len(), mean, s.get(s.len() / 2).copied().unwrap_or(0.0))
    };
    let (frames, frame_mean, frame_median) = stats(&run.frame_ms);
    let (steps, step_mean, step_median) = stats(&run.step_ms);
    println!(
        "viewer: {frames} frames after warm-up: mean {frame_mean:.1} ms, median \
         {frame_median:.1} ms; {steps} physics steps: mean {step_mean:.2} ms, median \
         {step_median:.2} ms"
    );
}
