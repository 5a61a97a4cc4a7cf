//! `ColliderConstructor` and `ColliderConstructorHierarchy` (avian3d 0.7's names): reflectable
//! descriptions of colliders, replaced by a [`Collider`] once it can be built (for the mesh
//! variants, feature `mesh`, once the entity's `Mesh3d` asset is loaded).

use bevy::platform::collections::HashMap;
use bevy::prelude::*;

use super::{Collider, CollisionLayers};
use crate::dynamics::Density;
use crate::dynamics::validation::body_label;

/// A collider described by data (reflectable, so it can come from a scene file or an editor),
/// replaced by the [`Collider`] it describes by [`build_collider_constructors`] in `PreUpdate`:
/// after one update for the primitive variants; for the mesh variants (feature `mesh`) in the
/// first update after the entity's `Mesh3d` asset is loaded. The fields have avian3d 0.7's
/// names and meanings (full lengths), whatever the matching [`Collider`] constructor takes.
///
/// Bad values give a collider that carries the error (the body is then quarantined with a
/// logged error naming the entity). An entity that already has a `Collider` keeps it; the
/// constructor is removed with a warning. A mesh variant on an entity without `Mesh3d` gives a
/// collider that carries that error.
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// let mut app = App::new();
/// app.add_plugins((MinimalPlugins, PhysicsPlugins::default()));
/// let body = app
///     .world_mut()
///     .spawn((RigidBody::Dynamic, ColliderConstructor::Cylinder { radius: 0.5, height: 2.0 }))
///     .id();
/// app.update();
/// assert!(app.world().get::<Collider>(body).is_some());
/// assert!(app.world().get::<ColliderConstructor>(body).is_none());
/// ```
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component, Debug, PartialEq)]
#[reflect(no_field_bounds)]
pub enum ColliderConstructor {
    /// [`Collider::sphere`].
    Sphere {
        /// m.
        radius: f32,
    },
    /// [`Collider::cuboid`] with half the lengths.
    Cuboid {
        /// Full length along x, m.
        x_length: f32,
        /// Full length along y, m.
        y_length: f32,
        /// Full length along z, m.
        z_length: f32,
    },
    /// [`Collider::round_cuboid`].
    RoundCuboid {
        /// Full length along x of the inner box, m.
        x_length: f32,
        /// Full length along y of the inner box, m.
        y_length: f32,
        /// Full length along z of the inner box, m.
        z_length: f32,
        /// Rounding added outside the inner box, m.
        border_radius: f32,
    },
    /// [`Collider::cylinder`].
    Cylinder {
        /// m.
        radius: f32,
        /// Full height along y, m.
        height: f32,
    },
    /// [`Collider::cone`].
    Cone {
        /// Base radius, m.
        radius: f32,
        /// Full height along y, m.
        height: f32,
    },
    /// [`Collider::capsule`] with half the height.
    Capsule {
        /// m.
        radius: f32,
        /// Length of the axis between the hemispheres' centres, m.
        height: f32,
    },
    /// [`Collider::half_space`].
    HalfSpace {
        /// Outward normal, local frame.
        outward_normal: Vec3,
    },
    /// [`Collider::trimesh`].
    Trimesh {
        /// Local frame, m.
        vertices: Vec<Vec3>,
        /// Triangles, indices into `vertices`.
        indices: Vec<[u32; 3]>,
    },
    /// [`Collider::convex_decomposition`].
    ConvexDecomposition {
        /// Local frame, m.
        vertices: Vec<Vec3>,
        /// Triangles, indices into `vertices`.
        indices: Vec<[u32; 3]>,
    },
    /// [`Collider::convex_hull`] (a degenerate hull gives a collider that carries the error).
    ConvexHull {
        /// Local frame, m.
        points: Vec<Vec3>,
    },
    /// [`Collider::heightfield`].
    Heightfield {
        /// `heights[i][j]`: row `i` along x, column `j` along z.
        heights: Vec<Vec<f32>>,
        /// Size of the grid in x and z, m, and the factor of the heights.
        scale: Vec3,
    },
    /// [`Collider::trimesh_from_mesh`] of the entity's `Mesh3d` (feature `mesh`).
    #[cfg(feature = "mesh")]
    TrimeshFromMesh,
    /// [`Collider::convex_hull_from_mesh`] of the entity's `Mesh3d` (feature `mesh`).
    #[cfg(feature = "mesh")]
    ConvexHullFromMesh,
    /// [`Collider::convex_decomposition_from_mesh`] of the entity's `Mesh3d` (feature `mesh`).
    #[cfg(feature = "mesh")]
    ConvexDecompositionFromMesh,
    /// [`Collider::compound`] of the parts, each at (position, rotation).
    Compound(Vec<(Vec3, Quat, ColliderConstructor)>),
}

