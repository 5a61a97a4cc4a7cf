//! Collision layers: which bodies may touch which, by avian3d 0.7's names and rule.
//!
//! A body belongs to the layers of its [`CollisionLayers::memberships`] and interacts with the
//! layers of its [`CollisionLayers::filters`]. Two bodies interact only when each one's filters
//! contain a layer the other belongs to ([`CollisionLayers::interacts_with`]); a pair that does
//! not interact is dropped where the step decides its candidate pairs
//! ([`CandidatePairs::set`](crate::pipeline::CandidatePairs::set)), so it gets no contacts, no
//! solver rows and no collision messages. A body without [`CollisionLayers`] has
//! [`CollisionLayers::DEFAULT`]: the first layer, interacting with every layer.

use std::ops::{BitAnd, BitAndAssign, BitOr, BitOrAssign, BitXor, BitXorAssign, Not};

use bevy::prelude::*;

/// A type that names layers, such as a game's own enum: each value is a bit mask of the
/// layers it names (one bit for one layer, of 32). Implement it by hand:
///
/// ```
/// use impact3d::prelude::*;
///
/// #[derive(Clone, Copy, Default)]
/// enum GameLayer {
///     #[default]
///     Default,
///     Player,
///     Ground,
/// }
///
/// impl PhysicsLayer for GameLayer {
///     fn to_bits(&self) -> u32 {
///         1 << *self as u32
///     }
///     fn all_bits() -> u32 {
///         0b111
///     }
/// }
///
/// assert_eq!(LayerMask::from(GameLayer::Ground), LayerMask(0b100));
/// assert_eq!(LayerMask::from([GameLayer::Player, GameLayer::Ground]), LayerMask(0b110));
/// ```
///
/// (avian3d derives this trait; impact3d has no derive macro.)
pub trait PhysicsLayer: Sized + Default {
    /// The layer as a bit mask.
    fn to_bits(&self) -> u32;
    /// A mask with the bits of every layer of the type set.
    fn all_bits() -> u32;
}

/// A bit mask of layers, one bit for each of 32 layers. Bit 0 (`0b0001`) is the default
/// layer, the one every body without [`CollisionLayers`] belongs to. Built from bits, from a
/// [`PhysicsLayer`] or from an array of either; combined with `|`, `&`, `^` and `!`, with
/// anything that converts into a mask on the right.
///
/// # Examples
///
/// ```
/// use impact3d::prelude::*;
///
/// let mut layers = LayerMask(0b1010);
/// layers |= 0b0001;
/// assert_eq!(layers, 0b1011);
/// layers.remove(0b0010);
/// assert_eq!(layers, LayerMask(0b1001));
/// assert!(layers.has_all(0b1000) && !layers.has_all(0b1100));
/// assert_eq!(!LayerMask::NONE, LayerMask::ALL);
/// ```
#[derive(Reflect, Clone, Copy, Debug, Deref, DerefMut, Eq, PartialOrd, Ord, Hash)]
#[reflect(Debug, PartialEq)]
pub struct LayerMask(pub u32);

impl LayerMask {
    /// Every layer.
    pub const ALL: Self = Self(0xffff_ffff);
    /// No layer.
    pub const NONE: Self = Self(0);
    /// The default layer (bit 0).
    pub const DEFAULT: Self = Self(1);

    /// Adds `layers` to this mask.
    pub fn add(&mut self, layers: impl Into<Self>) {
        *self |= layers.into();
    }

    /// Removes `layers` from this mask.
    pub fn remove(&mut self, layers: impl Into<Self>) {
        *self &= !layers.into();
    }

    /// Whether this mask contains every one of `layers`. (avian3d 0.7's method of this name
    /// answers whether it contains any of them; for a single layer the two agree.)
    pub fn has_all(self, layers: impl Into<Self>) -> bool {
        let layers = layers.into();
        (self & layers).0 == layers.0
    }

    /// Whether this mask and `layers` share a layer.
    pub fn intersects(self, layers: impl Into<Self>) -> bool {
        (self & layers).0 != 0
    }
}

impl From<u32> for LayerMask {
    fn from(bits: u32) -> Self {
        Self(bits)
    }
}

impl<L: PhysicsLayer> From<L> for LayerMask {
    fn from(layer: L) -> Self {
        Self(layer.to_bits())
    }
}

