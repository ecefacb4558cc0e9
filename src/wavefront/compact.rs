//! Stage 5: retire finished paths and compact the live ones.
//!
//! A finished path writes its radiance into its result slot. The live
//! paths are gathered at the front so the batch is dense again and the
//! generate stage can refill its tail with new camera paths: waves stay
//! full.

use glam::Vec3;

use super::paths::Paths;

/// Retires dead paths into `slots`; returns how many paths live on.
///
/// Holes are filled from the back (the last live path moves into the
/// first hole), so a wave moves one path per path that died, not every
/// live path behind the first hole. Nothing depends on the order of paths
/// in a wave: each path carries its own sample stream and result slot.
pub fn compact(paths: &mut Paths, slots: &mut [Vec3]) -> usize {
    for (&alive, (&slot, &radiance)) in paths
        .alive
        .iter()
        .zip(paths.slot.iter().zip(&paths.radiance))
    {
        if !alive {
            slots[slot as usize] = radiance;
        }
    }
    let (mut lo, mut hi) = (0, paths.len());
    loop {
        while lo < hi && paths.alive[lo] {
            lo += 1;
        }
        while hi > lo && !paths.alive[hi - 1] {
            hi -= 1;
        }
        if lo >= hi {
            break;
        }
        // `lo` is dead and `hi − 1 > lo` is live.
        paths.move_path(hi - 1, lo);
        lo += 1;
        hi -= 1;
    }
    paths.truncate(lo);
    lo
}
