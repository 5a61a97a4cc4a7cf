//! Broad phase: sweep and prune over axis-aligned bounding boxes.

use parry3d::bounding_volume::Aabb;

/// Finds every pair of overlapping boxes by sweep and prune: sort the boxes by their lower
/// bound on the axis where their centres spread most, then compare each box only with those
/// whose interval on that axis starts before it ends. Writes `(i, j)` with `i < j`, sorted, into
/// `pairs`; `order` is scratch space. Ties are broken by index, so the output is deterministic.
///
/// Unbounded boxes (a half-space's) overlap everything and stay correct: they sort first.
///
/// # Examples
///
/// ```
/// use bevy::math::Vec3;
/// use parry3d::bounding_volume::Aabb;
/// use impact3d::collision::broad_phase::sweep_and_prune;
///
/// let boxes = [
///     Aabb::new(Vec3::ZERO, Vec3::ONE),
///     Aabb::new(Vec3::splat(0.5), Vec3::splat(1.5)),
///     Aabb::new(Vec3::splat(3.0), Vec3::splat(4.0)),
/// ];
/// let (mut pairs, mut order) = (Vec::new(), Vec::new());
/// sweep_and_prune(&boxes, &mut pairs, &mut order);
/// assert_eq!(pairs, vec![(0, 1)]);
/// ```
pub fn sweep_and_prune(aabbs: &[Aabb], pairs: &mut Vec<(u32, u32)>, order: &mut Vec<u32>) {
    pairs.clear();
    let axis = sweep_axis(aabbs);
    order.clear();
    order.extend(0..aabbs.len() as u32);
    sort_by_lower_bound(aabbs, order, axis);
    for (k, &i) in order.iter().enumerate() {
        for j in forward_overlaps(aabbs, order, k, axis) {
            pairs.push((i.min(j), i.max(j)));
        }
    }
    pairs.sort_unstable();
}

/// The pairs of overlapping boxes of which at least one is `active`, as [`sweep_and_prune`]
/// would give them filtered to those: `(i, j)` with `i < j`, sorted. Only the active boxes are
/// swept: forward as in `sweep_and_prune`, and backward over the inactive boxes that start at
/// most the widest box's width before them. Inactive boxes (sleeping bodies, unchanged static
/// ones) cost nothing beyond the sort, and nothing at all when no box is active.
///
/// # Examples
///
/// ```
/// use bevy::math::Vec3;
/// use parry3d::bounding_volume::Aabb;
/// use impact3d::collision::broad_phase::pairs_with_active;
///
/// let boxes = [
///     Aabb::new(Vec3::ZERO, Vec3::ONE),
///     Aabb::new(Vec3::splat(0.5), Vec3::splat(1.5)),
///     Aabb::new(Vec3::splat(1.2), Vec3::splat(2.0)),
/// ];
/// let (mut pairs, mut order) = (Vec::new(), Vec::new());
/// pairs_with_active(&boxes, &[false, false, true], &mut pairs, &mut order);
/// assert_eq!(pairs, vec![(1, 2)]);
/// pairs_with_active(&boxes, &[false; 3], &mut pairs, &mut order);
/// assert!(pairs.is_empty());
/// ```
pub fn pairs_with_active(
    aabbs: &[Aabb],
    active: &[bool],
    pairs: &mut Vec<(u32, u32)>,
    order: &mut Vec<u32>,
) {
    pairs.clear();
    if !active.iter().any(|&a| a) {
        return;
    }
    let axis = sweep_axis(aabbs);
    let unbounded = is_unbounded;
    // Unbounded boxes (a half-space's) are checked against every active box directly; the
    // others are sorted by their lower bound on the axis.
    order.clear();
    order.extend((0..aabbs.len() as u32).filter(|&i| !unbounded(&aabbs[i as usize])));
    sort_by_lower_bound(aabbs, order, axis);
    let widest = order
        .iter()
        .map(|&i| aabbs[i as usize].maxs[axis] - aabbs[i as usize].mins[axis])
        .fold(0.0f32, f32::max);
    let huge: Vec<u32> = (0..aabbs.len() as u32)
        .filter(|&i| unbounded(&aabbs[i as usize]))
        .collect();
    let any_inactive = active.iter().any(|&a| !a);
    let push = |pairs: &mut Vec<(u32, u32)>, i: u32, j: u32| pairs.push((i.min(j), i.max(j)));
    for &h in &huge {
        let a = &aabbs[h as usize];
        for j in 0..aabbs.len() as u32 {
            // An unbounded box pairs with the boxes it overlaps when either is active; pairs
            // of two unbounded boxes are found once, from the smaller index.
            let both_huge = unbounded(&aabbs[j as usize]);
            if j != h
                && (active[h as usize] || active[j as usize])
                && (!both_huge || h < j)
                && overlaps(a, &aabbs[j as usize])
            {
                push(pairs, h, j);
            }
        }
    }
    for (k, &i) in order.iter().enumerate() {
        if !active[i as usize] {
            continue;
        }
        let a = &aabbs[i as usize];
        // Forward, as in `sweep_and_prune`: every box starting before this one ends.
        for j in forward_overlaps(aabbs, order, k, axis) {
            push(pairs, i, j);
        }
        // Backward, for the inactive boxes that start before this one (an active one there
        // found this box in its own forward sweep): they start at most `widest` earlier.
        if any_inactive {
            let from = a.mins[axis] - widest;
            let start = order[..k].partition_point(|&j| aabbs[j as usize].mins[axis] < from);
            for &j in &order[start..k] {
                if !active[j as usize] && overlaps(a, &aabbs[j as usize]) {
                    push(pairs, i, j);
                }
            }
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
}

/// A box too large to sort usefully (a half-space's), or with a NaN extent: such boxes are
/// checked against every box directly.
pub(crate) fn is_unbounded(b: &Aabb) -> bool {
    (b.maxs - b.mins).max_element().partial_cmp(&1e6) != Some(std::cmp::Ordering::Less)
}

/// Sorts box indices by their lower bound on `axis` (ties by index, so the order is
/// deterministic).
pub(crate) fn sort_by_lower_bound(aabbs: &[Aabb], order: &mut [u32], axis: usize) {
    order.sort_unstable_by(|&i, &j| {
        aabbs[i as usize].mins[axis]
            .total_cmp(&aabbs[j as usize].mins[axis])
            .then(i.cmp(&j))
    });
}

/// The boxes after `order[k]` in the sorted `order` that overlap it: the sweep stops at the
/// first that starts after it ends on `axis`.
fn forward_overlaps<'a>(
    aabbs: &'a [Aabb],
    order: &'a [u32],
    k: usize,
    axis: usize,
) -> impl Iterator<Item = u32> + 'a {
    let a = &aabbs[order[k] as usize];
    order[k + 1..]
        .iter()
        .copied()
        .take_while(move |&j| aabbs[j as usize].mins[axis] <= a.maxs[axis])
        .filter(move |&j| overlaps(a, &aabbs[j as usize]))
}

