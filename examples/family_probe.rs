//! Exploration: the default method over scene families beyond the stress tests' members
//! (time steps, frictions, sizes, grid jitter, restitution), sleeping off, release. Prints,
//! per scene, the largest speed against the free-fall bound (plus the 3 m/s push-out), the
//! first body that left the box or was quarantined, the steps that hit the propagation bound,
//! the largest rise of the mechanical energy above its value after the first step and in one
//! step, and the cost. A scene fails on a bound hit or a quarantine, and, without restitution,
//! on a speed above the bound or a body out of the box (with restitution and 100:1 masses a
//! light body legitimately leaves faster than it fell, and bouncing bodies jump the walls).
//!
//! ```sh
//! cargo run --release --example family_probe [name filter, e.g. " e0.5" or "pyramid"]
//! ```
//!
//! The environment overrides the default's settings as `wall_cost`'s does
//! (`examples/support/config_env.rs`), e.g. `FRICTION=per_point`.

#[path = "support/config_env.rs"]
mod config_env;

use bevy::prelude::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, Pour, PourBodies, Spawned};

struct Scene {
    name: String,
    hz: f64,
    seconds: f32,
    build: Box<dyn Fn(&mut World) -> Spawned>,
    restitution: f32,
}

fn run(s: &Scene) {
    let mut app = scenes::headless_app(s.hz);
    app.insert_resource(SleepConfig {
        enabled: false,
        ..default()
    });
    let spawned = (s.build)(app.world_mut());
    if s.restitution > 0.0 {
        for &e in &spawned.bodies {
            app.world_mut()
                .entity_mut(e)
                .insert(Restitution(s.restitution));
        }
    }
    let mut config = SolverConfig::default();
    config_env::override_from_env(&mut config);
    app.insert_resource(config.clone());
    let limit = (2.0 * 9.81 * spawned.top).sqrt() + config.max_push_out_speed;
    let steps = (s.seconds as f64 * s.hz) as u32;
    let (mut fastest, mut at, mut hits) = (0.0f32, 0, 0);
    let mut failure = None;
    let energy = |app: &App| -> f64 {
        spawned
            .bodies
            .iter()
            .map(|&e| {
                let w = app.world();
                let m = w.get::<ComputedMass>(e).unwrap();
                if m.inverse_mass <= 0.0 {
                    return 0.0;
                }
                let mass = 1.0 / m.inverse_mass as f64;
                let t = w.get::<Transform>(e).unwrap();
                let v = w.get::<LinearVelocity>(e).unwrap().0;
                let om = w.get::<AngularVelocity>(e).unwrap().0;
                let inertia = m.world_inverse_inertia(t.rotation, BVec3::FALSE).inverse();
                0.5 * mass * v.length_squared() as f64
                    + 0.5 * om.dot(inertia * om) as f64
                    + mass * 9.81 * (t.translation.y as f64)
            })
            .sum()
    };
    app.update();
    let e0 = energy(&app);
    let (mut worst, mut worst_at) = (0.0f64, 0);
    let (mut rise, mut rise_at, mut last) = (0.0f64, 0, e0);
    let start = std::time::Instant::now();
    for step in 1..=steps {
        app.update();
        if app.world().resource::<SolverStats>().propagation_bound_hit {
            hits += 1;
        }
        let now = energy(&app);
        if now - last > rise {
            rise = now - last;
            rise_at = step;
        }
        last = now;
        let gain = now - e0;
        if gain > worst {
            worst = gain;
            worst_at = step;
        }
        for (i, &e) in spawned.bodies.iter().enumerate() {
            if app.world().get::<Quarantined>(e).is_some() {
                failure = Some(format!("step {step}: body {i} quarantined"));
            }
            let p = app.world().get::<Transform>(e).unwrap().translation;
            let v = app.world().get::<LinearVelocity>(e).unwrap().0.length();
            if v > fastest || v.is_nan() {
                fastest = v;
                at = step;
            }
            let outside =
                p.x.abs().max(p.z.abs()) > spawned.half_width || (spawned.floor && p.y <= 0.0);
            if outside && failure.is_none() {
                failure = Some(format!("step {step}: body {i} left at {p}"));
            }
        }
    }
    let ms = start.elapsed().as_secs_f64() * 1e3 / steps as f64;
    let quarantined = failure.as_ref().is_some_and(|f| f.contains("quarantined"));
    let bounded = s.restitution == 0.0 && (fastest > limit || failure.is_some());
    let verdict = if fastest.is_nan() || quarantined || bounded || hits > 0 {
        "FAIL"
    } else {
        "ok"
    };
    println!(
        "{verdict:4} {:48} fastest {fastest:8.3} m/s (step {at:4}) limit {limit:6.2}  bound hits {hits}  energy +{:.2e} of {:.2e} (step {worst_at}) step rise {rise:.2e} (step {rise_at}) {}  {ms:.2} ms/step",
        s.name,
        worst,
        e0.abs(),
        failure.unwrap_or_default()
    );
}

