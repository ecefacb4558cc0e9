//! What the COLLADA loader builds from valid input: transforms, up axes,
//! material bindings and records, spheres, lights, texture coordinates and
//! smooth normals, each checked against the conventions of the reference
//! renderer (`../shared/docs/cs184-reference.md`, section 1) on a targeted
//! edit of the fixture scene. These hold on any clone: unlike the CS184
//! scene tests they need nothing from `../shared`.

use std::path::Path;

use glam::{Mat4, Vec2, Vec3, Vec4};
use wavepath::scene::{Light, Material, Scene, collada::load_str};

mod common;
use common::fixture::{BASE, NAME, POSITION_ACCESSOR, edit, edits};

fn load(text: &str) -> Scene {
    load_str(text, Path::new(NAME)).unwrap_or_else(|e| panic!("{e}"))
}

/// The fixture triangle's vertices before any transform.
const TRIANGLE: [Vec3; 3] = [Vec3::ZERO, Vec3::X, Vec3::Y];

fn assert_close(got: Vec3, want: Vec3, what: &str) {
    assert!(
        (got - want).abs().max_element() <= 1e-5 * want.abs().max_element().max(1.0),
        "{what}: {got} != {want}"
    );
}

/// The loaded triangle's world vertices against `world` applied to [`TRIANGLE`].
fn assert_triangle_placed(scene: &Scene, world: Mat4, what: &str) {
    let t = &scene.geometry.triangles;
    assert_eq!(t.len(), 1, "{what}");
    for (k, &p) in t.indices[0].iter().enumerate() {
        let want = world.transform_point3(TRIANGLE[k]);
        assert_close(
            t.positions[p as usize],
            want,
            &format!("{what}, vertex {k}"),
        );
    }
}

fn warned(scene: &Scene, words: &str) -> bool {
    scene.warnings.iter().any(|w| w.contains(words))
}

#[test]
fn node_transforms_compose_parent_first_in_document_order() {
    // A parent <matrix> (row-major: its translation is the last column)
    // around the triangle's node, whose own list is translate, rotate,
    // scale: world = M · T · R · S, each post-multiplied in document order.
    let text = edits(&[
        (
            r#"      <node id="tri-node">"#,
            r#"<node><matrix>0 -1 0 10  1 0 0 20  0 0 1 30  0 0 0 1</matrix><node id="tri-node">"#,
        ),
        (
            "<rotate>0 1 0 30</rotate>",
            "<translate>1 2 3</translate><rotate>0 0 2 90</rotate><scale>2 3 4</scale>",
        ),
        (
            r#"      <node id="ball-node">"#,
            r#"</node><node id="ball-node">"#,
        ),
    ]);
    let m = Mat4::from_cols(
        Vec4::new(0.0, 1.0, 0.0, 0.0),
        Vec4::new(-1.0, 0.0, 0.0, 0.0),
        Vec4::Z,
        Vec4::new(10.0, 20.0, 30.0, 1.0),
    );
    let world = m
        * Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0))
        * Mat4::from_rotation_z(90f32.to_radians())
        * Mat4::from_scale(Vec3::new(2.0, 3.0, 4.0));
    assert_triangle_placed(&load(&text), world, "nested nodes");

    // The same chain reached through <instance_node>: the instanced node
    // takes the instancing node's world transform as its parent.
    let text = edits(&[
        (
            "<library_visual_scenes>",
            r##"<library_nodes><node id="shared"><translate>0 0 -5</translate><instance_geometry url="#tri"/></node></library_nodes><library_visual_scenes>"##,
        ),
        (
            r##"<instance_geometry url="#tri">"##,
            r##"<instance_node url="#shared"/><instance_geometry url="#tri">"##,
        ),
    ]);
    let scene = load(&text);
    let t = &scene.geometry.triangles;
    assert_eq!(t.len(), 2);
    let rotate = Mat4::from_rotation_y(30f32.to_radians());
    let instanced = rotate * Mat4::from_translation(Vec3::new(0.0, 0.0, -5.0));
    for (k, &corner) in TRIANGLE.iter().enumerate() {
        let got = t.positions[t.indices[0][k] as usize];
        assert_close(got, instanced.transform_point3(corner), "instanced");
        let got = t.positions[t.indices[1][k] as usize];
        assert_close(got, rotate.transform_point3(corner), "direct");
    }
}

