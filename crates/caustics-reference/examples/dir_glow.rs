//! Where a directional light's caustic flux lands on the floor, by path type, CPU reference
//! against GPU: `cargo run --release --example dir_glow -- SCENE GRID CPU_PHOTONS`
//! (one directional light, one glass sphere on the plane y = 0). The CPU reference's deposits are
//! split by specular interactions (1: reflected off the outside, 2: refracted in and out, 3: one
//! internal reflection, 4+: more); the GPU's caustic map is read per set of Fresnel-branch passes.
//! Prints the flux (W, mean of the channels) per ring of floor distance from the ball's foot
//! (`CAUSTIC_MAP=M`: caustic map size, default 512; `MAX_DEPTH=D`, default 16). Measured the
//! photon grid's coverage of the ball as the cause of the missing glow of a directional light
//! over a large floor (the light's orthographic face spans the whole scene).
use caustics::lightspace::LightView;
use glam::Vec3;

const RINGS: [f32; 7] = [0.25, 0.5, 1.0, 2.0, 4.0, 8.0, f32::INFINITY];

fn ring(p: Vec3, foot: Vec3) -> usize {
    let r = Vec3::new(p.x - foot.x, 0.0, p.z - foot.z).length();
    RINGS.iter().position(|&b| r < b).unwrap()
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let scene = caustics::Scene::load(std::path::Path::new(&a[1])).unwrap();
    let grid: u32 = a[2].parse().unwrap();
    let photons: u64 = a[3].parse().unwrap();
    let m: u32 = std::env::var("CAUSTIC_MAP").map_or(512, |v| v.parse().unwrap());
    let foot = scene
        .objects
        .iter()
        .find_map(|o| match o.shape {
            caustics::scene::Shape::Sphere { center, .. } => Some(Vec3::new(center.x, 0.0, center.z)),
            _ => None,
        })
        .unwrap();
    let view = LightView::new(&scene, &scene.lights[0]);
    let rs = caustics_reference::reference::ReferenceSettings { photons_per_light: photons, ..Default::default() };
    let deps = caustics_reference::reference::caustic_deposits(&scene, &rs, 0).unwrap();
    // [class][ring], class 0..4 = bounces 1, 2, 3, 4+; ring 7 = outside the light's map.
    let mut cpu = [[0.0f64; 8]; 4];
    for d in &deps {
        let c = (d.specular_bounces.clamp(1, 4) - 1) as usize;
        let r = if view.project(d.position, m).is_some() { ring(d.position, foot) } else { 7 };
        cpu[c][r] += d.flux.element_sum() as f64 / 3.0;
    }
    let hdr = format!("{:>22}", "ring (m) <");
    let mut h = hdr.clone();
    for b in RINGS {
        h.push_str(&format!("{b:>9.2}"));
    }
    h.push_str(&format!("{:>9}{:>9}", "outside", "sum"));
    println!("{h}");
    let row = |name: &str, v: &[f64; 8]| {
        let mut s = format!("{name:>22}");
        for x in v {
            s.push_str(&format!("{x:9.5}"));
        }
        s.push_str(&format!("{:9.5}", v.iter().sum::<f64>()));
        println!("{s}");
    };
    let names = ["CPU R (outside refl)", "CPU TT", "CPU TRT", "CPU TR..RT (2+)"];
    let mut all = [0.0; 8];
    for (c, n) in names.iter().enumerate() {
        row(n, &cpu[c]);
        for r in 0..8 {
            all[r] += cpu[c][r];
        }
    }
    row("CPU all", &all);

    let ctx = caustics::gpu::GpuContext::new(None).unwrap();
    let base = caustics::render::RenderSettings {
        photons: caustics::settings::PhotonSettings {
            count: grid,
            caustic_map_size: m,
            max_depth: std::env::var("MAX_DEPTH").map_or(16, |v| v.parse().unwrap()),
            ..Default::default()
        },
        shading: caustics::settings::ShadingSettings { shadow_map_size: 1024, ..Default::default() },
        ..Default::default()
    };
    let variants: [(&str, bool, bool, bool); 4] = [
        ("GPU T only", false, false, false),
        ("GPU T+R", true, false, false),
        ("GPU T+R+internal", true, true, false),
        ("GPU all (+residual)", true, true, true),
    ];
    let mut prev = [0.0f64; 8];
    for (name, refl, internal, residual) in variants {
        let s = caustics::render::RenderSettings {
            photons: caustics::settings::PhotonSettings {
                reflection: refl,
                internal_reflection: internal,
                residual,
                ..base.photons
            },
            ..base.clone()
        };
        let mut r = caustics::renderer::Renderer::with_context(ctx.clone(), scene.clone(), s).unwrap();
        let g = r.render_once().unwrap();
        let map = &g.caustic_maps[0][0];
        let mut v = [0.0f64; 8];
        for j in 0..m {
            for i in 0..m {
                let px = map.pixels[(j * m + i) as usize];
                let e = (px[0] + px[1] + px[2]) as f64 / 3.0;
                if e == 0.0 {
                    continue;
                }
                let (o, d) = view.texel_ray(0, i as f32 + 0.5, j as f32 + 0.5, m);
                if d.y >= 0.0 {
                    continue;
                }
                let p = o + d * (-o.y / d.y);
                let area = view.texel_area(0, p, Vec3::Y, m) as f64;
                v[ring(p, foot)] += e * area;
            }
        }
        row(name, &v);
        let mut dv = [0.0; 8];
        for k in 0..8 {
            dv[k] = v[k] - prev[k];
        }
        row("  added by this pass", &dv);
        prev = v;
        let f = &g.flux[0];
        println!(
            "  flux: emitted {:.5} landed {:.5} no_exit {:.5} tir {:.5} no_receiver {:.5} outside {:.5} untraced {:.5}",
            f.emitted, f.landed, f.lost_no_exit, f.lost_tir, f.lost_no_receiver, f.lost_outside, f.untraced_branches
        );
    }
}
