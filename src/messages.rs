//! Messages the plugin writes each step. Read them with `MessageReader`.

use bevy::prelude::*;

use crate::collision::ContactPairs;
use crate::dynamics::ImpactMessages;
use crate::dynamics::solver::ContactConstraint;

/// A contact that received a collision impulse in the last step (which contacts count is set by
/// [`SolverConfig::impact_messages`](crate::dynamics::SolverConfig::impact_messages)).
#[derive(Message, Clone, Copy, Debug, PartialEq)]
pub struct Impact {
    /// The body the normal points away from.
    pub a: Entity,
    /// The body the normal points towards.
    pub b: Entity,
    /// Contact point, world frame, m.
    pub point: Vec3,
    /// Unit normal from `a` to `b`.
    pub normal: Vec3,
    /// The scalar impulse `j` applied to this contact over the step, N s: `+j n` on `b` and
    /// `-j n` on `a`.
    pub impulse: f32,
}

/// Two colliders started touching in the last step.
#[derive(Message, Clone, Copy, Debug, PartialEq, Eq)]
pub struct CollisionStarted(pub Entity, pub Entity);

/// Two colliders stopped touching in the last step (or one of them was despawned, lost its
/// collider or was quarantined).
#[derive(Message, Clone, Copy, Debug, PartialEq, Eq)]
pub struct CollisionEnded(pub Entity, pub Entity);

/// The step's [`Impact`]s from its solved rows (`keys`: each row's candidate pair, manifold
/// and point in `pairs`): the rows that struck ([`ImpactMessages::Impacts`]), or every row
/// that pushed ([`ImpactMessages::AllContacts`]), or none, with the impulse each took over the
/// step.
pub fn impacts(
    pairs: &ContactPairs,
    rows: &[ContactConstraint],
    keys: &[(u32, u32, u32)],
    which: ImpactMessages,
) -> impl Iterator<Item = Impact> {
    rows.iter()
        .zip(keys)
        .filter(move |(c, _)| match which {
            ImpactMessages::Off => false,
            ImpactMessages::Impacts => c.impact,
            ImpactMessages::AllContacts => c.total_impulse > 0.0,
        })
        .map(|(c, &(p, _, _))| {
            let pair = &pairs.candidates()[p as usize];
            Impact {
                a: pair.a,
                b: pair.b,
                point: c.point,
                normal: c.normal,
                impulse: c.total_impulse,
            }
        })
}
