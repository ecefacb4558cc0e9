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

/// The colour `node` holds as a reflectance or transmittance (`what`):
/// refused with a negative component, kept with a warning above 1 (as the
/// reference keeps it: a test scene may want it).
fn fraction_colour(
    src: &Source,
    node: Node,
    what: &str,
    warnings: &mut Vec<String>,
) -> Result<Vec3, LoadError> {
    let colour = src.vec3(node)?;
    if colour.min_element() < 0.0 {
        return Err(src.error(node, format!("{what} {colour} has a negative component")));
    }
    if colour.max_element() > 1.0 {
        warnings.push(src.warning(
            node,
            format!(
                "{what} has a component of {}: above 1, it reflects more light than it receives, and with several bounces the image can grow without bound",
                short(colour.max_element())
            ),
        ));
    }
    Ok(colour)
}

/// `node`'s child `name` as a [`fraction_colour`], or `default`.
fn fraction_or(
    src: &Source,
    node: Node,
    name: &str,
    default: Vec3,
    warnings: &mut Vec<String>,
) -> Result<Vec3, LoadError> {
    match child(node, name) {
        Some(c) => fraction_colour(src, c, name, warnings),
        None => Ok(default),
    }
}

/// `node`'s child `name` as a number that `valid` accepts (`rule` says
/// what that is), or `default`.
fn scalar_or(
    src: &Source,
    node: Node,
    name: &str,
    default: f32,
    (valid, rule): (fn(f32) -> bool, &str),
) -> Result<f32, LoadError> {
    match child(node, name) {
        Some(c) => {
            let x = src.scalar(c)?;
            if !valid(x) {
                return Err(src.error(c, format!("{name} {x} {rule}")));
            }
            Ok(x)
        }
        None => Ok(default),
    }
}

const NON_NEGATIVE: (fn(f32) -> bool, &str) = (|x| x >= 0.0, "must not be negative");
const POSITIVE: (fn(f32) -> bool, &str) = (|x| x > 0.0, "must be positive");

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
                reflectance: fraction_or(src, record, "reflectance", one, warnings)?,
            },
            "glass" => Material::Glass {
                reflectance: fraction_or(src, record, "reflectance", one, warnings)?,
                transmittance: fraction_or(src, record, "transmittance", one, warnings)?,
                roughness: scalar_or(src, record, "roughness", 0.0, NON_NEGATIVE)?,
                ior: scalar_or(src, record, "ior", 1.5, POSITIVE)?,
            },
            "refraction" => Material::Refraction {
                transmittance: fraction_or(src, record, "transmittance", one, warnings)?,
                roughness: scalar_or(src, record, "roughness", 0.0, NON_NEGATIVE)?,
                ior: scalar_or(src, record, "ior", 1.5, POSITIVE)?,
            },
            "microfacet" => {
                let (eta, k) = (src.require(record, "eta")?, src.require(record, "k")?);
                let (eta_value, k_value) = (src.vec3(eta)?, src.vec3(k)?);
                // A conductor's complex index of refraction: n > 0, k ≥ 0.
                if eta_value.min_element() <= 0.0 {
                    return Err(src.error(eta, format!("eta {eta_value} must be positive")));
                }
                if k_value.min_element() < 0.0 {
                    return Err(src.error(k, format!("k {k_value} has a negative component")));
                }
                Material::Microfacet {
                    alpha: scalar_or(src, record, "alpha", 0.5, POSITIVE)?,
                    eta: eta_value,
                    k: k_value,
                }
            }
            other => {
                return unusable(
                    format!(
                        "unknown material record <{other}> (expected emission, mirror, glass, refraction or microfacet)"
                    ),
                    warnings,
                );
            }
        };
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
        Some(color) => Ok(Material::Diffuse {
            albedo: fraction_colour(src, color, "diffuse colour", warnings)?,
        }),
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
