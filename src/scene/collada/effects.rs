//! Materials: `<material>` → `<effect>` → a typed [`Material`].
//!
//! The renderer's own records live in an `<extra><technique profile="CGL">`
//! (or the older `profile="CMU462"`); without one, the Phong/Lambert diffuse
//! colour of `profile_COMMON` is a Lambertian reflectance.

use glam::Vec3;
use roxmltree::Node;

use super::error::{LoadError, Source};
use super::xml::{Ids, child, children, first_element, path};
use crate::scene::Material;

/// The renderer-specific `<technique>` inside `node`'s `<extra>`, if any.
pub fn renderer_technique<'a, 'i>(node: Node<'a, 'i>) -> Option<Node<'a, 'i>> {
    children(node, "extra")
        .flat_map(|extra| children(extra, "technique"))
        .find(|t| matches!(t.attribute("profile"), Some("CGL") | Some("CMU462")))
}

/// Reads an optional colour child, defaulting when absent.
fn color_or(src: &Source, node: Node, name: &str, default: Vec3) -> Result<Vec3, LoadError> {
    match child(node, name) {
        Some(c) => src.vec3(c),
        None => Ok(default),
    }
}

fn scalar_or(src: &Source, node: Node, name: &str, default: f32) -> Result<f32, LoadError> {
    match child(node, name) {
        Some(c) => src.scalar(c),
        None => Ok(default),
    }
}

/// The material a `<material>` element describes.
pub fn parse_material(
    src: &Source,
    ids: &Ids,
    material: Node,
    warnings: &mut Vec<String>,
) -> Result<Material, LoadError> {
    let Some(instance) = child(material, "instance_effect") else {
        warnings.push(src.warning(
            material,
            format!(
                "material {:?} has no <instance_effect>; using grey diffuse",
                material.attribute("id").unwrap_or("")
            ),
        ));
        return Ok(Material::DEFAULT);
    };
    let effect = ids.resolve(src, instance, "url", "effect")?;
    parse_effect(src, effect, warnings)
}

fn parse_effect(
    src: &Source,
    effect: Node,
    warnings: &mut Vec<String>,
) -> Result<Material, LoadError> {
    if let Some(record) = renderer_technique(effect).and_then(first_element) {
        let one = Vec3::ONE;
        // A record we cannot use is not an error: the material becomes grey
        // diffuse with a warning, as the reference does. Malformed numbers
        // inside a usable record still are.
        let unusable = |why: String, warnings: &mut Vec<String>| {
            warnings.push(src.warning(record, format!("{why}; using grey diffuse")));
            Ok(Material::DEFAULT)
        };
        let required = ["radiance", "eta", "k"]
            .into_iter()
            .filter(|name| match record.tag_name().name() {
                "emission" => *name == "radiance",
                "microfacet" => *name != "radiance",
                _ => false,
            })
            .find(|name| child(record, name).is_none());
        if let Some(name) = required {
            return unusable(
                format!("<{}> has no <{name}>", record.tag_name().name()),
                warnings,
            );
        }
        let material = match record.tag_name().name() {
            "emission" => {
                let node = src.require(record, "radiance")?;
                let radiance = src.vec3(node)?;
                if radiance.min_element() < 0.0 {
                    return Err(src.error(
                        node,
                        format!("emitted radiance {radiance} has a negative component"),
                    ));
                }
                Material::Emission {
                    radiance,
                    one_sided: false,
                }
            }
            "mirror" => Material::Mirror {
                reflectance: color_or(src, record, "reflectance", one)?,
            },
            "glass" => Material::Glass {
                reflectance: color_or(src, record, "reflectance", one)?,
                transmittance: color_or(src, record, "transmittance", one)?,
                roughness: scalar_or(src, record, "roughness", 0.0)?,
                ior: scalar_or(src, record, "ior", 1.5)?,
            },
            "refraction" => Material::Refraction {
                transmittance: color_or(src, record, "transmittance", one)?,
                roughness: scalar_or(src, record, "roughness", 0.0)?,
                ior: scalar_or(src, record, "ior", 1.5)?,
            },
            "microfacet" => Material::Microfacet {
                alpha: scalar_or(src, record, "alpha", 0.5)?,
                eta: src.vec3(src.require(record, "eta")?)?,
                k: src.vec3(src.require(record, "k")?)?,
            },
            other => {
                return unusable(
                    format!(
                        "unknown material record <{other}> (expected emission, mirror, glass, refraction or microfacet)"
                    ),
                    warnings,
                );
            }
        };
        if let Material::Glass { ior, .. } | Material::Refraction { ior, .. } = material
            && ior <= 0.0
        {
            return Err(src.error(record, format!("ior {ior} must be positive")));
        }
        return Ok(material);
    }

    // profile_COMMON: the first shading model's diffuse colour.
    let technique = child(effect, "profile_COMMON").and_then(|p| {
        children(p, "technique")
            .find(|t| t.attribute("sid") == Some("common"))
            .or_else(|| child(p, "technique"))
    });
    let diffuse = technique.and_then(|t| {
        ["phong", "lambert", "blinn"]
            .iter()
            .find_map(|model| path(t, &[model, "diffuse"]))
    });
    match diffuse.and_then(|d| child(d, "color")) {
        Some(color) => {
            let albedo = src.vec3(color)?;
            if albedo.min_element() < 0.0 {
                return Err(src.error(
                    color,
                    format!("diffuse colour {albedo} has a negative component"),
                ));
            }
            if albedo.max_element() > 1.0 {
                // Kept, as the reference keeps it: a test scene may want it.
                warnings.push(src.warning(
                    color,
                    format!(
                        "diffuse colour has a component of {}: above 1, it reflects more light than it receives, and with several bounces the image can grow without bound",
                        short(albedo.max_element())
                    ),
                ));
            }
            Ok(Material::Diffuse { albedo })
        }
        None => {
            warnings.push(src.warning(
                effect,
                format!(
                    "effect {:?} has no usable diffuse colour; using grey diffuse",
                    effect.attribute("id").unwrap_or("")
                ),
            ));
            Ok(Material::DEFAULT)
        }
    }
}

/// A number as `{}` prints it, or in exponent form where that would run
/// to dozens of digits.
fn short(x: f32) -> String {
    if x.abs() < 1e6 {
        x.to_string()
    } else {
        format!("{x:e}")
    }
}
