//! Write an EXR's pixels as raw little-endian f32 RGB (row-major, top row first) after a
//! one-line text header "WIDTH HEIGHT\n", for analysis outside Rust (numpy).
//!
//! `cargo run --release -p caustics-reference --example exr_raw -- IN.exr OUT.raw`
use caustics::image_io::Image;
use caustics_reference::ImageIo as _;
use std::io::Write;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    assert_eq!(args.len(), 2, "usage: exr_raw IN.exr OUT.raw");
    let img = Image::read(std::path::Path::new(&args[0])).unwrap_or_else(|e| panic!("{e}"));
    let mut f = std::io::BufWriter::new(std::fs::File::create(&args[1]).unwrap());
    writeln!(f, "{} {}", img.width, img.height).unwrap();
    for p in &img.pixels {
        for v in p {
            f.write_all(&v.to_le_bytes()).unwrap();
        }
    }
}
