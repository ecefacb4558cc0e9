//! Stage 5: retire finished paths and compact the live ones.
//!
//! A finished path writes its radiance into its result slot. Live paths are
//! moved down, in order, so the batch is dense again and the generate stage
//! can refill its tail with new camera paths: waves stay full.

use glam::Vec3;

use super::paths::Paths;

/// Retires dead paths into `slots`; returns how many paths live on.
pub fn compact(paths: &mut Paths, slots: &mut [Vec3]) -> usize {
    let mut live = 0;
    for i in 0..paths.len() {
        if paths.alive[i] {
            if live != i {
                paths.move_path(i, live);
            }
            live += 1;
        } else {
            slots[paths.slot[i] as usize] = paths.radiance[i];
        }
    }
    paths.truncate(live);
    live
}
