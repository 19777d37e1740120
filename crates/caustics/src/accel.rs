//! The scene's ray-tracing acceleration structure for the GPU (`shaders/shared/raytrace.wgsl`):
//! one bottom-level BVH2 per mesh object, built once from the mesh as the scene file poses it
//! (refit in place when the mesh deforms: [`SceneBvh::refit`], on the GPU `bvh_refit`),
//! and a top level of instances (per mesh object: its transform from the file's pose to the
//! current one and the inverse, its world bounds), rewritten when an object moves. Analytic
//! shapes (spheres, cylinders, rectangles) are not in it: the tracer intersects them exactly.
//!
//! The bottom levels are built by `obvhs` (PLOC with reinsertion and leaf collapsing,
//! Meister et al.). Compared with the other maintained Rust builders: `bvh` builds a binned-SAH
//! BVH2 roughly an order of magnitude slower on 100k triangles and has no wide-BVH path;
//! `obvhs` builds BVH2 and CWBVH on the glam 0.30 we already use, is deterministic
//! single-threaded (no `parallel` feature), and is what the Tray Racing GPU benchmark traverses.
//! We keep its BVH2 node order (siblings adjacent, `first_index` the left child) and lay it out
//! for WGSL: 32-byte nodes and triangles permuted into leaf order, so a leaf indexes its
//! triangles directly.
//!
//! The top level is a list walked linearly with a box test per instance: scenes have a handful
//! of mesh objects; a tree over instances pays only with dozens (it would use the same node
//! layout).

use crate::gpu::types::{BvhInstance, BvhNode, BvhTri};
use crate::scene::{Scene, Shape};
use glam::{Affine3A, Vec3, Vec3A};

/// Traversal stack entries per ray in the WGSL tracer (`BVH_STACK` in raytrace.wgsl). A
/// bottom-level BVH deeper than this is still traversed; a ray that would overflow the stack is
/// counted (`FluxStats::stack_overflows`) and ends.
pub const BVH_STACK: usize = 32;

/// One mesh's bottom-level BVH in GPU layout.
#[derive(Clone, Debug)]
pub struct MeshBvh {
    pub nodes: Vec<BvhNode>,
    /// Triangles in leaf order: positions, shading normals.
    pub tris: Vec<BvhTri>,
    /// Longest root-to-leaf path (nodes).
    pub depth: usize,
}

/// Build the BVH of one triangle mesh (positions, per-vertex normals, indices).
pub fn build_mesh_bvh(positions: &[Vec3], normals: &[Vec3], indices: &[[u32; 3]]) -> MeshBvh {
    if indices.is_empty() {
        // An empty leaf: the traversal's root box test fails for every ray.
        let empty = BvhNode { lo: [f32::MAX; 3], a: 0, hi: [f32::MIN; 3], count: 0 };
        return MeshBvh { nodes: vec![empty], tris: Vec::new(), depth: 1 };
    }
    let tris: Vec<obvhs::triangle::Triangle> = indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| Vec3A::from(positions[i as usize]));
            obvhs::triangle::Triangle { v0: a, v1: b, v2: c }
        })
        .collect();
    let mut params = obvhs::BvhBuildParams::medium_build();
    // Small leaves: on the GPU a triangle test costs more than a box test (lanes diverge).
    params.max_prims_per_leaf = 4;
    let mut t = std::time::Duration::ZERO;
    let bvh = obvhs::bvh2::builder::build_bvh2_from_tris(&tris, params, &mut t);
    let mut nodes = Vec::with_capacity(bvh.nodes.len());
    for n in &bvh.nodes {
        let (lo, hi) = (Vec3::from(n.aabb.min), Vec3::from(n.aabb.max));
        nodes.push(BvhNode { lo: lo.to_array(), a: n.first_index, hi: hi.to_array(), count: n.prim_count });
    }
    let out_tris = bvh.primitive_indices.iter().map(|&pi| tri_record(pi, positions, normals, indices)).collect();
    let depth = depth_of(&nodes, 0);
    MeshBvh { nodes, tris: out_tris, depth }
}

