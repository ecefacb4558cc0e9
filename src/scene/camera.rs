//! The pinhole camera and the placement rule that decides framing.
//!
//! Scenes of the CS184 dialect do not place the camera where the file puts
//! it: the renderer keeps only the view *direction* of the camera node,
//! backs off from the centre of the scene bounds by 1.5 × the bounds'
//! diagonal, and fits the field of view to an 800×600 screen. Reproducing
//! that rule exactly is what makes our images frame like the reference.

use glam::{Mat3, Vec3};
use wide::f32x8;

use crate::lanes::Vec3x8;

/// Width and height of the screen the reference fits the field of view to.
pub const FIT_WIDTH: f32 = 800.0;
pub const FIT_HEIGHT: f32 = 600.0;

/// Pinhole camera, independent of the output resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub target: Vec3,
    /// Camera-to-world rotation; columns are screen x, screen y and the
    /// backward direction (the camera looks down its local −z).
    pub camera_to_world: Mat3,
    /// Distance from the eye to the image plane, in pixels of the 800×600 fit screen.
    pub screen_distance: f32,
    pub znear: f32,
    pub zfar: f32,
}

/// The camera's optics as the scene file states them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Perspective {
    /// Horizontal field of view in degrees, if given.
    pub xfov: Option<f32>,
    /// Vertical field of view in degrees, if given.
    pub yfov: Option<f32>,
    pub aspect_ratio: Option<f32>,
    pub znear: Option<f32>,
    pub zfar: Option<f32>,
}

impl Perspective {
    /// The near and far clipping distances, with the reference's defaults
    /// (0.001 and 1000) for those not given.
    pub fn clip_range(&self) -> (f32, f32) {
        (self.znear.unwrap_or(0.001), self.zfar.unwrap_or(1000.0))
    }

    /// (hfov, vfov) in degrees before fitting, with the reference's defaults.
    pub fn fov_degrees(&self) -> (f32, f32) {
        let h = self.xfov.unwrap_or(50.0);
        let v = match (self.yfov, self.aspect_ratio) {
            (Some(v), _) => v,
            (None, Some(a)) if a > 0.0 => {
                2.0 * ((0.5 * h.to_radians()).tan() / a).atan().to_degrees()
            }
            _ => 35.0,
        };
        (h, v)
    }
}

/// Per-resolution view parameters: the tangents of the half fields of view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraView {
    pub width: u32,
    pub height: u32,
    pub tan_half_hfov: f32,
    pub tan_half_vfov: f32,
}

impl Camera {
    /// Places the camera by the reference's rule.
    ///
    /// `view_dir` is the camera node's `T·(0,0,−1,1)` (not normalised; the
    /// translation is included on purpose), `scene_bounds` the bounds of all
    /// mesh vertices and spheres.
    pub fn place(view_dir: Vec3, optics: &Perspective, scene_min: Vec3, scene_max: Vec3) -> Camera {
        let c = view_dir.normalize_or(Vec3::Z);
        let (target, r) = if scene_min.cmple(scene_max).all() {
            (
                0.5 * (scene_min + scene_max),
                1.5 * (scene_max - scene_min).length(),
            )
        } else {
            (Vec3::ZERO, 1.0)
        };
        let r = if r > 0.0 && r.is_finite() { r } else { 1.0 };
        let position = target + r * c;
        let back = (position - target).normalize_or(Vec3::Z);
        // Screen x = Y × back; fall back to Z when looking straight up or down.
        let mut screen_x = Vec3::Y.cross(back);
        if screen_x.length_squared() < 1e-12 {
            screen_x = Vec3::Z.cross(back);
        }
        let screen_x = screen_x.normalize();
        let screen_y = back.cross(screen_x).normalize();

        // Fit to the 800×600 screen: widen whichever field of view is too
        // narrow. Widening the horizontal one leaves the vertical as it is;
        // otherwise the vertical follows the horizontal.
        let (h, v) = optics.fov_degrees();
        let (tan_h, tan_v) = ((0.5 * h.to_radians()).tan(), (0.5 * v.to_radians()).tan());
        let aspect = FIT_WIDTH / FIT_HEIGHT;
        let tan_v = if tan_h / tan_v < aspect {
            tan_v
        } else {
            tan_h / aspect
        };
        let screen_distance = FIT_HEIGHT / (2.0 * tan_v);

        let (znear, zfar) = optics.clip_range();
        Camera {
            position,
            target,
            camera_to_world: Mat3::from_cols(screen_x, screen_y, back),
            screen_distance,
            znear,
            zfar,
        }
    }

