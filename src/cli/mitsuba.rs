//! `wavepath mitsuba <scene.dae> <dir>`: the scene as wavepath renders it,
//! written as a Mitsuba 3 scene (`scene.xml` and binary PLY meshes).
//!
//! Why this exists: "faster than Mitsuba" is a claim about one machine in
//! one hour, and this VM's speed drifts by a third from hour to hour. Timed
//! side by side on the same scene, the two renderers give a ratio that the
//! drift cannot move (`benches/mitsuba.sh`). The export is what wavepath
//! renders after loading — world-space triangles with their shading
//! normals, area lights as the one-sided emissive rectangles wavepath
//! builds for them, materials after the Lambertian fallback — so both
//! renderers see the same geometry, materials and lights:
//!
//! * Lambertian surfaces are two-sided in wavepath: `twosided` `diffuse`.
//! * Emitters: an `area` emitter per emissive mesh, facing the mesh's
//!   normals; two-sided emissive meshes get a flipped copy (Mitsuba's area
//!   emitters are one-sided).
//! * Point and directional lights map to `point` and `directional`; a
//!   hemisphere light has no Mitsuba counterpart (it lights only from above
//!   the horizon), so it is written as a `constant` emitter with a warning.
//! * `-m k` (bounces) is Mitsuba's `max_depth` k + 1; the film uses a box
//!   filter, as wavepath does.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Parser;
use glam::Vec3;

use crate::integrator::bsdf::{self, Surface};
use crate::scene::{Light, Scene, collada};

#[derive(Parser, Debug)]
#[command(
    name = "wavepath mitsuba",
    bin_name = "wavepath mitsuba",
    about = "Write a scene as a Mitsuba 3 scene (scene.xml and PLY meshes) for side-by-side timing",
    after_help = "Example: wavepath mitsuba -s 64 -m 5 -r 480 360 CBbunny.dae mitsuba_cbbunny\n\
                  then: python3 -c \"import mitsuba as mi; mi.set_variant('llvm_ad_rgb'); \
                  mi.Bitmap(mi.render(mi.load_file('mitsuba_cbbunny/scene.xml'))).write('out.exr')\""
)]
pub struct MitsubaArgs {
    /// Scene file (.dae)
    pub scene: PathBuf,
    /// Directory to write scene.xml and meshes/ into (created if missing)
    pub out: PathBuf,
    /// Samples per pixel
    #[arg(short = 's', long = "spp", value_name = "N", default_value_t = 64)]
    pub spp: u32,
    /// Bounces as wavepath counts them (-m); Mitsuba's max_depth is one more
    #[arg(short = 'm', long = "max-depth", value_name = "N", default_value_t = 5)]
    pub max_depth: u32,
    /// Resolution in pixels
    #[arg(
        short = 'r',
        long = "resolution",
        num_args = 2,
        value_names = ["W", "H"],
        default_values_t = [480, 360],
        value_parser = clap::value_parser!(u32).range(1..=65536)
    )]
    pub resolution: Vec<u32>,
}

/// Runs `wavepath mitsuba`; returns the exit status.
pub fn run(argv: Vec<std::ffi::OsString>) -> Result<i32> {
    let args = MitsubaArgs::parse_from(argv);
    let scene = collada::load_file(&args.scene)?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let settings = Export {
        spp: args.spp,
        max_depth: args.max_depth,
        width: args.resolution[0],
        height: args.resolution[1],
    };
    let warnings = write(&scene, &settings, &args.out)?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    eprintln!("wrote {}", args.out.join("scene.xml").display());
    Ok(0)
}

/// What the exported scene renders.
#[derive(Clone, Copy, Debug)]
pub struct Export {
    pub spp: u32,
    /// Bounces, as `-m` counts them.
    pub max_depth: u32,
    pub width: u32,
    pub height: u32,
}