/// The GPU record of the mesh's triangle `pi`: its corners and shading normals, its index kept
/// in `p0.w`'s bits (a refit finds its vertices by it).
fn tri_record(pi: u32, positions: &[Vec3], normals: &[Vec3], indices: &[[u32; 3]]) -> BvhTri {
    let idx = indices[pi as usize];
    let p = idx.map(|i| positions[i as usize]);
    let n = idx.map(|i| normals.get(i as usize).copied().unwrap_or(Vec3::ZERO));
    BvhTri {
        p0: p[0].extend(f32::from_bits(pi)).to_array(),
        p1: p[1].extend(0.0).to_array(),
        p2: p[2].extend(0.0).to_array(),
        n0: n[0].extend(0.0).to_array(),
        n1: n[1].extend(0.0).to_array(),
        n2: n[2].extend(0.0).to_array(),
    }
}

fn depth_of(nodes: &[BvhNode], root: usize) -> usize {
    let mut best = 0;
    let mut stack = vec![(root, 1usize)];
    while let Some((i, d)) = stack.pop() {
        best = best.max(d);
        let n = nodes[i];
        if n.count == 0 {
            stack.push((n.a as usize, d + 1));
            stack.push((n.a as usize + 1, d + 1));
        }
    }
    best
}

/// All mesh objects' bottom levels, concatenated, and where each instance's begins.
#[derive(Clone, Debug, Default)]
pub struct SceneBvh {
    pub nodes: Vec<BvhNode>,
    pub tris: Vec<BvhTri>,
    /// Per mesh object: (object index, root node, first triangle, bounds in the file's pose).
    pub instances: Vec<(u32, u32, u32, (Vec3, Vec3))>,
    /// Deepest bottom level.
    pub max_depth: usize,
}

impl SceneBvh {
    /// Build the bottom levels of every mesh object of `scene` (in the scene file's pose).
    pub fn build(scene: &Scene) -> SceneBvh {
        let mut s = SceneBvh::default();
        for (i, o) in scene.objects.iter().enumerate() {
            let Shape::Mesh(m) = &o.shape else { continue };
            let b = build_mesh_bvh(&m.positions, &m.normals, &m.indices);
            let root = s.nodes.len() as u32;
            let first = s.tris.len() as u32;
            // Child and triangle indices become global.
            s.nodes.extend(b.nodes.iter().map(|n| {
                let a = if n.count == 0 { n.a + root } else { n.a + first };
                BvhNode { a, ..*n }
            }));
            s.tris.extend(b.tris);
            let n0 = b.nodes[0];
            s.instances.push((i as u32, root, first, (Vec3::from(n0.lo), Vec3::from(n0.hi))));
            s.max_depth = s.max_depth.max(b.depth);
        }
        s
    }

