//! Sampling an environment map for next-event estimation: directions
//! drawn in proportion to the light the map sends, so a small bright sun
//! in a dark sky gets nearly every sample rather than its share of the
//! sphere.
//!
//! The map is cut into cells, one per texel, each spanning its texel's
//! interval of φ and of θ. A cell is chosen with probability ∝ its weight
//! — the mean of the map's (bilinear) radiance over the cell, summed over
//! the colour channels, times the cell's solid angle — first its row, then
//! its column within the row; a direction is then uniform in solid angle
//! inside the cell (uniform in φ and in cos θ). The density of a direction
//! in cell (i, j) is therefore p = P(row j) · P(column i | j) / Ω_j, where
//! Ω_j = (2π / width) · (cos θ_j − cos θ_{j+1}), and a sample weighs
//! L(ω) / p.
//!
//! The weight is the exact mean of the interpolated radiance over the cell
//! (texel centres are at half-integers, so a cell's radiance comes from its
//! texel with weight ¾ and its two neighbours with ⅛ each, per axis), so
//! any cell where the map sends light has weight > 0: no direction that
//! brings light has density 0, and the estimate is unbiased. The choices
//! are [`SlotTable`]s of 2²⁴ slots, indexed by the 24-bit draws exactly,
//! so each cell's probability is the one the weight divides by; the
//! position inside the cell takes 16 more random bits per axis, so it is
//! uniform even in a cell that owns a single slot.

use std::f64::consts::{PI, TAU};
use std::sync::Arc;

use glam::Vec3;

use super::lights::LightSample;
use crate::lanes::{self, LANES};
use crate::prefetch::prefetch;
use crate::sampling::slots::{self, SlotTable, choose, owned};
use crate::scene::EnvironmentMap;
use crate::scene::environment::{azimuth, directions, polar_cosine};

/// Slots per choice: a draw in [0, 1) holds 24 bits.
const SLOTS: u64 = 1 << 24;

/// An environment map and the tables that sample it.
#[derive(Clone, Debug)]
pub struct EnvironmentLight {
    pub map: Arc<EnvironmentMap>,
    /// Where each row's slots end (a [`SlotTable`] of rows by their cells'
    /// summed weight), as `u32`: half the memory of the table's `u64`s,
    /// which the searches wait on when they miss the cache.
    row_ends: Vec<u32>,
    /// Where each cell's slots end within its row (each row a table of its
    /// cells by weight; all 0 for a row of weight 0, never chosen).
    column_ends: Vec<u32>,
    /// Where the search for a slot starts among the rows.
    row_guide: Guide,
    /// Where the search for a slot starts in each row's columns.
    column_guides: Vec<Guide>,
    /// cos θ at each row's upper and lower edge: `height + 1` values from 1 to −1.
    edge_cos: Vec<f64>,
}

