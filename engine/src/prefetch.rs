//! Cache prefetch hints for the simplifier's random accesses (`safe_arch` wraps the instruction, so
//! this crate keeps no `unsafe`).

/// Asks the cache for the line holding `value`. A hint only: it reads nothing, never faults and
/// changes no result; on targets without the instruction it does nothing.
#[inline(always)]
pub(crate) fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    safe_arch::prefetch_t0(value);
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}
