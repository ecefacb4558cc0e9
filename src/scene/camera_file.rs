//! Camera settings files (`-c`), as the CS184 viewer writes them: the
//! viewer's camera, saved so that a headless render can take the same view.
//!
//! The file is whitespace-separated numbers: the fields of view, aspect
//! ratio and clip planes; position and target; the orbit angles and
//! radius limits; the camera-to-world matrix row by row; the screen size
//! and distance in pixels; and, in newer files, the focal distance and lens
//! radius. The reference loads the file after sizing its screen and then
//! traces with the file's fields of view, whatever `-r` is. wavepath does
//! the same for the vertical field of view. Its pixels stay square, so
//! where the file's aspect ratio differs from `-r`'s, the horizontal field
//! of view follows from `-r` (the reference would stretch the image), and
//! the caller is told. The orbit values only steer the viewer. The lens
//! stays with `-b` and `-d`.

use glam::{Mat3, Vec3};

use super::Camera;

/// What each number of the file is, in order (the last two are optional).
const FIELDS: [&str; 30] = [
    "hfov",
    "vfov",
    "aspect ratio",
    "near clip",
    "far clip",
    "position x",
    "position y",
    "position z",
    "target x",
    "target y",
    "target z",
    "phi",
    "theta",
    "r",
    "min r",
    "max r",
    "c2w[0][0]",
    "c2w[0][1]",
    "c2w[0][2]",
    "c2w[1][0]",
    "c2w[1][1]",
    "c2w[1][2]",
    "c2w[2][0]",
    "c2w[2][1]",
    "c2w[2][2]",
    "screen width",
    "screen height",
    "screen distance",
    "focal distance",
    "lens radius",
];

/// A camera settings file: the view, and the fields of view it was saved with.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraFile {
    /// Position, orientation and clip planes; the screen distance is the
    /// file's, in pixels of the viewer's screen.
    pub camera: Camera,
    /// tan(hfov/2) and tan(vfov/2) of the file's fields of view.
    pub tan_half_fov: (f64, f64),
}

impl CameraFile {
    /// The camera for a `width × height` render: the file's vertical field
    /// of view over `height` pixels. The second value says what differs
    /// from the reference when the file's aspect ratio is not `width /
    /// height`.
    pub fn camera(&self, width: u32, height: u32) -> (Camera, Option<String>) {
        let (th, tv) = self.tan_half_fov;
        let camera = Camera {
            screen_distance: (height as f64 / (2.0 * tv)) as f32,
            ..self.camera.clone()
        };
        let (file, render) = (th / tv, width as f64 / height as f64);
        let note = ((file / render - 1.0).abs() > 1e-3).then(|| {
            format!(
                "its fields of view have aspect {file:.4}, the {width}×{height} render {render:.4}: \
                 the vertical field of view is kept and the horizontal one follows from -r \
                 (the CS184 renderer would stretch the image)"
            )
        });
        (camera, note)
    }
}

