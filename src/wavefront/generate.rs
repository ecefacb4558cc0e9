//! Stage 1: camera rays for the pixels still in the mask.
//!
//! A pass gives every active pixel of a tile the same number of new
//! samples; the pass's work items are numbered pixel-major, and each item
//! owns one result slot. Waves take items in order until full.

use glam::Vec3;
use wide::f32x8;

use crate::film::Tile;
use crate::lanes::{LANES, Vec3x8};
use crate::sampling::SampleStream;
use crate::sampling::rng::{new_streams, pixel_offsets};
use crate::sampling::warp;
use crate::scene::{Camera, CameraView};

use super::paths::Paths;

/// The camera samples of one pass over one tile.
pub struct PassQueue<'a> {
    pub tile: Tile,
    /// Local indices of the pixels still sampled.
    pub active: &'a [u32],
    /// Samples each active pixel takes in this pass.
    pub samples_per_pixel: u32,
    /// Sample index of each pixel's first sample in this pass.
    pub first_sample: u32,
    /// Next work item.
    pub next: usize,
}

impl PassQueue<'_> {
    pub fn len(&self) -> usize {
        self.active.len() * self.samples_per_pixel as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn is_done(&self) -> bool {
        self.next >= self.len()
    }

    /// Image column and row of the `a`-th active pixel.
    fn pixel(&self, a: usize) -> (u32, u32) {
        let local = self.active[a];
        let tile = &self.tile;
        (tile.x0 + local % tile.width, tile.y0 + local / tile.width)
    }
}

/// Everything needed to turn (pixel, sample) into a camera ray.
pub struct CameraRays<'a> {
    pub camera: &'a Camera,
    pub view: CameraView,
    pub seed: u32,
    /// Every ray goes through its pixel's centre (a 1-spp render, unless
    /// `RenderSettings::centre_single_sample` is false).
    pub pixel_centre: bool,
    /// Thin lens: aperture radius (0 = pinhole) and distance of the plane in focus.
    pub lens_radius: f32,
    pub focal_distance: f32,
}

/// Fills `paths` up to `capacity` with new camera paths from `queue`.
/// Returns how many were generated.
pub fn refill(
    paths: &mut Paths,
    capacity: usize,
    queue: &mut PassQueue,
    cam: &CameraRays,
) -> usize {
    let room = capacity.saturating_sub(paths.len());
    let take = room.min(queue.len() - queue.next.min(queue.len()));
    let spp = queue.samples_per_pixel as usize;
    let (width, height) = (cam.view.width, cam.view.height);
    if take == 0 {
        return 0;
    }
    let end = queue.next + take;
    // Item = active pixel · spp + sample: walked with counters, so the
    // divisions (tens of cycles each) happen once per pixel, not per item.
    let (mut active, mut sample) = (queue.next / spp, queue.next % spp);
    let mut pixel = queue.pixel(active);
    // Eight samples at a time: their pixel offsets are drawn together,
    // one Sobol point per vector lane (a long chain of dependent integer
    // operations each, drawn one by one before), and their rays computed
    // and appended in vector lanes.
    let camera = cam.camera;
    let t_max = camera.zfar - camera.znear;
    for first in (queue.next..end).step_by(LANES) {
        let n = (end - first).min(LANES);
        let mut slots = [0u32; LANES];
        let (mut pixel_ids, mut samples) = ([0u32; LANES], [0u32; LANES]);
        let (mut xs, mut ys) = ([0f32; LANES], [0f32; LANES]);
        for k in 0..n {
            if sample == spp {
                (active, sample) = (active + 1, 0);
                pixel = queue.pixel(active);
            }
            let (x, row) = pixel;
            slots[k] = (first + k) as u32;
            samples[k] = queue.first_sample + sample as u32;
            pixel_ids[k] = row * width + x;
            // Film rows run top-down; the camera's y = 0 is the bottom row.
            (xs[k], ys[k]) = (x as f32, (height - 1 - row) as f32);
            sample += 1;
        }
        let mut streams = new_streams(cam.seed, pixel_ids, samples);
        let (us, vs) = if cam.pixel_centre {
            ([0.5; LANES], [0.5; LANES])
        } else {
            pixel_offsets(&streams[..n])
        };
        let (fx, fy) = (
            f32x8::from(xs) + f32x8::from(us),
            f32x8::from(ys) + f32x8::from(vs),
        );
        let dir = camera.directions_x8(&cam.view, fx, fy);
        let (origin, dir) = if cam.lens_radius > 0.0 {
            thin_lens(cam, &mut streams[..n], dir)
        } else {
            (Vec3x8::splat(camera.position), dir)
        };
        // Unit directions, and t ∈ [znear, zfar] along them, as the
        // reference sets its camera rays: the clipping surfaces are
        // spheres about the eye (or the lens point), not planes. The ray
        // starts at znear (the BVH's queries start at t = 0).
        let (dir, _) = dir.normalize();
        let origin = origin + dir * f32x8::splat(camera.znear);
        paths.start(n, &slots, &streams, origin, dir, t_max);
    }
    queue.next += take;
    take
}

