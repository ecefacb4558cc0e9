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
//!   normals. Mitsuba's area emitters are one-sided, so a two-sided
//!   emissive mesh gets a flipped copy, the two moved apart along their
//!   normals by 1e-5 of the scene's size (coincident, each would hide the
//!   other from half the rays).
//! * Point and directional lights map to `point` and `directional`. A
//!   hemisphere light (sky above the horizon, unseen by camera rays) is an
//!   `envmap` whose upper half holds the radiance, with the integrator's
//!   `hide_emitters` on when nothing else emits (else camera rays would
//!   see the sky where wavepath shows black: a warning says so).
//! * An environment map (`-e`) is an `envmap`, its columns reordered for
//!   Mitsuba's azimuth (see `write_environment`).
//! * `-m k` (bounces) is Mitsuba's `max_depth` k + 1, and roulette starts
//!   where wavepath's does (`rr_depth` = [`ROULETTE_DEPTH`] + 1, Mitsuba
//!   counting depth from 1), though with Mitsuba's continuation rule; the
//!   film uses a box filter and wavepath's near and far clipping
//!   distances (Mitsuba clips at planes along the view axis, wavepath at
//!   those distances along each ray, so geometry near `zfar` off the
//!   image's centre can differ).
//! * Vertex normals that vanish (opposite faces cancelling) are replaced
//!   by the face's normal, which is what wavepath shades with there.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result, bail};
use clap::Parser;
use glam::Vec3;

use crate::film::{Image, output};
use crate::integrator::ROULETTE_DEPTH;
use crate::integrator::bsdf::{self, Surface};
use crate::lanes::normalize_any_scale;
use crate::scene::{EnvironmentMap, Light, Scene, collada};

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
    /// Environment map (.exr or .hdr), as wavepath's -e
    #[arg(short = 'e', long = "envmap", value_name = "FILE")]
    pub envmap: Option<PathBuf>,
    /// Samples per pixel
    #[arg(short = 's', long = "spp", value_name = "N", default_value_t = 64,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: u32,
    /// Bounces as wavepath counts them (-m); Mitsuba's max_depth is one more
    #[arg(short = 'm', long = "max-depth", value_name = "N", default_value_t = 5,
          value_parser = clap::value_parser!(u32).range(0..=1000))]
    pub max_depth: u32,
    /// Mitsuba's rr_depth (first depth at which its roulette plays) [default: where wavepath's starts]
    #[arg(long = "rr-depth", value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=i32::MAX as i64))]
    pub rr_depth: Option<u32>,
    /// Resolution in pixels
    #[arg(
        short = 'r',
        long = "resolution",
        num_args = 2,
        value_names = ["W", "H"],
        action = clap::ArgAction::Set,
        default_values_t = [480, 360],
        value_parser = clap::value_parser!(u32).range(1..=65536)
    )]
    pub resolution: Vec<u32>,
}

