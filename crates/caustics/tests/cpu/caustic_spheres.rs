//! Caustic spheres (Tandianus et al. 2010): layout, equation (1), the precomputation against
//! its own table, rotation and blending against direct tracing, linearity in the lights, the
//! cache, and occlusion. CPU only (the precomputation runs through the reference's tracer).

use caustics::Scene;
use caustics::caustic_spheres::cache::{self, Storage};
use caustics::caustic_spheres::{Blend, CausticSpheres, DirectionLayout, SphereGeometry, SphereSettings, radii};
use caustics_reference::reference::Progress;
use caustics_reference::reference::spheres::{self, Origin};
use glam::Vec3;
use std::path::Path;

const R: f32 = 0.5;
const C: Vec3 = Vec3::new(0.0, 1.0, 0.0);

fn small() -> SphereSettings {
    SphereSettings { directions: 5, spheres: 8, width: 32, height: 32, photons: 1 << 16, max_depth: 16 }
}

/// A glass ball of radius 0.5 at (0, 1, 0) over a floor, lit by the given directional lights.
fn ball_scene(lights: &str, extra: &str) -> Scene {
    let json = format!(
        r#"{{ "schema_version": 1, "name": "spheres_test",
        "camera": {{ "position": [0, 3.2, 2.4], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_y_deg": 40, "width": 48, "height": 48 }},
        "lights": [ {lights} ],
        "materials": {{ "floor": {{ "type": "diffuse", "albedo": 0.8 }}, "glass": {{ "type": "dielectric", "ior": 1.5 }} }},
        "objects": [
          {{ "type": "sphere", "center": [0, 1, 0], "radius": 0.5, "material": "glass" }},
          {{ "type": "rectangle", "center": [0, 0, 0], "normal": [0, 1, 0], "size": [8, 8], "material": "floor" }}
          {extra}
        ] }}"#
    );
    Scene::from_json(&json, "spheres_test.json", Path::new(".")).unwrap()
}

fn directional(d: Vec3, e: [f32; 3]) -> String {
    format!(
        r#"{{ "type": "directional", "direction": [{}, {}, {}], "irradiance": [{}, {}, {}] }}"#,
        d.x, d.y, d.z, e[0], e[1], e[2]
    )
}

#[test]
fn equation_1_radii() {
    let r = radii(1.0, 5.0, 5);
    let want = [1.0, 1.25, 2.0, 3.25, 5.0];
    for (a, b) in r.iter().zip(want) {
        assert!((a - b).abs() < 1e-6, "{r:?}");
    }
    let scene = ball_scene(&directional(Vec3::NEG_Y, [1.0; 3]), "");
    let g = SphereGeometry::for_shape(&scene.objects[0].shape, &small());
    let s = g.radii.len();
    assert_eq!(s, 8);
    // r_min just beyond the ball's surface (0.1 % and the spawn margin, 1e-4 (1 + |c| + R)),
    // r_max = 4 d with d = the box's largest extent.
    let want = R * (1.0 + caustics::caustic_spheres::R_MIN_GAP) + 1e-4 * (1.0 + C.y + R);
    assert!((g.radii[0] - want).abs() < 1e-6, "r_min {} (want {want})", g.radii[0]);
    // A mesh: the nearest point of its triangles, not of its vertices (a cube of side 2 about
    // the origin: 1 to its faces' centres, √3 to its corners).
    let cube = caustics::scene::Shape::Mesh(std::sync::Arc::new(caustics::scene::TriMesh {
        positions: (0..8).map(|i| Vec3::new([-1., 1.][i & 1], [-1., 1.][(i >> 1) & 1], [-1., 1.][i >> 2])).collect(),
        normals: vec![],
        indices: vec![
            [0, 1, 3],
            [0, 3, 2],
            [4, 6, 7],
            [4, 7, 5],
            [0, 4, 5],
            [0, 5, 1],
            [2, 3, 7],
            [2, 7, 6],
            [0, 2, 6],
            [0, 6, 4],
            [1, 5, 7],
            [1, 7, 3],
        ],
    }));
    let near = caustics::caustic_spheres::nearest_surface(&cube, Vec3::ZERO);
    assert!((near - 1.0).abs() < 1e-6, "cube: {near}");
    let near = caustics::caustic_spheres::nearest_surface(&cube, Vec3::new(0.5, 0.2, 0.0));
    assert!((near - 0.5).abs() < 1e-6, "cube, off centre: {near}");
    assert!((g.radii[s - 1] - 4.0 * 2.0 * R).abs() < 1e-5);
    assert!((g.center - C).length() < 1e-6);
    for (i, r) in g.radii.iter().enumerate() {
        let t = (r - g.radii[0]) / (g.radii[s - 1] - g.radii[0]);
        assert!((t - (i as f32 / (s - 1) as f32).powi(2)).abs() < 1e-5, "sphere {i}: {r}");
    }
}

