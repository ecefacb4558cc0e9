//! The order in which tiles take their passes: progressive.
//!
//! Every tile takes its k-th pass before any tile starts its (k+1)-th,
//! except that a thread finding no tile left at pass k goes on with one at
//! pass k + 1 while the others finish theirs (no barrier between passes).
//! So once every tile has had its first pass, the whole image has been
//! sampled nearly evenly: a render stopped by Ctrl-C leaves every pixel its
//! first passes, instead of some tiles with all their samples and the rest
//! black. The image does not depend on the order: each pixel's samples are
//! a function of the seed, the pixel and the sample index, and its film
//! sums them in sample order.
//!
//! A thread that finds the queue empty is done for good: every tile not
//! finished is then being rendered by another thread, which takes it back
//! itself if it has passes left, and a tile's passes run one after another
//! anyway. So no thread ever waits for another.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::Mutex;

use super::lock;

/// The tiles waiting for a pass: (pass, tile), lowest pass first, ties by
/// tile index (row-major order within a pass).
#[derive(Debug)]
pub(crate) struct TileQueue {
    waiting: Mutex<BinaryHeap<Reverse<(u32, usize)>>>,
}

impl TileQueue {
    /// Tiles `tiles`, each waiting for its first pass (pass 0).
    pub fn new(tiles: impl IntoIterator<Item = usize>) -> TileQueue {
        TileQueue {
            waiting: Mutex::new(tiles.into_iter().map(|t| Reverse((0, t))).collect()),
        }
    }

    /// The next (pass, tile) to render, if any tile is waiting.
    pub fn take(&self) -> Option<(u32, usize)> {
        lock(&self.waiting).pop().map(|Reverse(next)| next)
    }

    /// Puts `tile` back, waiting for its pass `pass`.
    pub fn give_back(&self, tile: usize, pass: u32) {
        lock(&self.waiting).push(Reverse((pass, tile)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One thread: every tile's first pass, then every tile's second, …,
    /// each pass in tile order; tiles drop out when they have no more.
    #[test]
    fn every_tile_takes_a_pass_before_any_takes_the_next() {
        let passes = [3u32, 1, 2, 5];
        // Tile 3 is not queued (nothing to render).
        let queue = TileQueue::new(0..3);
        let mut order = Vec::new();
        while let Some((pass, tile)) = queue.take() {
            order.push((pass, tile));
            if pass + 1 < passes[tile] {
                queue.give_back(tile, pass + 1);
            }
        }
        assert_eq!(order, [(0, 0), (0, 1), (0, 2), (1, 0), (1, 2), (2, 0)]);
    }

    /// A tile given back for a later pass waits behind every tile of an
    /// earlier pass, even those given back after it.
    #[test]
    fn earlier_passes_go_first_whatever_order_tiles_come_back_in() {
        let queue = TileQueue::new([4, 2]);
        assert_eq!(queue.take(), Some((0, 2)));
        queue.give_back(2, 1);
        queue.give_back(7, 0);
        assert_eq!(queue.take(), Some((0, 4)));
        assert_eq!(queue.take(), Some((0, 7)));
        assert_eq!(queue.take(), Some((1, 2)));
        assert_eq!(queue.take(), None);
    }
}