    /// What of the box `min..max` (the scene's) the far clipping plane
    /// cuts off, if any, as a warning; the caller says how to move the
    /// plane. A scene's camera is placed by the reference's rule (1.5
    /// diagonals from the centre), so a large scene with the default
    /// `zfar` of 1000 can lie wholly beyond it and render black. Camera
    /// rays end at distance `zfar` from the eye (the clipping "plane" is
    /// a sphere about it, as in the reference), so the box's nearest
    /// point and its farthest corner ahead of the eye are measured by
    /// distance (a sphere's box reaches a little further than the sphere;
    /// corners behind the eye, which no camera ray reaches, do not count).
    pub fn far_plane_cuts(&self, min: Vec3, max: Vec3) -> Option<String> {
        if !min.cmple(max).all() {
            return None;
        }
        let eye = self.position.as_dvec3();
        let (min, max) = (min.as_dvec3(), max.as_dvec3());
        let near = (eye.clamp(min, max) - eye).length();
        let forward = (-self.camera_to_world.z_axis).as_dvec3();
        let far = (0..8)
            .map(|k| {
                glam::DVec3::new(
                    if k & 1 == 0 { min.x } else { max.x },
                    if k & 2 == 0 { min.y } else { max.y },
                    if k & 4 == 0 { min.z } else { max.z },
                ) - eye
            })
            .filter(|to_corner| to_corner.dot(forward) > 0.0)
            .map(|to_corner| to_corner.length())
            .fold(0.0, f64::max);
        let zfar = self.zfar;
        if near > f64::from(zfar) {
            Some(format!(
                "the whole scene lies beyond the far clipping plane (zfar {zfar}; the scene is {near:.4e} to {far:.4e} from the camera), so none of it can show"
            ))
        } else if far > f64::from(zfar) {
            Some(format!(
                "part of the scene lies beyond the far clipping plane (zfar {zfar}; the scene reaches {far:.4e} from the camera) and is not drawn"
            ))
        } else {
            None
        }
    }

    /// View for a `width × height` render: the central crop of the fit screen
    /// at the same screen distance.
    pub fn view(&self, width: u32, height: u32) -> CameraView {
        CameraView {
            width,
            height,
            tan_half_hfov: width as f32 / (2.0 * self.screen_distance),
            tan_half_vfov: height as f32 / (2.0 * self.screen_distance),
        }
    }

    /// World-space direction (unnormalised, camera-space z = −1) through
    /// film position `(fx, fy)` in pixels, y = 0 at the bottom row.
    #[inline]
    pub fn direction(&self, view: &CameraView, fx: f32, fy: f32) -> Vec3 {
        self.directions_x8(view, f32x8::splat(fx), f32x8::splat(fy))
            .lane(0)
    }

    /// [`direction`](Self::direction) through eight film positions at
    /// once, one per lane.
    #[inline]
    pub fn directions_x8(&self, view: &CameraView, fx: f32x8, fy: f32x8) -> Vec3x8 {
        // Film position → [−1, 1] across the view → the screen at z = −1.
        let screen = |f: f32x8, size: u32, tan_half_fov: f32| {
            (f32x8::splat(2.0) * f / f32x8::splat(size as f32) - f32x8::ONE)
                * f32x8::splat(tan_half_fov)
        };
        let sx = screen(fx, view.width, view.tan_half_hfov);
        let sy = screen(fy, view.height, view.tan_half_vfov);
        // `camera_to_world * (sx, sy, −1)` in the order glam's `Mat3 * Vec3`
        // adds the columns; subtracting the z column is adding it times −1
        // exactly, so a lane holds what that product gives.
        let m = &self.camera_to_world;
        Vec3x8::splat(m.x_axis) * sx + Vec3x8::splat(m.y_axis) * sy - Vec3x8::splat(m.z_axis)
    }
}