/// A structure standing on the floor: its bodies must stay within `half_width` of the axis;
/// its highest centre starts `top` above the floor.
fn standing(bodies: Vec<Entity>, half_width: f32, top: f32) -> Spawned {
    Spawned {
        bodies,
        half_width,
        top,
        floor: true,
    }
}

fn pour(count: usize, bodies: PourBodies, friction: f32, size: f32, jitter: f32) -> Pour {
    let mut p = Pour::walled_box_sized(count, bodies, 1.0, friction, size);
    p.jitter = jitter * size;
    p
}

fn main() {
    let filter = std::env::args().nth(1).unwrap_or_default();
    let mut list: Vec<Scene> = Vec::new();
    for hz in [30.0, 60.0, 120.0] {
        for bodies in [PourBodies::Spheres, PourBodies::Boxes, PourBodies::Mixed] {
            for friction in [0.0, 0.2, 1.0] {
                for (size, jitter) in [(0.5, 0.1), (0.5, 0.0), (0.1, 0.1), (2.0, 0.1)] {
                    let p = pour(400, bodies, friction, size, jitter);
                    list.push(Scene {
                        name: format!("pour400 {bodies:?} f{friction} s{size} j{jitter} {hz}Hz"),
                        hz,
                        seconds: 8.0,
                        build: Box::new(move |w| scenes::pour_into(w, &p)),
                        restitution: 0.0,
                    });
                }
            }
        }
        for friction in [0.0, 0.2, 1.0] {
            for (base, three_d) in [(6, true), (12, false), (15, false)] {
                list.push(Scene {
                    name: format!("pyramid b{base} 3d{three_d} f{friction} {hz}Hz"),
                    hz,
                    seconds: 10.0,
                    build: Box::new(move |w| {
                        let bodies = scenes::pyramid_with(w, base, three_d, friction);
                        standing(bodies, 2.0 * base as f32, base as f32)
                    }),
                    restitution: 0.0,
                });
            }
            for (n, ratio) in [(10, 1.0), (10, 10.0), (30, 1.0), (10, 0.01)] {
                list.push(Scene {
                    name: format!("column n{n} r{ratio} f{friction} {hz}Hz"),
                    hz,
                    seconds: 10.0,
                    build: Box::new(move |w| {
                        let bodies = scenes::column(w, n, friction, ratio);
                        standing(bodies, n as f32 + 1.0, n as f32)
                    }),
                    restitution: 0.0,
                });
            }
        }
        for (e, bodies, friction) in [0.2f32, 0.5, 0.8, 1.0].into_iter().flat_map(|e| {
            [PourBodies::Spheres, PourBodies::Boxes, PourBodies::Mixed]
                .into_iter()
                .flat_map(move |b| [(e, b, 0.0), (e, b, 0.3)])
        }) {
            let p = pour(400, bodies, friction, 0.5, 0.1);
            list.push(Scene {
                name: format!("pour400 {bodies:?} e{e} f{friction} {hz}Hz"),
                hz,
                seconds: 8.0,
                build: Box::new(move |w| scenes::pour_into(w, &p)),
                restitution: e,
            });
        }
    }
    for s in list.iter().filter(|s| s.name.contains(&filter)) {
        run(s);
    }
}