impl ColliderConstructor {
    /// Whether building it needs the entity's mesh (the `...FromMesh` variants).
    pub fn requires_mesh(&self) -> bool {
        match self {
            #[cfg(feature = "mesh")]
            Self::TrimeshFromMesh
            | Self::ConvexHullFromMesh
            | Self::ConvexDecompositionFromMesh => true,
            Self::Compound(parts) => parts.iter().any(|(_, _, part)| part.requires_mesh()),
            _ => false,
        }
    }

    /// The collider it describes; `mesh` is the entity's mesh, for the mesh variants (a mesh
    /// variant without one gives a collider that carries that error).
    #[cfg(feature = "mesh")]
    pub fn build(&self, mesh: Option<&Mesh>) -> Collider {
        self.build_with(&|what: &Self| {
            let Some(mesh) = mesh else {
                return Collider::invalid(format!("{what:?} needs a Mesh3d on its entity"));
            };
            match what {
                Self::TrimeshFromMesh => Collider::trimesh_from_mesh(mesh),
                Self::ConvexHullFromMesh => Collider::convex_hull_from_mesh(mesh),
                _ => Collider::convex_decomposition_from_mesh(mesh),
            }
        })
    }

    /// The collider it describes.
    #[cfg(not(feature = "mesh"))]
    pub fn build(&self) -> Collider {
        self.build_with(&|_: &Self| unreachable!("no mesh variants without the `mesh` feature"))
    }

    // Without the `mesh` feature no variant reads `from_mesh`: it is only passed on to parts.
    #[cfg_attr(not(feature = "mesh"), allow(clippy::only_used_in_recursion))]
    fn build_with(&self, from_mesh: &dyn Fn(&Self) -> Collider) -> Collider {
        match self {
            Self::Sphere { radius } => Collider::sphere(*radius),
            Self::Cuboid {
                x_length,
                y_length,
                z_length,
            } => Collider::cuboid(0.5 * x_length, 0.5 * y_length, 0.5 * z_length),
            Self::RoundCuboid {
                x_length,
                y_length,
                z_length,
                border_radius,
            } => Collider::round_cuboid(*x_length, *y_length, *z_length, *border_radius),
            Self::Cylinder { radius, height } => Collider::cylinder(*radius, *height),
            Self::Cone { radius, height } => Collider::cone(*radius, *height),
            Self::Capsule { radius, height } => Collider::capsule(*radius, 0.5 * height),
            Self::HalfSpace { outward_normal } => Collider::half_space(*outward_normal),
            Self::Trimesh { vertices, indices } => {
                Collider::trimesh(vertices.clone(), indices.clone())
            }
            Self::ConvexDecomposition { vertices, indices } => {
                Collider::convex_decomposition(vertices.clone(), indices.clone())
            }
            Self::ConvexHull { points } => Collider::convex_hull(points).unwrap_or_else(|| {
                Collider::invalid(
                    "convex hull is degenerate or a point is not finite or too far".to_string(),
                )
            }),
            Self::Heightfield { heights, scale } => Collider::heightfield(heights.clone(), *scale),
            Self::Compound(parts) => Collider::compound(
                parts
                    .iter()
                    .map(|(p, r, part)| (*p, *r, part.build_with(from_mesh)))
                    .collect(),
            ),
            #[cfg(feature = "mesh")]
            Self::TrimeshFromMesh
            | Self::ConvexHullFromMesh
            | Self::ConvexDecompositionFromMesh => from_mesh(self),
        }
    }
}

/// Triggered on an entity whose [`ColliderConstructor`] was replaced by a valid [`Collider`].
#[derive(EntityEvent, Clone, Copy, Debug, PartialEq)]
pub struct ColliderConstructorReady {
    /// The entity that held the constructor.
    pub entity: Entity,
}