impl CameraView {
    /// Full horizontal and vertical field of view in degrees.
    pub fn fov_degrees(&self) -> (f32, f32) {
        (
            2.0 * self.tan_half_hfov.atan().to_degrees(),
            2.0 * self.tan_half_vfov.atan().to_degrees(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: (f32, f32), b: (f32, f32)) -> bool {
        (a.0 - b.0).abs() < 1e-3 && (a.1 - b.1).abs() < 1e-3
    }

    /// The fields of view a scene states, with the reference's defaults
    /// (50° across, 35° up), the vertical one from the aspect ratio when
    /// only that is given, and the 800×600 fit widening the narrower.
    #[test]
    fn fields_of_view_follow_the_reference_rules() {
        let optics = |xfov, yfov, aspect_ratio| Perspective {
            xfov,
            yfov,
            aspect_ratio,
            ..Perspective::default()
        };
        // tan 20° / 0.5 = 0.72794, whose angle doubled is 72.105°.
        let cases = [
            (optics(Some(30.0), Some(60.0), Some(2.0)), (30.0, 60.0)),
            (optics(Some(40.0), None, Some(0.5)), (40.0, 72.1048)),
            (optics(Some(40.0), None, Some(0.0)), (40.0, 35.0)),
            (optics(Some(40.0), None, Some(-1.0)), (40.0, 35.0)),
            (optics(None, None, None), (50.0, 35.0)),
        ];
        for (optics, fov) in cases {
            assert!(close(optics.fov_degrees(), fov), "{optics:?}");
        }
        // Fitted: a tall view keeps its vertical field (the horizontal
        // widens to 4:3); a wide one keeps its horizontal field (the
        // vertical follows: tan 45° · 3/4 is tan 36.87°).
        let fitted = |optics: Perspective| {
            Camera::place(Vec3::Z, &optics, -Vec3::ONE, Vec3::ONE)
                .view(800, 600)
                .fov_degrees()
        };
        // 2·atan(tan 30° · 4/3) = 75.178°.
        assert!(close(
            fitted(optics(Some(30.0), Some(60.0), None)),
            (75.1782, 60.0)
        ));
        assert!(close(
            fitted(optics(Some(90.0), Some(30.0), None)),
            (90.0, 73.7398)
        ));
    }

    /// The far clipping distance is measured along rays, from the eye: a
    /// box wholly within it says nothing, one whose far corners ahead lie
    /// past it is partly cut, one whose nearest point lies past it wholly;
    /// corners behind the eye, which no camera ray reaches, do not count.
    #[test]
    fn the_far_plane_is_a_distance_from_the_eye_ahead_of_it() {
        let camera = Camera {
            position: Vec3::ZERO,
            target: Vec3::NEG_Z,
            camera_to_world: Mat3::IDENTITY,
            screen_distance: 500.0,
            znear: 0.1,
            zfar: 150.0,
        };
        let cuts = |min: Vec3, max: Vec3| camera.far_plane_cuts(min, max);
        // Ahead, 100 deep and 200 wide: its far corners are 173 away,
        // though no farther than 100 along the view axis.
        let ahead = cuts(
            Vec3::new(-100.0, -100.0, -100.0),
            Vec3::new(100.0, 100.0, -1.0),
        );
        assert!(ahead.is_some_and(|w| w.starts_with("part of the scene")));
        // Around the eye, mostly behind it: the corners ahead are 142
        // away; those behind, 173, are never seen.
        let around = Vec3::new(100.0, 100.0, 100.0);
        assert_eq!(cuts(Vec3::new(-100.0, -100.0, -10.0), around), None);
        // Wholly beyond: its nearest point is 160 away.
        let beyond = cuts(Vec3::new(-1.0, -1.0, -200.0), Vec3::new(1.0, 1.0, -160.0));
        assert!(beyond.is_some_and(|w| w.starts_with("the whole scene")));
    }

    /// The camera backs off 1.5 diagonals from the scene's centre, or one
    /// unit where that distance is 0 (a scene that is one point) or not
    /// finite (bounds past f32's range).
    #[test]
    fn placement_backs_off_one_unit_when_the_diagonal_is_no_distance() {
        let optics = Perspective::default();
        let p = Vec3::new(1.0, 2.0, 3.0);
        let camera = Camera::place(Vec3::X, &optics, p, p);
        assert_eq!((camera.target, camera.position), (p, p + Vec3::X));
        let huge = Vec3::splat(3e38);
        let camera = Camera::place(Vec3::X, &optics, -huge, huge);
        assert_eq!((camera.target, camera.position), (Vec3::ZERO, Vec3::X));
        let camera = Camera::place(Vec3::X, &optics, -Vec3::ONE, Vec3::ONE);
        let diagonal = 1.5 * (2.0 * Vec3::ONE).length();
        assert_eq!(camera.position, diagonal * Vec3::X);
    }

    /// Every lane of `directions_x8` holds, bit for bit, the product
    /// `camera_to_world · (sx, sy, −1)` for its own film position, and the
    /// scalar `direction` is that lane.
    #[test]
    fn lane_directions_are_the_matrix_product_bit_for_bit() {
        let camera = Camera {
            position: Vec3::new(1.0, 2.0, -3.0),
            target: Vec3::ZERO,
            camera_to_world: Mat3::from_axis_angle(Vec3::new(0.3, -1.0, 0.5).normalize(), 0.7),
            screen_distance: 437.0,
            znear: 0.01,
            zfar: 100.0,
        };
        let view = camera.view(97, 61);
        let fx = [0.0, 0.5, 13.25, 48.5, 96.99, 3.0, 70.125, 1e-3];
        let fy = [60.99, 0.0, 30.5, 7.75, 0.25, 59.0, 12.0, 44.4];
        let lanes = camera.directions_x8(&view, f32x8::from(fx), f32x8::from(fy));
        for l in 0..8 {
            let sx = (2.0 * fx[l] / view.width as f32 - 1.0) * view.tan_half_hfov;
            let sy = (2.0 * fy[l] / view.height as f32 - 1.0) * view.tan_half_vfov;
            let expected = (camera.camera_to_world * Vec3::new(sx, sy, -1.0)).to_array();
            let bits = |v: Vec3| v.to_array().map(f32::to_bits);
            assert_eq!(bits(lanes.lane(l)), expected.map(f32::to_bits), "lane {l}");
            assert_eq!(
                bits(camera.direction(&view, fx[l], fy[l])),
                bits(lanes.lane(l))
            );
        }
    }
}
