//! Per-stage counters: rays processed and time spent, summed over tiles.

use std::ops::AddAssign;
use std::time::Instant;

use crate::bvh::TraversalStats;

/// Work and time of one stage.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stage {
    pub items: u64,
    pub nanos: u64,
    pub runs: u64,
}

impl Stage {
    /// Adds a run over `items` that started at `start`.
    #[inline]
    pub fn record(&mut self, items: usize, start: Instant) {
        self.items += items as u64;
        self.nanos += start.elapsed().as_nanos() as u64;
        self.runs += 1;
    }
}

impl AddAssign for Stage {
    fn add_assign(&mut self, o: Stage) {
        self.items += o.items;
        self.nanos += o.nanos;
        self.runs += o.runs;
    }
}

#[derive(Clone, Copy, Debug, Default)]
pub struct Stats {
    pub generate: Stage,
    pub intersect: Stage,
    pub shade: Stage,
    pub shadow: Stage,
    pub probe: Stage,
    pub compact: Stage,
    pub film: Stage,
    pub traversal: TraversalStats,
    /// Camera samples taken.
    pub samples: u64,
}

impl Stats {
    /// (name, what its items are, stage) for reporting, in pipeline order.
    pub fn stages(&self) -> [(&'static str, &'static str, Stage); 7] {
        [
            ("generate", "camera rays", self.generate),
            ("intersect", "rays", self.intersect),
            ("shade", "path vertices, hits and misses", self.shade),
            ("shadow-test", "shadow rays", self.shadow),
            ("probe (-H)", "rays", self.probe),
            ("compact", "paths", self.compact),
            ("film", "pixel samples", self.film),
        ]
    }

    /// Rays traced: closest-hit plus shadow and probe rays.
    pub fn rays(&self) -> u64 {
        self.intersect.items + self.shadow.items + self.probe.items
    }
}

impl AddAssign for Stats {
    fn add_assign(&mut self, o: Stats) {
        self.generate += o.generate;
        self.intersect += o.intersect;
        self.shade += o.shade;
        self.shadow += o.shadow;
        self.probe += o.probe;
        self.compact += o.compact;
        self.film += o.film;
        self.traversal += o.traversal;
        self.samples += o.samples;
    }
}
