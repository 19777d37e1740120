//! Writes the example density grid the repository ships, `scenes/volumes/smoke_puff.vol`
//! (`caustics::scene::density`: Mitsuba's `.vol`, float32, one channel): a smoke puff of
//! three overlapping Gaussian lobes over a thin haze, densest low in the box and thinning
//! upward, 48 × 40 × 48 voxels. Deterministic (no random numbers): the same file every run.
//!
//! `cargo run --release -p caustics-reference --example density_grid [OUT.vol]`

use caustics::scene::DensityGrid;
use glam::Vec3;

fn main() {
    let out = std::env::args().nth(1).unwrap_or_else(|| "scenes/volumes/smoke_puff.vol".into());
    let dims = [48u32, 40, 48];
    // Lobes in box coordinates (0..1 per axis): centre, radius (1/e² of the Gaussian), peak.
    let lobes = [
        // For scenes/smoke_puff.json's box: beside and below the ball, inside the spot's beam.
        (Vec3::new(0.575, 0.45, 0.38), 0.16, 2.5),
        (Vec3::new(0.4, 0.25, 0.28), 0.14, 1.8),
        (Vec3::new(0.525, 0.625, 0.37), 0.1, 1.4),
    ];
    let mut data = Vec::with_capacity(dims.iter().product::<u32>() as usize);
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let u = (Vec3::new(x as f32, y as f32, z as f32) + 0.5)
                    / Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
                let puff: f32 =
                    lobes.iter().map(|&(c, r, a)| a * (-2.0 * (u - c).length_squared() / (r * r)).exp()).sum();
                // Haze thinning with height.
                let haze = 0.15 * (1.0 - u.y);
                data.push(haze + puff);
            }
        }
    }
    let g = DensityGrid::new(dims, data).expect("a valid grid");
    let bytes = g.to_vol_bytes(Vec3::ZERO, Vec3::ONE);
    std::fs::write(&out, bytes).unwrap_or_else(|e| panic!("cannot write {out}: {e}"));
    println!("{out}: {}×{}×{} voxels, density 0 to {:.3}", dims[0], dims[1], dims[2], g.max);
}
