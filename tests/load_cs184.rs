//! Every CS184 scene loads, and loads the way the reference renderer reads it.

mod common;

use wavepath::scene::collada::load_file;
use wavepath::scene::{Light, Material};

#[test]
fn every_cs184_scene_loads() {
    let Some(dir) = common::cs184_dir() else {
        return;
    };
    let files = common::dae_files(&dir);
    assert!(
        files.len() >= 30,
        "expected the CS184 scene set, found {}",
        files.len()
    );
    for f in files {
        let scene = load_file(&f).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            scene.geometry.primitive_count() > 0,
            "{}: no geometry",
            f.display()
        );
        let t = &scene.geometry.triangles;
        assert_eq!(t.indices.len(), t.material.len());
        assert_eq!(t.positions.len(), t.normals.len());
        assert!(t.texcoords.is_empty() || t.texcoords.len() == t.indices.len());
        for tri in &t.indices {
            assert!(tri.iter().all(|&i| (i as usize) < t.positions.len()));
        }
        for &m in t.material.iter().chain(&scene.geometry.spheres.material) {
            assert!((m as usize) < scene.materials.len());
        }
        assert!(t.positions.iter().all(|p| p.is_finite()));
        assert!(t.normals.iter().all(|n| n.is_finite()));
    }
}

/// Triangle counts of the polygon lists (area lights add two each).
#[test]
fn triangle_and_sphere_counts_match_the_files() {
    let Some(dir) = common::cs184_dir() else {
        return;
    };
    let cases = [
        // Bunny 28576 + five walls 10 + light rectangle 2 (the light mesh is commented out).
        ("sky/CBbunny.dae", 28576 + 10 + 2, 0, 1),
        ("sky/CBspheres_lambertian.dae", 10 + 2, 2, 1),
        ("meshedit/maxplanck.dae", 50801, 0, 1),
        ("keenan/building.dae", 39506, 0, 2),
        ("basic/sphere_diffuse.dae", 0, 1, 0),
        ("basic/floating.dae", 4 + 2, 0, 1),
    ];
    for (rel, tris, spheres, lights) in cases {
        let scene = load_file(&dir.join(rel)).unwrap();
        assert_eq!(scene.geometry.triangles.len(), tris, "{rel} triangles");
        assert_eq!(scene.geometry.spheres.len(), spheres, "{rel} spheres");
        assert_eq!(scene.lights.len(), lights, "{rel} lights");
    }
}

#[test]
fn cornell_box_conventions() {
    let Some(path) = common::cs184_scene("sky/CBspheres_lambertian.dae") else {
        return;
    };
    let scene = load_file(&path).unwrap();

    // Framing: 49.134°×37.849° at 800×600, 30.676°×23.249° at 480×360.
    let (h, v) = scene.camera.view(800, 600).fov_degrees();
    assert!(
        (h - 49.134).abs() < 0.01 && (v - 37.849).abs() < 0.01,
        "{h} {v}"
    );
    let (h, v) = scene.camera.view(480, 360).fov_degrees();
    assert!(
        (h - 30.676).abs() < 0.01 && (v - 23.249).abs() < 0.01,
        "{h} {v}"
    );

    // Z_UP → Y_UP: the light sits under the ceiling, facing down.
    let area = scene.lights.iter().find_map(|l| match l {
        Light::Area {
            center,
            normal,
            dim_x,
            dim_y,
            radiance,
        } => Some((*center, *normal, *dim_x, *dim_y, *radiance)),
        _ => None,
    });
    let (center, normal, dim_x, dim_y, radiance) = area.expect("an area light");
    assert!((center.y - 1.49).abs() < 1e-5, "{center}");
    assert!((normal - glam::Vec3::NEG_Y).length() < 1e-5, "{normal}");
    assert!((dim_x.length() * dim_y.length() - 0.48).abs() < 1e-5);
    assert_eq!(radiance, glam::Vec3::splat(10.0));

    // The camera looks at the box from +z (Blender −y), up is +y.
    let cam = &scene.camera;
    assert!(
        cam.position.z > 3.0 && cam.position.x.abs() < 1e-4,
        "{}",
        cam.position
    );

    let red = scene
        .materials
        .iter()
        .position(|m| m.name == "leftWall")
        .unwrap();
    assert!(matches!(
        scene.materials[red].material,
        Material::Diffuse { .. }
    ));

    // Spheres: radius .3, on the floor.
    let s = &scene.geometry.spheres;
    for i in 0..s.len() {
        assert!((s.radius[i] - 0.3).abs() < 1e-6);
        assert!((s.center[i].y - 0.3).abs() < 1e-5);
    }
}

#[test]
fn material_records_are_typed() {
    let Some(dir) = common::cs184_dir() else {
        return;
    };
    let kinds = |rel: &str| -> Vec<&'static str> {
        let scene = load_file(&dir.join(rel)).unwrap();
        scene
            .materials
            .iter()
            .map(|m| m.material.kind_name())
            .collect()
    };
    assert!(kinds("sky/CBspheres.dae").contains(&"glass"));
    assert!(kinds("sky/CBspheres.dae").contains(&"mirror"));
    assert!(kinds("sky/CBspheres_refract.dae").contains(&"refraction"));
    assert!(kinds("sky/CBbunny_microfacet_cu.dae").contains(&"microfacet"));
    assert!(kinds("sky/CBbunny.dae").contains(&"emission"));
    assert!(
        kinds("basic/sphere7_glass.dae").contains(&"glass"),
        "CMU462 profile"
    );
}

#[test]
fn smooth_normals_are_area_weighted_unit_vectors() {
    let Some(path) = common::cs184_scene("sky/CBbunny.dae") else {
        return;
    };
    let scene = load_file(&path).unwrap();
    let t = &scene.geometry.triangles;
    // Recompute for a few vertices by brute force.
    for v in [0usize, 100, 1000, 5000] {
        let mut n = glam::Vec3::ZERO;
        for tri in 0..t.len() {
            if t.indices[tri].contains(&(v as u32)) {
                n += t.geometric_normal(tri);
            }
        }
        let n = n.normalize();
        assert!(
            (n - t.normals[v]).length() < 1e-4,
            "vertex {v}: {n} vs {}",
            t.normals[v]
        );
    }
}

/// Side of the image (−1 left, +1 right) on which the wall with material `name` lies.
fn screen_side(scene: &wavepath::scene::Scene, name: &str) -> f32 {
    let m = scene.materials.iter().position(|m| m.name == name).unwrap() as u32;
    let t = &scene.geometry.triangles;
    let tri = t.material.iter().position(|&x| x == m).unwrap();
    let centroid = t.vertices(tri).iter().copied().sum::<glam::Vec3>() / 3.0;
    (centroid - scene.camera.target)
        .dot(scene.camera.camera_to_world.x_axis)
        .signum()
}

#[test]
fn every_cornell_box_has_red_left_blue_right_and_light_above() {
    let Some(dir) = common::cs184_dir() else {
        return;
    };
    let boxes: Vec<_> = common::dae_files(&dir.join("sky"))
        .into_iter()
        .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with("CB"))
        .collect();
    assert!(boxes.len() >= 6);
    for path in boxes {
        let scene = load_file(&path).unwrap();
        assert_eq!(screen_side(&scene, "leftWall"), -1.0, "{}", path.display());
        assert_eq!(screen_side(&scene, "rightWall"), 1.0, "{}", path.display());
        // Up on screen is world up.
        assert!(
            scene.camera.camera_to_world.y_axis.y > 0.99,
            "{}",
            path.display()
        );
    }
}
