//! `caustics bench SCENE --load`: the time to read a scene file, turn it into a `Scene` (parse and
//! flatten: node transforms, primitives, materials, lights), and build its BVHs (the GPU
//! renderer's, built on the CPU by `obvhs`, and the CPU reference's), with the process's peak
//! memory after each step. CPU only. A large glTF file to try: `tools/make_big_glb.py`.

use anyhow::Result;
use std::time::Instant;

/// The process's peak resident memory (MiB), where /proc has it.
fn peak_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

fn mib(m: Option<f64>) -> String {
    m.map_or("n/a".into(), |m| format!("{m:.0} MiB"))
}

pub fn run(a: &super::BenchArgs) -> Result<()> {
    let Some(path) = a.scene.as_deref() else {
        return Err(caustics::Error::input("<command line>", "--load", "times loading a scene file: name one").into());
    };
    let t = Instant::now();
    let bytes = std::fs::read(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let read = t.elapsed().as_secs_f64();
    drop(bytes);
    let t = Instant::now();
    let scene = a.environment.apply(crate::load_scene(Some(path), a.camera.as_deref())?)?;
    let load = t.elapsed().as_secs_f64();
    let after_load = peak_mib();
    let triangles: usize = scene
        .objects
        .iter()
        .map(|o| match &o.shape {
            caustics::scene::Shape::Mesh(m) => m.indices.len(),
            _ => 0,
        })
        .sum();
    let t = Instant::now();
    let (nodes, tris) = caustics::build_scene_bvh(&scene);
    let gpu_bvh = t.elapsed().as_secs_f64();
    let after_gpu_bvh = peak_mib();
    let t = Instant::now();
    let accel = caustics_reference::reference::geometry::Accel::new(&scene);
    let cpu_bvh = t.elapsed().as_secs_f64();
    drop(accel);
    println!("{}: {triangles} triangles in {} objects", path.display(), scene.objects.len());
    println!("  read the file            {:8.3} s", read);
    println!("  parse and flatten        {:8.3} s   peak memory {}", load, mib(after_load));
    println!(
        "  GPU renderer's BVH       {:8.3} s   ({nodes} nodes, {tris} triangles; peak memory {})",
        gpu_bvh,
        mib(after_gpu_bvh)
    );
    println!("  CPU reference's BVH      {:8.3} s   peak memory {}", cpu_bvh, mib(peak_mib()));
    println!("  load + GPU BVH           {:8.3} s", load + gpu_bvh);
    Ok(())
}