impl EnvironmentLight {
    /// The sampling tables of `map`. `None` if the map sends no light.
    pub fn new(map: Arc<EnvironmentMap>) -> Option<EnvironmentLight> {
        let (w, h) = (map.width() as usize, map.height() as usize);
        // `EnvironmentMap::new` keeps both sides within the slots.
        debug_assert!(w as u64 <= SLOTS && h as u64 <= SLOTS, "{w}x{h} map");
        let edge_cos: Vec<f64> = (0..=h).map(|j| polar_cosine(j as f64, h as u32)).collect();
        // Channel sums, then the cell means: ⅛ ¾ ⅛ along each axis,
        // wrapping around in φ and clamped at the poles as lookups are.
        let filter = |a: f64, b: f64, c: f64| 0.125 * a + 0.75 * b + 0.125 * c;
        let sum = |x: i64, y: i64| map.texel(x, y).as_dvec3().element_sum();
        let across: Vec<f64> = (0..h as i64)
            .flat_map(|y| (0..w as i64).map(move |x| (x, y)))
            .map(|(x, y)| filter(sum(x - 1, y), sum(x, y), sum(x + 1, y)))
            .collect();
        let at = |x: usize, y: i64| across[y.clamp(0, h as i64 - 1) as usize * w + x];
        let mut row_weights = Vec::with_capacity(h);
        let mut column_ends = Vec::with_capacity(h * w);
        for j in 0..h {
            let band = edge_cos[j] - edge_cos[j + 1];
            let y = j as i64;
            let weights: Vec<f64> = (0..w)
                .map(|i| filter(at(i, y - 1), at(i, y), at(i, y + 1)) * band)
                .collect();
            row_weights.push(weights.iter().sum::<f64>());
            column_ends.extend(ends(SlotTable::new(&weights, SLOTS).as_ref(), w));
        }
        let rows = SlotTable::new(&row_weights, SLOTS)?;
        let row_ends: Vec<u32> = ends(Some(&rows), h).collect();
        Some(EnvironmentLight {
            row_guide: Guide::new(&row_ends),
            column_guides: column_ends.chunks_exact(w).map(Guide::new).collect(),
            row_ends,
            column_ends,
            edge_cos,
            map,
        })
    }

    /// The slots of row `j`'s cells.
    fn columns(&self, j: usize) -> &[u32] {
        let w = self.map.width() as usize;
        &self.column_ends[j * w..(j + 1) * w]
    }

    /// Solid angle of a cell of row `j`.
    fn cell_solid_angle(&self, j: usize) -> f64 {
        TAU / f64::from(self.map.width()) * (self.edge_cos[j] - self.edge_cos[j + 1])
    }

    /// A direction drawn with the uniform numbers `(u, v)` (24-bit draws:
    /// `u` picks the row, `v` the column) and 32 random bits `jitter` (the
    /// position inside the cell), with the radiance it brings and its
    /// density. [`sample_lanes`](Self::sample_lanes) draws the same for
    /// eight lanes at once.
    pub fn sample(&self, u: f32, v: f32, jitter: u32) -> EnvironmentSample {
        self.sample_lanes(1, &[(u, v, jitter); LANES])[0]
    }

