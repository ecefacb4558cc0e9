//! `<light>` elements placed by their node's world transform.

use glam::{Mat4, Vec3, Vec4};
use roxmltree::Node;

use super::effects::renderer_technique;
use super::error::{LoadError, Source};
use super::xml::{child, first_element};
use crate::lanes::normalize_any_scale;
use crate::scene::Light;

/// `T · (x, y, z, w)` as a 3-vector (the w of the result is dropped).
fn apply(t: &Mat4, v: Vec4) -> Vec3 {
    (*t * v).truncate()
}

/// The light a `<light>` describes, placed by world transform `t` (of the
/// node holding `instance`, its `<instance_light>`); `None` (with a warning)
/// for types the renderer has no use for.
pub fn parse_light(
    src: &Source,
    light: Node,
    instance: Node,
    t: &Mat4,
    warnings: &mut Vec<String>,
) -> Result<Option<Light>, LoadError> {
    let record = renderer_technique(light)
        .and_then(first_element)
        .or_else(|| child(light, "technique_common").and_then(first_element))
        .ok_or_else(|| {
            src.error(
                light,
                "no light type (expected <technique_common> or a CGL <technique>)",
            )
        })?;
    let kind = record.tag_name().name();
    if kind == "spot" {
        warnings.push(src.warning(light, "spot lights are not supported; skipped"));
        return Ok(None);
    }
    let spectrum = src.vec3(src.require(record, "color")?)?;
    if spectrum.min_element() < 0.0 {
        return Err(src.error(
            record,
            format!("light colour {spectrum} has a negative component"),
        ));
    }
    let p = apply(t, Vec4::W);
    // The node's transform is finite, but a light's points under it can
    // still overflow (a translation near f32's limit plus a unit step).
    let finite = |v: &[Vec3]| {
        if v.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(src.error(
                instance,
                "the light's placement overflows to a non-finite value under its node's transform",
            ))
        }
    };
    let light = match kind {
        "point" => {
            finite(&[p])?;
            Light::Point {
                position: p,
                intensity: spectrum,
            }
        }
        "directional" => {
            // The reference transforms the direction with w = 1, so the node's
            // translation leaks into it; reproduced for identical lighting.
            let d = apply(t, Vec4::new(0.0, 0.0, -1.0, 1.0));
            finite(&[d])?;
            let Some(to_light) = normalize_any_scale(d) else {
                return Err(src.error(
                    instance,
                    "directional light has a zero direction under its node's transform",
                ));
            };
            Light::Directional {
                to_light,
                radiance: spectrum,
            }
        }
        "area" => {
            let normal = apply(t, Vec4::new(0.0, 0.0, -1.0, 1.0)) - p;
            let dim_x = apply(t, Vec4::new(-1.0, 0.0, 0.0, 1.0)) - p;
            let dim_y = apply(t, Vec4::new(0.0, 1.0, 0.0, 1.0)) - p;
            finite(&[p, normal, dim_x, dim_y])?;
            let area = dim_x.cross(dim_y);
            if !area.is_finite() {
                return Err(src.error(
                    instance,
                    format!(
                        "area light is too large under its node's transform: sides of {:e} and {:e} make an area beyond single precision",
                        dim_x.as_dvec3().length() as f32,
                        dim_y.as_dvec3().length() as f32
                    ),
                ));
            }
            // At any scale: the squared length of a 1e-12 light's
            // dim_x × dim_y underflows f32, of a 1e20 one's normal overflows.
            let (Some(normal), Some(_)) = (
                normalize_any_scale(normal),
                normalize_any_scale(dim_x.cross(dim_y)),
            ) else {
                return Err(src.error(
                    instance,
                    "area light is degenerate under its node's transform (zero area or normal)",
                ));
            };
            Light::Area {
                center: p,
                normal,
                dim_x,
                dim_y,
                radiance: spectrum,
            }
        }
        "ambient" => Light::Hemisphere { radiance: spectrum },
        other => {
            warnings.push(src.warning(record, format!("unknown light type <{other}>; skipped")));
            return Ok(None);
        }
    };
    Ok(Some(light))
}
