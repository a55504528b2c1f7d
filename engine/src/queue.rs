//! The collapse queue: a small 4-ary min-heap of 16-byte entries over an unordered array.
//!
//! The simplifier pushes about seven entries per collapse and pops one or two (a stale one is
//! skipped). Most pushed entries go stale before they could be popped, and a heap over all of them
//! (100 k entries and more) is not in cache: every pop walks its whole depth through cache misses.
//! [`TieredQueue`] keeps only the front of the order in a heap (a sixteenth of the entries), the
//! rest unordered; an entry is 16 bytes (four to a cache line); the heap is 4-ary, so a pop walks
//! half as many levels as a binary heap and reads the four children of a node from one or two
//! cache lines; and while a pop compares four children it asks for the lines of their children,
//! one of which it reads next.

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

/// Packs a non-negative cost, its quadric error and the squared length of its edge into one
/// ordered integer: every zero-cost candidate (a flat region under QFVP with w > 0) comes before
/// every positive one, and among the zero-cost ones the smaller quadric error comes first.
/// Non-negative `f32` bit patterns order like the numbers and stay below 2³¹, which leaves the top
/// bit to separate the two groups.
///
/// An error that vanishes in `f32` (zero, or below its normal range: an exactly planar
/// neighbourhood) would tie every such candidate; they go shortest edge first instead, the length's
/// bits scaled into the subnormal range below every normal error. On planar regions this order
/// refuses far fewer candidates than the ties' order in the heap did (shorter edges make fewer
/// needles; docs/history/benchmarks-log.md), and it does not depend on how the queue is laid out.
#[inline]
pub(crate) fn order_key(cost: f64, error: f64, length2: f64) -> u32 {
    let bits = |x: f64| if x.is_nan() { f32::INFINITY.to_bits() } else { (x.max(0.0) as f32).to_bits() };
    let cost = bits(cost);
    if cost != 0 {
        return 0x8000_0000 | cost;
    }
    let error = bits(error);
    if error >= f32::MIN_POSITIVE.to_bits() { error } else { bits(length2) >> 8 }
}

const ARITY: usize = 4;

