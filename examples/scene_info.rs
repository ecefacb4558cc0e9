//! Prints what the loader made of a scene: counts, materials, lights, camera.
fn main() {
    for arg in std::env::args().skip(1) {
        match wavepath::scene::collada::load_file(std::path::Path::new(&arg)) {
            Ok(s) => {
                println!(
                    "{arg}: {} triangles, {} spheres, {} lights",
                    s.geometry.triangles.len(),
                    s.geometry.spheres.len(),
                    s.lights.len()
                );
                for m in &s.materials {
                    println!("  material {:?}: {:?}", m.name, m.material);
                }
                for l in &s.lights {
                    println!("  light {:?}", l);
                }
                println!("  camera {:?}", s.camera);
                for w in &s.warnings {
                    println!("  warning: {w}");
                }
            }
            Err(e) => println!("error: {e}"),
        }
    }
}
