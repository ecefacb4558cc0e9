//! Film: per-pixel accumulation, the adaptive-sampling mask, image output,
//! and references combined from independent replicates.
//!
//! The film is written tile by tile: a tile's passes add to its own
//! [`TileFilm`], rendered by one thread at a time, which is stored into
//! the [`Image`] when the tile's last pass ends (or the render stops).

pub mod adaptive;
pub mod metrics;
pub mod output;
pub mod replicates;

use glam::{DVec3, Vec3};

/// The most pixels an image may have, rendered or read: 2^28 (16384²),
/// whose [`Image`] alone takes 7 GiB (the CLI also checks what a render's
/// image needs against the memory available).
pub const MAX_PIXELS: u64 = 1 << 28;

/// A rectangle of pixels, in image coordinates (row 0 at the top).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
}

impl Tile {
    pub fn pixel_count(&self) -> usize {
        (self.width * self.height) as usize
    }

    /// The whole of a `width × height` image.
    pub fn whole(width: u32, height: u32) -> Tile {
        Tile {
            x0: 0,
            y0: 0,
            width,
            height,
        }
    }

    /// Splits the rectangle into tiles of at most `size × size`, row-major.
    pub fn split(&self, size: u32) -> Vec<Tile> {
        let (x_end, y_end) = (self.x0 + self.width, self.y0 + self.height);
        let mut tiles = Vec::new();
        for y0 in (self.y0..y_end).step_by(size as usize) {
            for x0 in (self.x0..x_end).step_by(size as usize) {
                tiles.push(Tile {
                    x0,
                    y0,
                    width: size.min(x_end - x0),
                    height: size.min(y_end - y0),
                });
            }
        }
        tiles
    }

    /// Tiles of at most `size × size` for `workers` threads, smaller ones
    /// (halving, down to [`MIN_SHARED_TILE`]) where `size` would leave fewer
    /// than two tiles per thread of several: tiles are the unit of parallel
    /// work, so a small image of many samples would otherwise keep threads
    /// idle (a 16 × 16 tile's pass is one thread's work however many
    /// samples it takes). A pixel gets the same value whatever the tiling.
    /// One thread keeps `size`: smaller tiles would only make its waves
    /// smaller.
    pub fn split_for(&self, size: u32, workers: usize) -> Vec<Tile> {
        let mut size = size.max(1);
        let mut tiles = self.split(size);
        while workers > 1 && tiles.len() < 2 * workers && size > MIN_SHARED_TILE {
            size = (size / 2).max(MIN_SHARED_TILE);
            tiles = self.split(size);
        }
        tiles
    }
}

/// The smallest tile side [`Tile::split_for`] goes down to: a pass of
/// 16 samples over 16 pixels still makes a wave of 256 paths.
pub const MIN_SHARED_TILE: u32 = 4;

/// Per-pixel statistics of one tile.
#[derive(Clone, Debug)]
pub struct TileFilm {
    pub tile: Tile,
    /// Sum of the radiance samples, in f64: a sum of finite f32 samples
    /// can overflow f32 (four samples of 1e38) where their mean does not.
    pub sum: Vec<DVec3>,
    /// Sum of their squares, per channel (for the variance of the mean), in
    /// f64: `Σx² − n·mean²` cancels badly in f32 on low-noise pixels.
    pub sum_sq: Vec<DVec3>,
    /// Number of samples taken.
    pub count: Vec<u32>,
    /// Sums of the samples' illuminance and of its square (adaptive sampling).
    pub illum_sum: Vec<f64>,
    pub illum_sq_sum: Vec<f64>,
}

impl TileFilm {
    /// Bytes per pixel: f64 RGB sums of samples and of their squares,
    /// f64 illuminance sums of both, and a u32 count.
    pub const BYTES_PER_PIXEL: u64 = (2 * std::mem::size_of::<DVec3>()
        + 2 * std::mem::size_of::<f64>()
        + std::mem::size_of::<u32>()) as u64;

    pub fn new(tile: Tile) -> Self {
        let n = tile.pixel_count();
        TileFilm {
            tile,
            sum: vec![DVec3::ZERO; n],
            sum_sq: vec![DVec3::ZERO; n],
            count: vec![0; n],
            illum_sum: vec![0.0; n],
            illum_sq_sum: vec![0.0; n],
        }
    }

    /// Adds radiance samples to local pixel `i`, in order.
    #[inline]
    pub fn add(&mut self, i: usize, samples: &[Vec3]) {
        // The sums run in registers and are stored once: summed straight
        // into the film, every addition waited for the store of the one
        // before. The same additions in the same order, so the same bits.
        let (mut sum, mut sum_sq) = (self.sum[i], self.sum_sq[i]);
        let (mut illum_sum, mut illum_sq_sum) = (self.illum_sum[i], self.illum_sq_sum[i]);
        for &radiance in samples {
            let x = illuminance(radiance) as f64;
            let r = radiance.as_dvec3();
            sum += r;
            sum_sq += r * r;
            illum_sum += x;
            illum_sq_sum += x * x;
        }
        (self.sum[i], self.sum_sq[i]) = (sum, sum_sq);
        (self.illum_sum[i], self.illum_sq_sum[i]) = (illum_sum, illum_sq_sum);
        self.count[i] += samples.len() as u32;
    }
}