    /// [`sample`](Self::sample) for each lane in the mask `lanes` of
    /// `draws` (the other lanes' samples are meaningless). Three passes
    /// over the lanes, each requesting what the next reads: the rows and
    /// the columns' guide lines (small, mostly cached), then the columns'
    /// slot ends, then the texels, so that the eight lanes' cache misses
    /// overlap. (Out of line, as are the other lookups: called for the
    /// lanes that sample a map, they would only grow the shading stage's
    /// loop, which every scene runs.)
    #[inline(never)]
    pub fn sample_lanes(
        &self,
        lanes: u32,
        draws: &[(f32, f32, u32); LANES],
    ) -> [EnvironmentSample; LANES] {
        // The slot a draw falls in, and where in its choice's slots: a
        // fraction in [0, 1) filled out by 16 bits of `bits`.
        fn slot(draw: f32) -> u32 {
            ((f64::from(draw) * SLOTS as f64) as u64).min(SLOTS - 1) as u32
        }
        fn within(slots: std::ops::Range<u32>, slot: u32, bits: u32) -> f64 {
            let fine = (f64::from(bits & 0xffff) + 0.5) / 65536.0;
            (f64::from(slot - slots.start) + fine) / f64::from(slots.end - slots.start)
        }
        let w = self.map.width() as usize;
        let mut slots = [(0, 0); LANES];
        let mut rows = [0; LANES];
        for lane in lanes::each(lanes) {
            let (u, v, _) = draws[lane];
            let (su, sv) = (slot(u), slot(v));
            let j = self.row_guide.choose(&self.row_ends, su);
            prefetch(&self.column_ends[j * w + self.column_guides[j].first(sv)]);
            (slots[lane], rows[lane]) = ((su, sv), j);
        }
        let (mut x, mut cos_theta, mut pdf) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        for lane in lanes::each(lanes) {
            let ((su, sv), j, jitter) = (slots[lane], rows[lane], draws[lane].2);
            let fy = within(owned(&self.row_ends, j), su, jitter);
            let columns = self.columns(j);
            let i = self.column_guides[j].choose(columns, sv);
            let fx = within(owned(columns, i), sv, jitter >> 16);
            cos_theta[lane] = self.edge_cos[j] + fy * (self.edge_cos[j + 1] - self.edge_cos[j]);
            x[lane] = i as f64 + fx;
            let probability = probability(&self.row_ends, j) * probability(columns, i);
            pdf[lane] = probability / self.cell_solid_angle(j);
        }
        // The map position of each direction, found from the draw rather
        // than from the direction (one arc cosine instead of two inverse
        // trigonometric functions); the arc cosines, sines and cosines
        // four lanes at a time.
        let four = |v: &[f64; LANES], k: usize| -> [f64; 4] { v[k..k + 4].try_into().unwrap() };
        // (`from_fn`, not `array::map`, which is compiled out of line here.)
        let phi: [f64; LANES] = std::array::from_fn(|k| azimuth(x[k], self.map.width()));
        let y = by_fours(|k| self.map.rows_at(four(&cos_theta, k)));
        for lane in lanes::each(lanes) {
            self.map.prefetch(x[lane], y[lane]);
        }
        let direction = by_fours(|k| directions(four(&cos_theta, k), four(&phi, k)));
        let mut out = [EnvironmentSample::default(); LANES];
        for lane in lanes::each(lanes) {
            out[lane] = EnvironmentSample {
                direction: direction[lane],
                radiance: self.map.at(x[lane], y[lane]),
                pdf: pdf[lane],
            };
        }
        out
    }

    /// The light sample `s` of the map makes for a point of shading normal
    /// `n`: its radiance over its density, times — where the point's
    /// diffuse continuation ray may find the map as well (`shared_with`:
    /// `Some(count)` for `count` map samples per vertex) — the sample's
    /// multiple-importance share against that cosine-weighted ray. `None`
    /// below the surface.
    pub fn light_sample(
        &self,
        n: Vec3,
        s: &EnvironmentSample,
        shared_with: Option<u32>,
    ) -> Option<LightSample> {
        let cos_surface = n.dot(s.direction);
        // (A NaN cosine is refused too.)
        (cos_surface > 0.0).then(|| {
            let weight = match shared_with {
                Some(count) => {
                    let (share, _) = mis_weights(s.pdf, count, f64::from(cos_surface) / PI);
                    s.radiance * (share / s.pdf as f32)
                }
                None => s.radiance / s.pdf as f32,
            };
            LightSample {
                direction: s.direction,
                t_max: f32::INFINITY,
                weight,
                cos_surface,
            }
        })
    }

    /// The density (per unit solid angle) with which [`sample`](Self::sample)
    /// draws direction `d` (any length but 0).
    #[inline(never)]
    pub fn pdf(&self, d: Vec3) -> f64 {
        let (x, y) = self.map.position(d);
        self.pdf_at(x, y)
    }

    /// [`pdf`](Self::pdf) at map position `(x, y)`.
    fn pdf_at(&self, x: f64, y: f64) -> f64 {
        let (j, i) = self.cell(x, y);
        probability(&self.row_ends, j) * probability(self.columns(j), i) / self.cell_solid_angle(j)
    }

    /// The cell (row, column) holding map position `(x, y)`.
    #[inline]
    fn cell(&self, x: f64, y: f64) -> (usize, usize) {
        let (w, h) = (self.map.width() as usize, self.map.height() as usize);
        ((y as usize).min(h - 1), (x as usize) % w)
    }