#[test]
fn lookat_places_a_node_as_a_camera_looking_at_its_interest() {
    // Eye (1, 2, 3) looking at (1, 2, −7) (down −z) with up (0, 5, 1),
    // which is not perpendicular to the view: the frame is x = right,
    // y = the up vector made perpendicular, z = back toward the eye, and
    // the origin is the eye. Here that is the identity frame at the eye.
    // (A translation along z after it moves the flat triangle off its
    // plane, so the frame's z column shows.)
    let at = |lookat: &str| {
        load(&edit(
            "<rotate>0 1 0 30</rotate>",
            &format!("{lookat}<translate>0 0 1</translate>"),
        ))
    };
    let lift = Mat4::from_translation(Vec3::Z);
    let scene = at("<lookat>1 2 3  1 2 -7  0 5 1</lookat>");
    let eye = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0));
    assert_triangle_placed(&scene, eye * lift, "down -z");

    // Looking along +x from the origin with up +z: right = forward × up =
    // −y, true up = +z, back = −x.
    let scene = at("<lookat>0 0 0  4 0 0  0 0 1</lookat>");
    let frame = Mat4::from_cols(-Vec4::Y, Vec4::Z, -Vec4::X, Vec4::W);
    assert_triangle_placed(&scene, frame * lift, "along +x");
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
}

#[test]
fn skew_is_ignored_with_a_warning() {
    let scene = load(&edit(
        "<rotate>0 1 0 30</rotate>",
        "<skew>45 0 1 0 1 0 0</skew><translate>0 0 1</translate>",
    ));
    assert_triangle_placed(
        &scene,
        Mat4::from_translation(Vec3::Z),
        "skew then translate",
    );
    assert!(
        warned(&scene, "<skew> is not supported"),
        "{:?}",
        scene.warnings
    );
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
}

#[test]
fn up_axes_map_as_the_reference_does() {
    let moved = edit("<rotate>0 1 0 30</rotate>", "<translate>1 2 3</translate>");
    let at = |axis: &str| {
        let text = moved.replace("<up_axis>Y_UP</up_axis>", axis);
        load(&text)
    };
    let shift = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0));
    // (x, y, z) → (−x, z, y) and (x, y, z) → (y, x, −z), as root transforms.
    let z_up = Mat4::from_cols(-Vec4::X, Vec4::Z, Vec4::Y, Vec4::W);
    let x_up = Mat4::from_cols(Vec4::Y, Vec4::X, -Vec4::Z, Vec4::W);
    for (axis, root) in [
        ("<up_axis>Y_UP</up_axis>", Mat4::IDENTITY),
        ("<up_axis>Z_UP</up_axis>", z_up),
        ("<up_axis> X_UP </up_axis>", x_up),
    ] {
        let scene = at(axis);
        assert_triangle_placed(&scene, root * shift, axis);
        // The sphere's centre (node translation 2, 0, 0) goes the same way.
        let want = root.transform_point3(Vec3::new(2.0, 0.0, 0.0));
        assert_close(scene.geometry.spheres.center[0], want, axis);
        assert!(scene.warnings.is_empty(), "{axis}: {:?}", scene.warnings);
    }
    // No up axis: Y_UP, with a warning (the reference refuses the file).
    let scene = load(&moved.replace("<up_axis>Y_UP</up_axis>", ""));
    assert_triangle_placed(&scene, shift, "no up axis");
    assert!(warned(&scene, "Y_UP"), "{:?}", scene.warnings);
}

