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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lanes::{LANES, Vec3x8};
    use crate::sampling::SampleStream;

    /// Every dead path's radiance lands in its slot, and the live paths
    /// survive whole (all arrays moved together), whatever the pattern.
    #[test]
    fn retires_the_dead_and_keeps_every_live_path_whole() {
        let patterns: [&[bool]; 7] = [
            &[],
            &[true, true, true],
            &[false, false, false],
            &[true, false, true, false, true],
            &[false, true, true, false],
            &[true, true, false, false],
            &[false, true, false, false, true, true, false, true],
        ];
        for alive in patterns {
            let mut paths = Paths::default();
            for (k, &a) in alive.iter().enumerate() {
                let f = k as f32;
                let stream = [SampleStream::new(3, k as u32, 0); LANES];
                let (origin, dir) = (Vec3x8::splat(Vec3::splat(f)), Vec3x8::splat(Vec3::X));
                paths.start(1, &[k as u32; LANES], &stream, origin, dir, f + 1.0);
                paths.radiance[k] = Vec3::new(f, 2.0 * f, 1.0);
                paths.depth[k] = k as u32;
                paths.alive[k] = a;
            }
            let mut slots = vec![Vec3::NEG_ONE; alive.len()];
            let live = compact(&mut paths, &mut slots);
            let expected_live: Vec<usize> = (0..alive.len()).filter(|&k| alive[k]).collect();
            assert_eq!(live, expected_live.len(), "{alive:?}");
            assert_eq!(paths.len(), live);
            let mut kept: Vec<usize> = paths.slot.iter().map(|&s| s as usize).collect();
            kept.sort_unstable();
            assert_eq!(kept, expected_live, "{alive:?}");
            for i in 0..live {
                let k = paths.slot[i] as usize;
                let f = k as f32;
                assert!(paths.alive[i]);
                assert_eq!(paths.depth[i], k as u32);
                assert_eq!(paths.radiance[i], Vec3::new(f, 2.0 * f, 1.0));
                assert_eq!(paths.stream[i], SampleStream::new(3, k as u32, 0));
                assert_eq!(paths.rays.origin(i), Vec3::splat(f));
                assert_eq!(paths.rays.t_max[i], f + 1.0);
            }
            for (k, &a) in alive.iter().enumerate() {
                let f = k as f32;
                let want = if a {
                    Vec3::NEG_ONE
                } else {
                    Vec3::new(f, 2.0 * f, 1.0)
                };
                assert_eq!(slots[k], want, "{alive:?}, slot {k}");
            }
        }
    }
}