/// Triggered on the root of a [`ColliderConstructorHierarchy`] when it has built its colliders.
#[derive(EntityEvent, Clone, Copy, Debug, PartialEq)]
pub struct ColliderConstructorHierarchyReady {
    /// The root that held the hierarchy constructor.
    pub entity: Entity,
}

/// Builds colliders for the descendants of its entity (not the entity itself), typically the
/// root of a glTF scene: each descendant gets the collider of its constructor (by its `Name` in
/// [`config`](Self::config), else [`default_constructor`](Self::default_constructor)), with the
/// layers and density of its entry. Mesh constructors (feature `mesh`) apply to descendants
/// with a `Mesh3d` and skip the others.
///
/// It waits until the root has descendants (a scene spawns them some updates after the root)
/// and every descendant's `Mesh3d` asset needed is loaded, then builds all of them in one
/// update, removes itself and triggers [`ColliderConstructorHierarchyReady`] (without Bevy's
/// scene crate, impact3d cannot ask whether a scene instance is complete: glTF scenes spawn
/// all their entities at once, with their meshes loaded as part of the same asset). A
/// descendant that already has a `Collider` keeps it unless its name is in `config`.
///
/// Colliders on child entities are placed by their own `Transform` until impact3d handles
/// hierarchies (see the README's components table).
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component, Debug, PartialEq, Default)]
pub struct ColliderConstructorHierarchy {
    /// The constructor of descendants not named in `config`; `None` skips them.
    pub default_constructor: Option<ColliderConstructor>,
    /// Layers of the colliders built, unless their entry says otherwise.
    pub default_layers: CollisionLayers,
    /// Density of the colliders built, unless their entry says otherwise.
    pub default_density: Density,
    /// Entries by `Name`; `None` skips that descendant.
    pub config: HashMap<String, Option<ColliderConstructorHierarchyConfig>>,
}

/// What [`ColliderConstructorHierarchy`] builds for the descendants of one name; each `None`
/// falls back on the hierarchy's default.
#[derive(Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Debug, Default, PartialEq)]
pub struct ColliderConstructorHierarchyConfig {
    /// The constructor.
    pub constructor: Option<ColliderConstructor>,
    /// The layers.
    pub layers: Option<CollisionLayers>,
    /// The density.
    pub density: Option<Density>,
}

impl ColliderConstructorHierarchy {
    /// Every descendant gets `default_constructor` (`None`: only those named in `config`).
    pub fn new(default_constructor: impl Into<Option<ColliderConstructor>>) -> Self {
        Self {
            default_constructor: default_constructor.into(),
            ..default()
        }
    }

    /// Layers for the colliders not given others by name.
    pub fn with_default_layers(mut self, layers: CollisionLayers) -> Self {
        self.default_layers = layers;
        self
    }

    /// Density for the colliders not given another by name.
    pub fn with_default_density(mut self, density: Density) -> Self {
        self.default_density = density;
        self
    }

    /// The constructor for descendants named `name`.
    pub fn with_constructor_for_name(self, name: &str, constructor: ColliderConstructor) -> Self {
        self.with_config_for_name(name, |c| c.constructor = Some(constructor))
    }

    /// The layers for descendants named `name`.
    pub fn with_layers_for_name(self, name: &str, layers: CollisionLayers) -> Self {
        self.with_config_for_name(name, |c| c.layers = Some(layers))
    }

    /// The density for descendants named `name`.
    pub fn with_density_for_name(self, name: &str, density: Density) -> Self {
        self.with_config_for_name(name, |c| c.density = Some(density))
    }

    /// No collider for descendants named `name`.
    pub fn without_constructor_for_name(mut self, name: &str) -> Self {
        self.config.insert(name.to_string(), None);
        self
    }

    fn with_config_for_name(
        mut self,
        name: &str,
        edit: impl FnOnce(&mut ColliderConstructorHierarchyConfig),
    ) -> Self {
        let entry = self
            .config
            .entry(name.to_string())
            .or_insert_with(|| Some(default()));
        edit(entry.get_or_insert_with(default));
        self
    }
}

#[cfg(feature = "mesh")]
type MeshOf<'a> = Option<&'a Mesh3d>;
#[cfg(not(feature = "mesh"))]
type MeshOf<'a> = ();

