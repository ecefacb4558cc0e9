//! COLLADA (`.dae`) loader for the CS184/CMU462 scene dialect.
//!
//! Reads the subset the assignment scenes use, plus what the COLLADA spec
//! says those elements may carry: meshes (`polylist`, `triangles`,
//! `polygons`), renderer extensions (`profile="CGL"` / `"CMU462"`: spheres,
//! lights, materials), the node hierarchy with its transforms, and the
//! camera. The result is flat world-space data (see [`crate::scene::Scene`]).
//!
//! Every malformed input is a [`LoadError`] naming the file, the element and
//! its line; the loader never panics on any input.

mod effects;
mod error;
mod lights;
mod mesh;
mod transform;
mod xml;

use std::collections::HashMap;
use std::path::Path;

use glam::{Mat4, Vec3, Vec4};
use roxmltree::{Document, Node};

pub use error::LoadError;
use error::Source;
use mesh::LocalMesh;
use xml::{Ids, child, children, path};

use crate::lanes::normalize_any_scale;
use crate::scene::{Aabb, Camera, Geometry, Light, Material, NamedMaterial, Perspective, Scene};

/// How deep `<node>`/`<instance_node>` nesting may go.
const MAX_NODE_DEPTH: usize = 256;
/// How many node instances the scene graph may expand to: `<instance_node>`
/// chains can multiply without a cycle (each node instancing the next twice).
const MAX_NODE_VISITS: usize = 1 << 20;
/// How many primitives (triangles, spheres) the instances may add up to:
/// a few hundred bytes each once loaded, built into a BVH and shaded, so
/// 2^26 already takes ~20 GB. A small file can ask for far more (a mesh
/// instanced by a chain of nodes that each instance the next twice), and
/// would otherwise end in a failed allocation.
const MAX_PRIMITIVES: u64 = 1 << 26;
/// The largest coordinate the renderer is made for: the watertight
/// ray/triangle test multiplies three coordinates relative to the ray
/// origin, which overflows f32 (3.4e38) near 7e12.
const MAX_COORDINATE: f32 = 1e12;

/// Loads a `.dae` file.
pub fn load_file(path: &Path) -> Result<Scene, LoadError> {
    // A device (/dev/zero) would be read until memory runs out. Pipes are
    // fine (`wavepath <(zcat scene.dae.gz)`). A path that cannot be
    // examined is left to the read below to report.
    if let Ok(meta) = std::fs::metadata(path) {
        if meta.is_dir() {
            return Err(LoadError::file(path, "is a directory, not a scene file"));
        }
        if !meta.is_file() && !is_pipe(&meta.file_type()) {
            return Err(LoadError::file(
                path,
                "is a device or socket, not a scene file",
            ));
        }
    }
    let bytes =
        std::fs::read(path).map_err(|e| LoadError::file(path, format!("cannot read: {e}")))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        LoadError {
            line: Some(line_at(valid)),
            ..LoadError::file(
                path,
                format!("not UTF-8 text (invalid byte at offset {})", valid.len()),
            )
        }
    })?;
    load_str(&text, path)
}

#[cfg(unix)]
fn is_pipe(kind: &std::fs::FileType) -> bool {
    std::os::unix::fs::FileTypeExt::is_fifo(kind)
}

#[cfg(not(unix))]
fn is_pipe(_: &std::fs::FileType) -> bool {
    false
}

/// Loads a scene from the text of a `.dae` file; `path` is used in messages.
pub fn load_str(text: &str, path: &Path) -> Result<Scene, LoadError> {
    if text.trim().is_empty() {
        return Err(LoadError::file(path, "file is empty"));
    }
    let doc = Document::parse(text).map_err(|e| xml_error(text, path, e))?;
    let src = Source { path, doc: &doc };
    let root = doc.root_element();
    if root.tag_name().name() != "COLLADA" {
        return Err(src.error(
            root,
            "not a COLLADA document (the root element must be <COLLADA>)",
        ));
    }
    let mut loader = Loader {
        src: &src,
        ids: Ids::index(&doc),
        warnings: Vec::new(),
        geometry: Geometry::default(),
        materials: Vec::new(),
        material_index: HashMap::new(),
        meshes: HashMap::new(),
        lights: Vec::new(),
        camera: None,
        node_path: Vec::new(),
        node_visits: 0,
        primitive_counts: HashMap::new(),
    };
    loader.load(root)?;
    Ok(loader.finish())
}

