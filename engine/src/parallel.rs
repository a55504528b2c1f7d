//! The engine's own passes on the rayon pool, taken only where the pool has more than one thread:
//! on one, a pass handed to the pool would only move to its thread and back (and its data to that
//! thread's core). Every parallel pass here gives the result of the sequential one, bit for bit.

use rayon::prelude::*;

/// Whether the pool the caller would hand work to has more than one thread.
pub(crate) fn enabled() -> bool {
    rayon::current_num_threads() > 1
}

/// `(a(), b())`, side by side where [`enabled`].
pub(crate) fn join<A: Send, B: Send>(a: impl FnOnce() -> A + Send, b: impl FnOnce() -> B + Send) -> (A, B) {
    if enabled() { rayon::join(a, b) } else { (a(), b()) }
}

/// `f` over the `block`-long blocks of `items` (the last may be shorter) with the block's index,
/// the results in the blocks' order.
pub(crate) fn map_blocks<T: Sync, R: Send>(
    items: &[T],
    block: usize,
    f: impl Fn(usize, &[T]) -> R + Sync + Send,
) -> Vec<R> {
    if enabled() {
        items.par_chunks(block).enumerate().map(|(i, chunk)| f(i, chunk)).collect()
    } else {
        items.chunks(block).enumerate().map(|(i, chunk)| f(i, chunk)).collect()
    }
}
