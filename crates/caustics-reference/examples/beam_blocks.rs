//! Block sums of two images (A / B) as text: where a beam image differs from the reference.
use caustics::image_io::Image;
use caustics_reference::io::ImageIo;
fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let (x, y) = (Image::read(std::path::Path::new(&a[0])).unwrap(), Image::read(std::path::Path::new(&a[1])).unwrap());
    let bs = 4;
    for by in 0..x.height / bs {
        let mut line = String::new();
        for bx in 0..x.width / bs {
            let (mut sa, mut sb) = (0.0, 0.0);
            for j in 0..bs {
                for i in 0..bs {
                    sa += x.get(bx * bs + i, by * bs + j)[1];
                    sb += y.get(bx * bs + i, by * bs + j)[1];
                }
            }
            line += &if sb > 1e-4 || sa > 1e-4 {
                format!("{:5.2}/{:<5.3}", sa / sb.max(1e-9), sb)
            } else {
                "     .     ".into()
            };
        }
        println!("{line}");
    }
}
