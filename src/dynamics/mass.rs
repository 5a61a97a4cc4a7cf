//! Mass properties: from the collider's volume and density (or a mass override), or summed over
//! a compound body's colliders, validated.

use bevy::prelude::*;

use super::validation::{MAX_INVERSE_INERTIA, MAX_LENGTH, MAX_MASS, MIN_MASS, within};
use parry3d::mass_properties::MassProperties;

use crate::collision::Collider;
use crate::collision::collider::{BodyPart, is_unbounded_or_hollow, part_mass_properties};

/// Mass properties the plugin derives from [`Collider`], [`Density`](super::Density) and
/// [`Mass`](super::Mass) whenever one of them changes.
///
/// For a body with colliders on child entities (see
/// [`ColliderOf`](crate::collision::collider::ColliderOf)) or a `Transform` scale, it is the sum
/// of its colliders' mass properties by the parallel-axis theorem
/// ([`from_parts`](Self::from_parts)): each collider, scaled, at its pose relative to the body,
/// with its own `Mass` (kg, its inertia scaled to match) if it has one, else its own `Density`,
/// else the body's `Density`; the body's own collider takes the body's `Density`. A `Mass` on the
/// body overrides the total (the inertia scaled to match, the centre of mass kept). Mass from
/// density grows with the scaled volume; an explicit `Mass` stays.
///
/// Read-only: the plugin owns it. A value written into it (by a system, a command or
/// reflection) is discarded at the start of the next step, recomputed from the collider,
/// density and mass with a warning naming the entity, so it never reaches the solve.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct ComputedMass {
    /// `1/m` in 1/kg.
    pub inverse_mass: f32,
    /// Centre of mass in the body's local frame, m.
    pub local_center_of_mass: Vec3,
    /// Inverse inertia tensor in the body's local frame, 1/(kg m^2).
    pub local_inverse_inertia: Mat3,
    /// The inertia is the same about every axis (sphere, cube): the world tensor never changes
    /// with rotation, so it needs no update while the body turns.
    pub isotropic: bool,
}

impl Default for ComputedMass {
    fn default() -> Self {
        ComputedMass {
            inverse_mass: 0.0,
            local_center_of_mass: Vec3::ZERO,
            local_inverse_inertia: Mat3::ZERO,
            isotropic: true,
        }
    }
}

impl ComputedMass {
    /// Mass properties of `collider` with `density` (kg/m^3), or with total mass `mass` (kg) when
    /// given, the inertia scaled to that mass. Errors name what is wrong.
    pub fn from_collider(
        collider: &Collider,
        density: f32,
        mass: Option<f32>,
    ) -> Result<ComputedMass, String> {
        if let Some(error) = collider.error() {
            return Err(format!("invalid collider: {error}"));
        }
        if collider.is_unbounded_or_hollow() {
            return Err(
                "a dynamic body needs a collider with volume (not a half-space or trimesh)"
                    .to_string(),
            );
        }
        if let Some(m) = mass {
            if !(MIN_MASS..=MAX_MASS).contains(&m) {
                return Err(format!(
                    "mass must be in [{MIN_MASS:e}, {MAX_MASS:e}] kg, got {m:?}"
                ));
            }
        } else if !(density.is_finite() && density > 0.0) {
            return Err(format!("density must be finite and > 0, got {density}"));
        }
        Self::from_properties(collider.mass_properties(density), mass, || {
            format!("density {density:?}")
        })
    }

