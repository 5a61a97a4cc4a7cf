//! The narrow phase's settings ([`NarrowPhaseConfig`]): how far ahead contacts are generated and
//! when a pair counts as touching.

use bevy::prelude::*;

/// Points closer than this count as touching for collision start and end, m (times the
/// world's [`PhysicsLengthUnit`](crate::dynamics::validation::PhysicsLengthUnit)): the default of
/// [`NarrowPhaseConfig::touch_distance`].
pub const TOUCH_DISTANCE: f32 = 0.005;

/// The share of [`NarrowPhaseConfig::contact_margin`] each body's broad-phase box is widened by
/// (and each sleeping body's box in the
/// [`SleepingSet`](crate::dynamics::sleep::SleepingSet)): half, so that the boxes of two bodies
/// overlap once their shapes' boxes are within one margin of each other.
pub(crate) const BOX_MARGIN_SHARE: f32 = 0.5;

/// Narrow-phase settings, read every step: change them at run time. Lengths are in metres times
/// the world's [`PhysicsLengthUnit`](crate::dynamics::validation::PhysicsLengthUnit). An
/// invalid value is logged once, as an error naming the field and the value, and the last good
/// value is used (see [`NarrowPhaseConfig::validated`]).
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// let mut app = App::new();
/// app.add_plugins((MinimalPlugins, PhysicsPlugins::default()))
///     .insert_resource(NarrowPhaseConfig {
///         contact_margin: 0.01,
///         ..default()
///     });
/// ```
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Debug, Default, PartialEq)]
pub struct NarrowPhaseConfig {
    /// Contacts are generated this far before shapes touch, m; each body's broad-phase box is
    /// widened by half of it. Valid: finite, in [0, 1e6]. Default 0.02.
    pub contact_margin: f32,
    /// Widen each pair's contact margin by how far the pair can close in one step, so fast
    /// bodies are caught before they pass through thin ones (speculative contacts). Default true.
    pub speculative_contacts: bool,
    /// A pair whose contact point is closer than this counts as touching (collision start and
    /// end, [`CollidingEntities`](crate::collision::CollidingEntities), sensors), m; a pair also
    /// touches while any of its points takes an impulse. Valid: finite, in [0, 1e6]. Default
    /// [`TOUCH_DISTANCE`] (0.005).
    pub touch_distance: f32,
}

impl Default for NarrowPhaseConfig {
    fn default() -> Self {
        NarrowPhaseConfig {
            contact_margin: 0.02,
            speculative_contacts: true,
            touch_distance: TOUCH_DISTANCE,
        }
    }
}
