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

use std::f64::consts::TAU;
use std::sync::Arc;

use glam::Vec3;

use crate::sampling::slots::SlotTable;
use crate::scene::EnvironmentMap;
use crate::scene::environment::{azimuth, direction, polar_cosine};

/// Slots per choice: a draw in [0, 1) holds 24 bits.
const SLOTS: u64 = 1 << 24;

/// An environment map and the tables that sample it.
#[derive(Clone, Debug)]
pub struct EnvironmentLight {
    pub map: Arc<EnvironmentMap>,
    /// Rows by their cells' summed weight.
    rows: SlotTable,
    /// Each row's cells by weight (`None` for a row of weight 0, never chosen).
    columns: Vec<Option<SlotTable>>,
    /// cos θ at each row's upper and lower edge: `height + 1` values from 1 to −1.
    edge_cos: Vec<f64>,
}

impl EnvironmentLight {
    /// The sampling tables of `map`. `None` if the map sends no light.
    pub fn new(map: Arc<EnvironmentMap>) -> Option<EnvironmentLight> {
        let (w, h) = (map.width() as usize, map.height() as usize);
        assert!(w as u64 <= SLOTS && h as u64 <= SLOTS, "{w}x{h} map");
        let edge_cos: Vec<f64> = (0..=h).map(|j| polar_cosine(j as f64, h as u32)).collect();
        // Channel sums, then the cell means: ⅛ ¾ ⅛ along each axis,
        // wrapping around in φ and clamped at the poles as lookups are.
        let filter = |a: f64, b: f64, c: f64| 0.125 * a + 0.75 * b + 0.125 * c;
        let sum = |x: i64, y: i64| f64::from(map.texel(x, y).element_sum());
        let across: Vec<f64> = (0..h as i64)
            .flat_map(|y| (0..w as i64).map(move |x| (x, y)))
            .map(|(x, y)| filter(sum(x - 1, y), sum(x, y), sum(x + 1, y)))
            .collect();
        let at = |x: usize, y: i64| across[y.clamp(0, h as i64 - 1) as usize * w + x];
        let mut row_weights = Vec::with_capacity(h);
        let columns = (0..h)
            .map(|j| {
                let band = edge_cos[j] - edge_cos[j + 1];
                let y = j as i64;
                let weights: Vec<f64> = (0..w)
                    .map(|i| filter(at(i, y - 1), at(i, y), at(i, y + 1)) * band)
                    .collect();
                row_weights.push(weights.iter().sum::<f64>());
                SlotTable::new(&weights, SLOTS)
            })
            .collect();
        Some(EnvironmentLight {
            rows: SlotTable::new(&row_weights, SLOTS)?,
            columns,
            edge_cos,
            map,
        })
    }

    /// Solid angle of a cell of row `j`.
    fn cell_solid_angle(&self, j: usize) -> f64 {
        TAU / f64::from(self.map.width()) * (self.edge_cos[j] - self.edge_cos[j + 1])
    }

    /// A direction drawn with the uniform numbers `(u, v)` (24-bit draws:
    /// `u` picks the row, `v` the column) and 32 random bits `jitter` (the
    /// position inside the cell), with its radiance divided by its density.
    /// (Out of line, as is [`pdf`](Self::pdf): called once per sample, they
    /// would only grow the shading stage's loop, which every scene runs.)
    #[inline(never)]
    pub fn sample(&self, u: f32, v: f32, jitter: u32) -> (Vec3, Vec3) {
        // The slot a draw falls in, and where in its choice's slots: a
        // fraction in [0, 1) filled out by 16 bits of `bits`.
        fn slot(draw: f32) -> u64 {
            ((f64::from(draw) * SLOTS as f64) as u64).min(SLOTS - 1)
        }
        fn within(slots: std::ops::Range<u64>, slot: u64, bits: u32) -> f64 {
            let fine = (f64::from(bits & 0xffff) + 0.5) / 65536.0;
            ((slot - slots.start) as f64 + fine) / (slots.end - slots.start) as f64
        }
        let (su, sv) = (slot(u), slot(v));
        let j = self.rows.choose(su);
        let fy = within(self.rows.slots(j), su, jitter);
        let columns = self.columns[j]
            .as_ref()
            .expect("a row of weight 0 owns no slot");
        let i = columns.choose(sv);
        let fx = within(columns.slots(i), sv, jitter >> 16);
        let cos_theta = self.edge_cos[j] + fy * (self.edge_cos[j + 1] - self.edge_cos[j]);
        let d = direction(cos_theta as f32, azimuth(i as f64 + fx, self.map.width()));
        let probability = self.rows.probability(j) * columns.probability(i);
        let weight = self.cell_solid_angle(j) / probability;
        (d, self.map.radiance(d) * weight as f32)
    }

    /// The density (per unit solid angle) with which [`sample`](Self::sample)
    /// draws direction `d` (any length but 0).
    #[inline(never)]
    pub fn pdf(&self, d: Vec3) -> f64 {
        let (x, y) = self.map.position(d);
        let (w, h) = (self.map.width() as usize, self.map.height() as usize);
        let j = (y as usize).min(h - 1);
        let i = (x as usize) % w;
        match &self.columns[j] {
            Some(columns) => {
                self.rows.probability(j) * columns.probability(i) / self.cell_solid_angle(j)
            }
            None => 0.0,
        }
    }
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