/// Photometric luminance of linear Rec.709 RGB.
#[inline]
pub fn illuminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// The finished image: mean radiance per pixel plus per-pixel sample counts.
#[derive(Clone, Debug)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// Linear RGB, row-major, row 0 at the top.
    pub pixels: Vec<Vec3>,
    /// Estimated variance of each pixel's mean, per channel: s² / n with
    /// s² the unbiased sample variance (0 with fewer than two samples).
    pub variance: Vec<Vec3>,
    pub samples: Vec<u32>,
}

impl Image {
    /// Bytes per pixel: f32 RGB mean and variance and a u32 sample count.
    pub const BYTES_PER_PIXEL: u64 =
        (2 * std::mem::size_of::<Vec3>() + std::mem::size_of::<u32>()) as u64;

    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Image {
            width,
            height,
            pixels: vec![Vec3::ZERO; n],
            variance: vec![Vec3::ZERO; n],
            samples: vec![0; n],
        }
    }

    /// Copies a finished tile in, dividing sums by sample counts. The
    /// image covers `area` of the frame the tile's coordinates are in.
    pub fn store(&mut self, film: &TileFilm, area: Tile) {
        let t = film.tile;
        let (x0, y0) = (t.x0 - area.x0, t.y0 - area.y0);
        for ty in 0..t.height {
            for tx in 0..t.width {
                let local = (ty * t.width + tx) as usize;
                let global = ((y0 + ty) * self.width + x0 + tx) as usize;
                let n = film.count[local];
                let nf = n as f64;
                let mean = if n > 0 {
                    film.sum[local] / nf
                } else {
                    DVec3::ZERO
                };
                self.pixels[global] = mean.as_vec3();
                self.variance[global] = if n > 1 {
                    (((film.sum_sq[local] - nf * mean * mean) / (nf - 1.0)).max(DVec3::ZERO) / nf)
                        .as_vec3()
                } else {
                    Vec3::ZERO
                };
                self.samples[global] = n;
            }
        }
    }

    /// Number of pixels with a NaN or infinite component.
    pub fn non_finite_count(&self) -> usize {
        self.pixels.iter().filter(|p| !p.is_finite()).count()
    }

    pub fn at(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small image is cut into enough tiles for every thread (two each
    /// where the pixels allow); a large one keeps the tile size asked for.
    /// Either way the tiles cover every pixel once.
    #[test]
    fn small_images_are_shared_among_the_threads() {
        let covered = |tiles: &[Tile], w: u32, h: u32| {
            let mut seen = vec![0u8; (w * h) as usize];
            for t in tiles {
                for y in t.y0..t.y0 + t.height {
                    for x in t.x0..t.x0 + t.width {
                        seen[(y * w + x) as usize] += 1;
                    }
                }
            }
            seen.iter().all(|&n| n == 1)
        };
        let small = Tile::whole(16, 12);
        assert_eq!(small.split(16).len(), 1);
        // Halving stops at the first side that gives two tiles per thread.
        let shared = small.split_for(16, 2);
        assert_eq!(shared, small.split(8));
        assert_eq!(shared.len(), 4);
        assert!(covered(&shared, 16, 12));
        // Six 16 × 16 tiles are too few for four threads; 8 × 8 gives 24.
        assert_eq!(Tile::whole(48, 32).split_for(16, 4).len(), 24);
        assert_eq!(Tile::whole(48, 32).split_for(16, 3).len(), 6);
        // Never below the smallest side, even for more threads than pixels.
        let tiny = Tile::whole(5, 3);
        let tiles = tiny.split_for(16, 64);
        assert_eq!(tiles.len(), 2, "{tiles:?}");
        assert_eq!((tiles[0].width, tiles[0].height), (MIN_SHARED_TILE, 3));
        assert!(covered(&tiles, 5, 3));
        // One thread: the size asked for (smaller tiles would not help it).
        assert_eq!(small.split_for(16, 1), small.split(16));
        // Enough tiles already: the size asked for.
        let large = Tile::whole(480, 360);
        assert_eq!(large.split_for(16, 2), large.split(16));
        assert_eq!(large.split_for(7, 1), large.split(7));
    }

    /// Samples added in runs of any length leave the same statistics as
    /// the samples added one by one, in the same order.
    #[test]
    fn runs_of_samples_add_up_like_single_samples() {
        let tile = Tile::whole(2, 1);
        let samples: Vec<Vec3> = (0..7)
            .map(|k| Vec3::new(0.1 * k as f32, 1.0 / (k + 1) as f32, 3.0 - 0.3 * k as f32))
            .collect();
        let mut one_by_one = TileFilm::new(tile);
        for &s in &samples {
            one_by_one.add(1, &[s]);
        }
        let mut in_runs = TileFilm::new(tile);
        in_runs.add(1, &samples[..3]);
        in_runs.add(1, &[]);
        in_runs.add(1, &samples[3..]);
        for film in [&one_by_one, &in_runs] {
            assert_eq!((film.count[0], film.count[1]), (0, 7));
            assert_eq!(film.sum[0], DVec3::ZERO);
        }
        assert_eq!(in_runs.sum[1], one_by_one.sum[1]);
        assert_eq!(in_runs.sum_sq[1], one_by_one.sum_sq[1]);
        assert_eq!(in_runs.illum_sum[1], one_by_one.illum_sum[1]);
        assert_eq!(in_runs.illum_sq_sum[1], one_by_one.illum_sq_sum[1]);
        // And they are the sums they stand for.
        let sum: DVec3 = samples.iter().map(|s| s.as_dvec3()).sum();
        assert!((in_runs.sum[1] - sum).abs().max_element() < 1e-9);
        let illum: f64 = samples.iter().map(|&s| illuminance(s) as f64).sum();
        assert!((in_runs.illum_sum[1] - illum).abs() < 1e-9);
    }

    #[test]
    fn bright_finite_samples_average_to_a_finite_pixel() {
        // Four samples of 3e38 sum past f32's largest value (3.4e38); the
        // mean of finite samples is finite, and the pixel must say so.
        let tile = Tile::whole(1, 1);
        let mut film = TileFilm::new(tile);
        film.add(0, &[Vec3::splat(3e38); 4]);
        let mut image = Image::new(1, 1);
        image.store(&film, tile);
        assert_eq!(image.pixels[0], Vec3::splat(3e38));
        assert_eq!(image.non_finite_count(), 0);
    }

    /// The adaptive test's sample illuminance, x = 0.2126R + 0.7152G +
    /// 0.0722B (Rec. 709 luminance), as the reference defines it: each
    /// primary gets its own weight, and the map is linear.
    #[test]
    fn illuminance_weighs_the_primaries_as_rec709() {
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-6 * b.abs().max(1.0);
        for (c, w) in [(Vec3::X, 0.2126), (Vec3::Y, 0.7152), (Vec3::Z, 0.0722)] {
            assert!(close(illuminance(3.0 * c), 3.0 * w), "{c}");
        }
        assert!(close(illuminance(Vec3::ONE), 1.0));
        let (a, b) = (Vec3::new(0.3, 2.0, 0.7), Vec3::new(5.0, 0.25, 1.5));
        assert!(close(illuminance(a + b), illuminance(a) + illuminance(b)));
    }

    /// A stored pixel is the mean of its samples and its variance that of
    /// the mean, s²/n with the unbiased s² (n − 1); a pixel with no
    /// sample (a tile an interrupted render never reached) is black with
    /// no variance, and one sample has no variance. The tile lands at its
    /// place in an image covering part of the frame.
    #[test]
    fn stored_pixels_are_means_with_the_variance_of_the_mean() {
        let area = Tile {
            x0: 4,
            y0: 2,
            width: 4,
            height: 3,
        };
        let tile = Tile {
            x0: 5,
            y0: 3,
            width: 3,
            height: 1,
        };
        let mut film = TileFilm::new(tile);
        let one = Vec3::new(0.5, 2.0, 4.0);
        film.add(1, &[one]);
        let several = [1.0f32, 2.0, 6.0].map(|x| Vec3::new(x, 2.0 * x, -x));
        film.add(2, &several);
        let mut image = Image::new(area.width, area.height);
        image.store(&film, area);
        // Tile pixel k is image pixel (1 + k, 1).
        let at = |k: usize| image.width as usize + 1 + k;
        assert_eq!(
            (image.pixels[at(0)], image.variance[at(0)]),
            (Vec3::ZERO, Vec3::ZERO)
        );
        assert_eq!(image.samples[at(0)], 0);
        assert_eq!(
            (image.pixels[at(1)], image.variance[at(1)]),
            (one, Vec3::ZERO)
        );
        assert_eq!(image.samples[at(1)], 1);
        // Samples 1, 2, 6: mean 3, s² = (4 + 1 + 9) / 2 = 7, s²/n = 7/3.
        let scale = Vec3::new(1.0, 2.0, -1.0);
        assert!((image.pixels[at(2)] - 3.0 * scale).abs().max_element() < 1e-6);
        let want = 7.0 / 3.0 * scale * scale;
        assert!((image.variance[at(2)] - want).abs().max_element() < 1e-5);
        assert_eq!(image.samples[at(2)], 3);
        // Nothing else was written.
        let written = [at(0), at(1), at(2)];
        for i in (0..image.pixels.len()).filter(|i| !written.contains(i)) {
            assert_eq!(image.samples[i], 0);
            assert_eq!(image.pixels[i], Vec3::ZERO);
        }
    }
}
