//! Sleeping: resting islands are taken out of the step until something touches them.
//!
//! A dynamic body is *slow* when `|v| + |w| R` (the speed of its farthest point, `R` its
//! bounding radius about the centre of mass) stays below [`SleepConfig::linear_threshold`].
//! Bodies that touch (a contact point within the contact margin) form an island; when every
//! body of an island has been slow for [`SleepConfig::time_to_sleep`], the whole island sleeps:
//! its velocities are zeroed, it gets the [`Sleeping`] marker, and it enters later steps as a
//! static body (no solver work; pairs of sleeping or static bodies are not even narrow-phased).
//! An island wakes, all at once, when an awake body touches one of its bodies, or when the user
//! changes a sleeping body's pose or velocity or removes its `Sleeping` marker.

use bevy::prelude::*;

/// Marks a sleeping body. Insert `Sleeping::default()` to put a body to sleep on its own;
/// remove it to wake the body.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Eq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct Sleeping {
    /// A body of the island this body fell asleep with, which names the island: bodies of one
    /// island wake together. `Entity::PLACEHOLDER` (the default) is an island of its own.
    pub island: Entity,
}

impl Default for Sleeping {
    fn default() -> Self {
        Sleeping {
            island: Entity::PLACEHOLDER,
        }
    }
}

/// How long a dynamic body has been slow, s. Maintained by the plugin.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct SleepTimer(pub f32);

/// Sleeping settings.
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Debug, Default, PartialEq)]
pub struct SleepConfig {
    /// Let resting islands sleep. Default true.
    pub enabled: bool,
    /// A body is slow while `|v| + |w| R` stays below this, m/s. Default 0.05 (Box2D's).
    pub linear_threshold: f32,
    /// An island sleeps once all its bodies have been slow this long, s. Default 0.5.
    pub time_to_sleep: f32,
}

impl Default for SleepConfig {
    fn default() -> Self {
        SleepConfig {
            enabled: true,
            linear_threshold: 0.05,
            time_to_sleep: 0.5,
        }
    }
}

/// Disjoint sets over `0..n` with path halving and union by index (deterministic roots: the
/// smallest index of each set).
pub struct Islands {
    parent: Vec<u32>,
}

impl Islands {
    /// `n` singletons.
    pub fn new(n: usize) -> Self {
        Islands {
            parent: (0..n as u32).collect(),
        }
    }

    /// The root (smallest member) of `i`'s island.
    pub fn find(&mut self, mut i: u32) -> u32 {
        while self.parent[i as usize] != i {
            let grand = self.parent[self.parent[i as usize] as usize];
            self.parent[i as usize] = grand;
            i = grand;
        }
        i
    }

    /// Joins the islands of `a` and `b`.
    pub fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            let (lo, hi) = (ra.min(rb), ra.max(rb));
            self.parent[hi as usize] = lo;
        }
    }
}

/// Decides which bodies fall asleep this step. `timers[i]` is body `i`'s slow time (s) after
/// this step, or `None` for bodies that take no part (static, kinematic, sleeping, or kept
/// awake); `links` are pairs of touching participating bodies. Returns, for each body, the
/// island root it sleeps with, if its whole island has been slow for `time_to_sleep`.
///
/// # Examples
///
/// ```
/// use impact3d::dynamics::sleep::islands_to_sleep;
///
/// // Bodies 0-1 touch and are both slow long enough; 2 touches 3, which is not slow yet.
/// let timers = [Some(0.6), Some(0.7), Some(0.9), Some(0.1)];
/// let asleep = islands_to_sleep(&timers, &[(0, 1), (2, 3)], 0.5);
/// assert_eq!(asleep, vec![Some(0), Some(0), None, None]);
/// ```
pub fn islands_to_sleep(
    timers: &[Option<f32>],
    links: &[(u32, u32)],
    time_to_sleep: f32,
) -> Vec<Option<u32>> {
    let mut islands = Islands::new(timers.len());
    for &(a, b) in links {
        islands.union(a, b);
    }
    // An island may sleep only if every member is slow long enough.
    let mut ready = vec![true; timers.len()];
    for (i, timer) in timers.iter().enumerate() {
        let root = islands.find(i as u32) as usize;
        if timer.is_none_or(|t| t < time_to_sleep) {
            ready[root] = false;
        }
    }
    (0..timers.len())
        .map(|i| {
            let root = islands.find(i as u32);
            (timers[i].is_some() && ready[root as usize]).then_some(root)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A chain 0-1-2 sleeps only when all three are ready; a body linked to a non-participant
    /// (here 3, e.g. touching a moving kinematic body, marked None) keeps its island awake.
    #[test]
    fn islands_sleep_together() {
        let t = |x: f32| Some(x);
        assert_eq!(
            islands_to_sleep(&[t(1.0), t(1.0), t(1.0)], &[(0, 1), (1, 2)], 0.5),
            vec![Some(0); 3]
        );
        assert_eq!(
            islands_to_sleep(&[t(1.0), t(1.0), t(0.2)], &[(0, 1), (1, 2)], 0.5),
            vec![None; 3]
        );
        assert_eq!(
            islands_to_sleep(&[t(1.0), t(1.0), None], &[(1, 2)], 0.5),
            vec![Some(0), None, None]
        );
    }
}