/// Thin lens: rays from points on the aperture (one 2D draw of each
/// path's stream) through where the pinhole rays `pinhole` meet the plane
/// in focus (camera-space z = −`focal_distance`), for the lanes of
/// `streams`; lanes past `streams.len()` are zero.
fn thin_lens(cam: &CameraRays, streams: &mut [SampleStream], pinhole: Vec3x8) -> (Vec3x8, Vec3x8) {
    let camera = cam.camera;
    let (mut origin, mut dir) = ([Vec3::ZERO; LANES], [Vec3::ZERO; LANES]);
    for (k, stream) in streams.iter_mut().enumerate() {
        let focus = camera.position + cam.focal_distance * pinhole.lane(k);
        let (lu, lv) = stream.next_2d();
        let disk = warp::concentric_disk(lu, lv) * cam.lens_radius;
        let lens = camera.position + camera.camera_to_world * Vec3::new(disk.x, disk.y, 0.0);
        (origin[k], dir[k]) = (lens, (focus - lens) / cam.focal_distance);
    }
    (Vec3x8::gather(&origin), Vec3x8::gather(&dir))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat3;

    /// Waves of every size take the pass's items in order, each with the
    /// stream of its own (pixel, sample) — waves that start and end in
    /// the middle of a pixel's samples included — and each path starts
    /// fresh with the camera ray through that sample's film position:
    /// pinhole, or thin lens with one 2D draw of the stream for the
    /// aperture point.
    #[test]
    fn waves_take_every_item_once_with_its_own_pixel_and_sample() {
        let camera = Camera {
            position: Vec3::new(0.5, -2.0, 3.0),
            target: Vec3::ZERO,
            camera_to_world: Mat3::from_axis_angle(Vec3::new(0.3, -1.0, 0.5).normalize(), 0.7),
            screen_distance: 500.0,
            znear: 0.01,
            zfar: 100.0,
        };
        let (width, height) = (40, 30);
        let tile = Tile {
            x0: 8,
            y0: 4,
            width: 5,
            height: 3,
        };
        let active = [0u32, 3, 4, 9, 14];
        for lens_radius in [0.0, 0.25] {
            let cam = CameraRays {
                camera: &camera,
                view: camera.view(width, height),
                seed: 9,
                pixel_centre: false,
                lens_radius,
                focal_distance: 2.5,
            };
            for (spp, wave) in [(3, 5), (3, 8), (1, 3), (4, 4), (2, 13)] {
                let mut queue = PassQueue {
                    tile,
                    active: &active,
                    samples_per_pixel: spp,
                    first_sample: 6,
                    next: 0,
                };
                let mut paths = Paths::default();
                let mut seen = 0;
                while !queue.is_done() {
                    paths.truncate(0);
                    let taken = refill(&mut paths, wave, &mut queue, &cam);
                    assert_eq!(taken, paths.len());
                    for (k, &slot) in paths.slot.iter().enumerate() {
                        let item = seen + k;
                        let at =
                            format!("lens {lens_radius}, spp {spp}, waves of {wave}, item {item}");
                        assert_eq!(slot as usize, item, "{at}");
                        let local = active[item / spp as usize];
                        let (x, y) = (tile.x0 + local % tile.width, tile.y0 + local / tile.width);
                        let sample = 6 + (item % spp as usize) as u32;
                        let (origin, dir, stream) =
                            expected_ray(&cam, (x, y), SampleStream::new(9, y * width + x, sample));
                        assert_eq!(paths.stream[k], stream, "{at}");
                        assert_eq!(paths.rays.direction(k), dir, "{at}");
                        assert_eq!(paths.rays.origin(k), origin, "{at}");
                        assert_eq!(paths.rays.t_max[k], camera.zfar - camera.znear);
                        assert_eq!(paths.throughput[k], Vec3::ONE);
                        assert_eq!(paths.radiance[k], Vec3::ZERO);
                        assert!(paths.alive[k] && paths.depth[k] == 0 && !paths.specular[k]);
                    }
                    seen += taken;
                }
                assert_eq!(seen, active.len() * spp as usize);
                // A drained queue adds nothing.
                paths.truncate(0);
                assert_eq!(refill(&mut paths, wave, &mut queue, &cam), 0);
            }
        }
    }

    /// The camera ray of one sample of pixel `(x, y)` (film rows top-down),
    /// one ray at a time: origin, direction and the stream after it.
    fn expected_ray(
        cam: &CameraRays,
        (x, y): (u32, u32),
        mut stream: SampleStream,
    ) -> (Vec3, Vec3, SampleStream) {
        let camera = cam.camera;
        let (u, v) = stream.pixel_offset();
        let row = (cam.view.height - 1 - y) as f32;
        let pinhole = camera.direction(&cam.view, x as f32 + u, row + v);
        let (origin, dir) = if cam.lens_radius > 0.0 {
            let focus = camera.position + cam.focal_distance * pinhole;
            let (lu, lv) = stream.next_2d();
            let disk = warp::concentric_disk(lu, lv) * cam.lens_radius;
            let lens = camera.position + camera.camera_to_world * Vec3::new(disk.x, disk.y, 0.0);
            (lens, (focus - lens) / cam.focal_distance)
        } else {
            (camera.position, pinhole)
        };
        let dir = crate::lanes::normalize_any_scale(dir).unwrap();
        (origin + camera.znear * dir, dir, stream)
    }
}
