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

    /// The next pass to render; None once every tile has finished (none
    /// waiting, none being rendered that could come back) or `cancel` is
    /// set. While the only tiles left are being rendered by other threads,
    /// waits for them: one may come back for another pass.
    pub fn take(&self, cancel: &AtomicBool) -> Option<Pass<'_>> {
        let mut state = self.lock();
        loop {
            if cancel.load(Ordering::Relaxed) {
                return None;
            }
            if let Some(Reverse((pass, tile))) = state.tiles.pop() {
                state.in_flight += 1;
                return Some(Pass {
                    queue: self,
                    pass,
                    tile,
                    ended: false,
                });
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

    fn pass_done(&self, tile: usize, next: Option<u32>) {
        let mut state = self.lock();
        state.in_flight -= 1;
        if let Some(pass) = next {
            state.tiles.push(Reverse((pass, tile)));
        }
        drop(state);
        self.pass_ended.notify_all();
    }
}

/// A tile's pass, taken from a [`TileQueue`].
#[derive(Debug)]
pub(crate) struct Pass<'q> {
    queue: &'q TileQueue,
    /// Which pass of the tile (0 = its first).
    pub pass: u32,
    pub tile: usize,
    ended: bool,
}

impl Pass<'_> {
    /// Ends the pass; the tile comes back for its next one if `more`.
    pub fn end(mut self, more: bool) {
        self.ended = true;
        self.queue
            .pass_done(self.tile, more.then_some(self.pass + 1));
    }
}

impl Drop for Pass<'_> {
    /// A pass dropped without [`end`](Pass::end) (its thread panicked)
    /// still ends, the tile with it: the other threads, which may be
    /// waiting for it, finish, and the panic reaches the caller instead of
    /// leaving them waiting for ever.
    fn drop(&mut self) {
        if !self.ended {
            self.queue.pass_done(self.tile, None);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// (pass, tile) of what `take` returns.
    fn taken(queue: &TileQueue, cancel: &AtomicBool) -> Option<(u32, usize)> {
        queue.take(cancel).map(|p| {
            let at = (p.pass, p.tile);
            std::mem::forget(p);
            at
        })
    }

    /// One thread: every tile's first pass, then every tile's second, …,
    /// each pass in tile order; tiles drop out when they have no more.
    #[test]
    fn every_tile_takes_a_pass_before_any_takes_the_next() {
        let passes = [3u32, 1, 2];
        let queue = TileQueue::new(passes.len());
        let cancel = AtomicBool::new(false);
        let mut order = Vec::new();
        while let Some(p) = queue.take(&cancel) {
            order.push((p.pass, p.tile));
            let more = p.pass + 1 < passes[p.tile];
            p.end(more);
        }
        assert_eq!(order, [(0, 0), (0, 1), (0, 2), (1, 0), (1, 2), (2, 0)]);
    }

    /// A tile being rendered elsewhere keeps a thread that finds nothing
    /// waiting from leaving: the tile may come back for another pass.
    #[test]
    fn a_thread_waits_for_tiles_in_flight_and_stops_on_cancel() {
        let queue = TileQueue::new(1);
        let cancel = AtomicBool::new(false);
        let first = queue.take(&cancel).unwrap();
        std::thread::scope(|s| {
            let waiter = s.spawn(|| taken(&queue, &cancel));
            std::thread::sleep(std::time::Duration::from_millis(50));
            assert!(!waiter.is_finished(), "left while a tile was in flight");
            first.end(true);
            assert_eq!(waiter.join().unwrap(), Some((1, 0)));
        });
        // Its last pass: nothing left, nobody waits.
        queue.pass_done(0, None);
        assert_eq!(taken(&queue, &cancel), None);

        // Cancelled while waiting: a pass that ends afterwards does not
        // hand its tile back to the waiting thread.
        let queue = TileQueue::new(2);
        let first = queue.take(&cancel).unwrap();
        let _second = queue.take(&cancel).unwrap();
        std::thread::scope(|s| {
            let waiter = s.spawn(|| taken(&queue, &cancel));
            std::thread::sleep(std::time::Duration::from_millis(50));
            cancel.store(true, Ordering::Relaxed);
            first.end(true);
            assert_eq!(waiter.join().unwrap(), None);
        });
    }

    /// A thread that panics mid-pass ends its pass as it unwinds: a thread
    /// waiting for that tile finishes instead of waiting for ever.
    #[test]
    fn a_panicking_pass_does_not_leave_the_others_waiting() {
        let queue = TileQueue::new(1);
        let cancel = AtomicBool::new(false);
        std::thread::scope(|s| {
            let pass = queue.take(&cancel).unwrap();
            let waiter = s.spawn(|| taken(&queue, &cancel));
            let panicked = s.spawn(move || {
                let _pass = pass;
                panic!("a bug in a stage");
            });
            assert!(panicked.join().is_err());
            assert_eq!(waiter.join().unwrap(), None);
        });
    }
}