/// 1-based line number just past `bytes`.
fn line_at(bytes: &[u8]) -> u32 {
    bytes.iter().filter(|&&b| b == b'\n').count() as u32 + 1
}

/// A located error for XML that does not parse.
fn xml_error(text: &str, path: &Path, e: roxmltree::Error) -> LoadError {
    // One line: the parser quotes an offending character raw, even a newline.
    let mut what = String::new();
    for c in e.to_string().chars() {
        if c.is_control() {
            what.extend(c.escape_default());
        } else {
            what.push(c);
        }
    }
    let mut error = LoadError {
        line: Some(e.pos().row),
        ..LoadError::file(path, format!("not well-formed XML: {what}"))
    };
    let last_line = line_at(text.trim_end().as_bytes());
    let open = xml::innermost_open_element(text);
    let ends_inside = |name: &str, start: usize| {
        format!(
            "the file ends inside <{name}> (opened on line {}); is it truncated?",
            line_at(&text.as_bytes()[..start])
        )
    };
    match (&e, open) {
        // Name the element whose end tag is missing or misspelt.
        (roxmltree::Error::UnexpectedCloseTag(expected, ..), _) => {
            error.element = Some(expected.clone());
        }
        // These carry no position (roxmltree says 1:1): the file ends early,
        // so point at its last line and the element it was cut off inside.
        (roxmltree::Error::UnclosedRootNode | roxmltree::Error::UnexpectedEndOfStream, _) => {
            error.line = Some(last_line);
            error.message = match open {
                Some((name, start)) => {
                    error.element = Some(name.to_string());
                    format!("not well-formed XML: {}", ends_inside(name, start))
                }
                None => "not well-formed XML: the file ends before the root element is closed; is it truncated?".to_string(),
            };
        }
        // Any other error on the last line of a file whose text does not end
        // a tag, while an element is still open (a comment, CDATA section,
        // processing instruction or entity left open at the end): cut off
        // there too. The parser's complaint and position stay, and the hint
        // follows.
        (_, Some((name, start))) if e.pos().row >= last_line && !text.trim_end().ends_with('>') => {
            error.element = Some(name.to_string());
            error.message = format!("{}; {}", error.message, ends_inside(name, start));
        }
        _ => {}
    }
    error
}

/// The camera's view direction from its node's world transform:
/// T·(0,0,−1,1), the translation included on purpose (see camera.rs).
fn camera_view_dir(world: &Mat4) -> Vec3 {
    (*world * Vec4::new(0.0, 0.0, -1.0, 1.0)).truncate()
}

/// The camera node as found: world transform and optics.
struct CameraNode {
    world: Mat4,
    optics: Perspective,
}

struct Loader<'s, 'a, 'i> {
    src: &'s Source<'a, 'i>,
    ids: Ids<'a, 'i>,
    warnings: Vec<String>,
    geometry: Geometry,
    materials: Vec<NamedMaterial>,
    /// Material element id → index into `materials`.
    material_index: HashMap<String, u32>,
    /// Geometry element id → parsed mesh, so instanced meshes parse once.
    meshes: HashMap<String, LocalMesh>,
    lights: Vec<Light>,
    camera: Option<CameraNode>,
    /// Nodes on the path from the scene root to the node being visited.
    node_path: Vec<roxmltree::NodeId>,
    node_visits: usize,
    /// [`Loader::expanded_primitives`] of the nodes counted so far.
    primitive_counts: HashMap<roxmltree::NodeId, u64>,
}

