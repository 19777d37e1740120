//! The BVH's tests: watertightness, degenerate triangles, every layout against brute force,
//! a tree independent of the thread count.

use super::watertight::WatertightRay;
use super::*;

#[test]
fn shared_edge_is_watertight() {
    // Two triangles forming a square; rays through the diagonal must hit exactly one.
    let tris = vec![
        [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0)],
        [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)],
    ];
    let bvh = Bvh::build(tris);
    for i in 0..1000 {
        let x = i as f32 / 1000.0 * 0.98 + 0.01;
        let o = Vec3::new(x, x, 1.0);
        assert!(bvh.intersect(o, Vec3::new(0.0, 0.0, -1.0), f32::INFINITY).is_some(), "{x}");
    }
}

#[test]
fn degenerate_triangle_is_never_hit() {
    let tris = vec![[Vec3::ZERO, Vec3::X, Vec3::X * 2.0]];
    let bvh = Bvh::build(tris);
    assert!(bvh.intersect(Vec3::new(0.5, 1.0, 0.0), Vec3::NEG_Y, 10.0).is_none());
    assert!(bvh.intersect(Vec3::new(0.5, 0.0, 1.0), Vec3::NEG_Z, 10.0).is_none());
}

#[test]
fn many_triangles_match_brute_force() {
    let mut tris = Vec::new();
    let mut s = 1u64;
    let mut r = || {
        s = super::super::sampling::mix64(s);
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    for _ in 0..2000 {
        let c = Vec3::new(r(), r(), r()) * 10.0;
        tris.push([c, c + Vec3::new(r(), r(), r()) - 0.5, c + Vec3::new(r(), r(), r()) - 0.5]);
    }
    let bvh = Bvh::build(tris.clone());
    for _ in 0..500 {
        let o = Vec3::new(r(), r(), r()) * 12.0 - 1.0;
        let d = (Vec3::new(r(), r(), r()) - 0.5).normalize();
        let h = bvh.intersect(o, d, f32::INFINITY).map(|h| h.t);
        let ray = WatertightRay::new(o, d);
        let mut best = f32::INFINITY;
        for t in &tris {
            if let Some((t, _, _)) = ray.hit(t, best) {
                best = t;
            }
        }
        assert_eq!(h.unwrap_or(f32::INFINITY), best);
    }
}

/// A closed sphere-like mesh (a cube's faces as `n`×`n` grids pushed onto the unit sphere,
/// vertices shared through their grid coordinates so that neighbours share edges exactly),
/// plus degenerate triangles (a repeated vertex, three collinear points) on its surface.
fn closed_mesh(n: i32) -> (Vec<[Vec3; 3]>, Vec<Vec3>, Vec<[Vec3; 2]>) {
    let vert =
        |x: i32, y: i32, z: i32| (Vec3::new(x as f32, y as f32, z as f32) / n as f32 * 2.0 - 1.0).normalize() * 1.3;
    let mut tris = Vec::new();
    let mut verts = Vec::new();
    let mut edges = Vec::new();
    for axis in 0..3 {
        for side in [0, n] {
            let at = |u: i32, v: i32| {
                let mut c = [0; 3];
                c[axis] = side;
                c[(axis + 1) % 3] = u;
                c[(axis + 2) % 3] = v;
                vert(c[0], c[1], c[2])
            };
            for u in 0..n {
                for v in 0..n {
                    let (a, b, c, d) = (at(u, v), at(u + 1, v), at(u + 1, v + 1), at(u, v + 1));
                    let (t1, t2) = if side == 0 { ([a, c, b], [a, d, c]) } else { ([a, b, c], [a, c, d]) };
                    tris.push(t1);
                    tris.push(t2);
                    verts.push(a);
                    edges.push([a, c]);
                    edges.push([a, b]);
                    edges.push([a, d]);
                }
            }
        }
    }
    let k = tris.len();
    for i in (0..k).step_by(7) {
        let [a, b, _] = tris[i];
        tris.push([a, a, b]);
        tris.push([a, (a + b) * 0.5, b]);
    }
    (tris, verts, edges)
}

/// The nearest of all the hits. Where triangles meet, several hit within an ulp or two of
/// each other, and which of them a closest-hit search keeps depends on the order it tests
/// them in (the test compares t·det with tmax·det before dividing): a BVH may return any
/// hit within `NEAR_TIE_ULPS` of this one.
fn nearest(tris: &[[Vec3; 3]], o: Vec3, d: Vec3) -> Option<f32> {
    let ray = WatertightRay::new(o, d);
    tris.iter().filter_map(|t| ray.hit(t, f32::INFINITY)).map(|h| h.0).min_by(f32::total_cmp)
}

const NEAR_TIE_ULPS: u32 = 2;

fn assert_nearest(got: Option<TriHit>, want: Option<f32>, what: &str) {
    match (got, want) {
        (None, None) => {}
        (Some(h), Some(w)) => assert!(
            h.t >= w && h.t.to_bits() - w.to_bits() <= NEAR_TIE_ULPS,
            "{what}: got t = {}, the nearest hit is at {w}",
            h.t
        ),
        _ => panic!("{what}: got {got:?}, want {want:?}"),
    }
}

fn brute(tris: &[[Vec3; 3]], o: Vec3, d: Vec3, tmax: f32) -> Option<(f32, u32)> {
    let ray = WatertightRay::new(o, d);
    let mut best = None;
    let mut tm = tmax;
    for (i, t) in tris.iter().enumerate() {
        if let Some((t, _, _)) = ray.hit(t, tm) {
            tm = t;
            best = Some((t, i as u32));
        }
    }
    best
}

#[test]
fn every_layout_matches_brute_force_and_is_watertight_on_a_closed_mesh() {
    let (tris, verts, edges) = closed_mesh(8);
    let mut s = 7u64;
    let mut r = || {
        s = super::super::sampling::mix64(s);
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    let bvhs = [
        ("default", Bvh::build(tris.clone())),
        ("binary", Bvh::build_with(tris.clone(), Layout::Binary)),
        ("wide4", Bvh::build_with(tris.clone(), Layout::Wide4)),
        ("wide4, deep-tree stack", {
            let mut b = Bvh::build_with(tris.clone(), Layout::Wide4);
            assert!(b.small_stack);
            b.small_stack = false;
            b
        }),
        ("wide8", Bvh::build_with(tris.clone(), Layout::Wide8)),
        ("binned SAH", Bvh::build_binned_sah(tris.clone())),
    ];
    let mut targets: Vec<Vec3> = verts.clone();
    for (k, e) in edges.iter().enumerate() {
        // Points on shared edges: the midpoint and a point a random way along.
        targets.push((e[0] + e[1]) * 0.5);
        if k % 3 == 0 {
            targets.push(e[0].lerp(e[1], r()));
        }
    }
    for (n, &p) in targets.iter().enumerate() {
        // From outside, from inside (the centre and an off-centre point) towards p.
        let outside = Vec3::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize() * 4.0;
        let inside = Vec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * 0.6;
        // A point computed on an edge may round to just outside the (convex) mesh, which a
        // ray from outside may then rightly miss: from outside, aim just inside.
        for (o, p) in [(outside, p * (1.0 - 1e-6)), (Vec3::ZERO, p), (inside, p)] {
            let to = p - o;
            let d = to.normalize();
            let want = nearest(&tris, o, d);
            for (name, bvh) in &bvhs {
                let got = bvh.intersect(o, d, f32::INFINITY);
                assert_nearest(got, want, &format!("{name}, target {n}, from {o}"));
                // Watertight: aimed at a surface point, a ray hits at or before it.
                let h = got.unwrap_or_else(|| panic!("{name}: ray from {o} to {p} slipped through"));
                assert!(h.t <= to.length() * 1.0001, "{name}: {} > {}", h.t, to.length());
                // The reported triangle is hit at that distance, with those barycentrics.
                let (t, b1, b2) = WatertightRay::new(o, d).hit(&tris[h.id as usize], f32::INFINITY).unwrap();
                assert_eq!((t, b1, b2), (h.t, h.b1, h.b2), "{name}");
                for tmax in if n % 4 == 0 { vec![h.t, h.t * 1.001, h.t * 0.999] } else { vec![] } {
                    let occ = brute(&tris, o, d, tmax).is_some();
                    assert_eq!(bvh.occluded(o, d, tmax), occ, "{name}, tmax {tmax}");
                }
            }
        }
    }
    // Random rays, most of them missing or grazing.
    for _ in 0..2000 {
        let o = Vec3::new(r(), r(), r()) * 6.0 - 3.0;
        let d = (Vec3::new(r(), r(), r()) - 0.5).normalize();
        let want = nearest(&tris, o, d);
        for (name, bvh) in &bvhs {
            assert_nearest(bvh.intersect(o, d, f32::INFINITY), want, name);
            assert_eq!(bvh.occluded(o, d, 2.0), brute(&tris, o, d, 2.0).is_some(), "{name}");
        }
    }
    // Axis-aligned rays (zero direction components) through vertices and edges.
    for &p in targets.iter().step_by(5) {
        for d in [Vec3::X, Vec3::NEG_Y, Vec3::Z] {
            let o = p - d * 3.0;
            let want = nearest(&tris, o, d);
            for (name, bvh) in &bvhs {
                assert_nearest(bvh.intersect(o, d, f32::INFINITY), want, name);
            }
        }
    }
}

/// Everything a traversal reads, as bits.
fn fingerprint(b: &Bvh) -> Vec<u32> {
    let mut v: Vec<u32> = b.ids.clone();
    for t in &b.tris {
        v.extend(t.iter().flat_map(|p| p.to_array()).map(f32::to_bits));
    }
    for pk in &b.packets {
        v.extend(pk.id);
        v.extend(pk.p.iter().flatten().flatten().map(|x| x.to_bits()));
    }
    let mut wide = |lo: &[[f32; 8]], hi: &[[f32; 8]], child: &[u32]| {
        v.extend(lo.iter().chain(hi).flatten().map(|x| x.to_bits()));
        v.extend(child);
    };
    match &b.nodes {
        Nodes::Binary { root, pairs } => {
            for n in std::iter::once(root).chain(pairs.iter().flat_map(|p| &p.0)) {
                wide(&[], &[], &[n.start, n.count, n.lo.x.to_bits(), n.hi.z.to_bits()]);
            }
        }
        Nodes::Wide4(nodes) => {
            for n in nodes {
                let pad = |a: &[[f32; 4]; 3]| a.map(|r| [r[0], r[1], r[2], r[3], 0.0, 0.0, 0.0, 0.0]);
                wide(&pad(&n.b[0]), &pad(&n.b[1]), &n.child);
            }
        }
        Nodes::Wide8(nodes) => {
            for n in nodes {
                wide(&n.b[0], &n.b[1], &n.child);
            }
        }
    }
    v
}

#[test]
fn tree_does_not_depend_on_the_thread_count() {
    let (tris, _, _) = closed_mesh(24);
    let build = |threads: usize, layout: Layout| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| fingerprint(&Bvh::build_with(tris.clone(), layout)))
    };
    for layout in [Layout::Binary, Layout::Wide4, Layout::Wide8] {
        let one = build(1, layout);
        for threads in [2, 3, 8] {
            assert!(build(threads, layout) == one, "{layout:?}: {threads} threads build another tree");
        }
    }
}

#[test]
fn tiny_inputs() {
    for n in 0..10 {
        let tris: Vec<[Vec3; 3]> = (0..n)
            .map(|i| {
                [Vec3::new(i as f32, 0.0, 0.0), Vec3::new(i as f32 + 1.0, 0.0, 0.0), Vec3::new(i as f32, 1.0, 0.0)]
            })
            .collect();
        for layout in [Layout::Binary, Layout::Wide4, Layout::Wide8] {
            let bvh = Bvh::build_with(tris.clone(), layout);
            for i in 0..n {
                let h = bvh.intersect(Vec3::new(i as f32 + 0.25, 0.25, 1.0), Vec3::NEG_Z, f32::INFINITY);
                assert_eq!(h.map(|h| (h.id, h.t)), Some((i as u32, 1.0)), "{layout:?} {n} {i}");
            }
            assert!(bvh.intersect(Vec3::new(-0.5, 0.25, 1.0), Vec3::NEG_Z, f32::INFINITY).is_none());
        }
    }
}