/// A 4-ary min-heap of [`QueueEntry`]: the front of a [`TieredQueue`].
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

    /// Keeps only the entries `keep` accepts ([`retain_unordered`]) and restores the heap order
    /// (linear time).
    pub(crate) fn retain(&mut self, keep: impl FnMut(&QueueEntry) -> bool) {
        let mut entries = std::mem::take(&mut self.entries);
        retain_unordered(&mut entries, keep);
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

/// The collapse queue: a small heap of the entries ranked at most `threshold` (the front of the
/// greedy order) over an unordered array of the rest.
///
/// A push above the threshold is an append; pops walk a heap of a few thousand entries, in cache;
/// and when the heap runs dry, one pass over the array drops its stale entries and moves the
/// lowest-ranked ~1/[`REFILL_SHARE`] of the rest into the heap (the threshold read at that share of
/// an evenly spaced sample). The pops come in the order of a single heap over every entry: each
/// entry of the array ranks above each entry of the heap. Against one heap of every entry, with a
/// sweep and a rebuild whenever a quarter of it was stale, it took less time, through fewer cache
/// misses above all; other shares did no better (docs/history/benchmarks-log.md).
#[derive(Debug, Default)]
pub(crate) struct TieredQueue {
    hot: CollapseQueue,
    cold: Vec<QueueEntry>,
    /// Every hot entry ranks at most this, every cold one above it.
    threshold: u64,
}

/// A refill moves about 1/REFILL_SHARE of the current entries into the heap.
const REFILL_SHARE: usize = 16;
/// Refills move at least this many entries (while there are so many).
const REFILL_MIN: usize = 2048;
/// Entries sampled to place the threshold.
const SAMPLES: usize = 512;

impl TieredQueue {
    /// Every entry starts in the array; the first pop fills the heap.
    pub(crate) fn new(entries: Vec<QueueEntry>) -> TieredQueue {
        TieredQueue { hot: CollapseQueue::default(), cold: entries, threshold: 0 }
    }

    /// Entries held, stale ones included.
    pub(crate) fn len(&self) -> usize {
        self.hot.len() + self.cold.len()
    }

    pub(crate) fn push(&mut self, entry: QueueEntry) {
        if entry.rank() <= self.threshold {
            self.hot.push(entry);
        } else {
            self.cold.push(entry);
        }
    }

    /// The lowest-ranked entry, if the heap holds one (a hint: an empty heap over a non-empty
    /// array says `None`; [`TieredQueue::top`] refills).
    #[inline]
    pub(crate) fn peek(&self) -> Option<&QueueEntry> {
        self.hot.peek()
    }

    /// The lowest-ranked entry, refilling the heap from the array if it is empty.
    pub(crate) fn top(&mut self, current: impl Fn(&QueueEntry) -> bool) -> Option<&QueueEntry> {
        self.refill_if_dry(current);
        self.hot.peek()
    }

    pub(crate) fn pop(&mut self, current: impl Fn(&QueueEntry) -> bool) -> Option<QueueEntry> {
        self.refill_if_dry(current);
        self.hot.pop()
    }

    #[inline]
    fn refill_if_dry(&mut self, current: impl Fn(&QueueEntry) -> bool) {
        if self.hot.len() == 0 {
            self.refill(current);
        }
    }

    /// Drops the stale entries (those `current` refuses) of the heap and of the array.
    pub(crate) fn sweep(&mut self, current: impl Fn(&QueueEntry) -> bool) {
        self.hot.retain(&current);
        retain_unordered(&mut self.cold, current);
    }

    /// Moves the lowest-ranked current entries of the array into the (empty) heap, dropping the
    /// stale ones on the way; repeats with a higher threshold while it moved none (all stale).
    fn refill(&mut self, current: impl Fn(&QueueEntry) -> bool) {
        debug_assert_eq!(self.hot.len(), 0);
        while !self.cold.is_empty() {
            let n = self.cold.len();
            let wanted = (n / REFILL_SHARE).max(REFILL_MIN);
            let threshold = if wanted >= n {
                u64::MAX
            } else {
                // The rank at the wanted share of an evenly spaced sample: deterministic.
                let step = (n / SAMPLES).max(1);
                let mut sample: Vec<u64> = self.cold.iter().step_by(step).map(|e| e.rank()).collect();
                let at = (sample.len() * wanted / n).min(sample.len() - 1);
                *sample.select_nth_unstable(at).1
            };
            let mut taken = Vec::with_capacity(wanted + wanted / 2);
            let mut kept = 0;
            for read in 0..n {
                let entry = self.cold[read];
                let live = current(&entry);
                if live && entry.rank() <= threshold {
                    taken.push(entry);
                } else {
                    self.cold[kept] = entry;
                    kept += live as usize;
                }
            }
            self.cold.truncate(kept);
            self.threshold = threshold;
            if !taken.is_empty() {
                self.hot = CollapseQueue::from_vec(taken);
                return;
            }
        }
    }
}

/// Keeps the entries `keep` accepts, in their order: every entry is copied and the write position
/// advanced by the verdict, without a branch on it (a quarter to a third of the entries are dropped,
/// in no pattern a predictor could learn).
fn retain_unordered(entries: &mut Vec<QueueEntry>, mut keep: impl FnMut(&QueueEntry) -> bool) {
    let mut kept = 0;
    for read in 0..entries.len() {
        let entry = entries[read];
        entries[kept] = entry;
        kept += keep(&entry) as usize;
    }
    entries.truncate(kept);
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

    /// Pushes and pops interleaved, as the simplifier does, with a share of the entries going
    /// stale: the tiered queue pops the current entries in the order one heap would, each once,
    /// and never a stale one that a refill or a sweep has seen.
    #[test]
    fn tiered_queue_pops_like_one_heap() {
        let mut rng = SplitMix64::new(23);
        // An entry is current while its stamp is at least the stamp of its `a` (stale below).
        let mut floor = vec![0u32; 64];
        let mut next_id = 0u32;
        let mut entry = |rng: &mut SplitMix64, floor: &[u32]| {
            let a = (rng.next_u64() % 64) as u32;
            next_id += 1;
            QueueEntry::new((rng.next_u64() % 5000) as u32, a, next_id, floor[a as usize])
        };
        let initial: Vec<QueueEntry> = (0..20_000).map(|_| entry(&mut rng, &floor)).collect();
        let mut queue = TieredQueue::new(initial.clone());
        let mut reference = CollapseQueue::from_vec(initial);
        let mut popped = 0;
        for step in 0..60_000 {
            match rng.next_u64() % 10 {
                0..=3 => {
                    let e = entry(&mut rng, &floor);
                    queue.push(e);
                    reference.push(e);
                }
                4 => {
                    let a = (rng.next_u64() % 64) as usize;
                    floor[a] += 1;
                }
                5 if step % 97 == 0 => {
                    let floor = &floor;
                    queue.sweep(|e| e.stamp >= floor[e.a() as usize]);
                }
                _ => {
                    let floor = &floor;
                    let current = |e: &QueueEntry| e.stamp >= floor[e.a() as usize];
                    let expected = loop {
                        match reference.pop() {
                            Some(e) if !current(&e) => continue,
                            other => break other,
                        }
                    };
                    let got = loop {
                        match queue.pop(current) {
                            Some(e) if !current(&e) => continue,
                            other => break other,
                        }
                    };
                    assert_eq!(got.map(|e| e.rank()), expected.map(|e| e.rank()), "step {step}");
                    if got.is_some() {
                        popped += 1;
                    }
                }
            }
        }
        assert!(popped > 20_000, "the test drains a good part of the queue ({popped} pops)");
        assert!(queue.len() <= reference.len(), "stale entries are dropped on the way");
    }

    #[test]
    fn zero_costs_come_first_ordered_by_error() {
        assert!(order_key(0.0, 1.0, 1.0) < order_key(1e-30, 0.0, 1.0));
        assert!(order_key(0.0, 0.5, 1.0) < order_key(0.0, 1.0, 1.0));
        assert!(order_key(1.0, 5.0, 1.0) < order_key(2.0, 0.0, 1.0));
        assert_eq!(order_key(0.0, 0.0, 0.0), 0);
        assert!(order_key(f64::NAN, 0.0, 1.0) >= order_key(f64::MAX, 0.0, 1.0));
        // A vanishing error: shorter edges first, all of them before any error in f32's normal
        // range, whatever the length (an infinite one included).
        assert!(order_key(0.0, 0.0, 1.0) < order_key(0.0, 0.0, 2.0));
        assert!(order_key(0.0, 1e-45, 1.0) < order_key(0.0, 0.0, 2.0));
        assert!(order_key(0.0, 0.0, f64::INFINITY) < order_key(0.0, f32::MIN_POSITIVE as f64, 0.0));
        assert!(order_key(0.0, 0.0, f64::NAN) < order_key(0.0, f32::MIN_POSITIVE as f64, 0.0));
    }
}