#[test]
fn layout_weights_are_a_partition_exact_at_vertices() {
    for n in [3, 5, 7, 9] {
        let layout = DirectionLayout::new(n);
        // The vertices of the octahedron with its edges cut in k = (N − 1)/2: 4k² + 2 unique
        // directions (the folded border pairs up, the four corners are one).
        assert_eq!(layout.dirs.len() as u32, (n - 1) * (n - 1) + 2, "n = {n}");
        for (k, d) in layout.dirs.iter().enumerate() {
            for blend in [Blend::Triangle, Blend::Quad] {
                let w = layout.weights(*d, blend);
                let on_k: f32 = w.iter().filter(|(i, _)| *i as usize == k).map(|(_, w)| w).sum();
                assert!((on_k - 1.0).abs() < 1e-5, "n = {n}, direction {k} ({d}): {w:?}");
            }
        }
        for i in 0..500 {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / 500.0;
            let phi = i as f32 * 2.399_963;
            let d = Vec3::new((1.0 - z * z).sqrt() * phi.cos(), z, (1.0 - z * z).sqrt() * phi.sin());
            for blend in [Blend::Triangle, Blend::Quad] {
                let w = layout.weights(d, blend);
                let sum: f32 = w.iter().map(|(_, w)| w).sum();
                assert!((sum - 1.0).abs() < 1e-5 && w.iter().all(|(_, w)| *w >= -1e-6), "{d}: {w:?}");
                // The blended directions lie around d. With the octahedron's edges cut in
                // k = (N − 1)/2 steps of 90°/k: a triangle's vertices within 1.5 steps (its
                // longest edge is 60° where an octant's corner cell is split); the quad's within
                // 2.5 (a corner cell of the map reaches from the pole to the equator, and a point
                // inside it can lie beyond the pole from its far corner: the reason
                // the triangle is the default).
                let step = std::f32::consts::FRAC_PI_2 / ((n - 1) / 2) as f32;
                let reach = if blend == Blend::Triangle { 1.5 * step } else { 2.5 * step };
                for (k, wk) in w {
                    if wk > 1e-4 {
                        assert!(
                            layout.dirs[k as usize].dot(d) >= reach.min(std::f32::consts::PI).cos() - 1e-5,
                            "n {n} {d} {blend:?}: {w:?} {:?}",
                            w.map(|(k, _)| layout.dirs[k as usize].dot(d))
                        );
                    }
                }
            }
        }
    }
}

fn precompute(scene: &Scene, settings: &SphereSettings, dirs: Option<Vec<Vec3>>) -> CausticSpheres {
    spheres::precompute(scene, 0, settings, dirs, &Progress::new()).unwrap()
}

/// The caustic on a disc receiver perpendicular to `l`, `dist` beyond the ball, sampled on a
/// polar grid: (per sample, area-weighted total).
fn receiver_disc(f: impl Fn(Vec3, Vec3) -> f32, l: Vec3, dist: f32) -> (Vec<f32>, f32) {
    let (a, b) = caustics::caustic_spheres::basis(l);
    let mut v = Vec::new();
    let mut total = 0.0;
    for ir in 0..24 {
        let rad = (ir as f32 + 0.5) / 24.0 * 1.2;
        for ia in 0..16 {
            let ang = ia as f32 / 16.0 * std::f32::consts::TAU;
            let p = C + l * dist + (a * ang.cos() + b * ang.sin()) * rad;
            let e = f(p, -l);
            v.push(e);
            total += e * rad;
        }
    }
    (v, total)
}