    /// The map's radiance arriving along `d` (any length but 0) at a
    /// point where a ray drawn with density `bsdf_pdf` escaped, weighted
    /// by that ray's multiple-importance share against `light_samples`
    /// samples of the map (its whole radiance for `bsdf_pdf` = +∞: a ray
    /// no map sample stands in for, such as a camera ray).
    pub fn escaping(&self, d: Vec3, bsdf_pdf: f32, light_samples: u32) -> Vec3 {
        self.escaping_at(self.locate(d), bsdf_pdf, light_samples)
    }

    /// The map position of direction `d` (any length but 0), with the
    /// texels and slot ends that [`escaping_at`](Self::escaping_at) will
    /// read there requested (see [`prefetch`](crate::prefetch)).
    pub fn locate(&self, d: Vec3) -> (f64, f64) {
        self.locate_lanes([d; 4], 1)[0]
    }

    /// [`locate`](Self::locate) for the first `count` of four directions
    /// (the others' positions are meaningless).
    #[inline(never)]
    pub fn locate_lanes(&self, d: [Vec3; 4], count: usize) -> [(f64, f64); 4] {
        let positions = self.map.positions(d);
        for &(x, y) in &positions[..count] {
            self.map.prefetch(x, y);
            let (j, i) = self.cell(x, y);
            prefetch(&self.column_ends[j * self.map.width() as usize + i]);
        }
        positions
    }

    /// [`escaping`](Self::escaping) at the map position
    /// [`locate`](Self::locate) found.
    #[inline(never)]
    pub fn escaping_at(&self, (x, y): (f64, f64), bsdf_pdf: f32, light_samples: u32) -> Vec3 {
        let radiance = self.map.at(x, y);
        if bsdf_pdf == f32::INFINITY {
            return radiance;
        }
        let (_, bsdf) = mis_weights(self.pdf_at(x, y), light_samples, f64::from(bsdf_pdf));
        radiance * bsdf
    }
}

/// Eight lanes of a function computed four lanes at a time, `f(0)` giving
/// lanes 0–3 and `f(4)` lanes 4–7.
#[inline(always)]
fn by_fours<T: Copy + Default>(f: impl Fn(usize) -> [T; 4]) -> [T; LANES] {
    let (low, high) = (f(0), f(4));
    std::array::from_fn(|k| if k < 4 { low[k] } else { high[k - 4] })
}

/// The ends of `table`'s `n` choices' slots (all 0 without a table).
fn ends(table: Option<&SlotTable>, n: usize) -> impl Iterator<Item = u32> + '_ {
    (0..n).map(move |i| table.map_or(0, |t| t.ends()[i] as u32))
}

/// Buckets of a [`Guide`]: sixteen `u32`, one cache line.
const GUIDE_BUCKETS: usize = 16;
/// A slot's bucket is its top four of 24 bits.
const GUIDE_SHIFT: u32 = 20;

/// A guide table (Chen and Asau's cutpoint method) for searching a table
/// of slot ends: bucket k holds the first choice whose slots end past
/// k·2²⁰, so a slot of bucket k belongs to a choice between bucket k's
/// entry and bucket k + 1's. The search of a row's 512 columns, nine
/// steps through 2 KB that the cache rarely holds, becomes one load of
/// the guide and a few steps within a line or two of ends; where a
/// bucket spans many choices, they are small ones, rarely drawn. The
/// choice found is exactly [`choose`]'s.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Guide([u32; GUIDE_BUCKETS]);

impl Guide {
    /// The guide of a table of slot ends (of 2²⁴ slots in all, or all 0
    /// for a table never searched).
    fn new(ends: &[u32]) -> Guide {
        let last = ends.len() - 1;
        let mut bucket = [0; GUIDE_BUCKETS];
        for (k, first) in bucket.iter_mut().enumerate() {
            *first = choose(ends, (k as u32) << GUIDE_SHIFT).min(last) as u32;
        }
        Guide(bucket)
    }