impl<'a, 'i> Loader<'_, 'a, 'i> {
    fn load(&mut self, root: Node<'a, 'i>) -> Result<(), LoadError> {
        let src = self.src;
        let up = match path(root, &["asset", "up_axis"]) {
            Some(node) => {
                let axis = xml::text(node);
                let axis = axis.trim();
                transform::up_axis_matrix(axis).ok_or_else(|| {
                    src.error(
                        node,
                        format!("unknown up axis {axis:?} (expected X_UP, Y_UP or Z_UP)"),
                    )
                })?
            }
            None => {
                self.warnings.push(format!(
                    "{}: no <up_axis>; assuming Y_UP",
                    src.path.display()
                ));
                Mat4::IDENTITY
            }
        };

        // The reference ignores units; so does wavepath, but says so where
        // the file asks for a scale (a centimetre file's point lights then
        // fall off per centimetre, not per metre).
        if let Some(unit) = path(root, &["asset", "unit"])
            && let Some(meter) = unit.attribute("meter")
            && meter.trim().parse::<f64>() != Ok(1.0)
        {
            self.warnings.push(src.warning(
                unit,
                format!(
                    "<unit meter=\"{meter}\"> is not applied: coordinates are read as they \
                     stand, one unit to the metre, as the reference reads them"
                ),
            ));
        }

        let scene = match path(root, &["scene", "instance_visual_scene"]) {
            Some(instance) => self.ids.resolve(src, instance, "url", "visual_scene")?,
            None => child(root, "library_visual_scenes")
                .and_then(|l| child(l, "visual_scene"))
                .ok_or_else(|| src.error(root, "no <visual_scene> to render"))?,
        };
        // Counted before anything is built: a small file can instance its
        // way to billions of primitives.
        let mut primitives = 0u64;
        for node in children(scene, "node") {
            primitives = primitives.saturating_add(self.expanded_primitives(node, 0)?);
        }
        if primitives > MAX_PRIMITIVES {
            let count = match primitives {
                u64::MAX => "more than 2^64".to_string(),
                n => n.to_string(),
            };
            return Err(src.error(
                scene,
                format!(
                    "the scene's instances add up to {count} primitives, more than the {MAX_PRIMITIVES} (2^{}) wavepath takes",
                    MAX_PRIMITIVES.trailing_zeros()
                ),
            ));
        }
        for node in children(scene, "node") {
            self.visit(node, &up, 0)?;
        }
        Ok(())
    }

    /// Walks a `<node>` with its parent's world transform.
    fn visit(&mut self, node: Node<'a, 'i>, parent: &Mat4, depth: usize) -> Result<(), LoadError> {
        let src = self.src;
        if depth > MAX_NODE_DEPTH {
            return Err(src.error(
                node,
                format!("nodes nest deeper than {MAX_NODE_DEPTH} levels"),
            ));
        }
        if self.node_path.contains(&node.id()) {
            return Err(src.error(
                node,
                "<instance_node> makes a cycle: this node instances itself",
            ));
        }
        self.node_visits += 1;
        if self.node_visits > MAX_NODE_VISITS {
            return Err(src.error(
                node,
                format!("the scene graph expands to more than {MAX_NODE_VISITS} node instances"),
            ));
        }
        self.node_path.push(node.id());
        let result = self.visit_children(node, parent, depth);
        self.node_path.pop();
        result
    }

    fn visit_children(
        &mut self,
        node: Node<'a, 'i>,
        parent: &Mat4,
        depth: usize,
    ) -> Result<(), LoadError> {
        let src = self.src;
        let world = *parent * transform::node_local_transform(src, node, &mut self.warnings)?;
        // Each node's own transform is finite (checked there); their
        // product can still overflow (a scale of 1e20 around a translation
        // of 1e20), which would place lights and cameras at infinity.
        if !world.is_finite() {
            return Err(src.error(
                node,
                "the node's transform, composed with its parents', overflows to a non-finite value",
            ));
        }
        for item in node.children().filter(|c| c.is_element()) {
            match item.tag_name().name() {
                "node" => self.visit(item, &world, depth + 1)?,
                "instance_node" => {
                    let target = self.ids.resolve(src, item, "url", "node")?;
                    self.visit(target, &world, depth + 1)?;
                }
                "instance_geometry" => self.instance_geometry(item, &world)?,
                "instance_light" => {
                    let light = self.ids.resolve(src, item, "url", "light")?;
                    if let Some(l) =
                        lights::parse_light(src, light, item, &world, &mut self.warnings)?
                    {
                        self.lights.push(l);
                    }
                }
                "instance_camera" => {
                    let camera = self.ids.resolve(src, item, "url", "camera")?;
                    let optics = self.perspective(camera)?;
                    if !camera_view_dir(&world).is_finite() {
                        return Err(src.error(
                            item,
                            "the camera's view direction overflows to a non-finite value under its node's transform",
                        ));
                    }
                    // The last camera in the file wins.
                    self.camera = Some(CameraNode { world, optics });
                }
                "instance_controller" => self.warnings.push(src.warning(
                    item,
                    "skinned/morphed geometry (<instance_controller>) is not supported; skipped",
                )),
                _ => {}
            }
        }
        Ok(())
    }

    fn perspective(&mut self, camera: Node) -> Result<Perspective, LoadError> {
        let src = self.src;
        let Some(p) = path(camera, &["optics", "technique_common", "perspective"]) else {
            self.warnings.push(src.warning(
                camera,
                "camera is not perspective; using the default field of view",
            ));
            return Ok(Perspective::default());
        };
        let get = |name: &str| -> Result<Option<f32>, LoadError> {
            child(p, name).map(|n| src.scalar(n)).transpose()
        };
        let optics = Perspective {
            xfov: get("xfov")?,
            yfov: get("yfov")?,
            aspect_ratio: get("aspect_ratio")?,
            znear: get("znear")?,
            zfar: get("zfar")?,
        };
        for (name, value, max) in [("xfov", optics.xfov, 180.0), ("yfov", optics.yfov, 180.0)] {
            if let Some(v) = value
                && !(v > 0.0 && v < max)
            {
                return Err(src.error(
                    child(p, name).unwrap_or(p),
                    format!("field of view {v}° is outside (0°, 180°)"),
                ));
            }
        }
        if let Some(a) = optics.aspect_ratio
            && a <= 0.0
        {
            return Err(src.error(
                child(p, "aspect_ratio").unwrap_or(p),
                format!("aspect ratio {a} must be positive"),
            ));
        }
        // Checked with the defaults standing in for what is not given: a
        // lone <znear> beyond the default zfar would clip everything.
        let (n, f) = optics.clip_range();
        if !(n >= 0.0 && f > n) {
            let given = |value: Option<f32>| {
                if value.is_some() {
                    ""
                } else {
                    " (the default)"
                }
            };
            return Err(src.error(
                p,
                format!(
                    "znear {n}{} and zfar {f}{} must satisfy 0 ≤ znear < zfar",
                    given(optics.znear),
                    given(optics.zfar)
                ),
            ));
        }
        Ok(optics)
    }

    /// Index of the material bound to `symbol` in an `<instance_geometry>`.
    fn bound_material(
        &mut self,
        instance: Node<'a, 'i>,
        symbol: Option<&str>,
    ) -> Result<u32, LoadError> {
        let src = self.src;
        let binding = path(instance, &["bind_material", "technique_common"]).and_then(|t| {
            children(t, "instance_material")
                .find(|m| symbol.is_none() || m.attribute("symbol") == symbol)
        });
        let material = match binding {
            Some(b) => Some(self.ids.resolve(src, b, "target", "material")?),
            // Unbound symbol: exporters often use the material id itself.
            None => symbol
                .and_then(|s| self.ids.get(s))
                .filter(|n| n.tag_name().name() == "material"),
        };
        let Some(material) = material else {
            if let Some(symbol) = symbol {
                self.warnings.push(src.warning(
                    instance,
                    format!(
                        "material symbol \"{symbol}\" is bound by no <instance_material> here and is no material's id; the default material is used"
                    ),
                ));
            }
            return Ok(self.default_material());
        };
        let id = material.attribute("id").unwrap_or("").to_string();
        if let Some(&index) = self.material_index.get(&id) {
            return Ok(index);
        }
        let parsed = effects::parse_material(src, &self.ids, material, &mut self.warnings)?;
        let name = material.attribute("name").unwrap_or(&id).to_string();
        Ok(self.add_material(id, name, parsed))
    }

    fn add_material(&mut self, id: String, name: String, material: Material) -> u32 {
        let index = self.materials.len() as u32;
        self.materials.push(NamedMaterial { name, material });
        self.material_index.insert(id, index);
        index
    }

    fn default_material(&mut self) -> u32 {
        const KEY: &str = "\0default";
        match self.material_index.get(KEY) {
            Some(&i) => i,
            None => self.add_material(KEY.into(), "default".into(), Material::DEFAULT),
        }
    }

    /// The id under which `geometry`'s mesh is in `self.meshes`, parsed
    /// the first time it is asked for; `None` if it has no `<mesh>`.
    fn parse_mesh(&mut self, geometry: Node<'a, 'i>) -> Result<Option<String>, LoadError> {
        let Some(mesh_node) = child(geometry, "mesh") else {
            return Ok(None);
        };
        let id = geometry.attribute("id").unwrap_or("").to_string();
        if !self.meshes.contains_key(&id) {
            let (mesh, warnings) = mesh::parse_mesh(self.src, &self.ids, mesh_node)?;
            self.warnings.extend(warnings);
            self.meshes.insert(id.clone(), mesh);
        }
        Ok(Some(id))
    }

    /// How many primitives `node` expands to with everything it instances
    /// (a mesh's triangles, one per sphere, two per light, which an area
    /// light becomes), counted once per node, so a chain of nodes that
    /// each instance the next twice costs one visit per node, however
    /// many instances it makes. A cycle or too deep a nesting counts as
    /// nothing here; the walk reports it.
    fn expanded_primitives(&mut self, node: Node<'a, 'i>, depth: usize) -> Result<u64, LoadError> {
        if depth > MAX_NODE_DEPTH {
            return Ok(0);
        }
        if let Some(&n) = self.primitive_counts.get(&node.id()) {
            return Ok(n);
        }
        self.primitive_counts.insert(node.id(), 0);
        let src = self.src;
        let mut total = 0u64;
        for item in node.children().filter(|c| c.is_element()) {
            let n = match item.tag_name().name() {
                "node" => self.expanded_primitives(item, depth + 1)?,
                "instance_node" => {
                    let target = self.ids.resolve(src, item, "url", "node")?;
                    self.expanded_primitives(target, depth + 1)?
                }
                "instance_geometry" => {
                    let geometry = self.ids.resolve(src, item, "url", "geometry")?;
                    match self.parse_mesh(geometry)? {
                        Some(id) => self.meshes[&id].triangles.len() as u64,
                        None => 1,
                    }
                }
                "instance_light" => 2,
                _ => 0,
            };
            total = total.saturating_add(n);
        }
        self.primitive_counts.insert(node.id(), total);
        Ok(total)
    }

    fn instance_geometry(&mut self, instance: Node<'a, 'i>, world: &Mat4) -> Result<(), LoadError> {
        let src = self.src;
        let geometry = self.ids.resolve(src, instance, "url", "geometry")?;
        if let Some(id) = self.parse_mesh(geometry)? {
            let positions = &self.meshes[&id].positions;
            if let Some(p) = positions
                .iter()
                .map(|&p| world.transform_point3(p))
                .find(|p| !p.is_finite())
            {
                return Err(src.error(
                    instance,
                    format!("a vertex of the mesh is not finite in world space ({p}): the node's transform overflows"),
                ));
            }
            let symbols = self.meshes[&id].symbols.clone();
            let materials = symbols
                .iter()
                .map(|s| self.bound_material(instance, s.as_deref()))
                .collect::<Result<Vec<u32>, _>>()?;
            self.add_mesh(&id, &materials, world);
            return Ok(());
        }
        let sphere = effects::renderer_technique(geometry).and_then(|t| child(t, "sphere"));
        if let Some(sphere) = sphere {
            let radius_node = src.require(sphere, "radius")?;
            let radius = src.scalar(radius_node)?;
            if radius <= 0.0 {
                return Err(src.error(
                    radius_node,
                    format!("sphere radius {radius} must be positive"),
                ));
            }
            // Radius scales with the length of the transformed x axis.
            let scale = (*world * Vec4::X).truncate().length();
            let center = (*world * Vec4::W).truncate();
            let radius = radius * scale;
            if !(radius > 0.0 && radius.is_finite()) {
                return Err(src.error(
                    instance,
                    format!("sphere's world radius {radius} is not a positive finite number"),
                ));
            }
            // As for mesh vertices: a sphere whose box overflows cannot be
            // placed in the BVH.
            if !(center.abs() + Vec3::splat(radius)).is_finite() {
                return Err(src.error(
                    instance,
                    format!(
                        "sphere at {center} of radius {radius:e} reaches beyond single precision"
                    ),
                ));
            }
            let material = self.bound_material(instance, None)?;
            let spheres = &mut self.geometry.spheres;
            spheres.center.push(center);
            spheres.radius.push(radius);
            spheres.material.push(material);
            return Ok(());
        }
        self.warnings.push(src.warning(
            geometry,
            "geometry is neither a <mesh> nor a sphere; skipped",
        ));
        Ok(())
    }

    /// Appends a parsed mesh in world space with smooth vertex normals.
    fn add_mesh(&mut self, id: &str, materials: &[u32], world: &Mat4) {
        let mesh = &self.meshes[id];
        let tris = &mut self.geometry.triangles;
        let base = tris.positions.len() as u32;
        let first_normal = tris.normals.len();
        tris.positions
            .extend(mesh.positions.iter().map(|&p| world.transform_point3(p)));
        tris.normals.resize(tris.positions.len(), Vec3::ZERO);
        let had_texcoords = tris.texcoords.len() == tris.indices.len();
        for (t, &[a, b, c]) in mesh.triangles.iter().enumerate() {
            let idx = [a + base, b + base, c + base];
            // Area-weighted normal: the unnormalised cross product.
            let [pa, pb, pc] = idx.map(|i| tris.positions[i as usize]);
            let n = (pb - pa).cross(pc - pa);
            for i in idx {
                tris.normals[i as usize] += n;
            }
            tris.indices.push(idx);
            tris.material
                .push(materials[mesh.symbol_of_triangle[t] as usize]);
        }
        for n in &mut tris.normals[first_normal..] {
            *n = normalize_any_scale(*n).unwrap_or(Vec3::ZERO);
        }
        // Texture coordinates are kept only while every mesh so far has them.
        if had_texcoords && !mesh.texcoords.is_empty() {
            tris.texcoords.extend_from_slice(&mesh.texcoords);
        } else {
            tris.texcoords.clear();
        }
    }

    fn finish(mut self) -> Scene {
        let repeated = self.ids.repeated_warnings(self.src);
        self.warnings.extend(repeated);
        // The camera frames mesh vertices and spheres only (not lights).
        let bounds = self.geometry.bounds();
        let path = self.src.path.display();
        if self.geometry.triangles.is_empty() && self.geometry.spheres.is_empty() {
            self.warnings.push(format!(
                "{path}: no geometry (no <instance_geometry> of a mesh or sphere); only lights can show"
            ));
        } else {
            let reach = bounds.max_abs();
            if reach > MAX_COORDINATE {
                self.warnings.push(format!(
                    "{path}: coordinates reach {reach:e}; past {MAX_COORDINATE:e} the single-precision ray/triangle test overflows, and triangles may be missed"
                ));
            }
        }
        // Area lights are not geometry yet (the scene's assembly makes each
        // two triangles) and are held to the same limit.
        let light_reach = self
            .lights
            .iter()
            .filter_map(Light::area_corners)
            .flatten()
            .fold(0.0f32, |m, corner| m.max(corner.abs().max_element()));
        if light_reach > MAX_COORDINATE {
            self.warnings.push(format!(
                "{path}: an area light reaches {light_reach:e}; past {MAX_COORDINATE:e} the single-precision ray/triangle test overflows, and the light may be missed by camera rays and light nothing"
            ));
        }
        let (view_dir, optics) = match &self.camera {
            Some(c) => (camera_view_dir(&c.world), c.optics),
            None => {
                self.warnings
                    .push(format!("{path}: no camera; viewing from +z"));
                (Vec3::Z, Perspective::default())
            }
        };
        if view_dir.length_squared() == 0.0 {
            self.warnings.push(format!(
                "{path}: the camera's view direction is zero; viewing from +z"
            ));
        }
        let camera = Camera::place(view_dir, &optics, bounds.min, bounds.max);
        // A record instanced by several nodes (a light, a mesh) meets the
        // same problem at each: said once, where it was first met.
        let mut said = std::collections::HashSet::new();
        self.warnings.retain(|w| said.insert(w.clone()));

        let mut scene = Scene::assemble(
            self.geometry,
            self.materials,
            self.lights,
            camera,
            self.warnings,
        );
        // Measured on the assembled scene, whose area lights are triangles
        // too, as a camera settings file's camera is (`-c`).
        let bounds = scene.geometry.bounds();
        if let Some(warning) = far_plane_warning(self.src.path, &scene.camera, &bounds) {
            scene.warnings.push(warning);
        }
        scene
    }
}

/// The warning a scene loaded from `path`, of bounds `bounds` (its
/// assembled geometry's), carries when its camera's far clipping plane
/// cuts it off ([`Camera::far_plane_cuts`]); a caller that replaces the
/// camera can find it by this text.
pub fn far_plane_warning(path: &Path, camera: &Camera, bounds: &Aabb) -> Option<String> {
    let cut = camera.far_plane_cuts(bounds.min, bounds.max)?;
    Some(format!(
        "{}: {cut}; a larger <zfar> in the camera's <optics> moves the plane",
        path.display()
    ))
}
