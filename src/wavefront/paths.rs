//! The state of the paths in flight, as structure of arrays.

use glam::Vec3;

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

    /// Starts a path with a camera ray.
    #[inline]
    pub fn push(
        &mut self,
        slot: u32,
        stream: SampleStream,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
    ) {
        self.slot.push(slot);
        self.stream.push(stream);
        self.throughput.push(Vec3::ONE);
        self.radiance.push(Vec3::ZERO);
        self.depth.push(0);
        self.specular.push(false);
        self.alive.push(true);
        self.rays.push(origin, direction, t_max);
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

    #[inline]
    pub fn push(&mut self, path: usize, origin: Vec3, direction: Vec3, t_max: f32, weight: Vec3) {
        self.rays.push(origin, direction, t_max);
        self.path.push(path as u32);
        self.weight.push(weight);
    }
}
