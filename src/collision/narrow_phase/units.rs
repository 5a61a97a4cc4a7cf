//! Contact generation in the world's length unit: the power of two nearest it, and the
//! colliders' shapes scaled to it.

use bevy::prelude::*;
use parry3d::shape::SharedShape;

/// The power of two nearest the world's length unit `unit` (m), in which contacts are generated
/// (see [`ContactPair::update`](super::ContactPair::update)): scaling by a power of two is exact in
/// `f32`, so contact generation at this unit gives bit for bit what it gives in metres, except
/// where parry's absolute tolerances decide. 1 for the default unit.
///
/// # Examples
///
/// ```
/// use impact3d::collision::narrow_phase::binary_unit;
///
/// assert_eq!(binary_unit(1.0), 1.0);
/// assert_eq!(binary_unit(1e-3), 1.0 / 1024.0);
/// assert_eq!(binary_unit(1e-2), 1.0 / 128.0);
/// assert_eq!(binary_unit(1e3), 1024.0);
/// ```
pub fn binary_unit(unit: f32) -> f32 {
    2f32.powi(unit.log2().round() as i32)
}

/// The colliders' shapes scaled to the world's length unit, for contact generation (see
/// [`ContactPair::update`](super::ContactPair::update)), each made once per shape and unit. A shape
/// is known by its allocation: the entry keeps the original alive, so its address is not reused
/// while the entry stands, and [`prune`](Self::prune) drops the entries of shapes nothing else
/// holds.
#[derive(Default)]
pub struct UnitShapes {
    unit: f32,
    shapes: std::collections::HashMap<usize, (SharedShape, Option<SharedShape>)>,
}

impl UnitShapes {
    /// `shape` scaled by `1 / unit`, or `None` when parry cannot scale it.
    pub fn get(&mut self, shape: &SharedShape, unit: f32) -> Option<SharedShape> {
        if unit != self.unit {
            self.shapes.clear();
            self.unit = unit;
        }
        let key = std::sync::Arc::as_ptr(&shape.0) as *const u8 as usize;
        let (_, scaled) = self.shapes.entry(key).or_insert_with(|| {
            let scaled = shape
                .scale_dyn(Vec3::splat(1.0 / unit), 0)
                .map(|s| SharedShape(s.into()));
            (shape.clone(), scaled)
        });
        scaled.clone()
    }

    /// Drops the entries of shapes that only this cache still holds.
    pub fn prune(&mut self) {
        self.shapes
            .retain(|_, (original, _)| std::sync::Arc::strong_count(&original.0) > 1);
    }
}
