//! `<mesh>` geometry: sources, accessors and primitive lists, triangulated.
//!
//! Every index is checked against the array it points into, and every count
//! against the data it describes, so a malformed file fails here with a
//! located error instead of panicking later in the renderer.

use glam::{Vec2, Vec3};
use roxmltree::Node;

use super::error::{LoadError, Source};
use super::xml::{Ids, child, children};

/// A mesh in its own coordinate frame, triangulated.
#[derive(Clone, Debug, Default)]
pub struct LocalMesh {
    pub positions: Vec<Vec3>,
    /// Position indices per triangle.
    pub triangles: Vec<[u32; 3]>,
    /// Material symbol per triangle, as an index into `symbols`.
    pub symbol_of_triangle: Vec<u32>,
    /// Material symbols of the primitive lists (`None` when a list names none).
    pub symbols: Vec<Option<String>>,
    /// Texture coordinates per triangle corner; empty unless every list has them.
    pub texcoords: Vec<[Vec2; 3]>,
}

/// The numbers of a `<source>` as its accessor describes them.
struct Accessor {
    data: Vec<f32>,
    offset: usize,
    stride: usize,
    count: usize,
}

impl Accessor {
    #[inline]
    fn get(&self, i: usize, j: usize) -> f32 {
        self.data[self.offset + i * self.stride + j]
    }
}

fn read_source(
    src: &Source,
    ids: &Ids,
    node: Node,
    min_params: usize,
) -> Result<Accessor, LoadError> {
    let array = src.require(node, "float_array")?;
    let data = src.floats(array)?;
    if let Some(count) = src.usize_attr(array, "count")?
        && count != data.len()
    {
        return Err(src.error(
            array,
            format!(
                "count=\"{count}\" but the array holds {} numbers",
                data.len()
            ),
        ));
    }
    let accessor = child(node, "technique_common").and_then(|t| child(t, "accessor"));
    let Some(accessor) = accessor else {
        // No accessor: assume tightly packed tuples of `min_params`.
        if data.len() % min_params != 0 {
            return Err(src.error(
                array,
                format!(
                    "{} numbers is not a whole number of {min_params}-tuples",
                    data.len()
                ),
            ));
        }
        return Ok(Accessor {
            count: data.len() / min_params,
            data,
            offset: 0,
            stride: min_params,
        });
    };
    // The numbers read are always the source's own array; an accessor
    // that names another (or nothing) would be read wrongly, so it is an
    // error rather than ignored.
    if let Some(url) = accessor.attribute("source")
        && url.strip_prefix('#') != array.attribute("id")
    {
        // Compared by text first: with ids repeated in a file, a lookup
        // would find the last element of the id, not this one.
        let named = ids.resolve(src, accessor, "source", "float_array")?;
        if named != array {
            return Err(src.error(
                accessor,
                "source= names another <source>'s array; only an accessor's own <source>'s array is read",
            ));
        }
    }
    let stride = src.usize_attr(accessor, "stride")?.unwrap_or(1);
    let offset = src.usize_attr(accessor, "offset")?.unwrap_or(0);
    let count = src
        .usize_attr(accessor, "count")?
        .ok_or_else(|| src.error(accessor, "missing attribute count"))?;
    if stride < min_params {
        return Err(src.error(
            accessor,
            format!("stride=\"{stride}\" but at least {min_params} components are needed"),
        ));
    }
    let needed = count
        .checked_mul(stride)
        .and_then(|n| n.checked_add(offset))
        .filter(|&n| count == 0 || n - stride + min_params <= data.len());
    if needed.is_none() {
        return Err(src.error(
            accessor,
            format!(
                "count=\"{count}\" stride=\"{stride}\" offset=\"{offset}\" reach past the {} numbers of the array",
                data.len()
            ),
        ));
    }
    Ok(Accessor {
        data,
        offset,
        stride,
        count,
    })
}

/// An `<input>` of a primitive list, resolved.
struct ListInput {
    semantic: String,
    offset: usize,
    /// Index into `sources`.
    source: usize,
}

