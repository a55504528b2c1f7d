//! The collapse queue: a 4-ary min-heap of 16-byte entries.
//!
//! The simplifier pushes about seven entries per collapse and pops one or two (a stale one is
//! skipped), and the lower levels of a heap of 100 k entries are not in cache, so the queue's
//! memory traffic is a large share of its time. An entry is 16 bytes (four to a cache line); the
//! heap is 4-ary, so a pop walks half as many levels as a binary heap and reads the four children
//! of a node from one or two cache lines; and while a pop compares four children it asks for the
//! lines of their children, one of which it reads next.

use crate::prefetch::prefetch;

/// A queued candidate collapse of edge {a, b}, ordered by `(key, a)`: one integer comparison.
/// Entries that tie on both still pop in an order fixed by the push sequence, so a run is
/// deterministic.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct QueueEntry {
    /// The ordered cost ([`order_key`]) in the high half, `a` in the low half.
    rank: u64,
    pub(crate) b: u32,
    /// Sum of the two endpoints' version stamps when queued: stamps only grow, so the entry is
    /// current exactly when the sum is unchanged.
    pub(crate) stamp: u32,
}

impl QueueEntry {
    pub(crate) fn new(key: u32, a: u32, b: u32, stamp: u32) -> QueueEntry {
        QueueEntry { rank: ((key as u64) << 32) | a as u64, b, stamp }
    }

    #[inline]
    pub(crate) fn a(&self) -> u32 {
        self.rank as u32
    }

    #[inline]
    pub(crate) fn rank(&self) -> u64 {
        self.rank
    }
}

/// Packs a non-negative cost and its quadric error into one ordered integer: every zero-cost
/// candidate (a flat region under QFVP with w > 0) comes before every positive one, and among the
/// zero-cost ones the smaller quadric error comes first. Non-negative `f32` bit patterns order like
/// the numbers and stay below 2³¹, which leaves the top bit to separate the two groups.
#[inline]
pub(crate) fn order_key(cost: f64, error: f64) -> u32 {
    let bits = |x: f64| if x.is_nan() { f32::INFINITY.to_bits() } else { (x.max(0.0) as f32).to_bits() };
    let cost = bits(cost);
    if cost == 0 { bits(error) } else { 0x8000_0000 | cost }
}

const ARITY: usize = 4;

/// A 4-ary min-heap of [`QueueEntry`].
#[derive(Debug, Default)]
pub(crate) struct CollapseQueue {
    entries: Vec<QueueEntry>,
}

impl CollapseQueue {
    /// Builds the heap from unordered entries in linear time.
    pub(crate) fn from_vec(entries: Vec<QueueEntry>) -> CollapseQueue {
        let mut queue = CollapseQueue { entries };
        let n = queue.entries.len();
        if n > 1 {
            for i in (0..=(n - 2) / ARITY).rev() {
                queue.sift_down::<false>(i);
            }
        }
        queue
    }

    pub(crate) fn len(&self) -> usize {
        self.entries.len()
    }

    /// Keeps only the entries `keep` accepts, in their order, and restores the heap order (linear
    /// time). Every entry is copied and the write position advanced by the verdict, without a
    /// branch on it: a quarter to a third of the entries are dropped, in no pattern a predictor
    /// could learn.
    pub(crate) fn retain(&mut self, mut keep: impl FnMut(&QueueEntry) -> bool) {
        let mut entries = std::mem::take(&mut self.entries);
        let mut kept = 0;
        for read in 0..entries.len() {
            let entry = entries[read];
            entries[kept] = entry;
            kept += keep(&entry) as usize;
        }
        entries.truncate(kept);
        *self = CollapseQueue::from_vec(entries);
    }

    pub(crate) fn push(&mut self, entry: QueueEntry) {
        self.entries.push(entry);
        let mut i = self.entries.len() - 1;
        let rank = entry.rank();
        while i > 0 {
            let parent = (i - 1) / ARITY;
            if self.entries[parent].rank() <= rank {
                break;
            }
            self.entries[i] = self.entries[parent];
            i = parent;
        }
        self.entries[i] = entry;
    }

    /// The entry `pop` would return next.
    #[inline]
    pub(crate) fn peek(&self) -> Option<&QueueEntry> {
        self.entries.first()
    }

    pub(crate) fn pop(&mut self) -> Option<QueueEntry> {
        let last = self.entries.pop()?;
        if self.entries.is_empty() {
            return Some(last);
        }
        let top = std::mem::replace(&mut self.entries[0], last);
        self.sift_down::<true>(0);
        Some(top)
    }