#[test]
fn precomputed_direction_reproduces_its_table() {
    let scene = ball_scene(&directional(Vec3::NEG_Y, [1.0; 3]), "");
    let s = small();
    let sp = precompute(&scene, &s, None);
    let layout = DirectionLayout::new(s.directions);
    assert_eq!(sp.layout_dirs, layout.dirs);
    // Deterministic: the same bits again.
    assert!(precompute(&scene, &s, None) == sp);
    for k in [0, layout.dirs.len() / 2, layout.dirs.len() - 1] {
        let l = layout.dirs[k];
        // At a stored direction the blend is that direction alone, unrotated.
        for blend in [Blend::Triangle, Blend::Quad] {
            let (blended, _) = receiver_disc(|p, n| sp.irradiance(p, n, l, &layout, blend).x, l, 2.0);
            let (own, _) = receiver_disc(|p, n| sp.irradiance_of(k, p, n, l).x, l, 2.0);
            for (a, b) in blended.iter().zip(&own) {
                assert!((a - b).abs() <= 1e-5 * b.abs().max(1e-3), "{a} vs {b}");
            }
        }
        // Sampled at a cell's centre on a sphere, the table gives the stored cell.
        let g = &sp.geometry;
        let (ba, bb) = caustics::caustic_spheres::basis(l);
        for (si, row, col) in [(2usize, 0u32, 0u32), (3, 1, 7), (4, 3, 12), (5, 2, 7), (7, 30, 31)] {
            let t = (row as f32 + 0.5) / g.height as f32;
            let th = std::f32::consts::PI * t * t;
            let ph = (col as f32 + 0.5) / g.width as f32 * std::f32::consts::TAU;
            let u = l * th.cos() + (ba * ph.cos() + bb * ph.sin()) * th.sin();
            let (c, _) = sp.sample(k, g.center + u * g.radii[si]);
            let idx = ((k * g.radii.len() + si) * g.height as usize + row as usize) * g.width as usize + col as usize;
            let want = sp.data[idx][0];
            // Exact but for the rounding of the cell centre's angles into the table's
            // coordinates: a bilinear weight of ~1e-6 on a neighbour, relative to the sphere's
            // largest value.
            let sphere = &sp.data[idx - (row * g.width + col) as usize..][..g.cells()];
            let top = sphere.iter().map(|c| c[0]).fold(0.0, f32::max);
            assert!(
                (c.x - want).abs() <= 1e-4 * top,
                "k {k} sphere {si} cell ({row}, {col}): {} vs {want} (max {top})",
                c.x
            );
        }
    }
}

#[test]
fn blended_glass_sphere_equals_traced_at_any_direction() {
    let scene = ball_scene(&directional(Vec3::NEG_Y, [1.0; 3]), "");
    let s = small();
    let sp = precompute(&scene, &s, None);
    let layout = DirectionLayout::new(s.directions);
    // Directions between the stored ones (in the middle of grid cells and triangles).
    for l in [Vec3::new(0.3, -1.0, 0.2), Vec3::new(-0.7, -0.4, 0.5), Vec3::new(0.2, 0.3, -0.9)] {
        let l = l.normalize();
        // Two independent traces of l (other photon seeds): the noise floor.
        let direct = precompute(&scene, &s, Some(vec![l, l]));
        for dist in [1.2, 2.0, 3.0] {
            let (b, tb) = receiver_disc(|p, n| sp.irradiance(p, n, l, &layout, Blend::Triangle).x, l, dist);
            let (d, td) = receiver_disc(|p, n| direct.irradiance_of(0, p, n, l).x, l, dist);
            let (d2, _) = receiver_disc(|p, n| direct.irradiance_of(1, p, n, l).x, l, dist);
            let rel_l1 =
                |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<f32>() / b.iter().sum::<f32>();
            let (l1, noise) = (rel_l1(&b, &d), rel_l1(&d2, &d));
            eprintln!("{l} at {dist}: total {tb} vs {td}, relative L1 {l1}, between two traces {noise}");
            // The ball is symmetric: the blend of rotated patterns is the pattern. They differ
            // by photon noise (each stored direction is its own trace) and the table's
            // interpolation of rotated sample points.
            assert!((tb / td - 1.0).abs() < 0.03, "{l} at {dist}: total {tb} vs {td}");
            assert!(l1 < 1.5 * noise, "{l} at {dist}: relative L1 {l1}, between two traces {noise}");
        }
    }
}

#[test]
fn two_lights_add() {
    let a = (Vec3::new(0.3, -1.0, 0.1).normalize(), [3.0, 1.0, 0.5]);
    let b = (Vec3::new(-0.4, -1.0, -0.3).normalize(), [0.5, 2.0, 4.0]);
    let s = small();
    let both = ball_scene(&format!("{}, {}", directional(a.0, a.1), directional(b.0, b.1)), "");
    let sp = precompute(&both, &s, None);
    let layout = DirectionLayout::new(s.directions);
    let render = |lights: &str| {
        let scene = ball_scene(lights, "");
        spheres::render_caustic(&scene, &[(0, &sp)], &layout, Blend::Triangle, 1)
    };
    let ab = render(&format!("{}, {}", directional(a.0, a.1), directional(b.0, b.1)));
    let ia = render(&directional(a.0, a.1));
    let ib = render(&directional(b.0, b.1));
    let mut lit = 0;
    for ((x, y), z) in ab.pixels.iter().zip(&ia.pixels).zip(&ib.pixels) {
        for c in 0..3 {
            assert!((x[c] - (y[c] + z[c])).abs() <= 1e-5 * x[c].abs().max(1e-6), "{x:?} vs {y:?} + {z:?}");
        }
        lit += (x[0] > 0.0) as u32;
    }
    assert!(lit > 20, "the caustics reach the floor ({lit} pixels)");
}

