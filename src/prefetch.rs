//! Asking the cache for a line before it is read, where a stage can say
//! what it will read while other work is still to be done: the lookups
//! of an environment map, whose tables and texels (megabytes for a map
//! of 2048 columns) mostly miss the cache, are split into a pass that
//! finds the addresses of a group of lanes and requests them, and a
//! pass that reads them once they have arrived, so the group's misses
//! overlap instead of following one another.

/// Requests the cache line holding `value` (a hint only: it reads
/// nothing, cannot fault, and does nothing on targets without one).
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint that touches no memory the program
    // can observe; the pointer comes from a live reference.
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>((value as *const T).cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}
