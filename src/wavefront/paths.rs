//! The state of the paths in flight, as structure of arrays.

use glam::Vec3;
use wide::f32x8;

use crate::lanes::{self, LANES, Vec3x8};
use crate::ray::Rays;
use crate::sampling::SampleStream;

/// Live paths of one wave. Index `i` of every array is path `i`; the next
/// ray of path `i` is `rays[i]`.
#[derive(Clone, Debug, Default)]
pub struct Paths {
    /// Where the path's result goes: an index into the pass's sample slots.
    pub slot: Vec<u32>,
    pub stream: Vec<SampleStream>,
    /// Product of BSDF weights so far (divided by roulette survival).
    pub throughput: Vec<Vec3>,
    /// Radiance gathered so far.
    pub radiance: Vec<Vec3>,
    /// Vertex index of the next hit: 0 for camera rays.
    pub depth: Vec<u32>,
    /// Whether the ray left a delta (specular) bounce, so emission it finds counts.
    pub specular: Vec<bool>,
    /// The density with which the ray's direction was drawn, for the share
    /// of the environment map's light it takes if it escapes: +∞ for
    /// camera rays (all of it), cos θ / π after a diffuse bounce (shared
    /// with the map's samples by multiple importance), 0 where hemisphere
    /// probes count the map. Written only in scenes with a map.
    pub escape_pdf: Vec<f32>,
    /// Whether the path continues after the current shade stage.
    pub alive: Vec<bool>,
    pub rays: Rays,
}

impl Paths {
    pub fn with_capacity(n: usize) -> Self {
        Paths {
            slot: Vec::with_capacity(n),
            stream: Vec::with_capacity(n),
            throughput: Vec::with_capacity(n),
            radiance: Vec::with_capacity(n),
            depth: Vec::with_capacity(n),
            specular: Vec::with_capacity(n),
            escape_pdf: Vec::with_capacity(n),
            alive: Vec::with_capacity(n),
            rays: Rays::with_capacity(n),
        }
    }

    pub fn len(&self) -> usize {
        self.slot.len()
    }

    pub fn is_empty(&self) -> bool {
        self.slot.is_empty()
    }

    /// Starts `n` (at most eight) paths with camera rays: path `k` gets
    /// result slot `slots[k]`, sample stream `streams[k]` and the ray in
    /// lane `k` of `origin` and `direction`, ending at `t_max`. Whole
    /// groups of eight are fixed-size copies, as in [`ShadowWriter`].
    #[inline]
    pub fn start(
        &mut self,
        n: usize,
        slots: &[u32; LANES],
        streams: &[SampleStream; LANES],
        origin: Vec3x8,
        direction: Vec3x8,
        t_max: f32,
    ) {
        lanes::extend(&mut self.slot, slots, n);
        lanes::extend(&mut self.stream, streams, n);
        lanes::extend(&mut self.throughput, &[Vec3::ONE; LANES], n);
        lanes::extend(&mut self.radiance, &[Vec3::ZERO; LANES], n);
        lanes::extend(&mut self.depth, &[0; LANES], n);
        lanes::extend(&mut self.specular, &[false; LANES], n);
        lanes::extend(&mut self.escape_pdf, &[f32::INFINITY; LANES], n);
        lanes::extend(&mut self.alive, &[true; LANES], n);
        self.rays
            .extend_lanes(n, origin, direction, f32x8::splat(t_max));
    }

    /// Moves path `from` to index `to` (`to < from`), overwriting it.
    #[inline]
    pub fn move_path(&mut self, from: usize, to: usize) {
        self.slot[to] = self.slot[from];
        self.stream[to] = self.stream[from];
        self.throughput[to] = self.throughput[from];
        self.radiance[to] = self.radiance[from];
        self.depth[to] = self.depth[from];
        self.specular[to] = self.specular[from];
        self.escape_pdf[to] = self.escape_pdf[from];
        self.alive[to] = self.alive[from];
        self.rays.copy_within(from, to);
    }

    /// Keeps the first `n` paths.
    pub fn truncate(&mut self, n: usize) {
        self.slot.truncate(n);
        self.stream.truncate(n);
        self.throughput.truncate(n);
        self.radiance.truncate(n);
        self.depth.truncate(n);
        self.specular.truncate(n);
        self.escape_pdf.truncate(n);
        self.alive.truncate(n);
        self.rays.truncate(n);
    }
}