/// Writes `dir/scene.xml` and `dir/meshes/*.ply`; returns what could not be
/// exported exactly, one line each.
pub fn write(scene: &Scene, settings: &Export, dir: &Path) -> Result<Vec<String>> {
    let mut warnings = Vec::new();
    let surfaces = bsdf::prepare(&scene.materials, &mut warnings);
    let meshes = dir.join("meshes");
    std::fs::create_dir_all(&meshes)
        .with_context(|| format!("{}: cannot create directory", meshes.display()))?;

    let mut xml = String::new();
    let _ = writeln!(xml, "<scene version=\"3.0.0\">");
    let _ = writeln!(
        xml,
        "  <integrator type=\"path\">\n    <integer name=\"max_depth\" value=\"{}\"/>\n  </integrator>",
        settings.max_depth + 1
    );
    write_sensor(&mut xml, scene, settings);

    let tris = &scene.geometry.triangles;
    for (m, surface) in surfaces.iter().enumerate() {
        let faces: Vec<usize> = (0..tris.len())
            .filter(|&t| tris.material[t] as usize == m)
            .collect();
        if faces.is_empty() {
            continue;
        }
        let name = format!("material{m}.ply");
        write_ply(&meshes.join(&name), scene, &faces, false)?;
        write_shape(&mut xml, &format!("meshes/{name}"), surface);
        if let Surface::Emitter {
            one_sided: false, ..
        } = surface
        {
            let flipped = format!("material{m}_back.ply");
            write_ply(&meshes.join(&flipped), scene, &faces, true)?;
            write_shape(&mut xml, &format!("meshes/{flipped}"), surface);
        }
    }
    let spheres = &scene.geometry.spheres;
    for s in 0..spheres.len() {
        let surface = &surfaces[spheres.material[s] as usize];
        let _ = writeln!(
            xml,
            "  <shape type=\"sphere\">\n    <point name=\"center\" value=\"{}\"/>\n    <float name=\"radius\" value=\"{}\"/>",
            triple(spheres.center[s]),
            spheres.radius[s]
        );
        write_material(&mut xml, surface);
        let _ = writeln!(xml, "  </shape>");
    }
    for light in &scene.lights {
        match light {
            Light::Point {
                position,
                intensity,
            } => {
                let _ = writeln!(
                    xml,
                    "  <emitter type=\"point\">\n    <point name=\"position\" value=\"{}\"/>\n    <rgb name=\"intensity\" value=\"{}\"/>\n  </emitter>",
                    triple(*position),
                    triple(*intensity)
                );
            }
            Light::Directional { to_light, radiance } => {
                let _ = writeln!(
                    xml,
                    "  <emitter type=\"directional\">\n    <vector name=\"direction\" value=\"{}\"/>\n    <rgb name=\"irradiance\" value=\"{}\"/>\n  </emitter>",
                    triple(-*to_light),
                    triple(*radiance)
                );
            }
            // Already geometry: the emissive rectangle written above.
            Light::Area { .. } => {}
            Light::Hemisphere { radiance } => {
                warnings.push(
                    "hemisphere light written as Mitsuba's `constant` emitter, which also \
                     lights from below the horizon"
                        .into(),
                );
                let _ = writeln!(
                    xml,
                    "  <emitter type=\"constant\">\n    <rgb name=\"radiance\" value=\"{}\"/>\n  </emitter>",
                    triple(*radiance)
                );
            }
        }
    }
    let _ = writeln!(xml, "</scene>");
    let path = dir.join("scene.xml");
    std::fs::write(&path, xml).with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(warnings)
}