    /// The instance records for the objects' current transforms (`transforms[object]`, from the
    /// scene file's pose), with one record of an empty instance when there is no mesh (the
    /// buffer must not be empty).
    pub fn instance_records(&self, transforms: &[Affine3A]) -> Vec<BvhInstance> {
        let mut out: Vec<BvhInstance> = self
            .instances
            .iter()
            .map(|&(obj, root, first, (lo, hi))| {
                let t = transforms.get(obj as usize).copied().unwrap_or(Affine3A::IDENTITY);
                let inv = t.inverse();
                // World bounds: the transformed box's corners.
                let (mut wlo, mut whi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
                for k in 0..8 {
                    let c = Vec3::new(
                        if k & 1 == 0 { lo.x } else { hi.x },
                        if k & 2 == 0 { lo.y } else { hi.y },
                        if k & 4 == 0 { lo.z } else { hi.z },
                    );
                    let w = t.transform_point3(c);
                    wlo = wlo.min(w);
                    whi = whi.max(w);
                }
                BvhInstance {
                    to_object: rows(&inv),
                    to_world: rows(&t),
                    lo: wlo.extend(0.0).to_array(),
                    hi: whi.extend(0.0).to_array(),
                    root,
                    first_tri: first,
                    object: obj,
                    _pad: 0,
                }
            })
            .collect();
        if out.is_empty() {
            out.push(BvhInstance {
                to_object: rows(&Affine3A::IDENTITY),
                to_world: rows(&Affine3A::IDENTITY),
                lo: [1.0, 1.0, 1.0, 0.0],
                hi: [-1.0, -1.0, -1.0, 0.0],
                root: 0,
                first_tri: 0,
                object: u32::MAX,
                _pad: 0,
            });
        }
        out
    }

    /// Node and triangle arrays for upload (one empty node / triangle where there are none).
    pub fn gpu_arrays(&self) -> (Vec<BvhNode>, Vec<BvhTri>) {
        let mut nodes = self.nodes.clone();
        if nodes.is_empty() {
            nodes.push(BvhNode { lo: [f32::MAX; 3], a: 0, hi: [f32::MIN; 3], count: 0 });
        }
        let mut tris = self.tris.clone();
        if tris.is_empty() {
            tris.push(bytemuck::Zeroable::zeroed());
        }
        (nodes, tris)
    }
}

/// A bottom level refit in place (deformed meshes, [`SceneBvh::refit`]): the tree's topology
/// is kept and its boxes are recomputed bottom-up. Nodes are grouped by height (leaves 0, an
/// inner node one above the higher of its children), so that every node of a level depends only
/// on lower levels: the GPU refits one level per dispatch (`shaders/bvh_refit.wgsl`), the CPU in
/// the same order. Boxes are minima and maxima of the vertices (leaves) and of the two children
/// (inner nodes), exact operations: both give the same bits.
impl SceneBvh {
    /// The instance of mesh object `object` (an index into [`SceneBvh::instances`]).
    pub fn instance_of(&self, object: usize) -> Option<usize> {
        self.instances.iter().position(|i| i.0 as usize == object)
    }

    /// Instance `k`'s nodes and triangles (global index ranges).
    pub fn instance_ranges(&self, k: usize) -> (std::ops::Range<usize>, std::ops::Range<usize>) {
        let (_, root, first, _) = self.instances[k];
        let next = self.instances.get(k + 1);
        let nodes_end = next.map_or(self.nodes.len(), |n| n.1 as usize);
        let tris_end = next.map_or(self.tris.len(), |n| n.2 as usize);
        (root as usize..nodes_end, first as usize..tris_end)
    }

    /// Instance `k`'s nodes (global indices) by height, leaves first; empty for a mesh without
    /// triangles (its one node is the empty box, which stays).
    pub fn refit_levels(&self, k: usize) -> Vec<Vec<u32>> {
        let (nodes, tris) = self.instance_ranges(k);
        if tris.is_empty() {
            return Vec::new();
        }
        // Heights by an explicit post-order walk (children before their parent).
        let mut height = vec![0u32; nodes.len()];
        let mut levels: Vec<Vec<u32>> = Vec::new();
        let mut stack = vec![(nodes.start, false)];
        while let Some((i, children_done)) = stack.pop() {
            let n = self.nodes[i];
            let h = if n.count != 0 {
                0
            } else if children_done {
                let (a, b) = (n.a as usize - nodes.start, n.a as usize + 1 - nodes.start);
                height[a].max(height[b]) + 1
            } else {
                stack.push((i, true));
                stack.push((n.a as usize, false));
                stack.push((n.a as usize + 1, false));
                continue;
            };
            height[i - nodes.start] = h;
            if levels.len() <= h as usize {
                levels.resize(h as usize + 1, Vec::new());
            }
            levels[h as usize].push(i as u32);
        }
        for l in &mut levels {
            l.sort_unstable();
        }
        levels
    }

