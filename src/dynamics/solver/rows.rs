//! Compressed rows: for each of `n` keys (bodies), the values given to it, in one buffer.

use super::refill;

/// For each key `0..n`, the values an iterator of `(key, value)` entries gave it, in entry
/// order, stored as compressed rows (one buffer of values and each key's start in it). The
/// buffers are kept between builds, so rebuilding a table of the same size allocates nothing.
#[derive(Clone, Debug, Default)]
pub(crate) struct CompressedRows {
    /// Each key's first value in `values`; `start[n]` is the number of values.
    start: Vec<u32>,
    /// The values, key by key.
    values: Vec<u32>,
    /// Each key's next free place in `values`, while they are written.
    fill: Vec<u32>,
}

impl CompressedRows {
    /// Rebuilds the table for keys `0..n` from `entries` (read twice: once to count, once to
    /// fill), its earlier contents dropped.
    pub(crate) fn build(&mut self, n: usize, entries: impl Iterator<Item = (usize, u32)> + Clone) {
        let CompressedRows {
            start,
            values,
            fill,
        } = self;
        refill(start, n + 1, 0);
        for (key, _) in entries.clone() {
            start[key + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        fill.clear();
        fill.extend_from_slice(start);
        refill(values, start[n] as usize, 0);
        for (key, value) in entries {
            values[fill[key] as usize] = value;
            fill[key] += 1;
        }
    }

    /// The values of `key`, in the order their entries came.
    #[inline]
    pub(crate) fn row(&self, key: usize) -> &[u32] {
        &self.values[self.start[key] as usize..self.start[key + 1] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each key's values in entry order, an empty key empty, and a rebuild forgets the last
    /// table: the same as pushing each entry onto a vector per key.
    #[test]
    fn rows_hold_each_keys_values_in_entry_order() {
        let entries = [(2, 7), (0, 1), (2, 3), (3, 9), (0, 4)];
        let mut rows = CompressedRows::default();
        rows.build(4, entries.iter().copied());
        let mut expected = vec![Vec::new(); 4];
        for &(key, value) in &entries {
            expected[key].push(value);
        }
        for (key, values) in expected.iter().enumerate() {
            assert_eq!(rows.row(key), values.as_slice(), "key {key}");
        }
        rows.build(2, [(1, 5)].into_iter());
        assert_eq!(rows.row(0), &[] as &[u32]);
        assert_eq!(rows.row(1), &[5]);
    }
}