    /// The first choice that may hold `slot`.
    #[inline]
    fn first(&self, slot: u32) -> usize {
        self.0[(slot >> GUIDE_SHIFT) as usize] as usize
    }

    /// [`choose`]`(ends, slot)` for the `ends` this guide was made of.
    #[inline]
    fn choose(&self, ends: &[u32], slot: u32) -> usize {
        let k = (slot >> GUIDE_SHIFT) as usize;
        let first = self.first(slot);
        let last = match self.0.get(k + 1) {
            Some(&next) => next as usize,
            None => ends.len() - 1,
        };
        first + choose(&ends[first..=last], slot)
    }
}

/// The probability of choice `i` (its share of the 2²⁴ slots).
#[inline]
fn probability(ends: &[u32], i: usize) -> f64 {
    slots::probability(ends, i, SLOTS)
}

/// A direction drawn from an environment map.
#[derive(Clone, Copy, Debug, Default)]
pub struct EnvironmentSample {
    /// Unit direction toward the map.
    pub direction: Vec3,
    /// The map's radiance along it.
    pub radiance: Vec3,
    /// The density (per unit solid angle) with which it was drawn.
    pub pdf: f64,
}

/// Multiple importance sampling of the map against the BSDF, by Veach's
/// power heuristic (β = 2) for `light_samples` map samples and one BSDF
/// sample per vertex: the weights (map, BSDF) of a direction that the map
/// draws with density `light_pdf` and the BSDF with `bsdf_pdf`. They add
/// up to 1 wherever either density is positive, so a vertex's map samples
/// and its continuation ray, weighted so, estimate the map's light without
/// bias; each weight is near 1 where its own strategy is the better one —
/// the map's on a small bright sun, the BSDF's (cosine-weighted) on an
/// even sky, where the map's samples fall below the surface half the time.
#[inline]
pub fn mis_weights(light_pdf: f64, light_samples: u32, bsdf_pdf: f64) -> (f32, f32) {
    let light = (f64::from(light_samples) * light_pdf).powi(2);
    let bsdf = bsdf_pdf * bsdf_pdf;
    let sum = light + bsdf;
    if sum > 0.0 {
        ((light / sum) as f32, (bsdf / sum) as f32)
    } else {
        (1.0, 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ends of a table of `weights`.
    fn table(weights: &[f64]) -> Vec<u32> {
        ends(SlotTable::new(weights, SLOTS).as_ref(), weights.len()).collect()
    }

    /// A guided search finds the choice a plain one does, for slots at
    /// and around every bucket's edge and every choice's ends, on tables
    /// even, skewed (one choice owning most slots, many tiny ones in a
    /// few buckets) and of one choice. (A row of zero weight is never
    /// searched: its guide only has to exist.)
    #[test]
    fn a_guided_search_chooses_what_a_plain_one_does() {
        let mut skewed = vec![1e-6; 300];
        skewed[17] = 1.0;
        skewed[299] = 0.3;
        let tables = [
            table(&[1.0; 512]),
            table(&skewed),
            table(&(0..37).map(|i| (i * i) as f64).collect::<Vec<_>>()),
            table(&[2.0]),
        ];
        Guide::new(&[0; 12]);
        for ends in &tables {
            let guide = Guide::new(ends);
            let mut slots: Vec<u32> = (0..GUIDE_BUCKETS as u32)
                .map(|k| k << GUIDE_SHIFT)
                .chain(ends.iter().copied())
                .flat_map(|s| [s.saturating_sub(1), s, s + 1])
                .filter(|&s| u64::from(s) < SLOTS)
                .collect();
            slots.extend((0..10_000u32).map(|k| k.wrapping_mul(2_654_435_761) >> 8));
            for slot in slots {
                let plain = choose(ends, slot);
                assert_eq!(guide.choose(ends, slot), plain, "slot {slot} of {ends:?}");
            }
        }
    }
}