/// The camera: the same eye, view direction, up and vertical field of view
/// (wavepath's pixels are square, so the horizontal one follows).
fn write_sensor(xml: &mut String, scene: &Scene, s: &Export) {
    let camera = &scene.camera;
    let view = camera.view(s.width, s.height);
    let fov = 2.0 * view.tan_half_vfov.atan().to_degrees();
    let m = camera.camera_to_world;
    let target = camera.position - m.z_axis;
    let _ = writeln!(
        xml,
        "  <sensor type=\"perspective\">\n    <string name=\"fov_axis\" value=\"y\"/>\n    <float name=\"fov\" value=\"{fov}\"/>\n    <transform name=\"to_world\">\n      <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n    </transform>\n    <sampler type=\"independent\">\n      <integer name=\"sample_count\" value=\"{}\"/>\n    </sampler>\n    <film type=\"hdrfilm\">\n      <integer name=\"width\" value=\"{}\"/>\n      <integer name=\"height\" value=\"{}\"/>\n      <rfilter type=\"box\"/>\n    </film>\n  </sensor>",
        triple(camera.position),
        triple(target),
        triple(m.y_axis),
        s.spp,
        s.width,
        s.height
    );
}

/// A PLY mesh shape with its material.
fn write_shape(xml: &mut String, file: &str, surface: &Surface) {
    let _ = writeln!(
        xml,
        "  <shape type=\"ply\">\n    <string name=\"filename\" value=\"{file}\"/>"
    );
    write_material(xml, surface);
    let _ = writeln!(xml, "  </shape>");
}

/// The BSDF of a shape, and its emitter if it emits.
fn write_material(xml: &mut String, surface: &Surface) {
    let (albedo, radiance) = match *surface {
        Surface::Diffuse { albedo } => (albedo, None),
        Surface::Emitter { radiance, .. } => (Vec3::ZERO, Some(radiance)),
    };
    let _ = writeln!(
        xml,
        "    <bsdf type=\"twosided\">\n      <bsdf type=\"diffuse\">\n        <rgb name=\"reflectance\" value=\"{}\"/>\n      </bsdf>\n    </bsdf>",
        triple(albedo)
    );
    if let Some(radiance) = radiance {
        let _ = writeln!(
            xml,
            "    <emitter type=\"area\">\n      <rgb name=\"radiance\" value=\"{}\"/>\n    </emitter>",
            triple(radiance)
        );
    }
}

/// Writes triangles `faces` as a binary little-endian PLY with per-vertex
/// normals, each triangle with its own three vertices (no sharing needed
/// for a timing comparison). `flip` reverses the winding and the normals.
fn write_ply(path: &Path, scene: &Scene, faces: &[usize], flip: bool) -> Result<()> {
    let tris = &scene.geometry.triangles;
    if faces.len() > i32::MAX as usize / 3 {
        bail!("{}: too many triangles for a PLY index", path.display());
    }
    let header = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        3 * faces.len(),
        faces.len()
    );
    let mut bytes = header.into_bytes();
    let sign = if flip { -1.0 } else { 1.0 };
    for &t in faces {
        for index in tris.indices[t] {
            let i = index as usize;
            let n = sign * tris.normals.get(i).copied().unwrap_or(Vec3::ZERO);
            for x in tris.positions[i].to_array().into_iter().chain(n.to_array()) {
                bytes.extend_from_slice(&x.to_le_bytes());
            }
        }
    }
    for k in 0..faces.len() as i32 {
        let corners = if flip { [2, 1, 0] } else { [0, 1, 2] };
        bytes.push(3);
        for c in corners {
            bytes.extend_from_slice(&(3 * k + c).to_le_bytes());
        }
    }
    let mut file = std::fs::File::create(path)
        .with_context(|| format!("{}: cannot create", path.display()))?;
    file.write_all(&bytes)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(())
}

