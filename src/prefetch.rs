//! Asking the cache for a line before it is read, where a stage can say
//! what it will read while other work is still to be done. The lookups of
//! an environment map, whose tables and texels (megabytes for a map of
//! 2048 columns) mostly miss the cache, are split into a pass that finds
//! the addresses of a group of lanes and requests them and a pass that
//! reads them once they have arrived, so the group's misses overlap
//! instead of following one another; a closest-hit walk requests the
//! node it will most likely visit next while it tests a leaf.

/// Requests the cache line holding `value` (a hint only: it reads
/// nothing, cannot fault, and does nothing on targets without one).
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    prefetch_address((value as *const T).cast());
}

/// Requests every cache line of `value` (for structures of a few lines
/// read whole, such as a wide node's bounds).
#[inline(always)]
pub fn prefetch_all<T>(value: &T) {
    let start: *const u8 = (value as *const T).cast();
    for offset in (0..std::mem::size_of::<T>()).step_by(64) {
        prefetch_address(start.wrapping_add(offset));
    }
}

#[inline(always)]
fn prefetch_address(address: *const u8) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint that touches no memory the program can
    // observe and cannot fault, whatever the address.
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>(address.cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = address;
}
