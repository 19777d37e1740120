//! Where two images differ, by blocks: `cargo run --release --example env_blocks -- A.exr REF.exr [BX BY]`
//! prints per block of the image (BX × BY blocks, default 8 × 6) the reference's mean luminance,
//! A's energy over the reference's, and the mean HDR-FLIP of A against the reference (the
//! per-pixel map of the whole-image HDR-FLIP). Used to locate the environment caustic's error
//! (docs/benchmarks.md, "Environment caustics spread over their regions").
use caustics_reference::ImageIo as _;
use caustics_reference::metrics::hdr_flip;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let x = caustics::image_io::Image::read(std::path::Path::new(&a[1])).unwrap();
    let r = caustics::image_io::Image::read(std::path::Path::new(&a[2])).unwrap();
    let bx: u32 = a.get(3).map_or(8, |v| v.parse().unwrap());
    let by: u32 = a.get(4).map_or(6, |v| v.parse().unwrap());
    let f = hdr_flip(&x, &r, None).unwrap();
    println!("mean HDR-FLIP {:.3}; exposures {:.2} .. {:.2}", f.mean, f.start_exposure, f.stop_exposure);
    let lum = |p: [f32; 3]| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
    for (name, what) in [("ref mean luminance", 0), ("A / ref energy", 1), ("mean FLIP", 2)] {
        println!("{name}:");
        for j in 0..by {
            let mut row = String::new();
            for i in 0..bx {
                let (mut sa, mut sr, mut sf, mut n) = (0.0, 0.0, 0.0, 0.0);
                for y in j * x.height / by..(j + 1) * x.height / by {
                    for xx in i * x.width / bx..(i + 1) * x.width / bx {
                        let k = (y * x.width + xx) as usize;
                        sa += lum(x.pixels[k]);
                        sr += lum(r.pixels[k]);
                        sf += f.map[k] as f64;
                        n += 1.0;
                    }
                }
                let v = match what {
                    0 => sr / n,
                    1 => sa / sr.max(1e-30),
                    _ => sf / n,
                };
                row.push_str(&format!("{v:9.3}"));
            }
            println!("{row}");
        }
    }
}
