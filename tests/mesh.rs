//! Feature `mesh`: colliders from Bevy meshes rest as the shapes they describe, and the mesh
//! variants of `ColliderConstructor` / `ColliderConstructorHierarchy` wait for their mesh
//! assets. Run with `cargo test --features mesh --test mesh`.

mod common;

use bevy::prelude::*;
use common::*;
use impact3d::prelude::*;
use impact3d::scenes::{self, headless_app, run_steps};

/// The half extents of the box used here, m (Bevy's `Cuboid` takes full lengths).
const HALF: Vec3 = Vec3::new(0.5, 0.25, 1.0);

fn box_mesh() -> Mesh {
    Mesh::from(Cuboid::new(2.0 * HALF.x, 2.0 * HALF.y, 2.0 * HALF.z))
}

/// Drops `collider` (density 1000) from 5 cm above its resting height on the ground, runs 2 s
/// and returns its height and tilt.
fn rest_height(collider: Collider) -> (f32, f32) {
    let (mut app, body) = on_ground((
        RigidBody::Dynamic,
        collider,
        Transform::from_xyz(0.0, HALF.y + 0.05, 0.0),
    ));
    run_steps(&mut app, 120);
    assert!(app.world().get::<Quarantined>(body).is_none());
    (
        position(&app, body).y,
        rotation(&app, body).angle_between(Quat::IDENTITY),
    )
}

/// The convex hull and the convex decomposition of Bevy's `Cuboid` mesh rest as
/// `Collider::cuboid` of the same size does: at the half height (less the soft contact's
/// 0.28 mm sink), upright. Measured: the hull at the cuboid's height to the bit, the
/// decomposition 0.9 um lower (its parts are hulls of VHACD's pieces, whose faces are the
/// box's own); tolerance 10 um, a tenth of anything a collider of a different size would
/// show. Their mass is the box's: measured within 2e-7 relative, tolerance 1e-5 (the f32
/// rounding of summing the hulls' volumes).
#[test]
fn box_mesh_hulls_rest_like_the_cuboid() {
    let mesh = box_mesh();
    let (reference, _) = rest_height(Collider::cuboid(HALF.x, HALF.y, HALF.z));
    assert!((reference - HALF.y).abs() < 1e-3, "{reference}");
    let box_mass = 8.0 * HALF.x * HALF.y * HALF.z * 1000.0;
    for (what, collider, mass_tolerance) in [
        ("convex hull", Collider::convex_hull_from_mesh(&mesh), 1e-5),
        (
            "convex decomposition",
            Collider::convex_decomposition_from_mesh(&mesh),
            1e-5,
        ),
    ] {
        assert!(collider.error().is_none(), "{what}: {:?}", collider.error());
        let m = ComputedMass::from_collider(&collider, 1000.0, None).unwrap();
        let mass = 1.0 / m.inverse_mass;
        assert!(
            (mass - box_mass).abs() <= mass_tolerance * box_mass,
            "{what}: mass {mass} vs {box_mass}"
        );
        let (y, tilt) = rest_height(collider);
        assert!(
            (y - reference).abs() < 1e-5,
            "{what}: rests at {y}, the cuboid at {reference}"
        );
        assert!(tilt < 1e-3, "{what}: tilted {tilt}");
    }
}

/// A static triangle mesh from Bevy's `Cuboid` mesh carries a box as a static
/// `Collider::cuboid` does: a 0.2 m cube dropped on each rests at the same height (0.45 +
/// 0.1 m less the sink; measured identical to the bit, tolerance 10 um).
#[test]
fn box_mesh_trimesh_floor_carries_like_the_cuboid() {
    let mut heights = Vec::new();
    for floor in [
        Collider::cuboid(HALF.x, HALF.y, HALF.z),
        Collider::trimesh_from_mesh(&box_mesh()),
    ] {
        assert!(floor.error().is_none(), "{:?}", floor.error());
        let mut app = headless_app(60.0);
        app.world_mut()
            .spawn((RigidBody::Static, floor, Transform::from_xyz(0.0, 0.2, 0.0)));
        let cube = app
            .world_mut()
            .spawn(scenes::cuboid(
                Vec3::splat(0.1),
                1.0,
                Vec3::new(0.0, 0.6, 0.0),
            ))
            .id();
        run_steps(&mut app, 120);
        heights.push(position(&app, cube).y);
    }
    assert!((heights[0] - 0.55).abs() < 1e-3, "{heights:?}");
    assert!((heights[1] - heights[0]).abs() < 1e-5, "{heights:?}");
}

