//! The CPU reference's triangle BVH on one core: build time and incoherent closest-hit /
//! occlusion throughput, the former hand-written binned-SAH builder against the `obvhs` build
//! (binary and 4-wide layouts). Writes the mesh's triangles, the rays and our results to a
//! binary file so that `embree_bench.py` shoots the same rays with Embree.
//!
//! ```text
//! taskset -c 0 cargo run --release -p caustics-reference --example bvh_bench -- \
//!     [mesh.obj(.gz)] [rays] [out.bin]
//! taskset -c 0 python3 crates/caustics-reference/examples/embree_bench.py [out.bin]
//! ```
//!
//! Rays: origins uniform on the sphere of twice the bounding box's circumradius, each aimed at
//! a uniform point of the bounding box (incoherent, most of them hit). Closest hit has
//! tmax = ∞; occlusion rays have tmax = the distance to that point. Seeded: the same rays on
//! every run.
//!
//! File layout (little endian): b"CBVH", u32 triangles, u32 rays, then triangles as 9 f32,
//! rays as 7 f32 (origin, unit direction, occlusion tmax), our closest t per ray (f32, ∞ for a
//! miss), our occlusion per ray (u8), then a UTF-8 JSON line of our timings.

use caustics_reference::reference::bvh::{Bvh, Layout};
use glam::Vec3;
use std::hint::black_box;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// This thread's time on a CPU (seconds), from the kernel's scheduler statistics: on a shared
/// machine, wall time also counts the time other processes hold our core; this does not.
fn cpu_now() -> f64 {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").expect("schedstat");
    s.split_whitespace().next().unwrap().parse::<f64>().unwrap() * 1e-9
}

