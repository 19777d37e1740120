//! Triangle meshes: OBJ loading (`tobj`, gzip through `flate2`), validation, transforms, and the
//! tessellation of the analytic shapes for rasterization.

use glam::{Mat3, Vec2, Vec3};
use std::collections::HashMap;
use std::io::BufReader;
use std::path::Path;

/// An indexed triangle mesh with one shading normal per vertex.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions (m).
    pub positions: Vec<Vec3>,
    /// Shading normal of each vertex (same index as `positions`).
    pub normals: Vec<Vec3>,
    /// Triangles, three indices into `positions` each.
    pub indices: Vec<[u32; 3]>,
}

/// Read an `.obj` or `.obj.gz` file. Errors are messages for the user (the caller adds the
/// file and field); bad indices and non-finite numbers are errors, not panics.
pub fn load_obj(path: &Path) -> Result<TriMesh, String> {
    let file = std::fs::File::open(path).map_err(|e| format!("cannot open: {e}"))?;
    let gz = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("gz"));
    let mut text = String::new();
    {
        use std::io::Read;
        let r: Box<dyn Read> = if gz { Box::new(flate2::read::GzDecoder::new(file)) } else { Box::new(file) };
        BufReader::new(r).read_to_string(&mut text).map_err(|e| format!("cannot read: {e}"))?;
    }
    check_obj_indices(&text)?;
    let opts = tobj::LoadOptions { single_index: true, triangulate: true, ignore_points: true, ignore_lines: true };
    let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| Ok(Default::default()))
        .map_err(|e| format!("not a valid OBJ file: {e}"))?;
    let mut mesh = TriMesh::default();
    for m in models {
        let mm = &m.mesh;
        let base = mesh.positions.len() as u32;
        let nv = mm.positions.len() / 3;
        for (i, p) in mm.positions.chunks_exact(3).enumerate() {
            let p = Vec3::new(p[0], p[1], p[2]);
            if !p.is_finite() {
                return Err(format!("vertex {} of object \"{}\" is not finite: {p}", i + 1, m.name));
            }
            mesh.positions.push(p);
        }
        let has_normals = mm.normals.len() == mm.positions.len();
        for i in 0..nv {
            let n = if has_normals {
                Vec3::new(mm.normals[3 * i], mm.normals[3 * i + 1], mm.normals[3 * i + 2])
            } else {
                Vec3::ZERO
            };
            mesh.normals.push(if n.is_finite() { n } else { Vec3::ZERO });
        }
        for t in mm.indices.chunks_exact(3) {
            if t.iter().any(|&x| x as usize >= nv) {
                return Err(format!("face index out of range in object \"{}\" ({} vertices)", m.name, nv));
            }
            mesh.indices.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    if mesh.indices.is_empty() {
        return Err("no triangles".into());
    }
    mesh.fix_normals();
    Ok(mesh)
}

/// Face lines with an index of 0 or beyond the vertex count make `tobj` fail in ways that do not
/// say where; check them first so the user is told the line.
fn check_obj_indices(text: &str) -> Result<(), String> {
    let (mut nv, mut nn) = (0i64, 0i64);
    for (lineno, line) in text.lines().enumerate() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => nv += 1,
            Some("vn") => nn += 1,
            Some("f") => {
                for tok in it {
                    for (k, part) in tok.split('/').enumerate() {
                        if part.is_empty() || k == 1 {
                            continue;
                        }
                        let idx: i64 =
                            part.parse().map_err(|_| format!("line {}: bad face index \"{part}\"", lineno + 1))?;
                        let count = if k == 0 { nv } else { nn };
                        let ok = if idx > 0 { idx <= count } else { idx < 0 && -idx <= count };
                        if !ok {
                            return Err(format!(
                                "line {}: face index {idx} out of range ({count} {} defined so far)",
                                lineno + 1,
                                if k == 0 { "vertices" } else { "normals" }
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

impl TriMesh {
    /// Axis-aligned bounds of the vertices, `(min, max)` (infinite and inverted when empty).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.positions
            .iter()
            .fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(a, b), p| (a.min(*p), b.max(*p)))
    }

    /// Unnormalised face normal (length = twice the area).
    pub fn face_cross(&self, t: [u32; 3]) -> Vec3 {
        let [a, b, c] = t.map(|i| self.positions[i as usize]);
        (b - a).cross(c - a)
    }

    /// Drop triangles of (near) zero area or with a repeated vertex; returns how many.
    pub fn drop_degenerate(&mut self) -> usize {
        let before = self.indices.len();
        let pos = &self.positions;
        self.indices.retain(|t| {
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return false;
            }
            let [a, b, c] = t.map(|i| pos[i as usize]);
            let cr = (b - a).cross(c - a).length();
            let scale = (b - a).length_squared().max((c - a).length_squared()).max((c - b).length_squared());
            cr > 1e-12 * scale && cr > 0.0
        });
        before - self.indices.len()
    }

    /// Replace missing or zero normals by area-weighted face normals; normalise all.
    pub fn fix_normals(&mut self) {
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.indices {
            let n = self.face_cross(*t);
            for &i in t {
                acc[i as usize] += n;
            }
        }
        for (n, a) in self.normals.iter_mut().zip(acc) {
            let len = n.length();
            *n = if len > 1e-6 && n.is_finite() { *n / len } else { a.normalize_or_zero() };
        }
    }

    /// Apply translate · rotate · scale (scale first), as the scene format defines it.
    pub fn transform(&mut self, scale: Mat3, rotate: Mat3, translate: Vec3) {
        let m = rotate * scale;
        let n = m.inverse().transpose();
        for p in &mut self.positions {
            *p = m * *p + translate;
        }
        for v in &mut self.normals {
            *v = (n * *v).normalize_or_zero();
        }
        if m.determinant() < 0.0 {
            for t in &mut self.indices {
                t.swap(1, 2);
            }
        }
    }

    /// Flat shading: one vertex per corner, with the face normal.
    pub fn use_face_normals(&mut self) {
        let mut out = TriMesh::default();
        for t in &self.indices {
            let n = self.face_cross(*t).normalize_or_zero();
            let b = out.positions.len() as u32;
            for &i in t {
                out.positions.push(self.positions[i as usize]);
                out.normals.push(n);
            }
            out.indices.push([b, b + 1, b + 2]);
        }
        *self = out;
    }

    /// Number of edges used by exactly one triangle (0 for a closed mesh). Vertices are matched
    /// by position, so flat-shaded copies count as one.
    pub fn boundary_edges(&self) -> usize {
        let key = |p: Vec3| p.to_array().map(f32::to_bits);
        let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
        let remap: Vec<u32> = self
            .positions
            .iter()
            .map(|p| {
                let n = ids.len() as u32;
                *ids.entry(key(*p)).or_insert(n)
            })
            .collect();
        let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
        for t in &self.indices {
            for k in 0..3 {
                let (a, b) = (remap[t[k] as usize], remap[t[(k + 1) % 3] as usize]);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        edges.values().filter(|&&c| c == 1).count()
    }

    /// Append another mesh.
    pub fn append(&mut self, other: &TriMesh) {
        let b = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        self.indices.extend(other.indices.iter().map(|t| t.map(|i| i + b)));
    }
}

/// UV sphere with exact outward normals; `segments` around, `segments / 2` pole to pole.
pub fn sphere(center: Vec3, radius: f32, segments: u32) -> TriMesh {
    let (nu, nv) = (segments, (segments / 2).max(4));
    let mut m = TriMesh::default();
    for j in 0..=nv {
        let theta = std::f32::consts::PI * j as f32 / nv as f32;
        // Exact poles and seam, so that the mesh is closed bit for bit.
        let (st, ct) = if j == 0 {
            (0.0, 1.0)
        } else if j == nv {
            (0.0, -1.0)
        } else {
            theta.sin_cos()
        };
        for i in 0..=nu {
            let phi = if i == nu { 0.0 } else { std::f32::consts::TAU * i as f32 / nu as f32 };
            let n = Vec3::new(st * phi.cos(), ct, -st * phi.sin());
            m.positions.push(center + n * radius);
            m.normals.push(n);
        }
    }
    let row = nu + 1;
    for j in 0..nv {
        for i in 0..nu {
            let (a, b, c, d) = (j * row + i, j * row + i + 1, (j + 1) * row + i, (j + 1) * row + i + 1);
            if j != 0 {
                m.indices.push([a, c, b]);
            }
            if j != nv - 1 {
                m.indices.push([b, c, d]);
            }
        }
    }
    m
}

/// Two triangles, normal `n` (counter-clockwise seen from the normal's side).
pub fn rectangle(center: Vec3, n: Vec3, u: Vec3, v: Vec3, size: Vec2) -> TriMesh {
    let (hu, hv) = (u * size.x * 0.5, v * size.y * 0.5);
    let positions = vec![center - hu - hv, center + hu - hv, center + hu + hv, center - hu + hv];
    let mut m = TriMesh { positions, normals: vec![n; 4], indices: vec![[0, 1, 2], [0, 2, 3]] };
    if m.face_cross([0, 1, 2]).dot(n) < 0.0 {
        m.indices = vec![[0, 2, 1], [0, 3, 2]];
    }
    m
}

/// Open tube with outward normals, `segments` around.
pub fn cylinder(base: Vec3, axis: Vec3, radius: f32, height: f32, segments: u32) -> TriMesh {
    let (x, z) = axis.any_orthonormal_pair();
    let mut m = TriMesh::default();
    for i in 0..=segments {
        let phi = std::f32::consts::TAU * i as f32 / segments as f32;
        let n = x * phi.cos() + z * phi.sin();
        for h in [0.0, height] {
            m.positions.push(base + n * radius + axis * h);
            m.normals.push(n);
        }
    }
    for i in 0..segments {
        let (a, b, c, d) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        let tri = [a, c, b];
        if m.face_cross(tri).dot(m.normals[a as usize]) > 0.0 {
            m.indices.push(tri);
            m.indices.push([b, c, d]);
        } else {
            m.indices.push([a, b, c]);
            m.indices.push([b, d, c]);
        }
    }
    m
}
