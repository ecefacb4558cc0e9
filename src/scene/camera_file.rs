//! Camera settings files (`-c`), as the CS184 viewer writes them: the
//! viewer's camera, saved so that a headless render can take the same view.
//!
//! The file is whitespace-separated numbers: the fields of view, aspect
//! ratio and clip planes; position and target; the orbit angles and
//! radius limits; the camera-to-world matrix row by row; the screen size
//! and distance in pixels; and, in newer files, the focal distance and lens
//! radius. The view is the position, the matrix, the clip planes and the
//! screen distance. With `-r W H` the screen distance decides the field of
//! view, as it does for scene cameras. The fields of view and aspect ratio
//! follow from the screen. The orbit values only steer the viewer. The
//! lens stays with `-b` and `-d`.

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

/// Reads the camera of a settings file; the error names the value at fault.
pub fn parse(text: &str) -> Result<Camera, String> {
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
    let position = Vec3::new(v[5], v[6], v[7]);
    Ok(Camera {
        position,
        target: Vec3::new(v[8], v[9], v[10]),
        camera_to_world: Mat3::from_cols(columns[0], columns[1], columns[2]),
        screen_distance,
        znear: near,
        zfar: far,
    })
}

/// The settings file of `camera` for a `width × height` screen, as the
/// viewer writes it (zero orbit values, no lens): for tests and for
/// handing a scene's view to the viewer.
pub fn write(camera: &Camera, width: u32, height: u32) -> String {
    let view = camera.view(width, height);
    let fov = |t: f32| 2.0 * t.atan().to_degrees();
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
        let back = parse(&write(&c, 800, 600)).unwrap();
        assert_eq!(back, c);
        // With the lens values newer files add.
        let with_lens = format!("{}4.7 0.25\n", write(&c, 800, 600));
        assert_eq!(parse(&with_lens).unwrap(), c);
    }

    #[test]
    fn bad_files_name_the_value_at_fault() {
        let good = write(&camera(), 800, 600);
        let words: Vec<&str> = good.split_whitespace().collect();
        let with = |i: usize, w: &str| {
            let mut v = words.clone();
            v[i] = w;
            v.join(" ")
        };
        let cases = [
            (words[..27].join(" "), "found 27"),
            (format!("{good} 1"), "found 29"),
            (with(6, "nan"), "position y (number 7)"),
            (with(16, "x"), "c2w[0][0]"),
            (with(27, "0"), "screen distance 0"),
            (with(4, "0.05"), "clip planes"),
            (with(16, "3"), "not a rotation"),
        ];
        for (text, says) in cases {
            let e = parse(&text).unwrap_err();
            assert!(e.contains(says), "{says}: {e}");
        }
    }
}