    /// Mass properties of a body made of `parts` (each scaled, placed in the body's frame, with
    /// its own density or mass; see [`BodyPart`]): their sum by the parallel-axis theorem
    /// (parry's `MassProperties` addition), or with total mass `mass` (kg) when given, the
    /// inertia scaled to that mass. Errors name what is wrong (a part without volume, a bad
    /// density or mass, a total outside the bounds).
    ///
    /// # Examples
    ///
    /// ```
    /// use bevy::prelude::*;
    /// use impact3d::collision::collider::BodyPart;
    /// use impact3d::prelude::*;
    /// use parry3d::math::Pose;
    ///
    /// // Two 1 kg balls 2 m apart: 2 kg, centred between them, I = 2 (2/5 m r^2) + 2 m (1 m)^2
    /// // about the axes across the bar.
    /// let ball = |x: f32| BodyPart {
    ///     shape: Collider::sphere(0.1).shape().clone(),
    ///     pose: Pose::from_parts(Vec3::new(x, 0.0, 0.0), Quat::IDENTITY),
    ///     density: 1000.0,
    ///     mass: Some(1.0),
    /// };
    /// let m = ComputedMass::from_parts(&[ball(-1.0), ball(1.0)], None).unwrap();
    /// assert!((m.inverse_mass - 0.5).abs() < 1e-6);
    /// let i_y = 2.0 * (0.4 * 0.01) + 2.0;
    /// assert!((1.0 / m.local_inverse_inertia.y_axis.y - i_y).abs() < 1e-5 * i_y);
    /// ```
    pub fn from_parts(parts: &[BodyPart], mass: Option<f32>) -> Result<ComputedMass, String> {
        if parts.is_empty() {
            return Err("a dynamic body needs a collider".to_string());
        }
        for part in parts {
            if is_unbounded_or_hollow(part.shape.as_ref()) {
                return Err(
                    "a dynamic body needs colliders with volume (not a half-space or trimesh)"
                        .to_string(),
                );
            }
            if let Some(m) = part.mass {
                if !(MIN_MASS..=MAX_MASS).contains(&m) {
                    return Err(format!(
                        "a collider's mass must be in [{MIN_MASS:e}, {MAX_MASS:e}] kg, got {m:?}"
                    ));
                }
            } else if !(part.density.is_finite() && part.density > 0.0) {
                return Err(format!(
                    "a collider's density must be finite and > 0, got {}",
                    part.density
                ));
            }
        }
        if let Some(m) = mass
            && !(MIN_MASS..=MAX_MASS).contains(&m)
        {
            return Err(format!(
                "mass must be in [{MIN_MASS:e}, {MAX_MASS:e}] kg, got {m:?}"
            ));
        }
        let props: MassProperties = parts.iter().map(part_mass_properties).sum();
        Self::from_properties(props, mass, || "the colliders' densities".to_string())
    }

    /// Finishes [`from_collider`](Self::from_collider) and [`from_parts`](Self::from_parts):
    /// applies the mass override, checks the result (`source` names what gave the mass).
    fn from_properties(
        mut props: MassProperties,
        mass: Option<f32>,
        source: impl Fn() -> String,
    ) -> Result<ComputedMass, String> {
        if let Some(m) = mass {
            props.set_mass(m, true);
        }
        let invalid = !props.inv_mass.is_finite()
            || props.inv_mass <= 0.0
            || !props.inv_principal_inertia.is_finite()
            || !props.local_com.is_finite();
        if invalid {
            return Err(format!(
                "collider gives no usable mass (1/m = {}, 1/I = {})",
                props.inv_mass, props.inv_principal_inertia
            ));
        }
        if mass.is_none() && !(MIN_MASS..=MAX_MASS).contains(&(1.0 / props.inv_mass)) {
            return Err(format!(
                "{} gives a mass of {:?} kg, outside [{MIN_MASS:e}, {MAX_MASS:e}] kg",
                source(),
                1.0 / props.inv_mass
            ));
        }
        let inv = props.inv_principal_inertia;
        let isotropic = (inv.x - inv.y).abs() <= 1e-6 * inv.x.abs()
            && (inv.x - inv.z).abs() <= 1e-6 * inv.x.abs();
        let local_inverse_inertia = if isotropic {
            Mat3::from_diagonal(inv)
        } else {
            props.reconstruct_inverse_inertia_matrix()
        };
        let computed = ComputedMass {
            inverse_mass: props.inv_mass,
            local_center_of_mass: props.local_com,
            local_inverse_inertia,
            isotropic,
        };
        computed.check()?;
        Ok(computed)
    }

    /// Checks that these mass properties are in the range the step handles without overflow
    /// (see [`validation`](super::validation)): `1/m` in `[1/MAX_MASS, 1/MIN_MASS]`, the
    /// inverse inertia finite with non-negative diagonal and entries at most
    /// [`MAX_INVERSE_INERTIA`], the centre of mass within [`MAX_LENGTH`] of the origin.
    pub fn check(&self) -> Result<(), String> {
        let inv = self.local_inverse_inertia;
        let diagonal = Vec3::new(inv.x_axis.x, inv.y_axis.y, inv.z_axis.z);
        let largest = inv.to_cols_array().iter().fold(0.0f32, |m, x| {
            if x.abs() > m || x.is_nan() {
                x.abs()
            } else {
                m
            }
        });
        if !(1.0 / MAX_MASS..=1.0 / MIN_MASS).contains(&self.inverse_mass) {
            Err(format!(
                "inverse mass {} 1/kg is outside [{:e}, {:e}]",
                self.inverse_mass,
                1.0 / MAX_MASS,
                1.0 / MIN_MASS
            ))
        } else if !within(largest, MAX_INVERSE_INERTIA) || diagonal.min_element() < 0.0 {
            Err(format!(
                "inverse inertia {inv} is not finite, has a negative diagonal or an entry above \
                 {MAX_INVERSE_INERTIA:e}"
            ))
        } else if !within(self.local_center_of_mass.length(), MAX_LENGTH) {
            Err(format!(
                "centre of mass {} is not finite or farther than {MAX_LENGTH:e} m",
                self.local_center_of_mass
            ))
        } else {
            Ok(())
        }
    }