impl<L: Into<LayerMask>, const N: usize> From<[L; N]> for LayerMask {
    fn from(layers: [L; N]) -> Self {
        Self(layers.into_iter().fold(0, |bits, l| bits | l.into().0))
    }
}

impl<L: Into<LayerMask> + Copy> PartialEq<L> for LayerMask {
    fn eq(&self, other: &L) -> bool {
        self.0 == (*other).into().0
    }
}

impl<L: Into<LayerMask>> BitAnd<L> for LayerMask {
    type Output = Self;
    fn bitand(self, rhs: L) -> Self {
        Self(self.0 & rhs.into().0)
    }
}

impl<L: Into<LayerMask>> BitAndAssign<L> for LayerMask {
    fn bitand_assign(&mut self, rhs: L) {
        self.0 &= rhs.into().0;
    }
}

impl<L: Into<LayerMask>> BitOr<L> for LayerMask {
    type Output = Self;
    fn bitor(self, rhs: L) -> Self {
        Self(self.0 | rhs.into().0)
    }
}

impl<L: Into<LayerMask>> BitOrAssign<L> for LayerMask {
    fn bitor_assign(&mut self, rhs: L) {
        self.0 |= rhs.into().0;
    }
}

impl<L: Into<LayerMask>> BitXor<L> for LayerMask {
    type Output = Self;
    fn bitxor(self, rhs: L) -> Self {
        Self(self.0 ^ rhs.into().0)
    }
}

impl<L: Into<LayerMask>> BitXorAssign<L> for LayerMask {
    fn bitxor_assign(&mut self, rhs: L) {
        self.0 ^= rhs.into().0;
    }
}

impl Not for LayerMask {
    type Output = Self;
    fn not(self) -> Self {
        Self(!self.0)
    }
}

/// The layers a body belongs to (`memberships`) and the layers it interacts with (`filters`).
/// Two bodies interact when each one's filters contain a layer of the other's memberships
/// ([`interacts_with`](Self::interacts_with)): both directions must agree. A pair that does not
/// interact gets no contacts, no solver rows and no collision messages, whatever its bodies
/// are (dynamic, kinematic, static or [`Sensor`](crate::collision::Sensor)).
///
/// Immutable, as in avian3d: change a body's layers by inserting a new value (the step takes
/// it up in the next step, sleeping bodies included).
///
/// # Examples
///
/// ```
/// use bevy::prelude::*;
/// use impact3d::prelude::*;
///
/// // A ghost on layer 1 that touches only layer 2 (the ground), not the default layer.
/// let ghost = CollisionLayers::new(0b010, 0b100);
/// let ground = CollisionLayers::new(0b100, LayerMask::ALL);
/// assert!(ghost.interacts_with(ground));
/// assert!(!ghost.interacts_with(CollisionLayers::DEFAULT));
///
/// // Filtered one way only is enough to keep two bodies apart.
/// let deaf = CollisionLayers::new(LayerMask::DEFAULT, LayerMask::NONE);
/// assert!(!deaf.interacts_with(CollisionLayers::DEFAULT));
/// assert!(!CollisionLayers::DEFAULT.interacts_with(deaf));
///
/// # let mut world = World::new();
/// world.spawn((RigidBody::Dynamic, Collider::sphere(0.5), ghost));
/// ```
#[derive(Reflect, Component, Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[component(immutable)]
#[reflect(Debug, Component, PartialEq)]
pub struct CollisionLayers {
    /// The layers the body belongs to.
    pub memberships: LayerMask,
    /// The layers the body interacts with.
    pub filters: LayerMask,
}

impl CollisionLayers {
    /// The default layer, interacting with every layer: what a body without the component has.
    pub const DEFAULT: Self = Self {
        memberships: LayerMask::DEFAULT,
        filters: LayerMask::ALL,
    };
    /// Every layer, interacting with every layer.
    pub const ALL: Self = Self {
        memberships: LayerMask::ALL,
        filters: LayerMask::ALL,
    };
    /// No layer, interacting with none: touches nothing.
    pub const NONE: Self = Self {
        memberships: LayerMask::NONE,
        filters: LayerMask::NONE,
    };
    /// Every layer, interacting with none: touches nothing.
    pub const ALL_MEMBERSHIPS: Self = Self {
        memberships: LayerMask::ALL,
        filters: LayerMask::NONE,
    };
    /// No layer, interacting with every layer: touches nothing (nobody's filters contain it).
    pub const ALL_FILTERS: Self = Self {
        memberships: LayerMask::NONE,
        filters: LayerMask::ALL,
    };