    /// With `PREFETCH`, asks for the next level's lines while comparing the current one: a pop
    /// walks from the root to a random leaf; heapifying walks the array backwards, which the
    /// hardware prefetcher follows by itself.
    ///
    /// A node with all four children (every node above the last level but one) takes the path
    /// with fixed bounds: one range check for the four, none per child.
    fn sift_down<const PREFETCH: bool>(&mut self, mut i: usize) {
        let entries = &mut self.entries[..];
        let n = entries.len();
        let entry = entries[i];
        let rank = entry.rank();
        loop {
            let first = ARITY * i + 1;
            let (best, best_rank) = if let Some(children) = entries.get(first..first + ARITY) {
                // The next level is one of four groups below these children: asking for all four
                // while these are compared hides most of the wait for the one that is taken.
                if PREFETCH {
                    let grandchildren = ARITY * first + 1;
                    if let Some(last) = entries.get(grandchildren + ARITY * (ARITY - 1)) {
                        prefetch(&entries[grandchildren]);
                        prefetch(&entries[grandchildren + ARITY]);
                        prefetch(&entries[grandchildren + 2 * ARITY]);
                        prefetch(last);
                    } else {
                        for c in 0..ARITY {
                            if let Some(grandchild) = entries.get(grandchildren + ARITY * c) {
                                prefetch(grandchild);
                            }
                        }
                    }
                }
                let children: &[QueueEntry; ARITY] = children.try_into().expect("four children");
                let (best, best_rank) = lowest(children);
                (first + best, best_rank)
            } else if first < n {
                // The last parent: fewer than four children, none with children of its own.
                let (best, best_rank) = lowest(&entries[first..]);
                (first + best, best_rank)
            } else {
                break;
            };
            if best_rank >= rank {
                break;
            }
            entries[i] = entries[best];
            i = best;
        }
        entries[i] = entry;
    }
}

/// The position and rank of the lowest-ranked of `children` (the first of equals), not empty.
#[inline(always)]
fn lowest(children: &[QueueEntry]) -> (usize, u64) {
    let mut best = 0;
    let mut best_rank = children[0].rank();
    for (c, child) in children.iter().enumerate().skip(1) {
        let r = child.rank();
        if r < best_rank {
            best = c;
            best_rank = r;
        }
    }
    (best, best_rank)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    #[test]
    fn pops_in_order_of_key_then_first_vertex() {
        let mut rng = SplitMix64::new(7);
        let mut reference = Vec::new();
        let mut entries = Vec::new();
        for i in 0..500u32 {
            let e = QueueEntry::new((rng.next_u64() % 50) as u32, (rng.next_u64() % 20) as u32, i, 0);
            entries.push(e);
            reference.push(e);
        }
        let mut queue = CollapseQueue::from_vec(entries);
        for i in 0..300u32 {
            let e = QueueEntry::new((rng.next_u64() % 50) as u32, 3, 1000 + i, 1);
            queue.push(e);
            reference.push(e);
        }
        let mut popped = Vec::new();
        while let Some(e) = queue.pop() {
            popped.push(e);
        }
        assert!(popped.windows(2).all(|w| w[0].rank() <= w[1].rank()), "popped out of order");
        let key = |e: &QueueEntry| (e.rank(), e.b, e.stamp);
        popped.sort_by_key(key);
        reference.sort_by_key(key);
        assert_eq!(popped, reference, "every pushed entry pops exactly once");
    }

    #[test]
    fn retain_drops_entries_and_keeps_the_order() {
        let mut rng = SplitMix64::new(11);
        let entries: Vec<QueueEntry> =
            (0..1000u32).map(|i| QueueEntry::new((rng.next_u64() % 100) as u32, i % 37, i, i % 3)).collect();
        let mut queue = CollapseQueue::from_vec(entries.clone());
        queue.retain(|e| e.stamp != 0);
        assert_eq!(queue.len(), entries.iter().filter(|e| e.stamp != 0).count());
        let mut previous = 0;
        while let Some(e) = queue.pop() {
            assert_ne!(e.stamp, 0);
            assert!(e.rank() >= previous);
            previous = e.rank();
        }
    }

    #[test]
    fn zero_costs_come_first_ordered_by_error() {
        assert!(order_key(0.0, 1.0) < order_key(1e-30, 0.0));
        assert!(order_key(0.0, 0.5) < order_key(0.0, 1.0));
        assert!(order_key(1.0, 5.0) < order_key(2.0, 0.0));
        assert_eq!(order_key(0.0, 0.0), 0);
        assert!(order_key(f64::NAN, 0.0) >= order_key(f64::MAX, 0.0));
    }
}
