//! How the split rules of the cube-map median cut treat a map's sun: per D, the lights within
//! 3° of the brightest texel, the angle from it to the centre of the region holding it and the
//! share of the map's L·Ω that region carries; and a floor's irradiance against the map's.
//! `cargo run --release --example env_segments -- MAP.exr [D1,D2,..]`
use caustics::scene::Environment;
use caustics::scene::environment_lights::{SplitRule, segment_map_with};
use glam::{Vec2, Vec3};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let env = Environment::load(std::path::Path::new(&a[1]), Vec3::ONE, 0.0).unwrap();
    let ds: Vec<usize> =
        a.get(2).map_or("6,12,24,48".into(), |s| s.clone()).split(',').map(|x| x.parse().unwrap()).collect();
    let (i, _) = env.texels.iter().enumerate().max_by(|a, b| a.1.y.total_cmp(&b.1.y)).unwrap();
    let (x, y) = (i as u32 % env.width, i as u32 / env.width);
    let sun = env.direction(Vec2::new((x as f32 + 0.5) / env.width as f32, (y as f32 + 0.5) / env.height as f32));
    // The floor's exact irradiance: Σ L Ω max(0, ω·y).
    let mut floor = 0.0f64;
    let mut total = 0.0f64;
    for yy in 0..env.height {
        for xx in 0..env.width {
            let d =
                env.direction(Vec2::new((xx as f32 + 0.5) / env.width as f32, (yy as f32 + 0.5) / env.height as f32));
            let v = env.texels[(yy * env.width + xx) as usize].y as f64 * env.texel_solid_angle(yy) as f64;
            floor += v * d.y.max(0.0) as f64;
            total += v;
        }
    }
    println!(
        "| rule | D | lights within 3° of the sun | sun region: angle to the sun | its share of L·Ω | floor irradiance / exact |"
    );
    println!("| --- | --- | --- | --- | --- | --- |");
    for rule in [SplitRule::Total, SplitRule::Spread, SplitRule::Radius] {
        for &d in &ds {
            let l = segment_map_with(&env, d, rule);
            let near = l.iter().filter(|l| l.centre.dot(sun) > 3f32.to_radians().cos()).count();
            let h = l.iter().find(|l| l.members.contains(&(i as u32))).unwrap();
            let ang = h.centre.dot(sun).clamp(-1.0, 1.0).acos().to_degrees();
            let f: f64 = l.iter().map(|l| l.facing.y as f64 * l.centre.y.max(0.0) as f64).sum();
            println!(
                "| {rule:?} | {d} | {near} | {ang:.2}° | {:.3} | {:.4} |",
                h.irradiance.y as f64 / total,
                f / floor
            );
        }
    }
}