/// (wall, on-CPU) seconds of `f`.
fn timed(f: impl FnOnce()) -> (f64, f64) {
    let (w, c) = (Instant::now(), cpu_now());
    f();
    (w.elapsed().as_secs_f64(), cpu_now() - c)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

struct Ray {
    o: Vec3,
    d: Vec3,
    tmax: f32,
}

fn rays(tris: &[[Vec3; 3]], n: usize) -> Vec<Ray> {
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for t in tris {
        for p in t {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
    }
    let c = (lo + hi) * 0.5;
    let r = (hi - lo).length();
    let mut s = 0x5eed_u64;
    let mut u = || {
        s = s.wrapping_add(0x9e37_79b9_7f4a_7c15);
        (mix64(s) >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            let z = 2.0 * u() - 1.0;
            let phi = std::f32::consts::TAU * u();
            let rho = (1.0 - z * z).max(0.0).sqrt();
            let o = c + Vec3::new(rho * phi.cos(), rho * phi.sin(), z) * r;
            let target = lo + (hi - lo) * Vec3::new(u(), u(), u());
            let to = target - o;
            Ray { o, d: to.normalize(), tmax: to.length() }
        })
        .collect()
}

/// Medians of (wall, on-CPU) seconds of `reps` runs of `f`.
fn medians(reps: usize, mut f: impl FnMut()) -> (f64, f64) {
    let (w, c): (Vec<f64>, Vec<f64>) = (0..reps).map(|_| timed(&mut f)).unzip();
    (median(w), median(c))
}

/// Seconds per pass over all rays (medians of `reps`), closest t per ray.
fn time_closest(bvh: &Bvh, rays: &[Ray], reps: usize) -> ((f64, f64), Vec<f32>) {
    let mut out = vec![f32::INFINITY; rays.len()];
    let s = medians(reps, || {
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = black_box(bvh.intersect(r.o, r.d, f32::INFINITY)).map_or(f32::INFINITY, |h| h.t);
        }
    });
    (s, out)
}

fn time_occluded(bvh: &Bvh, rays: &[Ray], reps: usize) -> ((f64, f64), Vec<u8>) {
    let mut out = vec![0u8; rays.len()];
    let s = medians(reps, || {
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = black_box(bvh.occluded(r.o, r.d, r.tmax)) as u8;
        }
    });
    (s, out)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mesh = PathBuf::from(args.first().map_or("/work/shared/assets/meshes/dragon_100k.obj.gz", |s| s.as_str()));
    let n: usize = args.get(1).map_or(1_000_000, |s| s.parse().expect("ray count"));
    let out = PathBuf::from(args.get(2).map_or("/tmp/bvh_bench.bin", |s| s.as_str()));
    let reps: usize = std::env::var("BENCH_REPS").ok().map_or(5, |s| s.parse().unwrap());

    let m = caustics::scene::mesh::load_obj(&mesh).expect("mesh");
    let tris: Vec<[Vec3; 3]> = m.indices.iter().map(|t| t.map(|i| m.positions[i as usize])).collect();
    println!("mesh {} : {} triangles; {} rays; {} reps (medians)", mesh.display(), tris.len(), n, reps);
    let rays = rays(&tris, n);

    type Builder = fn(Vec<[Vec3; 3]>) -> Bvh;
    let only = std::env::var("BENCH_ONLY").unwrap_or_default();
    let builders: [(&str, Builder); 4] = [
        ("old binned SAH (binary)", Bvh::build_binned_sah),
        ("obvhs (binary)", |t| Bvh::build_with(t, Layout::Binary)),
        ("obvhs (4-wide)", |t| Bvh::build_with(t, Layout::Wide4)),
        ("obvhs (8-wide)", |t| Bvh::build_with(t, Layout::Wide8)),
    ];
    let mut json = Vec::new();
    let mut ours = None;
    for (name, build) in builders.into_iter().filter(|(name, _)| name.contains(&only)) {
        let build_s = medians(reps, || {
            let tris = tris.clone();
            black_box(build(tris));
        });
        let bvh = build(tris.clone());
        let (cs, closest) = time_closest(&bvh, &rays, reps);
        let (os, occluded) = time_occluded(&bvh, &rays, reps);
        let hits = closest.iter().filter(|t| t.is_finite()).count();
        let occ = occluded.iter().filter(|&&o| o != 0).count();
        let mr = |s: f64| n as f64 / s * 1e-6;
        println!(
            "{name:24} build {:6.1} ms ({:6.1} on-CPU)  nodes {:6} depth {:2}  closest {:5.3} Mrays/s ({:5.3} on-CPU)  occluded {:5.3} ({:5.3} on-CPU)  [hits {hits}, occluded {occ}]",
            build_s.0 * 1e3,
            build_s.1 * 1e3,
            bvh.node_count(),
            bvh.wide_depth(),
            mr(cs.0),
            mr(cs.1),
            mr(os.0),
            mr(os.1),
        );
        json.push(format!(
            "\"{name}\": {{\"build_ms\": {:.3}, \"build_cpu_ms\": {:.3}, \"closest_mrays\": {:.4}, \"closest_cpu_mrays\": {:.4}, \"occluded_mrays\": {:.4}, \"occluded_cpu_mrays\": {:.4}}}",
            build_s.0 * 1e3,
            build_s.1 * 1e3,
            mr(cs.0),
            mr(cs.1),
            mr(os.0),
            mr(os.1)
        ));
        if let Some((c0, o0)) = &ours {
            let same_t = closest.iter().zip(c0).filter(|(a, b): &(&f32, &f32)| a.to_bits() == b.to_bits()).count();
            let same_o = occluded.iter().zip(o0).filter(|(a, b)| a == b).count();
            println!("{:26} same closest t as the old BVH: {same_t}/{n}; same occlusion: {same_o}/{n}", "");
        } else {
            ours = Some((closest.clone(), occluded.clone()));
        }
        if name == "obvhs (4-wide)" {
            ours = Some((closest, occluded));
        }
    }
    let (closest, occluded) = ours.unwrap();
    let mut f = std::io::BufWriter::new(std::fs::File::create(&out).expect("output file"));
    f.write_all(b"CBVH").unwrap();
    f.write_all(&(tris.len() as u32).to_le_bytes()).unwrap();
    f.write_all(&(n as u32).to_le_bytes()).unwrap();
    for t in &tris {
        for p in t {
            f.write_all(bytemuck::cast_slice(&p.to_array())).unwrap();
        }
    }
    for r in &rays {
        f.write_all(bytemuck::cast_slice(&[r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmax])).unwrap();
    }
    f.write_all(bytemuck::cast_slice(&closest)).unwrap();
    f.write_all(&occluded).unwrap();
    writeln!(f, "{{{}}}", json.join(", ")).unwrap();
    println!("wrote {}", out.display());
}
