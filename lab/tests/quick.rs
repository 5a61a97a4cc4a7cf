//! Keeps the lab from rotting: runs its quick scenes, cut down further (`Mode::Smoke`), on
//! impact3d alone into a temporary folder, and checks the files it writes.

use impact3d_lab::{Mode, Options, report, run, scenes, sweep};

/// A smoke run of impact3d alone into a fresh temporary folder named after `name`: the folder
/// and the options.
fn smoke_options(name: &str, sleeping_only: bool) -> (std::path::PathBuf, Options) {
    let out = std::env::temp_dir().join(format!("impact3d-lab-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let options = Options {
        mode: Mode::Smoke,
        peers: false,
        out: out.clone(),
        verbose: false,
        only: Vec::new(),
        sleeping_only,
    };
    (out, options)
}

#[test]
fn smoke_run_writes_csv_and_svg() {
    let (out, options) = smoke_options("test", false);
    let rows = run(&options).expect("the run writes its files");

    let scenes = scenes::all(Mode::Smoke);
    let expected: usize = scenes
        .iter()
        .map(|s| sweep::configs(s, Mode::Smoke, false).len())
        .sum();
    assert_eq!(rows.len(), expected);
    assert!(
        expected >= scenes.len() * impact3d::prelude::SolverMethod::ALL.len(),
        "every method runs on every scene"
    );

    let combined = std::fs::read_to_string(out.join("combined.csv")).unwrap();
    let mut lines = combined.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header, report::CSV_HEADER.split(',').collect::<Vec<_>>());
    let data: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(data.len(), expected);
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    for row in &data {
        assert_eq!(row.len(), header.len(), "{row:?}");
        assert_eq!(row[column("engine")], "impact3d");
        for name in [
            "dt",
            "ms_per_step",
            "ms_spread",
            "error",
            "tolerance",
            "penetration_m",
            "drift_m",
            "energy_change",
        ] {
            let value: f64 = row[column(name)]
                .parse()
                .unwrap_or_else(|_| panic!("{name} in {row:?}"));
            assert!(value.is_finite(), "{name} is not finite in {row:?}");
        }
        assert!(row[column("ms_per_step")].parse::<f64>().unwrap() > 0.0);
    }

    for scene in &scenes {
        let csv = std::fs::read_to_string(out.join(format!("{}.csv", scene.name))).unwrap();
        assert!(csv.lines().count() > 1, "{} has rows", scene.name);
        let svg = std::fs::read_to_string(out.join(format!("{}.svg", scene.name))).unwrap();
        assert!(
            svg.starts_with("<svg") && svg.contains("</svg>"),
            "{} chart",
            scene.name
        );
    }
    let summary = std::fs::read_to_string(out.join("summary.svg")).unwrap();
    assert!(summary.contains("</svg>") && summary.contains("Pareto front"));
    assert!(out.join("summary.md").exists());
    std::fs::remove_dir_all(&out).unwrap();
}

/// The sleeping pair (cut down to 100 spheres) writes one row per method, and the sleeping
/// spheres do not move at all: their free-flight error (the distance from where they were
/// put to sleep) is exactly zero.
#[test]
fn smoke_sleeping_pair_writes_its_table() {
    let (out, options) = smoke_options("sleep", true);
    assert!(run(&options).expect("the run writes its files").is_empty());
    let csv = std::fs::read_to_string(out.join("sleeping.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), impact3d::prelude::SolverMethod::ALL.len());
    for row in &rows {
        let value = |k: usize| row[k].parse::<f64>().unwrap();
        assert!(value(1) > 0.0 && value(2) > 0.0, "{row:?}");
        assert_eq!(value(7), 0.0, "sleeping spheres moved: {row:?}");
    }
    assert!(
        std::fs::read_to_string(out.join("sleeping.md"))
            .unwrap()
            .contains("asleep / awake")
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// impact3d without its `parallel` feature (as the lab builds it) steps a world of many pairs:
/// 2,028 touching spheres on a 13 x 13 x 12 grid (spacing 1 m, radius 0.5 m, gravity 0) make
/// 22,259 candidate pairs (the margin-widened boxes of all 26 grid neighbours overlap; 5,603
/// of them touch), and the narrow phase once split them into a task per 64, which overflowed
/// the fixed-capacity executor of Bevy's one-thread task pool (a panic inside the
/// schedule). After one step every sphere is still at its grid point to within 1e-3 m (touching
/// spheres at rest with gravity 0 exchange no impulse: checked by position, since the step
/// itself is what panicked) and no body is quarantined.
#[test]
fn one_thread_build_steps_thousands_of_pairs() {
    use bevy::prelude::*;
    use impact3d::prelude::*;

    let mut app = impact3d::scenes::headless_app(60.0);
    app.insert_resource(Gravity(Vec3::ZERO));
    let mut spheres = Vec::new();
    for x in 0..13 {
        for y in 0..12 {
            for z in 0..13 {
                let at = Vec3::new(x as f32, y as f32, z as f32);
                let sphere = app
                    .world_mut()
                    .spawn((
                        RigidBody::Dynamic,
                        Collider::sphere(0.5),
                        Transform::from_translation(at),
                    ))
                    .id();
                spheres.push((sphere, at));
            }
        }
    }
    impact3d::scenes::run_steps(&mut app, 1);
    for (sphere, at) in spheres {
        let world = app.world();
        assert!(world.get::<Quarantined>(sphere).is_none());
        let now = world.get::<Transform>(sphere).unwrap().translation;
        assert!((now - at).length() <= 1e-3, "{at} -> {now}");
    }
}

/// The ray-cast timing runs on impact3d alone: of 300 seeded rays into the 10,000-body grid, some
/// hit (the grid fills its box: a 20 m ray from inside it meets a body) and each hit is within
/// the 20 m reach; the table names the engine.
#[test]
fn smoke_ray_casts() {
    let rows = impact3d_lab::queries::run(300, 1, false);
    assert_eq!(rows.len(), 1);
    let row = &rows[0];
    assert!(row.hits > 150 && row.us_per_ray > 0.0, "{row:?}");
    assert!(
        row.distances
            .iter()
            .all(|d| d.is_nan() || (0.0..=20.0).contains(d))
    );
    assert!(impact3d_lab::queries::table(&rows, 300).contains("| impact3d |"));
}
