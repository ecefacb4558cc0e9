//! An environment map: radiance arriving from infinitely far away, looked
//! up by direction in a latitude–longitude image (`-e`).
//!
//! The mapping is the CS184 renderer's, so its maps light a scene the same
//! way there and here: the polar angle θ = acos(y) runs down the rows
//! (row 0 looks straight up, +y), the azimuth φ = atan2(−z, x) + π along
//! the columns, so the middle column looks along +x, the left and right
//! edges meet at −x, and a quarter of the way across looks along +z. A direction's radiance is the bilinear interpolation
//! of the four nearest texel centres, wrapping around in φ and clamped at
//! the poles.

use std::f64::consts::{PI, TAU};

use glam::Vec3;
use wide::f64x4;

use crate::prefetch::prefetch;

/// A latitude–longitude radiance map.
#[derive(Clone, PartialEq)]
pub struct EnvironmentMap {
    width: u32,
    height: u32,
    /// Linear RGB radiance, row-major, row 0 at the top (θ = 0).
    texels: Vec<Vec3>,
    /// Whether any texel is brighter than black.
    emits: bool,
}

/// Largest radiance a texel may hold: far above any captured sun (~1e9),
/// and far enough below f32's limit that a sample's radiance over its
/// density stays finite.
pub const MAX_RADIANCE: f32 = 1e20;

/// Largest width or height of a map: the sampling tables choose a row, and
/// a column within it, with a 24-bit draw (one slot at least per cell).
pub const MAX_SIDE: u32 = 1 << 24;

impl std::fmt::Debug for EnvironmentMap {
    /// The size only: a map holds millions of texels.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "EnvironmentMap({}x{})", self.width, self.height)
    }
}

