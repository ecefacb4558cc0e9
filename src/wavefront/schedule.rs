//! The order in which tiles take their passes: progressive.
//!
//! Every tile takes its k-th pass before any tile starts its (k+1)-th,
//! except that a thread finding no tile left at pass k goes on with one at
//! pass k + 1 while the others finish theirs (no barrier between passes).
//! So at any moment the whole image has been sampled nearly evenly: a
//! render stopped by Ctrl-C leaves every pixel its first passes, instead of
//! some tiles with all their samples and the rest black. The image does not
//! depend on the order: each pixel's samples are a function of the seed,
//! the pixel and the sample index, and its film sums them in sample order.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex, MutexGuard, PoisonError};

/// The tiles waiting for a pass, lowest pass first (ties by tile index, so
/// row-major order within a pass), and how many are being rendered.
#[derive(Debug)]
pub(crate) struct TileQueue {
    state: Mutex<Waiting>,
    /// Woken when a pass ends: a tile may be waiting again, or the last
    /// one has finished.
    pass_ended: Condvar,
}

#[derive(Debug)]
struct Waiting {
    /// (pass, tile), smallest first.
    tiles: BinaryHeap<Reverse<(u32, usize)>>,
    in_flight: usize,
}

impl TileQueue {
    /// Tiles `0..tiles`, each waiting for its first pass (pass 0).
    pub fn new(tiles: usize) -> TileQueue {
        TileQueue {
            state: Mutex::new(Waiting {
                tiles: (0..tiles).map(|t| Reverse((0, t))).collect(),
                in_flight: 0,
            }),
            pass_ended: Condvar::new(),
        }
    }

    fn lock(&self) -> MutexGuard<'_, Waiting> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The next (pass, tile) to render; None once every tile has finished
    /// (none waiting, none being rendered that could come back) or
    /// `cancel` is set. While the only tiles left are being rendered by
    /// other threads, waits for them: one may come back for another pass.
    pub fn take(&self, cancel: &AtomicBool) -> Option<(u32, usize)> {
        let mut state = self.lock();
        loop {
            if cancel.load(Ordering::Relaxed) {
                return None;
            }
            if let Some(Reverse(next)) = state.tiles.pop() {
                state.in_flight += 1;
                return Some(next);
            }
            if state.in_flight == 0 {
                return None;
            }
            state = self
                .pass_ended
                .wait(state)
                .unwrap_or_else(PoisonError::into_inner);
        }
    }

    /// Ends a pass taken with [`take`](Self::take): the tile waits for
    /// pass `next` if it has one.
    pub fn pass_done(&self, tile: usize, next: Option<u32>) {
        let mut state = self.lock();
        state.in_flight -= 1;
        if let Some(pass) = next {
            state.tiles.push(Reverse((pass, tile)));
        }
        drop(state);
        self.pass_ended.notify_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One thread: every tile's first pass, then every tile's second, …,
    /// each pass in tile order; tiles drop out when they have no more.
    #[test]
    fn every_tile_takes_a_pass_before_any_takes_the_next() {
        let passes = [3u32, 1, 2];
        let queue = TileQueue::new(passes.len());
        let cancel = AtomicBool::new(false);
        let mut order = Vec::new();
        while let Some((pass, tile)) = queue.take(&cancel) {
            order.push((pass, tile));
            queue.pass_done(tile, (pass + 1 < passes[tile]).then_some(pass + 1));
        }
        assert_eq!(order, [(0, 0), (0, 1), (0, 2), (1, 0), (1, 2), (2, 0)]);
    }

    /// A tile being rendered elsewhere keeps a thread that finds nothing
    /// waiting from leaving: the tile may come back for another pass.
    #[test]
    fn a_thread_waits_for_tiles_in_flight_and_stops_on_cancel() {
        let queue = TileQueue::new(1);
        let cancel = AtomicBool::new(false);
        assert_eq!(queue.take(&cancel), Some((0, 0)));
        std::thread::scope(|s| {
            let waiter = s.spawn(|| queue.take(&cancel));
            std::thread::sleep(std::time::Duration::from_millis(50));
            assert!(!waiter.is_finished(), "left while a tile was in flight");
            queue.pass_done(0, Some(1));
            assert_eq!(waiter.join().unwrap(), Some((1, 0)));
        });
        // Its last pass: nothing left, nobody waits.
        queue.pass_done(0, None);
        assert_eq!(queue.take(&cancel), None);

        // Cancelled while waiting: a pass that ends afterwards does not
        // hand its tile back to the waiting thread.
        let queue = TileQueue::new(2);
        assert_eq!(queue.take(&cancel), Some((0, 0)));
        assert_eq!(queue.take(&cancel), Some((0, 1)));
        std::thread::scope(|s| {
            let waiter = s.spawn(|| queue.take(&cancel));
            std::thread::sleep(std::time::Duration::from_millis(50));
            cancel.store(true, Ordering::Relaxed);
            queue.pass_done(0, Some(1));
            assert_eq!(waiter.join().unwrap(), None);
        });
    }
}