/// Rays from path vertices toward lights: shadow rays (light sampling) or
/// probe rays (hemisphere sampling), each with the path it belongs to and
/// the contribution it carries if it gets through.
#[derive(Clone, Debug, Default)]
pub struct ShadowRays {
    pub rays: Rays,
    /// Index of the owning path in [`Paths`].
    pub path: Vec<u32>,
    /// Radiance added to the path if unoccluded (shadow rays), or the factor
    /// multiplying the emitted radiance found (probe rays).
    pub weight: Vec<Vec3>,
}

impl ShadowRays {
    pub fn clear(&mut self) {
        self.rays.clear();
        self.path.clear();
        self.weight.clear();
    }

    pub fn len(&self) -> usize {
        self.path.len()
    }

    pub fn is_empty(&self) -> bool {
        self.path.is_empty()
    }

    /// A writer that appends rays eight at a time; the last few land when
    /// it is dropped.
    pub fn writer(&mut self) -> ShadowWriter<'_> {
        ShadowWriter {
            out: self,
            staged: Staged::default(),
            count: 0,
        }
    }
}

/// Appends rays to [`ShadowRays`] through a staging block of eight.
///
/// A ray is eleven numbers in nine vectors, and pushing them one by one
/// checks and bumps nine vector lengths per ray — which cost the shade
/// stage more than the light sampling that made the ray. Staged, a ray is
/// eleven stores to a block on the stack, and every eighth ray the block
/// is appended as nine fixed-size copies.
pub struct ShadowWriter<'a> {
    out: &'a mut ShadowRays,
    staged: Staged,
    /// Rays staged (below eight between calls).
    count: usize,
}

/// Eight rays in the layout of [`ShadowRays`].
#[derive(Default)]
struct Staged {
    /// Origin x, y, z, direction x, y, z, `t_max`.
    rays: [[f32; 8]; 7],
    path: [u32; 8],
    weight: [Vec3; 8],
}

impl ShadowWriter<'_> {
    /// Appends a ray of path `path` that carries `weight`.
    #[inline(always)]
    pub fn push(&mut self, path: usize, origin: Vec3, direction: Vec3, t_max: f32, weight: Vec3) {
        // `count` is below eight between calls; the mask tells the compiler
        // so, which drops the eleven stores' bounds checks.
        let k = self.count & 7;
        let s = &mut self.staged;
        let values = [
            origin.x,
            origin.y,
            origin.z,
            direction.x,
            direction.y,
            direction.z,
            t_max,
        ];
        for (component, value) in s.rays.iter_mut().zip(values) {
            component[k] = value;
        }
        s.path[k] = path as u32;
        s.weight[k] = weight;
        self.count = k + 1;
        if self.count == LANES {
            self.flush();
        }
    }

    /// Appends the staged rays (inlined for the same reason as
    /// [`Rays::extend_arrays`](crate::ray::Rays::extend_arrays)).
    #[inline(always)]
    fn flush(&mut self) {
        let (n, s, out) = (self.count, &self.staged, &mut *self.out);
        out.rays.extend_arrays(n, &s.rays);
        lanes::extend(&mut out.path, &s.path, n);
        lanes::extend(&mut out.weight, &s.weight, n);
        self.count = 0;
    }
}

impl Drop for ShadowWriter<'_> {
    fn drop(&mut self) {
        self.flush();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shadow_writer_appends_every_ray_in_order_across_staging_blocks() {
        let ray = |k: usize| {
            let f = k as f32;
            let origin = Vec3::new(f, f + 0.25, f + 0.5);
            (
                k + 1000,
                origin,
                Vec3::new(-f, 1.0, f),
                f + 2.0,
                Vec3::splat(3.0 * f),
            )
        };
        for count in [0, 1, 7, 8, 9, 17] {
            let mut shadow = ShadowRays::default();
            // Rays already in the batch stay in front of the new ones.
            shadow.writer().push(7, Vec3::ONE, Vec3::Y, 5.0, Vec3::ONE);
            {
                let mut writer = shadow.writer();
                for k in 0..count {
                    let (path, o, d, t, w) = ray(k);
                    writer.push(path, o, d, t, w);
                }
            }
            assert_eq!((shadow.len(), shadow.rays.len()), (count + 1, count + 1));
            assert_eq!(shadow.path[0], 7);
            for k in 0..count {
                let (path, o, d, t, w) = ray(k);
                let i = k + 1;
                assert_eq!(shadow.path[i], path as u32, "{count} rays, ray {k}");
                assert_eq!(shadow.rays.origin(i), o);
                assert_eq!(shadow.rays.direction(i), d);
                assert_eq!(shadow.rays.t_max[i], t);
                assert_eq!(shadow.weight[i], w);
            }
        }
    }
}