    /// Layers from anything that converts into masks: bits, a [`PhysicsLayer`], or arrays of
    /// either.
    pub fn new(memberships: impl Into<LayerMask>, filters: impl Into<LayerMask>) -> Self {
        Self {
            memberships: memberships.into(),
            filters: filters.into(),
        }
    }

    /// Layers from bits (bit `k` is layer `k`).
    pub const fn from_bits(memberships: u32, filters: u32) -> Self {
        Self {
            memberships: LayerMask(memberships),
            filters: LayerMask(filters),
        }
    }

    /// Whether a body with these layers and one with `other` interact: `self`'s filters contain
    /// a layer of `other`'s memberships, and `other`'s filters a layer of `self`'s. Symmetric.
    /// The one test the step applies to every candidate pair (and that spatial queries are to
    /// apply with their filter's mask).
    pub fn interacts_with(self, other: Self) -> bool {
        (self.memberships.0 & other.filters.0) != 0 && (other.memberships.0 & self.filters.0) != 0
    }
}

impl Default for CollisionLayers {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Clone, Copy, Default)]
    enum GameLayer {
        #[default]
        Default,
        Player,
        Enemy,
        Ground,
    }

    impl PhysicsLayer for GameLayer {
        fn to_bits(&self) -> u32 {
            1 << *self as u32
        }
        fn all_bits() -> u32 {
            0b1111
        }
    }

    /// The same layers written as bits, as an enum and as masks are equal (avian3d's own
    /// creation test, with `has_all` meaning all).
    #[test]
    fn creation() {
        let bits = CollisionLayers::new(0b00100, 0b01011);
        let named = CollisionLayers::new(
            GameLayer::Enemy,
            [GameLayer::Default, GameLayer::Player, GameLayer::Ground],
        );
        let masks = CollisionLayers::new(LayerMask::from(GameLayer::Enemy), LayerMask(0b01011));
        assert_eq!(bits, named);
        assert_eq!(bits, masks);
        assert!(bits.memberships.has_all(GameLayer::Enemy));
        assert!(!bits.memberships.has_all(GameLayer::Player));
        assert!(bits.filters.has_all([GameLayer::Player, GameLayer::Ground]));
        assert!(!bits.filters.has_all([GameLayer::Player, GameLayer::Enemy]));
        assert!(
            bits.filters
                .intersects([GameLayer::Player, GameLayer::Enemy])
        );
        assert_eq!(
            GameLayer::all_bits(),
            LayerMask::from(GameLayer::Ground).0 * 2 - 1
        );
    }

    /// Every pair of 4-bit memberships and filters: `interacts_with` is the two-way rule,
    /// checked layer by layer, and symmetric.
    #[test]
    fn interaction_is_the_two_way_rule() {
        let layers = |m: u32, f: u32| CollisionLayers::from_bits(m, f);
        let shares = |a: u32, b: u32| (0..4).any(|k| a & b & (1 << k) != 0);
        for code in 0..(1u32 << 16) {
            let (ma, fa, mb, fb) = (code & 15, (code >> 4) & 15, (code >> 8) & 15, code >> 12);
            let (a, b) = (layers(ma, fa), layers(mb, fb));
            let expected = shares(ma, fb) && shares(mb, fa);
            assert_eq!(a.interacts_with(b), expected, "{a:?} {b:?}");
            assert_eq!(b.interacts_with(a), expected);
        }
        assert!(CollisionLayers::default().interacts_with(CollisionLayers::DEFAULT));
        assert!(!CollisionLayers::ALL.interacts_with(CollisionLayers::ALL_MEMBERSHIPS));
        assert!(!CollisionLayers::ALL.interacts_with(CollisionLayers::ALL_FILTERS));
    }

    /// The bit operators, against the same operations on the bits.
    #[test]
    fn operators_act_on_the_bits() {
        let (a, b) = (LayerMask(0b1100), LayerMask(0b1010));
        assert_eq!((a | b).0, 0b1110);
        assert_eq!((a & b).0, 0b1000);
        assert_eq!((a ^ b).0, 0b0110);
        assert_eq!((!a).0, !0b1100u32);
        let mut c = a;
        c ^= b;
        c &= 0b0100;
        assert_eq!(c, 0b0100);
        assert_eq!(*LayerMask::ALL, u32::MAX);
    }
}
