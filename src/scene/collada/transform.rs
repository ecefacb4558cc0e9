//! Node transforms and the up-axis conversion.

use glam::{Mat4, Vec3, Vec4};
use roxmltree::Node;

use super::error::{LoadError, Source};

/// The root transform that brings a file's up axis to +Y.
///
/// `Z_UP` maps (x, y, z) → (−x, z, y) and `X_UP` maps (x, y, z) → (y, x, −z),
/// as the reference renderer does; both are proper rotations.
pub fn up_axis_matrix(axis: &str) -> Option<Mat4> {
    match axis {
        "Y_UP" => Some(Mat4::IDENTITY),
        "Z_UP" => Some(Mat4::from_cols(
            Vec4::new(-1.0, 0.0, 0.0, 0.0),
            Vec4::new(0.0, 0.0, 1.0, 0.0),
            Vec4::new(0.0, 1.0, 0.0, 0.0),
            Vec4::W,
        )),
        "X_UP" => Some(Mat4::from_cols(
            Vec4::new(0.0, 1.0, 0.0, 0.0),
            Vec4::new(1.0, 0.0, 0.0, 0.0),
            Vec4::new(0.0, 0.0, -1.0, 0.0),
            Vec4::W,
        )),
        _ => None,
    }
}

/// The local transform of a `<node>`: its transform elements composed in
/// document order (each post-multiplied), per the COLLADA spec.
pub fn node_local_transform(
    src: &Source,
    node: Node,
    warnings: &mut Vec<String>,
) -> Result<Mat4, LoadError> {
    let mut m = Mat4::IDENTITY;
    for t in node.children().filter(|c| c.is_element()) {
        let local = match t.tag_name().name() {
            "matrix" => {
                let v = src.floats_n(t, 16)?;
                // The bottom row of an affine transform; points and
                // directions are moved as if it were (the renderer has no
                // projective transforms), which the user is told.
                // (Within 1e-6: exporters working in f64 may write
                // 1.0000001.)
                let bottom = [0.0, 0.0, 0.0, 1.0];
                if v[12..]
                    .iter()
                    .zip(bottom)
                    .any(|(x, want)| (x - want).abs() > 1e-6)
                {
                    warnings.push(src.warning(
                        t,
                        format!(
                            "<matrix>: the bottom row is {} {} {} {}, not 0 0 0 1; projective transforms are not supported and it is read as 0 0 0 1",
                            v[12], v[13], v[14], v[15]
                        ),
                    ));
                }
                // Row-major in the file; glam is column-major.
                let mut m = Mat4::from_cols_slice(&v).transpose();
                m.w_axis.w = 1.0;
                m.x_axis.w = 0.0;
                m.y_axis.w = 0.0;
                m.z_axis.w = 0.0;
                m
            }
            "translate" => {
                let v = src.floats_n(t, 3)?;
                Mat4::from_translation(Vec3::new(v[0], v[1], v[2]))
            }
            "scale" => {
                let v = src.floats_n(t, 3)?;
                Mat4::from_scale(Vec3::new(v[0], v[1], v[2]))
            }
            "rotate" => {
                let v = src.floats_n(t, 4)?;
                let axis = Vec3::new(v[0], v[1], v[2]);
                if axis.length_squared() == 0.0 {
                    return Err(src.error(t, "rotation axis is zero"));
                }
                Mat4::from_axis_angle(axis.normalize(), v[3].to_radians())
            }
            "lookat" => {
                let v = src.floats_n(t, 9)?;
                let eye = Vec3::new(v[0], v[1], v[2]);
                let interest = Vec3::new(v[3], v[4], v[5]);
                let up = Vec3::new(v[6], v[7], v[8]);
                // Camera-to-world frame: x = right, y = up, −z = toward interest.
                let forward = (interest - eye).normalize_or_zero();
                let right = forward.cross(up).normalize_or_zero();
                if forward == Vec3::ZERO || right == Vec3::ZERO {
                    return Err(src.error(
                        t,
                        "degenerate lookat (eye = interest, or up parallel to the view)",
                    ));
                }
                let true_up = right.cross(forward);
                Mat4::from_cols(
                    right.extend(0.0),
                    true_up.extend(0.0),
                    (-forward).extend(0.0),
                    eye.extend(1.0),
                )
            }
            "skew" => {
                warnings.push(src.warning(t, "<skew> is not supported and was ignored"));
                continue;
            }
            _ => continue,
        };
        m *= local;
    }
    if !m.is_finite() {
        return Err(src.error(node, "the node's transform overflows to a non-finite value"));
    }
    Ok(m)
}