/// Reads a settings file; the error names the value at fault.
pub fn parse(text: &str) -> Result<CameraFile, String> {
    // A byte-order mark, as some editors write, is not part of a number.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let words: Vec<&str> = text.split_whitespace().collect();
    if words.len() != 28 && words.len() != 30 {
        return Err(format!(
            "expected 28 or 30 numbers (fields of view, clip planes, position, target, \
             orbit, camera-to-world matrix, screen, optionally focal distance and lens \
             radius), found {}",
            words.len()
        ));
    }
    let mut v = [0.0f32; 30];
    for (i, word) in words.iter().enumerate() {
        v[i] = match word.parse::<f32>() {
            Ok(x) if x.is_finite() => x,
            _ => {
                return Err(format!(
                    "{} (number {}) is '{word}', not a finite number",
                    FIELDS[i],
                    i + 1
                ));
            }
        };
    }
    for (i, fov) in [(0, v[0]), (1, v[1])] {
        if !(fov > 0.0 && fov < 180.0) {
            return Err(format!(
                "{} {fov}: need a field of view between 0 and 180 degrees",
                FIELDS[i]
            ));
        }
    }
    // Values the render does not use are still checked: a file with a
    // negative size or aspect is corrupt, not merely unusual.
    let mut positive = vec![(2, v[2]), (25, v[25]), (26, v[26])];
    if words.len() == 30 {
        positive.push((28, v[28]));
    }
    for (i, x) in positive {
        if x <= 0.0 {
            return Err(format!("{} {x} must be positive", FIELDS[i]));
        }
    }
    if words.len() == 30 && v[29] < 0.0 {
        return Err(format!("{} {} must not be negative", FIELDS[29], v[29]));
    }
    let (near, far) = (v[3], v[4]);
    if !(near >= 0.0 && far > near) {
        return Err(format!("clip planes {near} and {far}: need 0 ≤ near < far"));
    }
    let screen_distance = v[27];
    if screen_distance <= 0.0 {
        return Err(format!(
            "screen distance {screen_distance} must be positive"
        ));
    }
    // Row-major: row i, column j is v[16 + 3i + j]; the columns are the
    // screen's x and y and the direction back toward the eye.
    let column = |j: usize| Vec3::new(v[16 + j], v[19 + j], v[22 + j]);
    let columns = [column(0), column(1), column(2)];
    for (j, c) in columns.iter().enumerate() {
        if (c.length() - 1.0).abs() > 1e-3 {
            return Err(format!(
                "camera-to-world column {j} {c} has length {}, not 1: not a rotation",
                c.length()
            ));
        }
    }
    // Unit columns are a rotation only if they are also orthogonal and
    // right-handed (screen x × screen y = toward the eye): otherwise the
    // image would be sheared or mirrored.
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        let cos = columns[i].dot(columns[j]);
        if cos.abs() > 1e-3 {
            return Err(format!(
                "camera-to-world columns {i} {} and {j} {} are not orthogonal \
                 (cosine {cos}): not a rotation",
                columns[i], columns[j]
            ));
        }
    }
    let det = columns[0].cross(columns[1]).dot(columns[2]);
    if det < 0.0 {
        return Err(format!(
            "camera-to-world matrix has determinant {det}: a mirror image, not a rotation"
        ));
    }
    let tan_half = |degrees: f32| (0.5 * (degrees as f64).to_radians()).tan();
    Ok(CameraFile {
        camera: Camera {
            position: Vec3::new(v[5], v[6], v[7]),
            target: Vec3::new(v[8], v[9], v[10]),
            camera_to_world: Mat3::from_cols(columns[0], columns[1], columns[2]),
            screen_distance,
            znear: near,
            zfar: far,
        },
        tan_half_fov: (tan_half(v[0]), tan_half(v[1])),
    })
}

