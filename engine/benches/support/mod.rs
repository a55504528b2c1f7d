//! Shared helpers of the bench binaries: a peak-tracking allocator and timing.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Counts live and peak heap bytes.
pub struct PeakAlloc;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for PeakAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let live = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(live, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            if new_size > layout.size() {
                let live = LIVE.fetch_add(new_size - layout.size(), Ordering::Relaxed) + new_size - layout.size();
                PEAK.fetch_max(live, Ordering::Relaxed);
            } else {
                LIVE.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
            }
        }
        p
    }
}

/// Runs `f` and returns its result with the heap growth above the bytes live before it.
pub fn peak_during<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let base = LIVE.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    let out = f();
    (out, PEAK.load(Ordering::Relaxed) - base)
}

/// Best wall times of `runs` calls of `f` and of `g`, alternating f, g, f, g, … so that a burst of
/// load on a shared machine falls on both sides alike; the last results.
#[allow(dead_code)] // not every bench compares with a peer
pub fn best_of_interleaved<A, B>(
    runs: usize,
    mut f: impl FnMut() -> A,
    mut g: impl FnMut() -> B,
) -> ((A, f64), (B, f64)) {
    let (mut best_f, mut best_g) = (f64::INFINITY, f64::INFINITY);
    let (mut last_f, mut last_g) = (None, None);
    // The clock stops before a result replaces the previous one: dropping that one (for meshlod,
    // megabytes of progressive mesh handed back to the system) is not part of the call measured.
    for _ in 0..runs {
        let t = Instant::now();
        let out = f();
        best_f = best_f.min(t.elapsed().as_secs_f64());
        last_f = Some(out);
        let t = Instant::now();
        let out = g();
        best_g = best_g.min(t.elapsed().as_secs_f64());
        last_g = Some(out);
    }
    ((last_f.expect("runs > 0"), best_f), (last_g.expect("runs > 0"), best_g))
}

/// Best wall time of `runs` calls, in seconds, and the last result.
pub fn best_of<T>(runs: usize, mut f: impl FnMut() -> T) -> (T, f64) {
    let mut best = f64::INFINITY;
    let mut last = None;
    for _ in 0..runs {
        let t = Instant::now();
        let out = f();
        best = best.min(t.elapsed().as_secs_f64());
        last = Some(out);
    }
    (last.expect("runs > 0"), best)
}