/// Runs `wavepath mitsuba`; returns the exit status.
pub fn run(argv: Vec<std::ffi::OsString>) -> Result<i32> {
    let args = MitsubaArgs::parse_from(argv);
    if let Err(e) = super::check_pixel_count(&args.resolution) {
        super::usage_error::<MitsubaArgs>(e);
    }
    let mut scene = collada::load_file(&args.scene)?;
    if let Some(file) = &args.envmap {
        let map = super::load_environment(file)?;
        scene.lights.push(Light::Environment(Arc::new(map)));
    }
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let settings = Export {
        spp: args.spp,
        max_depth: args.max_depth,
        rr_depth: args.rr_depth.unwrap_or(ROULETTE_DEPTH + 1),
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
    /// Mitsuba's `rr_depth`.
    pub rr_depth: u32,
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

    let tris = &scene.geometry.triangles;
    let spheres = &scene.geometry.spheres;
    let sky = scene
        .lights
        .iter()
        .any(|l| matches!(l, Light::Hemisphere { .. }));
    let emits = |m: u32| matches!(surfaces[m as usize], Surface::Emitter { .. });
    let shapes_emit = tris
        .material
        .iter()
        .chain(&spheres.material)
        .any(|&m| emits(m));
    let environment = scene
        .lights
        .iter()
        .any(|l| matches!(l, Light::Environment(_)));
    let hide_sky = sky && !shapes_emit && !environment;
    if sky && (shapes_emit || environment) {
        warnings.push(
            "the sky (hemisphere light) is visible to Mitsuba's camera rays, not to wavepath's: \
             the scene also has emissive shapes or an environment map, which hiding emitters \
             would hide too"
                .into(),
        );
    }

    let mut xml = String::new();
    let _ = writeln!(xml, "<scene version=\"3.0.0\">");
    let _ = writeln!(
        xml,
        "  <integrator type=\"path\">\n    <integer name=\"max_depth\" value=\"{}\"/>\n    <integer name=\"rr_depth\" value=\"{}\"/>\n    <boolean name=\"hide_emitters\" value=\"{hide_sky}\"/>\n  </integrator>",
        settings.max_depth + 1,
        settings.rr_depth,
    );
    write_sensor(&mut xml, scene, settings);
    let separation = separation(scene);

    // The triangles of each material, in one pass.
    let mut faces_of = vec![Vec::new(); surfaces.len()];
    for (t, &m) in tris.material.iter().enumerate() {
        faces_of[m as usize].push(t);
    }
    for (m, (surface, faces)) in surfaces.iter().zip(&faces_of).enumerate() {
        if faces.is_empty() {
            continue;
        }
        let name = format!("material{m}.ply");
        let two_sided = is_two_sided_emitter(surface);
        let apart = if two_sided { separation } else { 0.0 };
        write_ply(&meshes.join(&name), scene, faces, false, apart)?;
        write_shape(&mut xml, &format!("meshes/{name}"), surface);
        if two_sided {
            let flipped = format!("material{m}_back.ply");
            write_ply(&meshes.join(&flipped), scene, faces, true, apart)?;
            write_shape(&mut xml, &format!("meshes/{flipped}"), surface);
        }
    }
    if spheres.material.iter().any(|&m| emits(m)) {
        warnings
            .push("emissive spheres emit only outward in Mitsuba; in wavepath, inward too".into());
    }
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
    let mut sky_maps = 0;
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
            Light::Environment(map) => {
                let name = format!("environment{sky_maps}.exr");
                sky_maps += 1;
                write_environment(&meshes.join(&name), map)?;
                if map.width() % 4 != 0 {
                    warnings.push(format!(
                        "the environment map is {} texels wide, not a multiple of 4: Mitsuba's \
                         copy is resampled, and interpolates a little differently",
                        map.width()
                    ));
                }
                envmap_emitter(&mut xml, &name);
            }
            Light::Hemisphere { radiance } => {
                let name = format!("sky{}.exr", sky_maps);
                sky_maps += 1;
                write_sky(&meshes.join(&name), *radiance)?;
                envmap_emitter(&mut xml, &name);
            }
        }
    }
    let _ = writeln!(xml, "</scene>");
    let path = dir.join("scene.xml");
    std::fs::write(&path, xml).with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(warnings)
}

/// Whether `surface` emits to both sides: Mitsuba's area emitters emit to
/// one, so such a mesh is written twice (the second copy flipped).
fn is_two_sided_emitter(surface: &Surface) -> bool {
    matches!(
        surface,
        Surface::Emitter {
            one_sided: false,
            ..
        }
    )
}