/// The settings file of `camera` for a `width × height` screen, as the
/// viewer writes it (zero orbit values, no lens): for tests and for
/// handing a scene's view to the viewer.
pub fn write(camera: &Camera, width: u32, height: u32) -> String {
    let view = camera.view(width, height);
    let fov = |t: f32| (2.0 * (t as f64).atan().to_degrees()) as f32;
    let m = camera.camera_to_world;
    let rows: Vec<String> = (0..3)
        .flat_map(|i| (0..3).map(move |j| m.col(j)[i].to_string()))
        .collect();
    let p = camera.position;
    let t = camera.target;
    format!(
        "{} {} {} {} {}\n{} {} {} {} {} {}\n0 0 0 0 0\n{}\n{width} {height} {}\n",
        fov(view.tan_half_hfov),
        fov(view.tan_half_vfov),
        width as f32 / height as f32,
        camera.znear,
        camera.zfar,
        p.x,
        p.y,
        p.z,
        t.x,
        t.y,
        t.z,
        rows.join(" "),
        camera.screen_distance,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        let back = Vec3::new(0.3, 0.4, 1.0).normalize();
        let x = Vec3::Y.cross(back).normalize();
        Camera {
            position: Vec3::new(1.0, 2.0, 3.0),
            target: Vec3::new(1.0, 2.0, 3.0) - back,
            camera_to_world: Mat3::from_cols(x, back.cross(x), back),
            screen_distance: 700.5,
            znear: 0.1,
            zfar: 100.0,
        }
    }

    #[test]
    fn a_written_file_reads_back_as_the_same_camera() {
        let c = camera();
        let file = parse(&write(&c, 800, 600)).unwrap();
        assert_eq!(file.camera, c);
        // Rendered at the size it was written for, the same screen
        // distance (to the rounding of the degrees written), no note.
        let (at, note) = file.camera(800, 600);
        assert!((at.screen_distance / c.screen_distance - 1.0).abs() < 1e-5);
        assert_eq!(note, None);
        // At another size, the same vertical field of view; another
        // aspect ratio is noted.
        let (small, note) = file.camera(80, 60);
        assert!((small.screen_distance / (0.1 * c.screen_distance) - 1.0).abs() < 1e-5);
        assert_eq!(note, None);
        assert!(file.camera(100, 60).1.is_some());
        // With the lens values newer files add.
        let with_lens = format!("{}4.7 0.25\n", write(&c, 800, 600));
        assert_eq!(parse(&with_lens).unwrap(), file);
        // Saved by an editor that starts files with a byte-order mark.
        let with_bom = format!("\u{feff}{}", write(&c, 800, 600));
        assert_eq!(parse(&with_bom).unwrap(), file);
    }

    /// A file laid out as the viewer writes it, with a matrix that is not
    /// symmetric: row i of the file is row i of camera-to-world, so the
    /// camera's columns are the file's columns.
    #[test]
    fn the_matrix_is_read_row_by_row() {
        let text = "49.1 37.8 1.333 0.1 100\n\
                    1 2 3 0 0 0\n\
                    1.2 0.3 4 1 10\n\
                    0 0.6 0.8 1 0 0 0 0.8 -0.6\n\
                    800 600 868.6\n";
        let c = parse(text).unwrap().camera;
        let m = c.camera_to_world;
        assert_eq!(m.col(0), Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(m.col(1), Vec3::new(0.6, 0.0, 0.8));
        assert_eq!(m.col(2), Vec3::new(0.8, 0.0, -0.6));
        assert_eq!(c.position, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!((c.znear, c.zfar, c.screen_distance), (0.1, 100.0, 868.6));
    }

    #[test]
    fn bad_files_name_the_value_at_fault() {
        let good = write(&camera(), 800, 600);
        let words: Vec<&str> = good.split_whitespace().collect();
        let with_all = |changes: &[(usize, &str)]| {
            let mut v = words.clone();
            for &(i, w) in changes {
                v[i] = w;
            }
            v.join(" ")
        };
        let with = |i: usize, w: &str| with_all(&[(i, w)]);
        let negate = |w: &str| format!("{}", -w.parse::<f32>().unwrap());
        let cases = [
            (words[..27].join(" "), "found 27"),
            (format!("{good} 1"), "found 29"),
            (with(6, "nan"), "position y (number 7)"),
            (with(16, "x"), "c2w[0][0]"),
            (with(27, "0"), "screen distance 0"),
            (with(4, "0.05"), "clip planes"),
            (with(16, "3"), "not a rotation"),
            // Column 1 made equal to column 0 (both unit length).
            (
                with_all(&[(17, words[16]), (20, words[19]), (23, words[22])]),
                "columns 0",
            ),
            // Column 2 negated: unit, orthogonal, mirrored.
            (
                with_all(&[
                    (18, &negate(words[18])),
                    (21, &negate(words[21])),
                    (24, &negate(words[24])),
                ]),
                "a mirror image",
            ),
            (with(1, "180"), "vfov 180"),
            (with(2, "-5"), "aspect ratio -5 must be positive"),
            (with(25, "0"), "screen width 0 must be positive"),
            (with(26, "-600"), "screen height -600 must be positive"),
            (
                format!("{good} 0 0.25"),
                "focal distance 0 must be positive",
            ),
            (
                format!("{good} 4.7 -1"),
                "lens radius -1 must not be negative",
            ),
        ];
        for (text, says) in cases {
            let e = parse(&text).unwrap_err();
            assert!(e.contains(says), "{says}: {e}");
        }
    }
}