/// Whether two boxes overlap (touching counts).
pub(crate) fn overlaps(a: &Aabb, b: &Aabb) -> bool {
    (0..3).all(|k| a.mins[k] <= b.maxs[k] && b.mins[k] <= a.maxs[k])
}

/// The axis (0, 1 or 2) along which the centres of the bounded boxes spread most.
pub(crate) fn sweep_axis(aabbs: &[Aabb]) -> usize {
    let mut sum = [0.0f64; 3];
    let mut sum_sq = [0.0f64; 3];
    let mut n = 0.0f64;
    for b in aabbs {
        let extent = b.maxs - b.mins;
        // Unbounded boxes (a half-space's) and NaN extents say nothing about the spread.
        if extent.max_element().partial_cmp(&1e6) != Some(std::cmp::Ordering::Less) {
            continue;
        }
        n += 1.0;
        let c = (b.mins + b.maxs) * 0.5;
        for k in 0..3 {
            sum[k] += c[k] as f64;
            sum_sq[k] += (c[k] as f64) * (c[k] as f64);
        }
    }
    if n == 0.0 {
        return 0;
    }
    let variance = |k: usize| sum_sq[k] / n - (sum[k] / n).powi(2);
    (0..3)
        .max_by(|&i, &j| variance(i).total_cmp(&variance(j)).then(j.cmp(&i)))
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::Vec3;

    /// Sweep and prune finds exactly the pairs the all-pairs test finds, on a pseudo-random
    /// cloud of boxes (a fixed linear congruential sequence, so the test is reproducible).
    #[test]
    fn matches_all_pairs() {
        let mut seed = 12345u32;
        let mut next = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut boxes: Vec<Aabb> = (0..300)
            .map(|_| {
                let c = Vec3::new(next() * 20.0, next() * 5.0, next() * 20.0);
                let h = Vec3::new(next(), next(), next()) * 0.8 + 0.1;
                Aabb::new(c - h, c + h)
            })
            .collect();
        boxes.push(Aabb::new(
            Vec3::splat(-f32::MAX * 0.5),
            Vec3::splat(f32::MAX * 0.5),
        ));
        let (mut pairs, mut order) = (Vec::new(), Vec::new());
        sweep_and_prune(&boxes, &mut pairs, &mut order);
        let mut brute = Vec::new();
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                if overlaps(&boxes[i], &boxes[j]) {
                    brute.push((i as u32, j as u32));
                }
            }
        }
        assert_eq!(pairs, brute);
        assert!(
            pairs.len() > 300,
            "the unbounded box pairs with all 300 others"
        );
        // With a third of the boxes active (the unbounded one among them, and not), the active
        // sweep gives exactly the all-pairs result filtered to pairs with an active box.
        for unbounded_active in [false, true] {
            let mut active: Vec<bool> = (0..boxes.len()).map(|i| i % 3 == 0).collect();
            active[300] = unbounded_active;
            let mut got = Vec::new();
            pairs_with_active(&boxes, &active, &mut got, &mut order);
            let expected: Vec<_> = brute
                .iter()
                .copied()
                .filter(|&(i, j)| active[i as usize] || active[j as usize])
                .collect();
            assert_eq!(got, expected);
        }
    }
}