/// How far a two-sided emitter's two copies sit apart (each moves half).
fn separation(scene: &Scene) -> f32 {
    1e-5 * scene.geometry.bounds().diagonal().length()
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
        "  <sensor type=\"perspective\">\n    <string name=\"fov_axis\" value=\"y\"/>\n    <float name=\"fov\" value=\"{fov}\"/>\n    <float name=\"near_clip\" value=\"{}\"/>\n    <float name=\"far_clip\" value=\"{}\"/>\n    <transform name=\"to_world\">\n      <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n    </transform>\n    <sampler type=\"independent\">\n      <integer name=\"sample_count\" value=\"{}\"/>\n    </sampler>\n    <film type=\"hdrfilm\">\n      <integer name=\"width\" value=\"{}\"/>\n      <integer name=\"height\" value=\"{}\"/>\n      <rfilter type=\"box\"/>\n    </film>\n  </sensor>",
        camera.znear,
        camera.zfar,
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
/// for a timing comparison). `flip` reverses the winding and the normals;
/// every vertex moves `apart / 2` along its (possibly flipped) normal.
fn write_ply(path: &Path, scene: &Scene, faces: &[usize], flip: bool, apart: f32) -> Result<()> {
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
        let face_normal = normalize_any_scale(tris.geometric_normal(t)).unwrap_or(Vec3::ZERO);
        for index in tris.indices[t] {
            let i = index as usize;
            let n = tris
                .normals
                .get(i)
                .copied()
                .filter(|n| n.length_squared() > 0.0)
                .unwrap_or(face_normal);
            let n = sign * n;
            let p = tris.positions[i] + 0.5 * apart * n;
            for x in p.to_array().into_iter().chain(n.to_array()) {
                bytes.extend_from_slice(&x.to_le_bytes());
            }
        }
    }
    let corners = if flip { [2, 1, 0] } else { [0, 1, 2] };
    for k in 0..faces.len() as i32 {
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

/// A hemisphere light as a latitude–longitude map: `radiance` in the rows
/// above the horizon (Mitsuba's envmap puts +y at the top row), black
/// below; 256 rows keep the horizon within 0.7° of where it is.
fn write_sky(path: &Path, radiance: Vec3) -> Result<()> {
    let (width, height) = (8, 256);
    let mut map = Image::new(width, height);
    for (row, pixels) in map.pixels.chunks_mut(width as usize).enumerate() {
        if row < height as usize / 2 {
            pixels.fill(radiance);
        }
    }
    output::write_exr(&map, path, false)
}

/// An environment map in Mitsuba's orientation. Rows are the same (polar
/// angle from +y down); along the columns, Mitsuba's envmap has azimuth
/// φ' = atan2(x, −z) where wavepath's (the CS184 renderer's) has
/// φ = atan2(−z, x) + π, so φ' = 3π/2 − φ. Each of Mitsuba's texels takes
/// wavepath's radiance at its centre: when the width is a multiple of 4,
/// exactly the texel it maps to, so both interpolate the same values.
fn write_environment(path: &Path, map: &EnvironmentMap) -> Result<()> {
    let (width, height) = (map.width(), map.height());
    let mut image = Image::new(width, height);
    for (row, pixels) in image.pixels.chunks_mut(width as usize).enumerate() {
        for (column, pixel) in pixels.iter_mut().enumerate() {
            let u = (0.75 - (column as f64 + 0.5) / f64::from(width)).rem_euclid(1.0);
            *pixel = map.at(u * f64::from(width), row as f64 + 0.5);
        }
    }
    output::write_exr(&image, path, false)
}

/// An `envmap` emitter of the map written to `meshes/{name}`.
fn envmap_emitter(xml: &mut String, name: &str) {
    let _ = writeln!(
        xml,
        "  <emitter type=\"envmap\">\n    <string name=\"filename\" value=\"meshes/{name}\"/>\n  </emitter>"
    );
}

/// `x y z` as Mitsuba's XML writes vectors.
fn triple(v: Vec3) -> String {
    format!("{} {} {}", v.x, v.y, v.z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Material;

    fn cornell() -> Scene {
        collada::load_str(
            include_str!("../../scenes/cornell.dae"),
            Path::new("cornell.dae"),
        )
        .unwrap()
    }

    const SETTINGS: Export = Export {
        spp: 16,
        max_depth: 5,
        rr_depth: 6,
        width: 320,
        height: 240,
    };

    /// Exports `scene` into a fresh directory; returns it, the XML and the
    /// warnings.
    fn export(scene: &Scene, tag: &str) -> (PathBuf, String, Vec<String>) {
        let dir = crate::cli::scratch_dir(&format!("mitsuba-{tag}"));
        let warnings = write(scene, &SETTINGS, &dir).unwrap();
        let xml = std::fs::read_to_string(dir.join("scene.xml")).unwrap();
        (dir, xml, warnings)
    }

    /// The `value` of the first element `<tag name="name">` below `node`.
    fn value<'a>(node: roxmltree::Node<'a, '_>, tag: &str, name: &str) -> &'a str {
        node.descendants()
            .find(|n| n.has_tag_name(tag) && n.attribute("name") == Some(name))
            .and_then(|n| n.attribute("value"))
            .unwrap_or_else(|| panic!("no <{tag} name=\"{name}\">"))
    }

    fn vec3(text: &str) -> Vec3 {
        let v: Vec<f32> = text.split(' ').map(|x| x.parse().unwrap()).collect();
        Vec3::new(v[0], v[1], v[2])
    }

    /// A binary PLY as `write_ply` lays it out: position and normal per
    /// vertex, three indices per face. Panics on any other layout or a
    /// byte count that does not match the header.
    struct Ply {
        vertices: Vec<(Vec3, Vec3)>,
        faces: Vec<[usize; 3]>,
    }

    fn read_ply(path: &Path) -> Ply {
        let bytes = std::fs::read(path).unwrap();
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
        let (nv, nf) = (count("vertex"), count("face"));
        assert_eq!(bytes.len() - end, 24 * nv + 13 * nf, "{}", path.display());
        let f32_at = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        let vertices = (0..nv)
            .map(|k| {
                let x = |j: usize| f32_at(end + 24 * k + 4 * j);
                (Vec3::new(x(0), x(1), x(2)), Vec3::new(x(3), x(4), x(5)))
            })
            .collect();
        let faces_at = end + 24 * nv;
        let faces = (0..nf)
            .map(|k| {
                let at = faces_at + 13 * k;
                assert_eq!(bytes[at], 3);
                std::array::from_fn(|j| {
                    i32::from_le_bytes(bytes[at + 1 + 4 * j..at + 5 + 4 * j].try_into().unwrap())
                        as usize
                })
            })
            .collect();
        Ply { vertices, faces }
    }

    #[test]
    fn settings_reach_the_integrator_sensor_and_film() {
        let scene = cornell();
        let (dir, xml, _) = export(&scene, "settings");
        let doc = roxmltree::Document::parse(&xml).unwrap();
        let root = doc.root();
        assert_eq!(value(root, "integer", "max_depth"), "6");
        assert_eq!(value(root, "integer", "rr_depth"), "6");
        assert_eq!(value(root, "boolean", "hide_emitters"), "false");
        assert_eq!(value(root, "integer", "sample_count"), "16");
        assert_eq!(value(root, "integer", "width"), "320");
        assert_eq!(value(root, "integer", "height"), "240");
        let near: f32 = value(root, "float", "near_clip").parse().unwrap();
        let far: f32 = value(root, "float", "far_clip").parse().unwrap();
        assert_eq!((near, far), (scene.camera.znear, scene.camera.zfar));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Every triangle lands once (twice, the second flipped, for two-sided
    /// emitters) with its material's reflectance or radiance, and every
    /// emitter faces the side wavepath's emits to: winding and normals
    /// agree, one-sided area lights face the light's normal, and a
    /// flipped copy mirrors its front copy at the stated separation.
    #[test]
    fn triangles_keep_their_materials_and_emitters_face_their_light() {
        let scene = cornell();
        let mut glowing = scene.clone();
        glowing.materials[0].material = Material::Emission {
            radiance: Vec3::splat(2.0),
            one_sided: false,
        };
        for (k, scene) in [scene, glowing].iter().enumerate() {
            let (dir, xml, _) = export(scene, &format!("materials{k}"));
            let doc = roxmltree::Document::parse(&xml).unwrap();
            let surfaces = bsdf::prepare(&scene.materials, &mut Vec::new());
            let tris = &scene.geometry.triangles;
            // 1e-5 of the scene's size, as the module documentation says.
            let separation = 1e-5 * scene.geometry.bounds().diagonal().length();
            assert!(separation > 0.0);
            let mut faces = 0;
            let mut backs = 0;
            for shape in doc
                .descendants()
                .filter(|n| n.attribute("type") == Some("ply"))
            {
                let file = value(shape, "string", "filename");
                let stem = file.trim_start_matches("meshes/material");
                let (m, back) = match stem.strip_suffix("_back.ply") {
                    Some(m) => (m, true),
                    None => (stem.strip_suffix(".ply").unwrap(), false),
                };
                let m: usize = m.parse().unwrap();
                let ply = read_ply(&dir.join(file));
                faces += ply.faces.len();
                let own: Vec<usize> = (0..tris.len())
                    .filter(|&t| tris.material[t] as usize == m)
                    .collect();
                assert_eq!(ply.faces.len(), own.len(), "{file}");
                let reflectance = vec3(value(shape, "rgb", "reflectance"));
                let emitter = shape.children().find(|n| n.has_tag_name("emitter"));
                match surfaces[m] {
                    Surface::Diffuse { albedo } => {
                        assert_eq!(reflectance, albedo, "{file}");
                        assert!(emitter.is_none(), "{file}");
                    }
                    Surface::Emitter {
                        radiance,
                        one_sided,
                    } => {
                        assert_eq!(reflectance, Vec3::ZERO, "{file}");
                        let e = emitter.unwrap_or_else(|| panic!("{file}: no emitter"));
                        assert_eq!(vec3(value(e, "rgb", "radiance")), radiance, "{file}");
                        assert!(
                            !back || !one_sided,
                            "{file}: one-sided emitters have no copy"
                        );
                        for (f, &t) in ply.faces.iter().zip(&own) {
                            let [a, b, c] = f.map(|i| ply.vertices[i].0);
                            let winding = (b - a).cross(c - a);
                            for i in f {
                                assert!(winding.dot(ply.vertices[*i].1) > 0.0, "{file}");
                            }
                            // Against the scene's own triangle: the same
                            // corners, moved apart for two-sided emitters.
                            let corners = tris.vertices(t);
                            let moved = if one_sided { 0.0 } else { 0.5 * separation };
                            for (j, &i) in f.iter().enumerate() {
                                let original = corners[if back { 2 - j } else { j }];
                                let (p, n) = ply.vertices[i];
                                let d = (p - original).length();
                                assert!((d - moved).abs() <= 1e-6 * (1.0 + moved), "{file}: {d}");
                                // Each copy moves out along its own normal.
                                assert!(moved == 0.0 || (p - original).dot(n) > 0.0, "{file}");
                            }
                        }
                        if one_sided {
                            let light_normal = scene
                                .lights
                                .iter()
                                .find_map(|l| l.emitting_normal())
                                .unwrap();
                            let [a, b, c] = ply.faces[0].map(|i| ply.vertices[i].0);
                            assert!((b - a).cross(c - a).dot(light_normal) > 0.0, "{file}");
                        }
                    }
                }
                backs += usize::from(back);
            }
            let two_sided_faces = (0..tris.len())
                .filter(|&t| is_two_sided_emitter(&surfaces[tris.material[t] as usize]))
                .count();
            assert_eq!(faces, tris.len() + two_sided_faces);
            assert_eq!(backs > 0, k == 1, "only the glowing box has a flipped copy");
            std::fs::remove_dir_all(&dir).unwrap();
        }
    }

    /// Vertex normals are written as the scene has them (a tilted one
    /// stays tilted), except that one that vanishes is replaced by the
    /// face's normal, which is what wavepath shades with there.
    #[test]
    fn vanished_vertex_normals_become_the_faces() {
        let mut scene = cornell();
        let tris = &mut scene.geometry.triangles;
        let t = 0;
        for i in tris.indices[t] {
            tris.normals[i as usize] = Vec3::ZERO;
        }
        let m = tris.material[t];
        let of_m: Vec<usize> = (0..tris.len()).filter(|&u| tris.material[u] == m).collect();
        // The first other triangle of that material with no corner shared
        // with triangle t gets a smooth normal that is not its face's.
        let kept = of_m
            .iter()
            .position(|&u| tris.indices[u].iter().all(|i| !tris.indices[t].contains(i)))
            .unwrap();
        let u = of_m[kept];
        let tilted = (tris.geometric_normal(u).normalize() + Vec3::new(0.2, 0.3, 0.1)).normalize();
        for i in tris.indices[u] {
            tris.normals[i as usize] = tilted;
        }
        let (dir, _, _) = export(&scene, "normals");
        let ply = read_ply(&dir.join(format!("meshes/material{m}.ply")));
        let face = scene.geometry.triangles.geometric_normal(t).normalize();
        assert_eq!(of_m[0], t);
        for &i in &ply.faces[0] {
            let n = ply.vertices[i].1;
            assert!((n - face).length() < 1e-6, "{n}");
        }
        for &i in &ply.faces[kept] {
            assert_eq!(ply.vertices[i].1, tilted);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The camera of the XML, read the way Mitsuba's `perspective` sensor
    /// reads it (camera x = up × view is image *left*, film (0, 0) at the
    /// top left), sends the rays wavepath sends through the same film
    /// points.
    #[test]
    fn the_camera_sends_the_rays_wavepath_sends() {
        let scene = cornell();
        let (dir, xml, _) = export(&scene, "camera");
        let doc = roxmltree::Document::parse(&xml).unwrap();
        let lookat = doc
            .descendants()
            .find(|n| n.has_tag_name("lookat"))
            .unwrap();
        let at = |name: &str| vec3(lookat.attribute(name).unwrap());
        let (origin, target, up) = (at("origin"), at("target"), at("up"));
        let fov: f32 = value(doc.root(), "float", "fov").parse().unwrap();
        let forward = (target - origin).normalize();
        let left = up.cross(forward).normalize();
        let up = forward.cross(left);
        let tan_y = (0.5 * fov.to_radians()).tan();
        let (w, h) = (SETTINGS.width as f32, SETTINGS.height as f32);
        let view = scene.camera.view(SETTINGS.width, SETTINGS.height);
        assert!((origin - scene.camera.position).length() < 1e-6);
        for (fx, fy) in [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h), (0.3 * w, 0.8 * h)] {
            // wavepath's film y grows upward; Mitsuba's v grows downward.
            let (u, v) = (fx / w, 1.0 - fy / h);
            let x = (1.0 - 2.0 * u) * tan_y * (w / h);
            let y = (1.0 - 2.0 * v) * tan_y;
            let mitsuba = (x * left + y * up + forward).normalize();
            let ours = scene.camera.direction(&view, fx, fy).normalize();
            assert!(
                (mitsuba - ours).length() < 1e-5,
                "film ({fx}, {fy}): Mitsuba {mitsuba}, wavepath {ours}"
            );
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A hemisphere light becomes an envmap bright above the horizon and
    /// black below, hidden from camera rays when nothing else emits (and a
    /// warning when something does, since hiding would hide that too).
    #[test]
    fn a_hemisphere_light_is_an_upper_half_envmap() {
        let radiance = Vec3::new(0.5, 1.0, 2.0);
        let mut sky_only = cornell();
        sky_only.lights = vec![Light::Hemisphere { radiance }];
        for m in &mut sky_only.materials {
            if let Material::Emission { .. } = m.material {
                m.material = Material::DEFAULT;
            }
        }
        let (dir, xml, warnings) = export(&sky_only, "sky");
        let doc = roxmltree::Document::parse(&xml).unwrap();
        assert_eq!(value(doc.root(), "boolean", "hide_emitters"), "true");
        assert!(warnings.is_empty(), "{warnings:?}");
        let envmap = doc
            .descendants()
            .find(|n| n.attribute("type") == Some("envmap"))
            .unwrap();
        let map = output::read_image(&dir.join(value(envmap, "string", "filename"))).unwrap();
        let w = map.width as usize;
        for (row, pixels) in map.pixels.chunks(w).enumerate() {
            let want = if row < map.height as usize / 2 {
                radiance
            } else {
                Vec3::ZERO
            };
            assert!(pixels.iter().all(|&p| p == want), "row {row}");
        }
        std::fs::remove_dir_all(&dir).unwrap();

        // Two skies: two maps, each its own file.
        let mut two_skies = sky_only.clone();
        two_skies.lights.push(Light::Hemisphere { radiance });
        let (dir, xml, _) = export(&two_skies, "two_skies");
        let doc = roxmltree::Document::parse(&xml).unwrap();
        let files: Vec<&str> = doc
            .descendants()
            .filter(|n| n.attribute("type") == Some("envmap"))
            .map(|n| value(n, "string", "filename"))
            .collect();
        assert_eq!(files.len(), 2);
        assert_ne!(files[0], files[1]);
        assert!(files.iter().all(|f| dir.join(f).is_file()), "{files:?}");
        std::fs::remove_dir_all(&dir).unwrap();

        let mut sky_and_light = cornell();
        sky_and_light.lights.push(Light::Hemisphere { radiance });
        let (dir, xml, warnings) = export(&sky_and_light, "sky_light");
        assert!(xml.contains("<boolean name=\"hide_emitters\" value=\"false\"/>"));
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