    /// Refit instance `k` to its mesh's new vertices (`positions`, `normals`, `indices` as the
    /// mesh has them, in the scene file's pose; same vertex count and triangles as it was built
    /// from): its triangles rewritten (leaf order kept), its node boxes recomputed bottom-up
    /// (`levels`: [`SceneBvh::refit_levels`]) and its bounds set to the root's box.
    pub fn refit(&mut self, k: usize, levels: &[Vec<u32>], positions: &[Vec3], normals: &[Vec3], indices: &[[u32; 3]]) {
        let (_, tris) = self.instance_ranges(k);
        for t in &mut self.tris[tris] {
            *t = tri_record(t.p0[3].to_bits(), positions, normals, indices);
        }
        for level in levels {
            for &i in level {
                let n = self.nodes[i as usize];
                let (lo, hi) = if n.count == 0 {
                    let (a, b) = (self.nodes[n.a as usize], self.nodes[n.a as usize + 1]);
                    (Vec3::from(a.lo).min(Vec3::from(b.lo)), Vec3::from(a.hi).max(Vec3::from(b.hi)))
                } else {
                    leaf_box(&self.tris[n.a as usize..(n.a + n.count) as usize])
                };
                self.nodes[i as usize].lo = lo.to_array();
                self.nodes[i as usize].hi = hi.to_array();
            }
        }
        let root = self.nodes[self.instances[k].1 as usize];
        self.instances[k].3 = (Vec3::from(root.lo), Vec3::from(root.hi));
    }
}

/// The box of a leaf's triangles: the minimum and maximum of their vertices, in the order
/// `shaders/bvh_refit.wgsl` takes them.
fn leaf_box(tris: &[BvhTri]) -> (Vec3, Vec3) {
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for t in tris {
        for p in [t.p0, t.p1, t.p2] {
            let p = Vec3::new(p[0], p[1], p[2]);
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    (lo, hi)
}

/// An affine map as three rows (x, y, z) of a 3 × 4 matrix.
fn rows(t: &Affine3A) -> [[f32; 4]; 3] {
    let m = t.matrix3;
    let tr = t.translation;
    [
        [m.x_axis.x, m.y_axis.x, m.z_axis.x, tr.x],
        [m.x_axis.y, m.y_axis.y, m.z_axis.y, tr.y],
        [m.x_axis.z, m.y_axis.z, m.z_axis.z, tr.z],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(tris: &[[Vec3; 3]], o: Vec3, d: Vec3) -> Option<f32> {
        let mut best = None::<f32>;
        for t in tris {
            let e1 = t[1] - t[0];
            let e2 = t[2] - t[0];
            let p = d.cross(e2);
            let det = e1.dot(p);
            if det.abs() < 1e-12 {
                continue;
            }
            let s = o - t[0];
            let u = s.dot(p) / det;
            let q = s.cross(e1);
            let v = d.dot(q) / det;
            let tt = e2.dot(q) / det;
            if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && tt > 0.0 && best.is_none_or(|b| tt < b) {
                best = Some(tt);
            }
        }
        best
    }

    #[test]
    fn layout_covers_every_triangle_once_and_boxes_nest() {
        let m = crate::scene::Shape::Sphere { center: Vec3::ZERO, radius: 1.0 }
            .tessellate(&crate::scene::Tessellation::default());
        let b = build_mesh_bvh(&m.positions, &m.normals, &m.indices);
        assert_eq!(b.tris.len(), m.indices.len());
        let mut seen = vec![0u32; m.indices.len()];
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = b.nodes[i];
            if n.count == 0 {
                for c in [n.a as usize, n.a as usize + 1] {
                    let k = b.nodes[c];
                    for ax in 0..3 {
                        assert!(k.lo[ax] >= n.lo[ax] && k.hi[ax] <= n.hi[ax], "child box outside parent");
                    }
                    stack.push(c);
                }
            } else {
                for t in &b.tris[n.a as usize..(n.a + n.count) as usize] {
                    seen[t.p0[3].to_bits() as usize] += 1;
                    for p in [t.p0, t.p1, t.p2] {
                        let inside = (0..3).all(|ax| p[ax] >= n.lo[ax] && p[ax] <= n.hi[ax]);
                        assert!(inside, "triangle outside its leaf");
                    }
                }
            }
        }
        assert!(seen.iter().all(|&c| c == 1), "every triangle in exactly one leaf");
        assert!(b.depth < BVH_STACK, "depth {}", b.depth);
        // The leaf-order triangles are the mesh's (positions by original index).
        let tris: Vec<[Vec3; 3]> = m.indices.iter().map(|t| t.map(|i| m.positions[i as usize])).collect();
        assert!(brute(&tris, Vec3::new(0.0, 0.0, -5.0), Vec3::Z).is_some_and(|t| (t - 4.0).abs() < 0.01));
    }

    fn two_meshes() -> (Scene, Vec<crate::scene::TriMesh>) {
        use crate::scene::{Shape, Tessellation};
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
        let mut scene = Scene::load(&dir.join("glass_sphere.json")).expect("catalogue scene");
        let t = Tessellation::default();
        let a = Shape::Sphere { center: Vec3::ZERO, radius: 1.0 }.tessellate(&t);
        let b = Shape::Cylinder { base_center: Vec3::X, axis: Vec3::Y, radius: 0.5, height: 1.0 }.tessellate(&t);
        let mut o = scene.objects[0].clone();
        scene.objects.clear();
        for m in [&a, &b] {
            o.shape = Shape::Mesh(std::sync::Arc::new(m.clone()));
            scene.objects.push(o.clone());
        }
        (scene, vec![a, b])
    }

    #[test]
    fn refit_of_unchanged_vertices_is_the_build_and_a_deformed_refit_nests() {
        let (scene, meshes) = two_meshes();
        let built = SceneBvh::build(&scene);
        let mut b = built.clone();
        for (k, m) in meshes.iter().enumerate() {
            let levels = b.refit_levels(k);
            let (nodes, _) = b.instance_ranges(k);
            assert_eq!(levels.iter().map(Vec::len).sum::<usize>(), nodes.len(), "every node in one level");
            b.refit(k, &levels, &m.positions, &m.normals, &m.indices);
        }
        assert!(b.nodes == built.nodes && b.tris == built.tris && b.instances == built.instances);
        // The second mesh deformed: its boxes contain their children and triangles, the first
        // mesh's are untouched, and the bounds are the positions' (every vertex is used).
        let m = &meshes[1];
        let moved: Vec<Vec3> =
            m.positions.iter().map(|p| *p + Vec3::new(0.3 * (p.y * 5.0).sin(), p.x * 0.2, 0.1)).collect();
        let levels = b.refit_levels(1);
        b.refit(1, &levels, &moved, &m.normals, &m.indices);
        let (nodes, tris) = b.instance_ranges(1);
        assert_eq!(b.nodes[..nodes.start], built.nodes[..nodes.start]);
        assert_ne!(b.tris[tris.clone()], built.tris[tris.clone()]);
        for i in nodes {
            let n = b.nodes[i];
            let inside = |p: [f32; 4]| (0..3).all(|ax| p[ax] >= n.lo[ax] && p[ax] <= n.hi[ax]);
            if n.count == 0 {
                for c in [b.nodes[n.a as usize], b.nodes[n.a as usize + 1]] {
                    assert!(inside([c.lo[0], c.lo[1], c.lo[2], 0.0]) && inside([c.hi[0], c.hi[1], c.hi[2], 0.0]));
                }
            } else {
                for t in &b.tris[n.a as usize..(n.a + n.count) as usize] {
                    assert!(inside(t.p0) && inside(t.p1) && inside(t.p2), "triangle outside its leaf");
                }
            }
        }
        let lo = moved.iter().fold(Vec3::splat(f32::MAX), |a, p| a.min(*p));
        let hi = moved.iter().fold(Vec3::splat(f32::MIN), |a, p| a.max(*p));
        assert_eq!(b.instances[1].3, (lo, hi));
    }
}