    /// World-space inverse inertia `R I_body^-1 R^T` for a body at `rotation`, with the rows and
    /// columns of locked world axes zeroed.
    pub fn world_inverse_inertia(&self, rotation: Quat, locked_rotation: BVec3) -> Mat3 {
        let world = if self.isotropic {
            self.local_inverse_inertia
        } else {
            let r = Mat3::from_quat(rotation);
            r * self.local_inverse_inertia * r.transpose()
        };
        lock_axes(world, locked_rotation)
    }
}

/// Zeroes the rows and columns of `m` for the locked axes: `D m D` with `D = diag(unlocked)`.
pub fn lock_axes(m: Mat3, locked: BVec3) -> Mat3 {
    if !locked.any() {
        return m;
    }
    let d = Mat3::from_diagonal(Vec3::select(locked, Vec3::ZERO, Vec3::ONE));
    d * m * d
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A solid sphere of radius r and density rho: m = 4/3 pi r^3 rho, I = 2/5 m r^2.
    /// Tolerance: relative 1e-5, the f32 rounding of these few operations.
    #[test]
    fn sphere_mass_matches_closed_form() {
        let m = ComputedMass::from_collider(&Collider::sphere(0.5), 1000.0, None).unwrap();
        let mass = 4.0 / 3.0 * std::f32::consts::PI * 0.125 * 1000.0;
        assert!((1.0 / m.inverse_mass - mass).abs() <= 1e-5 * mass);
        let inertia = 0.4 * mass * 0.25;
        assert!((1.0 / m.local_inverse_inertia.x_axis.x - inertia).abs() <= 1e-5 * inertia);
        assert!(m.isotropic);
    }

    /// A box of mass m (override) with half extents (a, b, c): I_x = m/3 (b^2 + c^2), etc.
    #[test]
    fn box_with_mass_override_scales_inertia() {
        let m = ComputedMass::from_collider(&Collider::cuboid(1.0, 0.25, 0.5), 1000.0, Some(2.0))
            .unwrap();
        assert!((m.inverse_mass - 0.5).abs() <= 1e-6);
        let expected = Vec3::new(
            2.0 / 3.0 * (0.0625 + 0.25),
            2.0 / 3.0 * (1.0 + 0.25),
            2.0 / 3.0 * (1.0 + 0.0625),
        );
        let world = m.world_inverse_inertia(Quat::IDENTITY, BVec3::FALSE);
        let diag = Vec3::new(world.x_axis.x, world.y_axis.y, world.z_axis.z);
        assert!(
            (diag.recip() - expected).abs().max_element() <= 1e-5,
            "{diag}"
        );
        assert!(!m.isotropic);
    }

    /// A rotated body's world inverse inertia is R I^-1 R^T: a box turned 90 degrees about z
    /// swaps its x and y entries.
    #[test]
    fn world_inertia_rotates() {
        let m = ComputedMass::from_collider(&Collider::cuboid(1.0, 0.25, 0.5), 1000.0, Some(1.0))
            .unwrap();
        let w0 = m.world_inverse_inertia(Quat::IDENTITY, BVec3::FALSE);
        let w1 = m.world_inverse_inertia(
            Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
            BVec3::FALSE,
        );
        assert!((w1.x_axis.x - w0.y_axis.y).abs() <= 1e-4 * w0.y_axis.y);
        assert!((w1.y_axis.y - w0.x_axis.x).abs() <= 1e-4 * w0.x_axis.x);
        let locked = m.world_inverse_inertia(Quat::IDENTITY, BVec3::TRUE);
        assert_eq!(locked, Mat3::ZERO);
    }

    #[test]
    fn bad_mass_inputs_are_errors() {
        let ball = Collider::sphere(0.5);
        assert!(ComputedMass::from_collider(&ball, 0.0, None).is_err());
        assert!(ComputedMass::from_collider(&ball, -1.0, None).is_err());
        assert!(ComputedMass::from_collider(&ball, f32::NAN, None).is_err());
        assert!(ComputedMass::from_collider(&ball, 1000.0, Some(0.0)).is_err());
        assert!(ComputedMass::from_collider(&ball, 1000.0, Some(f32::INFINITY)).is_err());
        assert!(ComputedMass::from_collider(&Collider::cuboid(0.0, 1.0, 1.0), 1.0, None).is_err());
        assert!(ComputedMass::from_collider(&Collider::half_space(Vec3::Y), 1.0, None).is_err());
    }
}