impl EnvironmentMap {
    /// The map of `width × height` texels (row 0 at the top). Radiance must
    /// be a number from 0 to [`MAX_RADIANCE`], and the sides at most
    /// [`MAX_SIDE`]: the error names the first texel that is not, by
    /// column and row.
    pub fn new(width: u32, height: u32, texels: Vec<Vec3>) -> Result<EnvironmentMap, String> {
        if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
            return Err(format!(
                "the map is {width}x{height} texels; its sides must be 1 to {MAX_SIDE}"
            ));
        }
        assert_eq!(texels.len(), width as usize * height as usize);
        // (glam's min and max of a vector pass over NaN components.)
        let usable =
            |t: &Vec3| t.is_finite() && t.min_element() >= 0.0 && t.max_element() <= MAX_RADIANCE;
        if let Some(i) = texels.iter().position(|t| !usable(t)) {
            let (x, y) = (i % width as usize, i / width as usize);
            return Err(format!(
                "texel ({x}, {y}) (column, row from the top) is {} {} {}; radiance must be a \
                 number from 0 to {MAX_RADIANCE:e}",
                texels[i].x, texels[i].y, texels[i].z
            ));
        }
        let emits = texels.iter().any(|t| t.max_element() > 0.0);
        Ok(EnvironmentMap {
            width,
            height,
            texels,
            emits,
        })
    }

    /// A map of one colour everywhere.
    pub fn uniform(radiance: Vec3) -> Result<EnvironmentMap, String> {
        EnvironmentMap::new(1, 1, vec![radiance])
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// Texel `(x, y)`: column `x` (wrapping around), row `y` from the top
    /// (clamped to the map).
    #[inline]
    pub fn texel(&self, x: i64, y: i64) -> Vec3 {
        let x = x.rem_euclid(i64::from(self.width)) as usize;
        let y = y.clamp(0, i64::from(self.height) - 1) as usize;
        self.texels[y * self.width as usize + x]
    }

    /// Whether any texel is brighter than black.
    pub fn emits(&self) -> bool {
        self.emits
    }

    /// Radiance arriving from direction `d` (any length but 0). Out of
    /// line: the shading stage calls it only for rays that escape.
    #[inline(never)]
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        let (x, y) = self.position(d);
        self.at(x, y)
    }

    /// Where direction `d` falls on the map, in texels: `x` in
    /// `[0, width]` along φ, `y` in `[0, height]` along θ.
    pub fn position(&self, d: Vec3) -> (f64, f64) {
        self.positions([d; 4])[0]
    }

    /// [`position`](Self::position) of four directions at once, their
    /// arc tangents and arc cosines in vector lanes (Agner Fog's
    /// polynomials, as `wide` has them: within a few units in the last
    /// place of f64, a hundred million times finer than a texel of the
    /// largest map).
    #[inline]
    pub fn positions(&self, d: [Vec3; 4]) -> [(f64, f64); 4] {
        // (`from_fn`, not `array::map`: the latter is compiled out of
        // line here, a call per lane.)
        let unit: [glam::DVec3; 4] = std::array::from_fn(|k| {
            let d = d[k].as_dvec3();
            d / d.length()
        });
        let axis = |k: usize| f64x4::new([unit[0][k], unit[1][k], unit[2][k], unit[3][k]]);
        let phi = (-axis(2)).atan2(axis(0)) + f64x4::splat(PI);
        let x = (phi * f64x4::splat(f64::from(self.width) / TAU)).to_array();
        let y = self.rows_at(axis(1).to_array());
        [(x[0], y[0]), (x[1], y[1]), (x[2], y[2]), (x[3], y[3])]
    }

    /// The row positions `y` (in texels) of four directions of polar
    /// cosines `cos_theta`.
    #[inline]
    pub fn rows_at(&self, cos_theta: [f64; 4]) -> [f64; 4] {
        let one = f64x4::splat(1.0);
        let theta = f64x4::new(cos_theta).max(-one).min(one).acos();
        (theta * f64x4::splat(f64::from(self.height) / PI)).to_array()
    }

    /// The bilinear interpolation at map position `(x, y)` (in texels;
    /// texel centres at half-integers): wrapping around in `x`, clamped to
    /// the first and last rows' centres in `y`.
    pub fn at(&self, x: f64, y: f64) -> Vec3 {
        let f = self.footprint(x, y);
        let row = |y: usize| {
            let texels = &self.texels[y * self.width as usize..];
            texels[f.columns[0]] * (1.0 - f.tx) + texels[f.columns[1]] * f.tx
        };
        row(f.rows[0]) * (1.0 - f.ty) + row(f.rows[1]) * f.ty
    }

    /// Requests the texels that [`at`](Self::at)`(x, y)` will read (see
    /// [`prefetch`](crate::prefetch)).
    #[inline]
    pub fn prefetch(&self, x: f64, y: f64) {
        let f = self.footprint(x, y);
        for y in f.rows {
            let row = y * self.width as usize;
            // A texel is 12 bytes: the pair may span two lines.
            prefetch(&self.texels[row + f.columns[0]]);
            prefetch(&self.texels[row + f.columns[1]].z);
        }
    }

    /// The four texels a lookup at `(x, y)` blends, and the weights.
    #[inline(always)]
    fn footprint(&self, x: f64, y: f64) -> Footprint {
        let (w, h) = (i64::from(self.width), i64::from(self.height));
        let (fx, fy) = (x - 0.5, (y - 0.5).clamp(0.0, (h - 1) as f64));
        let (x0, y0) = (fx.floor(), fy.floor());
        // Positions of directions lie in [0, w], so one wrap at most; the
        // remainder (a division) only for anything further out.
        let wrap = |i: i64| match i {
            i if i < 0 && i >= -w => i + w,
            i if i >= w && i < 2 * w => i - w,
            i => i.rem_euclid(w),
        } as usize;
        let y0i = y0 as usize;
        Footprint {
            columns: [wrap(x0 as i64), wrap(x0 as i64 + 1)],
            rows: [y0i, (y0i + 1).min(h as usize - 1)],
            tx: (fx - x0) as f32,
            ty: (fy - y0) as f32,
        }
    }
}

/// Where a bilinear lookup reads: two columns and two rows of texels,
/// with the second column's and row's weights.
struct Footprint {
    columns: [usize; 2],
    rows: [usize; 2],
    tx: f32,
    ty: f32,
}

/// The unit direction at polar angle θ (its cosine `cos_theta`) and
/// azimuth `phi`, in the map's convention (see the module docs). In f64:
/// near the poles a cell of a large map spans less than f32's spacing of
/// cos θ, and sin θ = √((1 − c)(1 + c)) keeps its digits there.
#[inline]
pub fn direction(cos_theta: f64, phi: f64) -> Vec3 {
    directions([cos_theta; 4], [phi; 4])[0]
}

/// [`direction`] for four lanes at once (sines and cosines in vector
/// lanes, as in [`EnvironmentMap::positions`]).
#[inline]
pub fn directions(cos_theta: [f64; 4], phi: [f64; 4]) -> [Vec3; 4] {
    let one = f64x4::splat(1.0);
    let c = f64x4::new(cos_theta).max(-one).min(one);
    let sin_theta = ((one - c) * (one + c)).sqrt();
    let (sin_phi, cos_phi) = f64x4::new(phi).sin_cos();
    let (x, y, z) = (
        (-cos_phi * sin_theta).to_array(),
        c.to_array(),
        (sin_phi * sin_theta).to_array(),
    );
    std::array::from_fn(|k| glam::DVec3::new(x[k], y[k], z[k]).as_vec3())
}