/// `x y z` as Mitsuba's XML writes vectors.
fn triple(v: Vec3) -> String {
    format!("{} {} {}", v.x, v.y, v.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The built-in Cornell box, as loaded and with its first material
    /// made a two-sided emitter.
    fn cornell_scenes() -> [Scene; 2] {
        let scene = collada::load_str(
            include_str!("../../scenes/cornell.dae"),
            Path::new("cornell.dae"),
        )
        .unwrap();
        let mut glowing = scene.clone();
        glowing.materials[0].material = crate::scene::Material::Emission {
            radiance: Vec3::splat(2.0),
            one_sided: false,
        };
        [scene, glowing]
    }

    /// Exported, every triangle lands in exactly one PLY of the right
    /// size (two-sided emitters twice, once flipped), every emissive
    /// material gets an area emitter per copy, and the sensor and
    /// integrator carry the settings.
    #[test]
    fn cornell_box_exports_every_triangle_and_emitter() {
        for (k, scene) in cornell_scenes().iter().enumerate() {
            check_export(scene, &format!("{}_{k}", std::process::id()));
        }
    }

    fn check_export(scene: &Scene, tag: &str) {
        let dir = std::env::temp_dir().join(format!("wavepath_mitsuba_{tag}"));
        let settings = Export {
            spp: 16,
            max_depth: 5,
            width: 320,
            height: 240,
        };
        write(scene, &settings, &dir).unwrap();
        let xml = std::fs::read_to_string(dir.join("scene.xml")).unwrap();
        let doc = roxmltree::Document::parse(&xml).unwrap();
        let value = |tag: &str, name: &str| {
            doc.descendants()
                .find(|n| n.has_tag_name(tag) && n.attribute("name") == Some(name))
                .and_then(|n| n.attribute("value"))
                .unwrap()
                .to_string()
        };
        assert_eq!(value("integer", "max_depth"), "6");
        assert_eq!(value("integer", "sample_count"), "16");
        assert_eq!(value("integer", "width"), "320");
        assert_eq!(value("integer", "height"), "240");

        let mut surfaces_warnings = Vec::new();
        let surfaces = bsdf::prepare(&scene.materials, &mut surfaces_warnings);
        let tris = &scene.geometry.triangles;
        let (mut faces, mut emitters) = (0, 0);
        for shape in doc
            .descendants()
            .filter(|n| n.attribute("type") == Some("ply"))
        {
            let file = shape
                .children()
                .find(|n| n.attribute("name") == Some("filename"))
                .and_then(|n| n.attribute("value"))
                .unwrap();
            let bytes = std::fs::read(dir.join(file)).unwrap();
            let end = bytes
                .windows(11)
                .position(|w| w == b"end_header\n")
                .unwrap()
                + 11;
            let header = std::str::from_utf8(&bytes[..end]).unwrap();
            let count = |element: &str| -> usize {
                header
                    .lines()
                    .find_map(|l| l.strip_prefix(&format!("element {element} ")))
                    .unwrap()
                    .parse()
                    .unwrap()
            };
            let (v, f) = (count("vertex"), count("face"));
            assert_eq!(v, 3 * f, "{file}");
            // Six floats per vertex, one count byte and three ints per face.
            assert_eq!(bytes.len() - end, 24 * v + 13 * f, "{file}");
            faces += f;
            emitters += shape
                .children()
                .filter(|n| n.has_tag_name("emitter"))
                .count();
        }
        let two_sided: Vec<usize> = surfaces
            .iter()
            .enumerate()
            .filter(|(_, s)| {
                matches!(
                    s,
                    Surface::Emitter {
                        one_sided: false,
                        ..
                    }
                )
            })
            .map(|(m, _)| m)
            .collect();
        let back_faces = (0..tris.len())
            .filter(|&t| two_sided.contains(&(tris.material[t] as usize)))
            .count();
        assert_eq!(faces, tris.len() + back_faces);
        let emissive: Vec<usize> = surfaces
            .iter()
            .enumerate()
            .filter(|(m, s)| {
                matches!(s, Surface::Emitter { .. })
                    && tris.material.iter().any(|&t| t as usize == *m)
            })
            .map(|(m, _)| m)
            .collect();
        assert!(!emissive.is_empty(), "the Cornell box has a light");
        assert_eq!(back_faces > 0, !two_sided.is_empty());
        let expected = emissive.len() + emissive.iter().filter(|m| two_sided.contains(m)).count();
        assert_eq!(emitters, expected);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