/// Units are not applied (the reference ignores them too), and a file that
/// asks for a scale other than one unit to the metre is told so; the
/// geometry stays where the file's numbers put it.
#[test]
fn units_other_than_metres_are_read_as_they_stand_with_a_warning() {
    let with_unit = |unit: &str| {
        load(&BASE.replacen(
            "<up_axis>Y_UP</up_axis>",
            &format!("{unit}<up_axis>Y_UP</up_axis>"),
            1,
        ))
    };
    let plain = load(BASE);
    for unit in [
        "",
        r#"<unit name="meter" meter="1"/>"#,
        r#"<unit meter=" 1.0 "/>"#,
    ] {
        let scene = with_unit(unit);
        assert!(scene.warnings.is_empty(), "{unit}: {:?}", scene.warnings);
    }
    for meter in ["0.01", "1000", "one"] {
        let scene = with_unit(&format!(r#"<unit name="centimeter" meter="{meter}"/>"#));
        assert_eq!(
            scene.geometry.triangles.positions, plain.geometry.triangles.positions,
            "meter {meter}"
        );
        assert!(
            warned(&scene, &format!("<unit meter=\"{meter}\"> is not applied")),
            "{:?}",
            scene.warnings
        );
        assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    }
}

/// A second material, `red`, for the binding tests.
const RED: &str = r##"<material id="red" name="red"><instance_effect url="#red-fx"/></material>
  </library_materials>"##;
const RED_FX: &str = r#"<effect id="red-fx"><profile_COMMON><technique sid="common"><lambert><diffuse><color>1 0 0 1</color></diffuse></lambert></technique></profile_COMMON></effect>
  </library_effects>"#;

/// The name of the triangle's material.
fn triangle_material(scene: &Scene) -> &str {
    &scene.materials[scene.geometry.triangles.material[0] as usize].name
}

#[test]
fn the_bound_material_is_the_one_the_lists_symbol_names() {
    let with_red = |pairs: &[(&str, &str)]| {
        let mut all = vec![
            ("  </library_materials>", RED),
            ("  </library_effects>", RED_FX),
        ];
        all.extend_from_slice(pairs);
        edits(&all)
    };
    // Two bindings; the list's symbol picks the second.
    let both = (
        r##"<instance_material symbol="grey-sym" target="#mat"/>"##,
        r##"<instance_material symbol="red-sym" target="#red"/><instance_material symbol="grey-sym" target="#mat"/>"##,
    );
    let text = with_red(&[both]);
    let scene = load(&text);
    assert_eq!(triangle_material(&scene), "grey");
    // And the first, when the list names it.
    let text = with_red(&[both, (r#"material="grey-sym""#, r#"material="red-sym""#)]);
    let scene = load(&text);
    assert_eq!(triangle_material(&scene), "red");
    assert_eq!(*scene.material_of(0), Material::Diffuse { albedo: Vec3::X });
    // A symbol bound nowhere that is a material's id (as exporters write
    // it) names that material; one that is not falls back to the default.
    let text = with_red(&[(r#"material="grey-sym""#, r#"material="red""#)]);
    assert_eq!(triangle_material(&load(&text)), "red");
    // One that is neither falls back to the default, with a warning
    // naming the symbol.
    let text = edit(r#"material="grey-sym""#, r#"material="fx""#);
    let scene = load(&text);
    assert_eq!(triangle_material(&scene), "default");
    assert!(
        warned(
            &scene,
            r#"material symbol "fx" is bound by no <instance_material>"#
        ),
        "{:?}",
        scene.warnings
    );
    // The fixture's own bindings say nothing.
    assert!(load(BASE).warnings.is_empty());
}

#[test]
fn a_matrix_with_a_projective_bottom_row_is_read_as_affine_with_a_warning() {
    // After a translation, a bottom row other than 0 0 0 1 would move the
    // triangle (the translation times the row); read as 0 0 0 1, the
    // triangle is only translated.
    let projective = "<translate>1 2 3</translate><matrix>1 0 0 0 0 1 0 0 0 0 1 0 1 0 0 1</matrix>";
    let scene = load(&edit("<rotate>0 1 0 30</rotate>", projective));
    assert!(
        warned(&scene, "the bottom row is 1 0 0 1, not 0 0 0 1"),
        "{:?}",
        scene.warnings
    );
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    let moved = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0));
    assert_triangle_placed(&scene, moved, "projective row read as 0 0 0 1");
    // A row an exporter wrote in double precision is not warned of.
    let nearly = "<matrix>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1.0000001</matrix>";
    let scene = load(&edit("<rotate>0 1 0 30</rotate>", nearly));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
}

#[test]
fn a_scene_beyond_the_far_clipping_plane_is_warned_of() {
    // The camera stands 1.5 diagonals from the scene's centre: a ball of
    // radius 500 puts everything beyond a zfar of 100, one of radius 20
    // only the back of the scene.
    let radius = |r: &str| edit("<radius>0.5</radius>", &format!("<radius>{r}</radius>"));
    let cases = [
        (
            "500",
            Some("the whole scene lies beyond the far clipping plane (zfar 100;"),
        ),
        (
            "20",
            Some("part of the scene lies beyond the far clipping plane (zfar 100;"),
        ),
        ("5", None),
    ];
    for (r, says) in cases {
        let scene = load(&radius(r));
        let warning = scene
            .warnings
            .iter()
            .find(|w| w.contains("far clipping plane"));
        match says {
            Some(says) => assert!(
                warning.is_some_and(|w| w.contains(says)),
                "{r}: {warning:?}"
            ),
            None => assert_eq!(warning, None, "{r}"),
        }
    }
}

/// The material of the fixture's effect with `record` as its CGL (or
/// `profile`) technique.
fn record_material(profile: &str, record: &str) -> Material {
    let text = edit(
        "    </effect>",
        &format!(
            r#"      <extra><technique profile="{profile}">{record}</technique></extra>
    </effect>"#
        ),
    );
    let scene = load(&text);
    assert!(scene.warnings.is_empty(), "{record}: {:?}", scene.warnings);
    scene.material_of(0).clone()
}

#[test]
fn renderer_records_become_typed_materials_with_their_defaults() {
    let one = Vec3::ONE;
    let c = Vec3::new(0.1, 0.2, 0.3);
    for (profile, record, want) in [
        (
            "CGL",
            "<emission><radiance>1 0 2</radiance></emission>",
            Material::Emission {
                radiance: Vec3::new(1.0, 0.0, 2.0),
                one_sided: false,
            },
        ),
        ("CMU462", "<mirror/>", Material::Mirror { reflectance: one }),
        (
            "CGL",
            "<mirror><reflectance>0.1 0.2 0.3</reflectance></mirror>",
            Material::Mirror { reflectance: c },
        ),
        (
            "CGL",
            "<glass><roughness>0.25</roughness></glass>",
            Material::Glass {
                reflectance: one,
                transmittance: one,
                roughness: 0.25,
                ior: 1.5,
            },
        ),
        (
            "CGL",
            "<glass><reflectance>0.1 0.2 0.3</reflectance><transmittance>0.1 0.2 0.3</transmittance><ior>1.33</ior></glass>",
            Material::Glass {
                reflectance: c,
                transmittance: c,
                roughness: 0.0,
                ior: 1.33,
            },
        ),
        (
            "CGL",
            "<refraction><ior>2.4</ior></refraction>",
            Material::Refraction {
                transmittance: one,
                roughness: 0.0,
                ior: 2.4,
            },
        ),
        (
            "CGL",
            "<microfacet><eta>0.1 0.2 0.3</eta><k>3 2 1</k></microfacet>",
            Material::Microfacet {
                alpha: 0.5,
                eta: c,
                k: Vec3::new(3.0, 2.0, 1.0),
            },
        ),
        (
            "CGL",
            "<microfacet><alpha>0.05</alpha><eta>0.1 0.2 0.3</eta><k>3 2 1</k></microfacet>",
            Material::Microfacet {
                alpha: 0.05,
                eta: c,
                k: Vec3::new(3.0, 2.0, 1.0),
            },
        ),
    ] {
        assert_eq!(record_material(profile, record), want, "{record}");
    }
    // Another profile's technique is not the renderer's: the Lambert
    // colour stands.
    assert_eq!(
        record_material("OTHER", "<mirror/>"),
        Material::Diffuse {
            albedo: Vec3::splat(0.5)
        }
    );
}

#[test]
fn diffuse_colours_come_from_the_common_technique_of_any_shading_model() {
    for (model, colour, want) in [
        ("lambert", "0 0.5 1 1", Vec3::new(0.0, 0.5, 1.0)),
        ("phong", "0.2 0.3 0.4", Vec3::new(0.2, 0.3, 0.4)),
        ("blinn", "1 1 1 1", Vec3::ONE),
    ] {
        // The technique with sid="common" counts, even after another one.
        let text = edit(
            r#"<technique sid="common">
          <lambert>
            <diffuse>
              <color>0.5 0.5 0.5 1</color>"#,
            &format!(
                r#"<technique sid="other"><lambert><diffuse><color>0.9 0.9 0.9 1</color></diffuse></lambert></technique>
        <technique sid="common">
          <{model}>
            <diffuse>
              <color>{colour}</color>"#
            ),
        )
        .replace("</lambert>\n        </technique>", &format!("</{model}>\n        </technique>"));
        let scene = load(&text);
        assert_eq!(
            *scene.material_of(0),
            Material::Diffuse { albedo: want },
            "{model}"
        );
        assert!(scene.warnings.is_empty(), "{model}: {:?}", scene.warnings);
    }
}

#[test]
fn spheres_take_the_world_origin_and_the_length_of_the_world_x_axis() {
    // Centre = T·(0,0,0,1); radius = 0.5 · |T·(1,0,0,0)|, whatever the y
    // and z scales.
    let text = edit(
        "<translate>2 0 0</translate>",
        "<translate>2 0 0</translate><rotate>0 0 1 90</rotate><scale>3 5 7</scale>",
    );
    let scene = load(&text);
    let s = &scene.geometry.spheres;
    assert_eq!(s.len(), 1);
    assert_close(s.center[0], Vec3::new(2.0, 0.0, 0.0), "centre");
    assert!((s.radius[0] - 1.5).abs() < 1e-6, "{}", s.radius[0]);
    assert_eq!(scene.materials[s.material[0] as usize].name, "grey");
}

/// The fixture's light, as a `kind` record with colour 0.25 0.5 1, under
/// the lamp node's transform `transform`.
fn light(kind: &str, transform: &str) -> Scene {
    load(&edits(&[
        (
            "<point>\n          <color>1 1 1</color>\n        </point>",
            &format!("<{kind}><color>0.25 0.5 1</color></{kind}>"),
        ),
        ("<translate>0 3 0</translate>", transform),
    ]))
}

/// An area light too far out for single precision (loadable, but its
/// points cannot be placed) is warned of; an ordinary one is not.
#[test]
fn an_area_light_beyond_the_coordinate_limit_is_warned_of() {
    let far = light("area", "<scale>1e16 1e16 1</scale>");
    assert!(
        warned(&far, "an area light reaches 5e15; past 1e12"),
        "{:?}",
        far.warnings
    );
    let near = light("area", "<scale>1e3 1e3 1</scale>");
    assert!(
        !warned(&near, "an area light reaches"),
        "{:?}",
        near.warnings
    );
}

#[test]
fn lights_are_placed_by_their_nodes_world_transform() {
    let colour = Vec3::new(0.25, 0.5, 1.0);
    let transform = "<translate>1 2 3</translate><rotate>1 0 0 90</rotate><scale>2 2 4</scale>";
    let t = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0))
        * Mat4::from_rotation_x(90f32.to_radians())
        * Mat4::from_scale(Vec3::new(2.0, 2.0, 4.0));
    let apply = |v: Vec4| (t * v).truncate();
    let p = apply(Vec4::W);

    let scene = light("point", transform);
    assert_eq!(scene.lights.len(), 1);
    let Light::Point {
        position,
        intensity,
    } = scene.lights[0]
    else {
        panic!("{:?}", scene.lights)
    };
    assert_close(position, p, "point position");
    assert_eq!(intensity, colour);

    // Toward the light: T·(0,0,−1,1) with w = 1 (the translation leaks in,
    // as in the reference).
    let scene = light("directional", transform);
    let Light::Directional { to_light, radiance } = scene.lights[0] else {
        panic!("{:?}", scene.lights)
    };
    assert_close(
        to_light,
        apply(Vec4::new(0.0, 0.0, -1.0, 1.0)).normalize(),
        "direction",
    );
    assert_eq!(radiance, colour);

    // An area light is also a one-sided emissive rectangle of two triangles.
    let scene = light("area", transform);
    let Light::Area {
        center,
        normal,
        dim_x,
        dim_y,
        radiance,
    } = scene.lights[0]
    else {
        panic!("{:?}", scene.lights)
    };
    assert_close(center, p, "area centre");
    let n = (apply(Vec4::new(0.0, 0.0, -1.0, 1.0)) - p).normalize();
    assert_close(normal, n, "area normal");
    assert_close(dim_x, apply(Vec4::new(-1.0, 0.0, 0.0, 1.0)) - p, "dim_x");
    assert_close(dim_y, apply(Vec4::new(0.0, 1.0, 0.0, 1.0)) - p, "dim_y");
    assert_eq!(radiance, colour);
    assert_eq!(scene.geometry.triangles.len(), 3);
    let emitter = scene.material_of(1);
    assert_eq!(
        *emitter,
        Material::Emission {
            radiance: colour,
            one_sided: true
        }
    );

    let scene = light("ambient", transform);
    assert_eq!(scene.lights, [Light::Hemisphere { radiance: colour }]);

    // Spot lights and unknown types are skipped, with a warning each.
    for kind in ["spot", "laser"] {
        let scene = light(kind, transform);
        assert!(scene.lights.is_empty(), "{kind}");
        assert!(warned(&scene, kind), "{kind}: {:?}", scene.warnings);
    }
    // A light instanced by two nodes is one record: its warning is given
    // once, not once per instance.
    let twice = edits(&[
        (
            "<point>\n          <color>1 1 1</color>\n        </point>",
            "<spot><color>1 1 1</color></spot>",
        ),
        (
            "<node id=\"tri-node\">",
            "<node id=\"lamp-again\"><instance_light url=\"#lamp\"/></node>\n      \
             <node id=\"tri-node\">",
        ),
    ]);
    let scene = load(&twice);
    let spots = scene.warnings.iter().filter(|w| w.contains("spot")).count();
    assert_eq!(spots, 1, "{:?}", scene.warnings);
}

#[test]
fn texture_coordinates_and_smooth_normals_follow_the_corners() {
    // The fixture's triangle: corner k takes texcoord index k and its
    // normal is the face normal (one face), rotated with the node.
    let scene = load(BASE);
    let t = &scene.geometry.triangles;
    assert_eq!(t.texcoords, [[Vec2::ZERO, Vec2::X, Vec2::Y]]);
    let face = Mat4::from_rotation_y(30f32.to_radians()).transform_vector3(Vec3::Z);
    for &i in &t.indices[0] {
        assert_close(t.normals[i as usize], face, "normal");
    }

    // A quad folded along its diagonal, as a polylist of two triangles
    // sharing vertices 0 and 2: there the normal is the area-weighted
    // mean of the two faces (the second face 2√3 times the first's area).
    let text = edits(&[
        (
            r#"count="9">0 0 0 1 0 0 0 1 0"#,
            r#"count="12">0 0 0 1 0 0 1 1 0 0 2 2"#,
        ),
        (r#"count="3" stride="3">"#, r#"count="4" stride="3">"#),
        (
            r#"<polylist material="grey-sym" count="1">"#,
            r#"<polylist material="grey-sym" count="2">"#,
        ),
        ("<vcount>3</vcount>", "<vcount>3 3</vcount>"),
        (
            "<p>0 0 0 1 0 1 2 0 2</p>",
            "<p>0 0 0 1 0 1 2 0 2 0 0 0 2 0 1 3 0 2</p>",
        ),
    ]);
    let scene = load(&text);
    let t = &scene.geometry.triangles;
    assert_eq!(t.len(), 2);
    let rotate = Mat4::from_rotation_y(30f32.to_radians());
    let world = |i: u32| t.positions[i as usize];
    let face = |k: usize| {
        let [a, b, c] = t.indices[k].map(world);
        (b - a).cross(c - a)
    };
    let (f0, f1) = (face(0), face(1));
    assert!((f1.length() / f0.length() - 2.0 * 3f32.sqrt()).abs() < 1e-4);
    let [s0, _, s2] = t.indices[0];
    for shared in [s0, s2] {
        assert_close(t.normals[shared as usize], (f0 + f1).normalize(), "shared");
    }
    assert_close(t.normals[t.indices[0][1] as usize], f0.normalize(), "own");
    assert_close(t.normals[t.indices[1][2] as usize], f1.normalize(), "own");
    assert_close(
        world(t.indices[1][2]),
        rotate.transform_point3(Vec3::new(0.0, 2.0, 2.0)),
        "fourth vertex",
    );
    assert_eq!(t.texcoords.len(), 2);
}

#[test]
fn warnings_name_what_a_scene_lacks_or_skips() {
    let base = load(BASE);
    assert!(base.warnings.is_empty(), "{:?}", base.warnings);
    // Triangles alone or a sphere alone are geometry; neither is not.
    for (keep, drop) in [("#tri", "#ball"), ("#ball", "#tri")] {
        let scene = load(&edit(
            &format!(r#"<instance_geometry url="{drop}">"#),
            &format!(r#"<instance_geometry url="{keep}">"#),
        ));
        let g = &scene.geometry;
        assert_eq!(
            (g.triangles.is_empty(), g.spheres.is_empty()),
            (keep == "#ball", keep == "#tri")
        );
        assert!(
            !warned(&scene, "no geometry"),
            "{keep}: {:?}",
            scene.warnings
        );
    }
    let neither = edits(&[
        (
            r##"<instance_geometry url="#tri">"##,
            r##"<instance_light url="#lamp">"##,
        ),
        (
            r##"<instance_geometry url="#ball">"##,
            r##"<instance_light url="#lamp">"##,
        ),
    ])
    .replace("</instance_geometry>", "</instance_light>");
    let neither = load(&neither);
    assert!(warned(&neither, "no geometry"), "{:?}", neither.warnings);

    // Skinned geometry is skipped with a warning naming it.
    let scene = load(&edit(
        r##"<instance_light url="#lamp"/>"##,
        r##"<instance_light url="#lamp"/><instance_controller url="#skin"/>"##,
    ));
    assert!(
        warned(&scene, "<instance_controller>"),
        "{:?}",
        scene.warnings
    );
    // No camera: viewed from +z, said once.
    let scene = load(&edit(r##"<instance_camera url="#cam"/>"##, ""));
    assert!(warned(&scene, "no camera"), "{:?}", scene.warnings);
}

/// The fixture with its triangle mesh replaced: `positions` (x y z per
/// vertex), texture coordinates `uvs` (u v each) and the primitive lists
/// `lists`, whose inputs may use `#tri-vtx`, `#tri-nrm` (one normal) and
/// `#tri-uv`.
fn with_mesh(positions: &[f32], uvs: &[f32], lists: &str) -> String {
    let numbers = |v: &[f32]| v.iter().map(f32::to_string).collect::<Vec<_>>().join(" ");
    let start = BASE.find(r#"<polylist material="grey-sym""#).unwrap();
    let end = BASE.find("</polylist>").unwrap() + "</polylist>".len();
    let text = format!("{}{lists}{}", &BASE[..start], &BASE[end..]);
    common::fixture::edit_text(
        &text,
        &[
            (
                r#"count="9">0 0 0 1 0 0 0 1 0<"#,
                &format!(r#"count="{}">{}<"#, positions.len(), numbers(positions)),
            ),
            (
                r##"<accessor source="#tri-pos-array" count="3" stride="3">"##,
                &format!(
                    r##"<accessor source="#tri-pos-array" count="{}" stride="3">"##,
                    positions.len() / 3
                ),
            ),
            (
                r#"count="6">0 0 1 0 0 1<"#,
                &format!(r#"count="{}">{}<"#, uvs.len(), numbers(uvs)),
            ),
            (
                r##"<accessor source="#tri-uv-array" count="3" stride="2"/>"##,
                &format!(
                    r##"<accessor source="#tri-uv-array" count="{}" stride="2"/>"##,
                    uvs.len() / 2
                ),
            ),
        ],
    )
}

/// A convex pentagon in the z = 0 plane, and texture coordinates (x, y)/4.
const PENTAGON: [f32; 15] = [
    0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 3.0, 1.0, 0.0, 1.0, 3.0, 0.0, -1.0, 1.0, 0.0,
];
const PENTAGON_UV: [f32; 10] = [0.0, 0.0, 0.5, 0.0, 0.75, 0.25, 0.25, 0.75, -0.25, 0.25];

/// Vertex, normal, texcoord inputs at offsets 0, 1, 2.
const INPUTS: &str = r##"<input semantic="VERTEX" source="#tri-vtx" offset="0"/><input semantic="NORMAL" source="#tri-nrm" offset="1"/><input semantic="TEXCOORD" source="#tri-uv" offset="2" set="0"/>"##;

/// The `<p>` entries of corners `corners` (vertex k, normal 0, texcoord k).
fn corners(corners: &[u32]) -> String {
    corners
        .iter()
        .map(|k| format!("{k} 0 {k}"))
        .collect::<Vec<_>>()
        .join(" ")
}

#[test]
fn every_kind_of_primitive_list_is_triangulated_as_a_fan() {
    let lists = format!(
        r#"<polylist material="grey-sym" count="2">{INPUTS}<vcount>5 3</vcount><p>{} {}</p></polylist>
        <triangles material="unbound" count="1">{INPUTS}<p>{}</p></triangles>
        <lines count="1">{INPUTS}<p>{}</p></lines>
        <polygons material="grey-sym" count="2">{INPUTS}<p>{}</p><ph><p>{}</p><h>{}</h></ph></polygons>
        <tristrips count="1">{INPUTS}<p>{}</p></tristrips>"#,
        corners(&[0, 1, 2, 3, 4]),
        corners(&[4, 2, 3]),
        corners(&[1, 2, 3]),
        corners(&[0, 1]),
        corners(&[2, 3, 4, 0, 1]),
        corners(&[0, 1, 2, 3]),
        corners(&[1, 2, 3]),
        corners(&[0, 1, 2]),
    );
    let scene = load(&with_mesh(&PENTAGON, &PENTAGON_UV, &lists));
    let t = &scene.geometry.triangles;
    // Fans from each polygon's first corner, lists in document order; the
    // holes and the unsupported lists skipped with a warning each.
    let want: [[u32; 3]; 10] = [
        [0, 1, 2],
        [0, 2, 3],
        [0, 3, 4],
        [4, 2, 3],
        [1, 2, 3],
        [2, 3, 4],
        [2, 4, 0],
        [2, 0, 1],
        [0, 1, 2],
        [0, 2, 3],
    ];
    // Vertices are shared within the mesh, so indices are the file's.
    assert_eq!(t.indices, want);
    let uv = |k: u32| Vec2::new(PENTAGON_UV[2 * k as usize], PENTAGON_UV[2 * k as usize + 1]);
    let want_uv: Vec<[Vec2; 3]> = want.iter().map(|c| c.map(uv)).collect();
    assert_eq!(t.texcoords, want_uv);
    let names: Vec<&str> = (0..10)
        .map(|i| scene.materials[t.material[i] as usize].name.as_str())
        .collect();
    assert_eq!(
        names,
        [
            "grey", "grey", "grey", "grey", "default", "grey", "grey", "grey", "grey", "grey"
        ]
    );
    for words in [
        "<lines> is not supported",
        "<tristrips> is not supported",
        "holes",
    ] {
        assert!(warned(&scene, words), "{words}: {:?}", scene.warnings);
    }
    // Every fan keeps its polygon's winding: all faces, and so all smooth
    // normals, point along +z (turned by the node's rotation).
    let face = Mat4::from_rotation_y(30f32.to_radians()).transform_vector3(Vec3::Z);
    for n in &t.normals {
        assert_close(*n, face, "pentagon normal");
    }

    // A polygon of fewer than three corners is skipped with a warning.
    let lists = format!(
        r#"<polylist count="2">{INPUTS}<vcount>2 3</vcount><p>{} {}</p></polylist>"#,
        corners(&[0, 1]),
        corners(&[0, 1, 2]),
    );
    let scene = load(&with_mesh(&PENTAGON, &PENTAGON_UV, &lists));
    assert_eq!(scene.geometry.triangles.indices, [[0, 1, 2]]);
    assert!(
        warned(&scene, "2 corners was skipped"),
        "{:?}",
        scene.warnings
    );
    // An empty <triangles> list needs no <p>.
    let lists = format!(
        r#"<triangles count="0">{INPUTS}</triangles><triangles count="1">{INPUTS}<p>{}</p></triangles>"#,
        corners(&[2, 3, 4]),
    );
    let scene = load(&with_mesh(&PENTAGON, &PENTAGON_UV, &lists));
    assert_eq!(scene.geometry.triangles.indices, [[2, 3, 4]]);
}

#[test]
fn texture_coordinates_are_the_first_sets_and_only_where_every_list_has_them() {
    // A second set (set="1") is neither used nor read: its source need
    // not exist.
    let two_sets = INPUTS.to_string()
        + r##"<input semantic="TEXCOORD" source="#no-such-uv" offset="3" set="1"/>"##;
    let p: Vec<String> = [0, 1, 2]
        .iter()
        .map(|k| format!("{k} 0 {k} {}", 4 - k))
        .collect();
    let lists = format!(
        r#"<triangles count="1">{two_sets}<p>{}</p></triangles>"#,
        p.join(" ")
    );
    let scene = load(&with_mesh(&PENTAGON, &PENTAGON_UV, &lists));
    let uv = |k: usize| Vec2::new(PENTAGON_UV[2 * k], PENTAGON_UV[2 * k + 1]);
    assert_eq!(scene.geometry.triangles.texcoords, [[uv(0), uv(1), uv(2)]]);
    // One list without texture coordinates: the mesh has none.
    let no_uv = r##"<input semantic="VERTEX" source="#tri-vtx" offset="0"/>"##;
    for lists in [
        format!(
            r#"<triangles count="1">{INPUTS}<p>{}</p></triangles><triangles count="1">{no_uv}<p>2 3 4</p></triangles>"#,
            corners(&[0, 1, 2])
        ),
        format!(
            r#"<triangles count="1">{no_uv}<p>2 3 4</p></triangles><triangles count="1">{INPUTS}<p>{}</p></triangles>"#,
            corners(&[0, 1, 2])
        ),
    ] {
        let scene = load(&with_mesh(&PENTAGON, &PENTAGON_UV, &lists));
        assert_eq!(scene.geometry.triangles.len(), 2);
        assert!(scene.geometry.triangles.texcoords.is_empty());
    }
    // A list without them that makes no triangles takes none away.
    let lists = format!(
        r#"<triangles count="1">{INPUTS}<p>{}</p></triangles><triangles count="0">{no_uv}<p></p></triangles>"#,
        corners(&[0, 1, 2])
    );
    let scene = load(&with_mesh(&PENTAGON, &PENTAGON_UV, &lists));
    assert_eq!(scene.geometry.triangles.texcoords, [[uv(0), uv(1), uv(2)]]);
}

#[test]
fn sources_without_an_accessor_are_packed_tuples() {
    // Positions with no <technique_common>: tightly packed x y z.
    let text = edit(POSITION_ACCESSOR, "");
    let scene = load(&text);
    assert_triangle_placed(&scene, Mat4::from_rotation_y(30f32.to_radians()), "packed");
}