/// The azimuth of a column position `x` (in texels) of a map `width` wide.
#[inline]
pub fn azimuth(x: f64, width: u32) -> f64 {
    x / f64::from(width) * std::f64::consts::TAU
}

/// Cosine of the polar angle at row position `y` of a map `height` tall.
#[inline]
pub fn polar_cosine(y: f64, height: u32) -> f64 {
    (y / f64::from(height) * std::f64::consts::PI).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Row 0 looks up, the last row down; the middle column looks along
    /// +x, three quarters of the way along −z, a quarter along +z, the
    /// edges along −x (φ = atan2(−z, x) + π); and the direction of a
    /// position maps back to that position.
    #[test]
    fn directions_and_positions_agree_with_the_reference_mapping() {
        let map = EnvironmentMap::new(8, 4, vec![Vec3::ZERO; 32]).unwrap();
        let close = |(x, y): (f64, f64), (ex, ey): (f64, f64)| {
            (x - ex).abs() < 1e-9 && (y - ey).abs() < 1e-9
        };
        assert!(close(map.position(Vec3::Y), (map.position(Vec3::Y).0, 0.0)));
        assert!(close(
            map.position(Vec3::NEG_Y),
            (map.position(Vec3::NEG_Y).0, 4.0)
        ));
        // +x: φ = atan2(0, 1) + π = π, the middle column.
        assert!(close(map.position(Vec3::X), (4.0, 2.0)));
        // −z: φ = atan2(1, 0) + π = 3π/2; +z: π/2.
        assert!(close(map.position(Vec3::NEG_Z), (6.0, 2.0)));
        assert!(close(map.position(Vec3::Z), (2.0, 2.0)));
        for &(x, y) in &[(0.3, 0.2), (4.0, 2.0), (7.9, 3.7), (2.5, 1.0)] {
            let d = direction(polar_cosine(y, 4), azimuth(x, 8));
            let (bx, by) = map.position(d);
            assert!(
                (bx - x).abs() < 1e-5 && (by - y).abs() < 1e-5,
                "({x}, {y}) -> {d} -> ({bx}, {by})"
            );
        }
    }

    /// At texel centres the map returns the texel; halfway between two
    /// it returns their mean, across the φ seam too; past the centres of
    /// the first and last rows it holds their value.
    #[test]
    fn lookups_interpolate_between_texel_centres() {
        let texels: Vec<Vec3> = (0..12).map(|i| Vec3::splat(i as f32)).collect();
        let map = EnvironmentMap::new(4, 3, texels).unwrap();
        assert_eq!(map.at(1.5, 1.5), Vec3::splat(5.0));
        assert_eq!(map.at(2.0, 1.5), Vec3::splat(5.5));
        assert_eq!(map.at(1.5, 2.0), Vec3::splat(7.0));
        // Column 3 and column 0 of row 1 (7 and 4), across the seam.
        assert_eq!(map.at(4.0, 1.5), Vec3::splat(5.5));
        assert_eq!(map.at(0.0, 1.5), Vec3::splat(5.5));
        assert_eq!(map.at(1.5, 0.0), Vec3::splat(1.0));
        assert_eq!(map.at(1.5, 3.0), Vec3::splat(9.0));
    }

    #[test]
    fn bad_texels_are_named() {
        let mut texels = vec![Vec3::ONE; 6];
        texels[4] = Vec3::new(1.0, f32::NAN, 0.0);
        let e = EnvironmentMap::new(3, 2, texels.clone()).unwrap_err();
        assert!(
            e.starts_with("texel (1, 1) (column, row from the top) is 1 NaN 0"),
            "{e}"
        );
        for bad in [-0.5, f32::INFINITY, 2.0 * MAX_RADIANCE] {
            texels[4] = Vec3::new(1.0, bad, 0.0);
            assert!(EnvironmentMap::new(3, 2, texels.clone()).is_err(), "{bad}");
        }
        texels[4] = Vec3::new(1.0, MAX_RADIANCE, 0.0);
        assert!(EnvironmentMap::new(3, 2, texels).is_ok());
        assert!(EnvironmentMap::new(0, 2, vec![]).is_err());
        let e = EnvironmentMap::new(MAX_SIDE + 1, 1, vec![]).unwrap_err();
        assert!(e.contains("must be 1 to 16777216"), "{e}");
    }
}
