//! Images side by side: `cargo run --release --example side_by_side -- OUT.png EXPOSURE SCALE A.exr B.exr ...`
//! writes the EXRs left to right, each enlarged SCALE times (nearest neighbour), a 2-pixel
//! black gap between them, tone-mapped as the PNG output is (`exposure`, ACES, sRGB).
use caustics::image_io::Image;
use caustics_reference::ImageIo as _;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let out = std::path::Path::new(&a[1]);
    let exposure: f32 = a[2].parse().unwrap();
    let scale: u32 = a[3].parse().unwrap();
    let imgs: Vec<Image> = a[4..].iter().map(|p| Image::read(std::path::Path::new(p)).unwrap()).collect();
    let (w, h) = (imgs[0].width * scale, imgs[0].height * scale);
    let gap = 2;
    let n = imgs.len() as u32;
    let mut o = Image::new(n * w + (n - 1) * gap, h);
    for (k, img) in imgs.iter().enumerate() {
        for y in 0..h {
            for x in 0..w {
                let p = img.pixels[((y / scale) * img.width + x / scale) as usize];
                o.pixels[(y * o.width + k as u32 * (w + gap) + x) as usize] = p;
            }
        }
    }
    o.write(out, exposure).unwrap();
}