#[test]
fn closed_box_around_the_object_gives_no_caustic() {
    let light = directional(Vec3::new(0.2, -1.0, 0.1).normalize(), [1.0; 3]);
    let s = small();
    let open = ball_scene(&light, "");
    let sp = precompute(&open, &s, None);
    let layout = DirectionLayout::new(s.directions);
    let free = spheres::render_caustic(&open, &[(0, &sp)], &layout, Blend::Triangle, 1);
    assert!(free.pixels.iter().any(|p| p[0] > 0.0));
    // Six diffuse walls around the ball (half-size 0.7, centre (0, 1, 0)).
    let mut walls = String::new();
    for (n, u) in [([1, 0, 0], [0, 1, 0]), ([0, 1, 0], [0, 0, 1]), ([0, 0, 1], [1, 0, 0])] {
        for sgn in [-1.0f32, 1.0] {
            let c = Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32) * 0.7 * sgn + C;
            walls += &format!(
                r#", {{ "type": "rectangle", "center": [{}, {}, {}], "normal": [{}, {}, {}], "u_axis": [{}, {}, {}], "size": [1.4, 1.4], "material": "floor" }}"#,
                c.x,
                c.y,
                c.z,
                n[0] as f32 * sgn,
                n[1] as f32 * sgn,
                n[2] as f32 * sgn,
                u[0],
                u[1],
                u[2]
            );
        }
    }
    let boxed = ball_scene(&light, &walls);
    let img = spheres::render_caustic(&boxed, &[(0, &sp)], &layout, Blend::Triangle, 1);
    // The camera sees the box's outside and the floor: no caustic light anywhere.
    assert!(img.pixels.iter().all(|p| p[0] == 0.0 && p[1] == 0.0 && p[2] == 0.0));
}

#[test]
fn cache_round_trip_and_rebuild() {
    let scene = ball_scene(&directional(Vec3::NEG_Y, [1.0; 3]), "");
    let s = SphereSettings { photons: 1 << 12, ..small() };
    let dir = std::env::temp_dir().join(format!("caustics-spheres-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let p = Progress::new();
    let (sp, origin) = spheres::load_or_precompute(&scene, 0, &s, Storage::F32, &dir, &p).unwrap();
    assert!(matches!(origin, Origin::Built(_)));
    let (again, origin) = spheres::load_or_precompute(&scene, 0, &s, Storage::F32, &dir, &p).unwrap();
    assert_eq!(origin, Origin::Cache);
    assert!(again == sp);
    let key = cache::key(&scene, &scene.objects[0], &s);
    let path = cache::path(&dir, key, Storage::F32);
    // Other settings: another key, another file; a file for other settings under this
    // key's name is refused.
    let other = SphereSettings { spheres: 6, ..s };
    let other_key = cache::key(&scene, &scene.objects[0], &other);
    assert_ne!(other_key, key);
    let (osp, _) = spheres::load_or_precompute(&scene, 0, &other, Storage::F32, &dir, &p).unwrap();
    std::fs::write(&path, cache::encode(&osp, key, Storage::F32)).unwrap();
    let (_, origin) = spheres::load_or_precompute(&scene, 0, &s, Storage::F32, &dir, &p).unwrap();
    assert!(matches!(&origin, Origin::Built(r) if r.contains("other settings")), "{origin:?}");
    // Another material: another key.
    let mut ior = scene.clone();
    ior.materials[ior.objects[0].material] = caustics::scene::Material::clear_dielectric(1.33, 1.0);
    assert_ne!(cache::key(&ior, &ior.objects[0], &s), key);
    // Truncated, or a byte changed: rebuilt, and the rebuilt table is the original.
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let (t, origin) = spheres::load_or_precompute(&scene, 0, &s, Storage::F32, &dir, &p).unwrap();
    assert!(matches!(origin, Origin::Built(_)));
    assert!(t == sp);
    let mut bad = std::fs::read(&path).unwrap();
    let mid = bad.len() / 2;
    bad[mid] ^= 0x40;
    std::fs::write(&path, &bad).unwrap();
    let (_, origin) = spheres::load_or_precompute(&scene, 0, &s, Storage::F32, &dir, &p).unwrap();
    assert!(matches!(&origin, Origin::Built(r) if r.contains("checksum")), "{origin:?}");
    // Half floats: half the bytes, values within half precision.
    let (h, _) = spheres::load_or_precompute(&scene, 0, &s, Storage::F16, &dir, &p).unwrap();
    let f32_len = std::fs::metadata(&path).unwrap().len();
    let f16_len = std::fs::metadata(cache::path(&dir, key, Storage::F16)).unwrap().len();
    assert!(f16_len * 2 < f32_len + 400, "{f16_len} vs {f32_len}");
    for (a, b) in h.data.iter().zip(&sp.data) {
        for (x, y) in a.iter().zip(b) {
            assert!((x - y).abs() <= 1e-3 * y.abs() + 1e-6, "{x} vs {y}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