/// The loaded meshes (feature `mesh`; nothing without it).
#[cfg(feature = "mesh")]
type Meshes<'w> = Option<Res<'w, Assets<Mesh>>>;
#[cfg(not(feature = "mesh"))]
type Meshes<'w> = ();

/// What a constructor on an entity can be built from now: `None` while its mesh is loading.
#[cfg(feature = "mesh")]
fn build_now(constructor: &ColliderConstructor, mesh: MeshOf, meshes: &Meshes) -> Option<Collider> {
    if !constructor.requires_mesh() {
        return Some(constructor.build(None));
    }
    let Some(handle) = mesh else {
        return Some(constructor.build(None));
    };
    let loaded = meshes.as_ref().and_then(|m| m.get(&handle.0))?;
    Some(constructor.build(Some(loaded)))
}

#[cfg(not(feature = "mesh"))]
fn build_now(constructor: &ColliderConstructor, _: MeshOf, _: &Meshes) -> Option<Collider> {
    Some(constructor.build())
}

/// What [`build_collider_constructors`] reads of an entity.
type ConstructorData<'a> = (
    Entity,
    &'a ColliderConstructor,
    Has<Collider>,
    Option<&'a Name>,
    MeshOf<'a>,
);

/// Replaces each [`ColliderConstructor`] with the [`Collider`] it describes, as soon as it can
/// be built (see the constructor's doc). Runs in `PreUpdate`.
pub fn build_collider_constructors(
    mut commands: Commands,
    meshes: Meshes,
    constructors: Query<ConstructorData>,
) {
    for (entity, constructor, has_collider, name, mesh) in &constructors {
        if has_collider {
            log::warn!(
                "impact3d: {} has a Collider and a ColliderConstructor; it keeps its Collider",
                body_label(entity, name)
            );
            commands.entity(entity).remove::<ColliderConstructor>();
            continue;
        }
        let Some(collider) = build_now(constructor, mesh, &meshes) else {
            continue;
        };
        let valid = collider.error().is_none();
        commands
            .entity(entity)
            .remove::<ColliderConstructor>()
            .insert(collider);
        if valid {
            commands.trigger(ColliderConstructorReady { entity });
        }
    }
}

/// Builds the colliders of each [`ColliderConstructorHierarchy`] whose descendants are all
/// ready (see its doc). Runs in `PreUpdate`.
pub fn build_collider_constructor_hierarchies(
    mut commands: Commands,
    meshes: Meshes,
    roots: Query<(Entity, &ColliderConstructorHierarchy)>,
    children: Query<&Children>,
    nodes: Query<(Option<&Name>, Has<Collider>, MeshOf)>,
) {
    'roots: for (root, hierarchy) in &roots {
        let mut plan = Vec::new();
        for entity in children.iter_descendants(root) {
            let Ok((name, has_collider, mesh)) = nodes.get(entity) else {
                continue;
            };
            let entry = name.and_then(|n| hierarchy.config.get(n.as_str()));
            let config = match entry {
                Some(None) => continue,
                Some(Some(config)) => config.clone(),
                None if has_collider => continue,
                None => ColliderConstructorHierarchyConfig::default(),
            };
            let Some(constructor) = config
                .constructor
                .clone()
                .or_else(|| hierarchy.default_constructor.clone())
            else {
                continue;
            };
            #[cfg(feature = "mesh")]
            if constructor.requires_mesh() && mesh.is_none() {
                continue;
            }
            let Some(collider) = build_now(&constructor, mesh, &meshes) else {
                // A mesh still loading: wait for it.
                continue 'roots;
            };
            plan.push((
                entity,
                collider,
                config.layers.unwrap_or(hierarchy.default_layers),
                config.density.unwrap_or(hierarchy.default_density),
            ));
        }
        if children.get(root).is_err() {
            // Not spawned yet (a scene arrives some updates after its root).
            continue;
        }
        for (entity, collider, layers, density) in plan {
            commands.entity(entity).insert((collider, layers, density));
        }
        commands
            .entity(root)
            .remove::<ColliderConstructorHierarchy>();
        commands.trigger(ColliderConstructorHierarchyReady { entity: root });
    }
}