/// Parses a `<mesh>` element.
pub fn parse_mesh(
    src: &Source,
    ids: &Ids,
    mesh: Node,
) -> Result<(LocalMesh, Vec<String>), LoadError> {
    let mut warnings = Vec::new();
    let vertices = src.require(mesh, "vertices")?;
    let position_input = children(vertices, "input")
        .find(|i| i.attribute("semantic") == Some("POSITION"))
        .ok_or_else(|| src.error(vertices, "no <input semantic=\"POSITION\">"))?;
    let position_source = ids.resolve(src, position_input, "source", "source")?;
    let positions_acc = read_source(src, ids, position_source, 3)?;
    let positions: Vec<Vec3> = (0..positions_acc.count)
        .map(|i| {
            Vec3::new(
                positions_acc.get(i, 0),
                positions_acc.get(i, 1),
                positions_acc.get(i, 2),
            )
        })
        .collect();

    let mut out = LocalMesh {
        positions,
        ..LocalMesh::default()
    };
    let mut texcoords: Vec<[Vec2; 3]> = Vec::new();

    for list in mesh.children().filter(|c| c.is_element()) {
        let kind = list.tag_name().name();
        match kind {
            "polylist" | "triangles" | "polygons" => {}
            "lines" | "linestrips" | "trifans" | "tristrips" => {
                warnings
                    .push(src.warning(list, format!("<{kind}> is not supported and was skipped")));
                continue;
            }
            _ => continue,
        }

        // Resolve the inputs; VERTEX goes through <vertices>, which we already read.
        let mut inputs: Vec<ListInput> = Vec::new();
        let mut sources: Vec<Accessor> = Vec::new();
        for input in children(list, "input") {
            let semantic = src.attr(input, "semantic")?.to_string();
            let offset = src
                .usize_attr(input, "offset")?
                .ok_or_else(|| src.error(input, "missing attribute offset"))?;
            // Bounds the index stride (largest offset + 1) so it cannot overflow.
            if offset >= u32::MAX as usize {
                return Err(src.error(input, format!("offset=\"{offset}\" is too large")));
            }
            // Only the first texture coordinate set is used; the others are
            // not even read.
            let later_texcoord_set =
                semantic == "TEXCOORD" && inputs.iter().any(|i| i.semantic == "TEXCOORD");
            match semantic.as_str() {
                "VERTEX" => {
                    ids.resolve(src, input, "source", "vertices")?;
                    inputs.push(ListInput {
                        semantic,
                        offset,
                        source: usize::MAX,
                    });
                }
                "NORMAL" | "TEXCOORD" if !later_texcoord_set => {
                    let source = ids.resolve(src, input, "source", "source")?;
                    let min = if semantic == "NORMAL" { 3 } else { 2 };
                    sources.push(read_source(src, ids, source, min)?);
                    inputs.push(ListInput {
                        semantic,
                        offset,
                        source: sources.len() - 1,
                    });
                }
                _ => inputs.push(ListInput {
                    semantic: String::new(),
                    offset,
                    source: usize::MAX,
                }),
            }
        }
        let vertex_offset = inputs
            .iter()
            .find(|i| i.semantic == "VERTEX")
            .map(|i| i.offset)
            .ok_or_else(|| src.error(list, "no <input semantic=\"VERTEX\">"))?;
        let stride = inputs.iter().map(|i| i.offset).max().unwrap_or(0) + 1;
        let texcoord_input = inputs.iter().find(|i| i.semantic == "TEXCOORD");

        // Gather the polygons as (vertex count, index slice) pairs.
        let count = src.usize_attr(list, "count")?;
        let mut polygons: Vec<(usize, Vec<u32>, Node)> = Vec::new();
        match kind {
            "polylist" => {
                let p_node = src.require(list, "p")?;
                let p = src.uints(p_node)?;
                let vcount: Vec<u32> = match child(list, "vcount") {
                    Some(v) => src.uints(v)?,
                    None => Vec::new(),
                };
                let count = count.ok_or_else(|| src.error(list, "missing attribute count"))?;
                if vcount.len() != count {
                    return Err(src.error(
                        list,
                        format!(
                            "count=\"{count}\" but <vcount> lists {} polygons",
                            vcount.len()
                        ),
                    ));
                }
                let corners: usize = vcount.iter().map(|&n| n as usize).sum();
                if corners.checked_mul(stride) != Some(p.len()) {
                    return Err(src.error(
                        p_node,
                        format!(
                            "<vcount> sums to {corners} corners × {stride} inputs = {} indices, but <p> holds {}",
                            corners.saturating_mul(stride),
                            p.len()
                        ),
                    ));
                }
                let mut at = 0;
                for &n in &vcount {
                    let n = n as usize;
                    polygons.push((n, p[at..at + n * stride].to_vec(), p_node));
                    at += n * stride;
                }
            }
            "triangles" => {
                let count = count.ok_or_else(|| src.error(list, "missing attribute count"))?;
                let p_node = match child(list, "p") {
                    Some(p) => p,
                    None if count == 0 => continue,
                    None => return Err(src.error(list, "missing <p>")),
                };
                let p = src.uints(p_node)?;
                let indices = stride.checked_mul(3).and_then(|n| count.checked_mul(n));
                if indices != Some(p.len()) {
                    return Err(src.error(
                        p_node,
                        format!(
                            "count=\"{count}\" triangles × 3 corners × {stride} inputs = {} indices, but <p> holds {}",
                            indices.map_or("too many".to_string(), |n| n.to_string()),
                            p.len()
                        ),
                    ));
                }
                for tri in p.chunks_exact(3 * stride) {
                    polygons.push((3, tri.to_vec(), p_node));
                }
            }
            _ => {
                // <polygons>: one <p> per polygon; <ph> adds holes, which we drop.
                for poly in list.children().filter(|c| c.is_element()) {
                    let p_node = match poly.tag_name().name() {
                        "p" => poly,
                        "ph" => {
                            warnings.push(src.warning(poly, "polygon holes (<h>) are ignored"));
                            src.require(poly, "p")?
                        }
                        _ => continue,
                    };
                    let p = src.uints(p_node)?;
                    if p.len() % stride != 0 {
                        return Err(src.error(
                            p_node,
                            format!(
                                "{} indices is not a whole number of {stride}-index corners",
                                p.len()
                            ),
                        ));
                    }
                    polygons.push((p.len() / stride, p, p_node));
                }
                if let Some(count) = count
                    && count != polygons.len()
                {
                    return Err(src.error(
                        list,
                        format!(
                            "count=\"{count}\" but {} polygons are listed",
                            polygons.len()
                        ),
                    ));
                }
            }
        }

        let symbol_index = out.symbols.len() as u32;
        out.symbols
            .push(list.attribute("material").map(str::to_string));

        for (n, indices, p_node) in polygons {
            if n < 3 {
                warnings
                    .push(src.warning(p_node, format!("a polygon with {n} corners was skipped")));
                continue;
            }
            // Check every index of every input against its array.
            let corner = |k: usize, offset: usize| indices[k * stride + offset];
            for k in 0..n {
                let v = corner(k, vertex_offset) as usize;
                if v >= out.positions.len() {
                    return Err(src.error(
                        p_node,
                        format!(
                            "vertex index {v} is out of range ({} positions)",
                            out.positions.len()
                        ),
                    ));
                }
                for input in inputs.iter().filter(|i| i.source != usize::MAX) {
                    let idx = corner(k, input.offset) as usize;
                    let count = sources[input.source].count;
                    if idx >= count {
                        return Err(src.error(
                            p_node,
                            format!(
                                "{} index {idx} is out of range ({count} entries)",
                                input.semantic
                            ),
                        ));
                    }
                }
            }
            // Fan triangulation (exact for the convex polygons exporters write).
            for k in 1..n - 1 {
                out.triangles.push([
                    corner(0, vertex_offset),
                    corner(k, vertex_offset),
                    corner(k + 1, vertex_offset),
                ]);
                out.symbol_of_triangle.push(symbol_index);
                if let Some(t) = texcoord_input {
                    let acc = &sources[t.source];
                    let uv = |c: usize| {
                        let i = corner(c, t.offset) as usize;
                        Vec2::new(acc.get(i, 0), acc.get(i, 1))
                    };
                    texcoords.push([uv(0), uv(k), uv(k + 1)]);
                }
            }
        }
    }
    // Every triangle of a list with texture coordinates has them, so
    // equal counts mean every list that made triangles had them.
    if texcoords.len() == out.triangles.len() {
        out.texcoords = texcoords;
    }
    Ok((out, warnings))
}
