//! The engine's own passes on the rayon pool, taken only where the pool has more than one thread
//! and the work is large enough: on one thread, a pass handed to the pool would only move to its
//! thread and back (and its data to that thread's core), and on a small mesh the hand-off costs
//! more than the pass (a mesh of 576 faces took a quarter longer when every pass went to the
//! pool). Every
//! parallel pass here gives the result of the sequential one, bit for bit.

use rayon::prelude::*;

/// Work smaller than this (faces, edges, vertices) stays on the calling thread.
const MIN_ITEMS: usize = 1 << 14;

/// Whether work over `items` elements goes to the pool.
fn worth_it(items: usize) -> bool {
    items >= MIN_ITEMS && rayon::current_num_threads() > 1
}

/// `(a(), b())`, side by side where the two together cover `items` elements that are
/// [`worth_it`].
pub(crate) fn join<A: Send, B: Send>(
    items: usize,
    a: impl FnOnce() -> A + Send,
    b: impl FnOnce() -> B + Send,
) -> (A, B) {
    if worth_it(items) { rayon::join(a, b) } else { (a(), b()) }
}

/// `f` over the `block`-long blocks of `items` (the last may be shorter) with the block's index,
/// the results in the blocks' order.
pub(crate) fn map_blocks<T: Sync, R: Send>(
    items: &[T],
    block: usize,
    f: impl Fn(usize, &[T]) -> R + Sync + Send,
) -> Vec<R> {
    if items.len() > block && worth_it(items.len()) {
        items.par_chunks(block).enumerate().map(|(i, chunk)| f(i, chunk)).collect()
    } else {
        items.chunks(block).enumerate().map(|(i, chunk)| f(i, chunk)).collect()
    }
}
