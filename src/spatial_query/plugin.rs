//! [`SpatialQueryPlugin`]: keeps the colliders queries see, and runs the casters.

use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;

use super::casters::{update_ray_casters, update_shape_casters};
use super::colliders::{SpatialQueryColliders, update_query_colliders};
use crate::collision::BroadPhaseTree;
use crate::schedule::{PhysicsSchedule, PhysicsSystems};

/// Spatial queries (part of [`PhysicsPlugins`](crate::PhysicsPlugins)): records the colliders
/// of each step for [`SpatialQuery`](super::SpatialQuery) (in
/// [`PhysicsSystems::SpatialQuery`], the last stage of the step) and runs the
/// [`RayCaster`](super::RayCaster)s and [`ShapeCaster`](super::ShapeCaster)s right after each
/// step ([`SpatialQuerySystems`], in the schedule physics is stepped in, before
/// [`PhysicsSystems::Last`]).
pub struct SpatialQueryPlugin {
    /// The schedule physics is stepped in (`FixedPostUpdate` by default), where the casters run.
    pub schedule: Interned<dyn ScheduleLabel>,
}

impl SpatialQueryPlugin {
    /// Casters run in `schedule`, the schedule physics is stepped in.
    pub fn new(schedule: impl ScheduleLabel) -> Self {
        SpatialQueryPlugin {
            schedule: schedule.intern(),
        }
    }
}

impl Default for SpatialQueryPlugin {
    fn default() -> Self {
        Self::new(FixedPostUpdate)
    }
}

/// The [`RayCaster`](super::RayCaster)s and [`ShapeCaster`](super::ShapeCaster)s cast, in the
/// schedule physics is stepped in, after [`PhysicsSystems::StepSimulation`] and before
/// [`PhysicsSystems::Last`] (avian3d's name), so that game systems in `Last` read this step's
/// hits.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SpatialQuerySystems;

impl Plugin for SpatialQueryPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<SpatialQueryColliders>()
            .init_resource::<BroadPhaseTree>()
            .add_systems(
                PhysicsSchedule,
                update_query_colliders.in_set(PhysicsSystems::SpatialQuery),
            )
            .configure_sets(
                self.schedule,
                SpatialQuerySystems
                    .after(PhysicsSystems::StepSimulation)
                    .before(PhysicsSystems::Last),
            )
            .add_systems(
                self.schedule,
                (update_ray_casters, update_shape_casters)
                    .chain()
                    .in_set(SpatialQuerySystems),
            );
    }
}
