//! A manifold as a block of rows: its support, hold, load and lever, and what a block solve
//! returns.

use super::*;

/// Settings of [`manifold_sweep`].
#[derive(Clone, Copy, Debug)]
pub struct ManifoldSolve {
    /// The soft spring for penetrating points; `None` for the rigid relax pass.
    pub soft: Option<Softness>,
    /// `1/h`, 1/s.
    pub inv_h: f32,
    /// Largest push-out speed, m/s.
    pub max_push_out: f32,
    /// Skip speculative rows approaching faster than this, m/s (see [`soft_sweep`](crate::dynamics::solver::soft_step::soft_sweep)).
    pub leave_impacts: Option<f32>,
    /// Most Gauss-Seidel iterations spent on one manifold per sweep.
    pub max_block_iterations: u32,
    /// A manifold's iterations stop once no row changes by more than this, m/s.
    pub tolerance: f32,
    /// `omega^2 / |g|`, 1/m: the soft contact's angular frequency squared over gravity's
    /// magnitude (infinite without gravity; the world's gravity, not counting the bodies' extra
    /// accelerations). A load-carrying manifold with friction gets soft
    /// rows only where this times its points' second moment is at least [`TILT_MARGIN`] times
    /// its lever (see [`manifold_sweep`]).
    pub tilt_stiffness: f32,
}

/// How much stiffer than its load's toppling moment the soft tilt of a load-carrying manifold
/// must be, for its points to be solved as soft rows (see [`manifold_sweep`]).
pub const TILT_MARGIN: f32 = 4.0;

/// How much tighter than [`ManifoldSolve::tolerance`] the rows of a manifold with friction and
/// a rigid tilt are solved (see [`manifold_sweep`]).
pub const RIGID_FRICTION_TOLERANCE: f32 = 1e-3;

/// One row of a manifold block: `(bias, soft)`, or `None` when the row takes no part.
pub type BlockRow = Option<(f32, bool)>;

/// Which body of a manifold block is its support, held by [`Block::hold`] while the block is
/// solved (see `shock_order` and `support_holds`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Support {
    /// Neither: both bodies respond (the usual two-body solve).
    Neither,
    /// Body A supports body B.
    A,
    /// Body B supports body A.
    B,
}

/// One manifold of the hybrid method's resting solve: its contacts, its support, how firmly
/// that support is held, and the mass it carries.
#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    /// The manifold's range in the contact slice.
    pub range: Range<usize>,
    /// The body held (wholly or partly) while the block is solved.
    pub support: Support,
    /// The fraction of the support's response to this block's impulse that the support's own
    /// supports take, in `[0, 1]`: the support responds in the block's solve with its inverse
    /// mass and inertia scaled by `1 - hold`. 1 for a static or kinematic support and for a body
    /// resting squarely on supports that are themselves held; 0 for a body free to move along
    /// the block's normal (see `support_holds`).
    pub hold: f32,
    /// The support's linear response per unit impulse along the contact normal, in place of
    /// the normal itself (scaled by its inverse mass): the part of a push that its own supports
    /// do not take, `n - s P(n)` in `support_holds`' terms. Its component along the normal is
    /// `1 - hold`. Unused without a support.
    pub push: Vec3,
    /// The mass this manifold's own impulse bears, kg: its supported body and that body's
    /// share of everything that presses on it in turn, that is, of all it carries except what
    /// passes on through it (see `carried_loads` and [`Block::passes_on`]). 0 for a manifold
    /// with no support, whose stiffness is then set by its own effective mass.
    pub load: f32,
    /// How high the centre of mass of what it carries stands above its centroid, along its
    /// normal, m (see `carried_loads`): the arm through which a tilt of
    /// the manifold moves that weight sideways. 0 with no support.
    pub lever: f32,
    /// The mean square distance of its points from their centroid over two, m^2 (the second
    /// moment about one axis of a rectangle's corners), set with [`Block::lever`].
    pub spread: f32,
    /// Some point of it can push and is within the touch distance at the start of the step:
    /// only touching manifolds make levels, support, share loads (see `shock_order`).
    pub touching: bool,
    /// Its supported body carries a released block (see `release_frictional_groups`): the load
    /// above that body comes through two-body soft rows, not a held chain (see
    /// [`manifold_sweep`] on which manifolds with friction keep a rigid tilt).
    pub carries_released: bool,
    /// What its hold leaves free of its support's response, its support's supports' friction
    /// holds: the support rests on fixed bodies only, the push lies inside their friction cone,
    /// and its line crosses the support's footprint (see `held_by_friction`; set by
    /// `support_holds`). Such a support passes its load on like a wholly held one.
    pub gripped: bool,
    /// The held part of its normal impulse (all of it where the support is held wholly) is
    /// passed on through its support, not applied to it (see [`held_warm_start`] and
    /// [`Transmitted`]; set by `mark_passing_on`).
    pub passes_on: bool,
}

impl Block {
    /// (the body this block supports, its support), if it has a support.
    pub fn pair(&self, contacts: &[ContactConstraint]) -> Option<(usize, usize)> {
        let c = &contacts[self.range.start];
        match self.support {
            Support::A => Some((c.body_b, c.body_a)),
            Support::B => Some((c.body_a, c.body_b)),
            Support::Neither => None,
        }
    }

    /// The body this block supports, if it has a support.
    pub fn upper(&self, contacts: &[ContactConstraint]) -> Option<usize> {
        self.pair(contacts).map(|(upper, _)| upper)
    }

    /// How each body responds to the block's impulse along `normal`: per body, its linear
    /// direction (the normal for a free body, [`Block::push`] for the support) and the factor on
    /// its angular response (1 for a free body, `1 - hold` for the support).
    pub fn response(&self, normal: Vec3) -> Response {
        let free = Side {
            direction: None,
            along_normal: 1.0,
            angular: 1.0,
        };
        let held = if self.hold > 0.0 {
            Side {
                direction: Some(self.push),
                along_normal: normal.dot(self.push),
                angular: 1.0 - self.hold.min(1.0),
            }
        } else {
            free
        };
        let (a, b) = match self.support {
            Support::Neither => (free, free),
            Support::A => (held, free),
            Support::B => (free, held),
        };
        Response { a, b }
    }
}

/// How one body of a block responds to the block's impulse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Side {
    /// Direction of its velocity change per unit impulse, before its inverse mass; `None`: the
    /// row's own normal (a free body).
    pub direction: Option<Vec3>,
    /// `direction . n`: 1 for a free body (exactly), `1 - hold` for a held support.
    pub along_normal: f32,
    /// Factor on its angular response.
    pub angular: f32,
}

impl Side {
    /// The direction of its velocity change per unit impulse on a row with normal `normal`,
    /// before its inverse mass.
    #[inline]
    pub fn direction_for(&self, normal: Vec3) -> Vec3 {
        self.direction.unwrap_or(normal)
    }

    /// The factor on its angular response to a row whose angular terms are `angular` (see
    /// [`ContactConstraint::angular`]): [`Side::angular`], or 0 where it does not turn.
    #[inline]
    pub fn turn(&self, angular: bool) -> f32 {
        if angular && self.angular > 0.0 {
            self.angular
        } else {
            0.0
        }
    }
}

/// How the two bodies of a block respond to its impulse (see [`Block::response`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Response {
    /// Body A.
    pub a: Side,
    /// Body B.
    pub b: Side,
}