/// A mesh that is not a triangle list, or has no positions, gives a collider that carries the
/// error; nothing panics.
#[test]
fn unreadable_meshes_carry_an_error() {
    use bevy::asset::RenderAssetUsages;
    use bevy::mesh::PrimitiveTopology;
    let lines = Mesh::new(PrimitiveTopology::LineList, RenderAssetUsages::default())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32; 3]; 4]);
    let empty = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    );
    for mesh in [&lines, &empty] {
        assert!(Collider::trimesh_from_mesh(mesh).error().is_some());
        assert!(Collider::convex_hull_from_mesh(mesh).error().is_some());
        assert!(
            Collider::convex_decomposition_from_mesh(mesh)
                .error()
                .is_some()
        );
    }
}

/// `ColliderConstructor::ConvexHullFromMesh` waits while the entity's mesh asset is not
/// loaded, and is replaced by the hull in the first update after it is; without a `Mesh3d` it
/// gives a collider that carries the error.
#[test]
fn mesh_constructor_waits_for_its_asset() {
    let mut app = headless_app(60.0);
    app.init_resource::<Assets<Mesh>>();
    let handle = app.world().resource::<Assets<Mesh>>().reserve_handle();
    let body = app
        .world_mut()
        .spawn((
            RigidBody::Dynamic,
            ColliderConstructor::ConvexHullFromMesh,
            Mesh3d(handle.clone()),
        ))
        .id();
    let orphan = app
        .world_mut()
        .spawn((RigidBody::Dynamic, ColliderConstructor::TrimeshFromMesh))
        .id();
    run_steps(&mut app, 3);
    assert!(app.world().get::<Collider>(body).is_none());
    assert!(app.world().get::<ColliderConstructor>(body).is_some());
    assert!(
        app.world()
            .get::<Collider>(orphan)
            .unwrap()
            .error()
            .is_some()
    );
    app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .insert(handle.id(), box_mesh())
        .unwrap();
    app.update();
    let collider = app.world().get::<Collider>(body).unwrap();
    let hull = collider.shape().as_convex_polyhedron().unwrap();
    assert_eq!(hull.points().len(), 8);
    assert!(app.world().get::<ColliderConstructor>(body).is_none());
}

/// `ColliderConstructorHierarchy` with a mesh constructor: descendants with a `Mesh3d` get a
/// triangle mesh once every mesh is loaded (it waits for the last), those without get none.
#[test]
fn mesh_hierarchy_waits_for_every_mesh() {
    let mut app = headless_app(60.0);
    app.init_resource::<Assets<Mesh>>();
    let (loaded, pending) = {
        let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
        (meshes.add(box_mesh()), meshes.reserve_handle())
    };
    let root = app
        .world_mut()
        .spawn(ColliderConstructorHierarchy::new(
            ColliderConstructor::TrimeshFromMesh,
        ))
        .id();
    let a = app.world_mut().spawn((Mesh3d(loaded), ChildOf(root))).id();
    let b = app
        .world_mut()
        .spawn((Mesh3d(pending.clone()), ChildOf(a)))
        .id();
    let empty = app.world_mut().spawn(ChildOf(root)).id();
    run_steps(&mut app, 2);
    assert!(
        app.world().get::<Collider>(a).is_none(),
        "waits for b's mesh"
    );
    app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .insert(pending.id(), box_mesh())
        .unwrap();
    app.update();
    for e in [a, b] {
        let collider = app.world().get::<Collider>(e).unwrap();
        assert!(collider.shape().as_trimesh().is_some());
    }
    assert!(app.world().get::<Collider>(empty).is_none());
    assert!(
        app.world()
            .get::<ColliderConstructorHierarchy>(root)
            .is_none()
    );
}
