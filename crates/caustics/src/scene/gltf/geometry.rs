//! The default scene's node hierarchy flattened: world matrices (TRS or `matrix`), every
//! triangle primitive read from its accessors (bounds checked before anything is allocated)
//! and placed in world space, and the nodes that carry cameras and lights.

use super::container::Document;
use super::{Ctx, label};
use crate::error::Result;
use crate::scene::mesh::TriMesh;
use crate::scene::{Material, Object, Shape};
use glam::{Mat3, Mat4, Quat, Vec3};
use gltf::json::accessor::{ComponentType, Type};
use gltf::json::mesh::{Mode, Semantic};
use gltf::json::validation::Checked;
use gltf::json::{Index, Node, Root};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::sync::Arc;

/// A node that carries something (a camera, a light), with its world matrix.
#[derive(Clone, Copy)]
pub(crate) struct Placed {
    /// Index into the file's `cameras` or `KHR_lights_punctual.lights` (unchecked).
    pub item: usize,
    /// The node.
    pub node: usize,
    /// The node's world matrix (finite).
    pub world: Mat4,
}

/// The meshes of one node with one material, in world space.
pub(crate) struct PlacedMesh {
    /// The glTF material (`None`: the default material).
    pub material: Option<usize>,
    /// Its triangles in world space.
    pub mesh: TriMesh,
    /// `/nodes/N` and the mesh's name, for warnings.
    pub at: String,
    pub what: String,
}

/// The scene flattened.
pub(crate) struct Flat {
    pub meshes: Vec<PlacedMesh>,
    pub cameras: Vec<Placed>,
    pub lights: Vec<Placed>,
    /// The materials the placed meshes use.
    pub used_materials: BTreeSet<Option<usize>>,
}

/// A primitive read once, in the mesh's own space: positions, normals (zero without `NORMAL`).
struct Local {
    mesh: TriMesh,
    has_normals: bool,
    material: Option<usize>,
}

/// The most elements an accessor without a bufferView (all zeros) may declare.
const MAX_ZERO_ELEMENTS: u64 = 1 << 20;

/// Walk the default scene (or scene 0, or every root node where the file has no scene).
pub(crate) fn flatten(cx: &mut Ctx, doc: &Document) -> Result<Flat> {
    let root = &doc.root;
    let roots = scene_roots(cx, root)?;
    let mut flat =
        Flat { meshes: Vec::new(), cameras: Vec::new(), lights: Vec::new(), used_materials: BTreeSet::new() };
    let mut seen = vec![false; root.nodes.len()];
    let mut cache: HashMap<usize, Vec<Local>> = HashMap::new();
    let mut stack: Vec<(usize, Mat4)> = roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY)).collect();
    while let Some((n, parent)) = stack.pop() {
        if std::mem::replace(&mut seen[n], true) {
            return Err(cx.err(format!("/nodes/{n}"), "is reached twice from the scene (a cycle or a shared child)"));
        }
        let node = &root.nodes[n];
        let world = parent * local_matrix(cx, node, n)?;
        if !world.is_finite() {
            return Err(cx.err(format!("/nodes/{n}"), "its world transform is not finite"));
        }
        visit_node(cx, doc, n, world, &mut cache, &mut flat)?;
        for (k, c) in node.children.as_deref().unwrap_or_default().iter().enumerate().rev() {
            let c = c.value();
            if c >= root.nodes.len() {
                return Err(cx.err(format!("/nodes/{n}/children/{k}"), missing("node", c, root.nodes.len())));
            }
            if seen[c] {
                return Err(cx.err(
                    format!("/nodes/{n}/children/{k}"),
                    format!("node {c} is drawn already (a cycle or a shared child)"),
                ));
            }
            stack.push((c, world));
        }
    }
    Ok(flat)
}

fn missing(kind: &str, i: usize, len: usize) -> String {
    format!("{kind} {i} does not exist (the file has {len})")
}

/// The root nodes to draw.
fn scene_roots(cx: &mut Ctx, root: &Root) -> Result<Vec<usize>> {
    let n = root.nodes.len();
    let scene = match root.scene {
        Some(s) if s.value() >= root.scenes.len() => {
            return Err(cx.err("/scene", missing("scene", s.value(), root.scenes.len())));
        }
        Some(s) => s.value(),
        None if root.scenes.is_empty() => {
            let mut child = vec![false; n];
            for c in root.nodes.iter().flat_map(|x| x.children.iter().flatten()) {
                if let Some(x) = child.get_mut(c.value()) {
                    *x = true;
                }
            }
            cx.warn("/scenes", "the file has no scene: every root node is drawn");
            return Ok((0..n).filter(|&i| !child[i]).collect());
        }
        None => 0,
    };
    let mut out = Vec::new();
    for (k, x) in root.scenes[scene].nodes.iter().enumerate() {
        if x.value() >= n {
            return Err(cx.err(format!("/scenes/{scene}/nodes/{k}"), missing("node", x.value(), n)));
        }
        out.push(x.value());
    }
    Ok(out)
}

/// A node's own matrix: `matrix`, or translation · rotation · scale.
fn local_matrix(cx: &Ctx, node: &Node, n: usize) -> Result<Mat4> {
    let finite = |field: &str, v: &[f32]| {
        if v.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(cx.err(format!("/nodes/{n}/{field}"), format!("must be finite numbers (got {v:?})")))
        }
    };
    if let Some(m) = &node.matrix {
        finite("matrix", m)?;
        return Ok(Mat4::from_cols_array(m));
    }
    let t = node.translation.unwrap_or([0.0; 3]);
    let s = node.scale.unwrap_or([1.0; 3]);
    let r = node.rotation.map_or([0.0, 0.0, 0.0, 1.0], |q| q.0);
    finite("translation", &t)?;
    finite("scale", &s)?;
    finite("rotation", &r)?;
    let q = Quat::from_array(r);
    if q.length() < 1e-6 {
        return Err(cx.err(format!("/nodes/{n}/rotation"), "must be a unit quaternion (got a zero one)"));
    }
    Ok(Mat4::from_scale_rotation_translation(Vec3::from_array(s), q.normalize(), Vec3::from_array(t)))
}

/// Record a node's mesh, camera and light.
fn visit_node(
    cx: &mut Ctx,
    doc: &Document,
    n: usize,
    world: Mat4,
    cache: &mut HashMap<usize, Vec<Local>>,
    flat: &mut Flat,
) -> Result<()> {
    let root = &doc.root;
    let node = &root.nodes[n];
    let at = format!("/nodes/{n}");
    let name = label("node", n, node.name.as_ref());
    if let Some(c) = node.camera {
        flat.cameras.push(Placed { item: c.value(), node: n, world });
    }
    if let Some(ext) = &node.extensions {
        if let Some(l) = &ext.khr_lights_punctual {
            flat.lights.push(Placed { item: l.light.value(), node: n, world });
        }
        for key in ext.others.keys() {
            cx.warn(&format!("{at}/extensions/{key}"), format!("{name}: extension {key} ignored"));
        }
    }
    let Some(m) = node.mesh else { return Ok(()) };
    let m = m.value();
    let Some(mesh) = root.meshes.get(m) else {
        return Err(cx.err(format!("{at}/mesh"), missing("mesh", m, root.meshes.len())));
    };
    if node.skin.is_some() {
        cx.warn(&format!("{at}/skin"), format!("{name}: skinning ignored: the mesh is drawn in its bind pose"));
    }
    if let std::collections::hash_map::Entry::Vacant(e) = cache.entry(m) {
        e.insert(read_mesh(cx, doc, m)?);
    }
    let what = label("mesh", m, mesh.name.as_ref());
    let det = Mat3::from_mat4(world).determinant();
    if det.is_nan() || det.abs() <= 1e-18 {
        cx.warn(&at, format!("{name}: its transform squashes {what} flat (determinant {det}): not drawn"));
        return Ok(());
    }
    let mut by_material: BTreeMap<Option<usize>, TriMesh> = BTreeMap::new();
    for local in &cache[&m] {
        let mut placed = place(&local.mesh, world);
        if !placed.positions.iter().all(|p| p.is_finite()) {
            return Err(cx.err(&at, format!("{name}: its transform moves {what} beyond the range of numbers")));
        }
        if !local.has_normals {
            // glTF 3.7.2.1: without normals, flat normals (after the transform, whose winding
            // flip keeps them outward).
            placed.use_face_normals();
        }
        by_material.entry(local.material).or_default().append(&placed);
    }
    for (material, mesh) in by_material {
        flat.used_materials.insert(material);
        flat.meshes.push(PlacedMesh { material, mesh, at: at.clone(), what: what.clone() });
    }
    Ok(())
}

/// A mesh moved to world space; a mirroring matrix (negative determinant) flips the winding so
/// that the front faces stay front faces.
fn place(local: &TriMesh, world: Mat4) -> TriMesh {
    let mut m = local.clone();
    m.transform(Mat3::from_mat4(world), Mat3::IDENTITY, world.w_axis.truncate());
    m
}

/// Every triangle primitive of mesh `m`, in its own space; others warned about and skipped.
fn read_mesh(cx: &mut Ctx, doc: &Document, m: usize) -> Result<Vec<Local>> {
    let mesh = &doc.root.meshes[m];
    let what = label("mesh", m, mesh.name.as_ref());
    let mut out = Vec::new();
    for (p, prim) in mesh.primitives.iter().enumerate() {
        let at = format!("/meshes/{m}/primitives/{p}");
        if prim.targets.as_ref().is_some_and(|t| !t.is_empty()) {
            cx.warn(&format!("{at}/targets"), format!("{what}: morph targets ignored: the base shape is drawn"));
        }
        if let Some(local) = read_primitive(cx, doc, &at, &what, prim)? {
            out.push(local);
        }
    }
    Ok(out)
}

fn read_primitive(
    cx: &mut Ctx,
    doc: &Document,
    at: &str,
    what: &str,
    prim: &gltf::json::mesh::Primitive,
) -> Result<Option<Local>> {
    let mode = match prim.mode {
        Checked::Valid(m) => m,
        Checked::Invalid => return Err(cx.err(format!("{at}/mode"), "is not a glTF primitive mode (0 to 6)")),
    };
    if matches!(mode, Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip) {
        cx.warn(
            &format!("{at}/mode"),
            format!("{what}: a primitive of points or lines ({mode:?}) skipped: only triangles are drawn"),
        );
        return Ok(None);
    }
    if prim.attributes.contains_key(&Checked::Valid(Semantic::Colors(0))) {
        cx.warn(&format!("{at}/attributes/COLOR_0"), format!("{what}: vertex colours ignored"));
    }
    let n_materials = doc.root.materials.len();
    if let Some(m) = prim.material.map(|m| m.value()).filter(|&m| m >= n_materials) {
        return Err(cx.err(format!("{at}/material"), missing("material", m, n_materials)));
    }
    let pos_at = format!("{at}/attributes/POSITION");
    let pos = prim
        .attributes
        .get(&Checked::Valid(Semantic::Positions))
        .ok_or_else(|| cx.err(format!("{at}/attributes"), "has no POSITION"))?;
    let positions = read_vec3(cx, doc, *pos, &pos_at)?;
    let nv = positions.len();
    let normals = match prim.attributes.get(&Checked::Valid(Semantic::Normals)) {
        None => None,
        Some(a) => {
            let n_at = format!("{at}/attributes/NORMAL");
            let n = read_vec3(cx, doc, *a, &n_at)?;
            if n.len() != nv {
                return Err(cx.err(n_at, format!("has {} elements, POSITION has {nv}", n.len())));
            }
            Some(n)
        }
    };
    let (order, order_at) = match prim.indices {
        Some(i) => {
            let i_at = format!("{at}/indices");
            let idx = read_indices(cx, doc, i, &i_at)?;
            if let Some((k, bad)) = idx.iter().enumerate().find(|(_, x)| **x as usize >= nv) {
                return Err(cx.err(i_at, format!("index {k} is {bad}, beyond the {nv} vertices")));
            }
            (idx, i_at)
        }
        None => ((0..nv as u32).collect(), pos_at),
    };
    let indices = triangles(&order, mode)
        .ok_or_else(|| cx.err(order_at, format!("{} vertices do not make whole triangles ({mode:?})", order.len())))?;
    let has_normals = normals.is_some();
    let mut mesh = TriMesh { normals: normals.unwrap_or_else(|| vec![Vec3::ZERO; nv]), positions, indices };
    if has_normals {
        mesh.fix_normals();
    }
    Ok(Some(Local { mesh, has_normals, material: prim.material.map(|m| m.value()) }))
}

/// Triangles of a triangle list, strip or fan (glTF 2.0, 3.7.2.1); `None` if the count does not
/// fit the mode.
pub(crate) fn triangles(v: &[u32], mode: Mode) -> Option<Vec<[u32; 3]>> {
    match mode {
        Mode::Triangles if v.len().is_multiple_of(3) => Some(v.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()),
        Mode::TriangleStrip if v.len() >= 3 => Some(
            (0..v.len() - 2)
                .map(|i| if i % 2 == 0 { [v[i], v[i + 1], v[i + 2]] } else { [v[i + 1], v[i], v[i + 2]] })
                .collect(),
        ),
        Mode::TriangleFan if v.len() >= 3 => Some((1..v.len() - 1).map(|i| [v[i], v[i + 1], v[0]]).collect()),
        _ => None,
    }
}

/// An accessor's element layout checked against its bufferView and buffer: the bytes of each
/// element, in order (all zero without a bufferView).
struct Layout<'a> {
    data: &'a [u8],
    count: usize,
    stride: usize,
    elem: usize,
}

impl Layout<'_> {
    fn element(&self, i: usize) -> &[u8] {
        if self.data.is_empty() {
            return &ZEROS[..self.elem];
        }
        &self.data[i * self.stride..i * self.stride + self.elem]
    }
}

static ZEROS: [u8; 16] = [0; 16];

/// Accessor `index` (referenced at `at`), of one of the `types`, laid out in its buffer.
fn layout<'a>(
    cx: &Ctx,
    doc: &'a Document,
    index: Index<gltf::json::Accessor>,
    at: &str,
    want: &[(Type, ComponentType)],
) -> Result<(Layout<'a>, ComponentType)> {
    let root = &doc.root;
    let i = index.value();
    let acc = root.accessors.get(i).ok_or_else(|| cx.err(at, missing("accessor", i, root.accessors.len())))?;
    let ap = format!("/accessors/{i}");
    if acc.sparse.is_some() {
        return Err(cx.err(format!("{ap}/sparse"), format!("sparse accessors are not read (used by {at})")));
    }
    let ty = match acc.type_ {
        Checked::Valid(t) => t,
        Checked::Invalid => return Err(cx.err(format!("{ap}/type"), "is not a glTF accessor type")),
    };
    let ct = match acc.component_type {
        Checked::Valid(c) => c.0,
        Checked::Invalid => return Err(cx.err(format!("{ap}/componentType"), "is not a glTF component type")),
    };
    if !want.iter().any(|(t, c)| *t == ty && *c == ct) {
        let list: Vec<String> = want.iter().map(|(t, c)| format!("{t:?} of {c:?}")).collect();
        return Err(cx.err(ap, format!("is {ty:?} of {ct:?}; {at} needs {}", list.join(" or "))));
    }
    let elem = ty.multiplicity() * ct.size();
    let count = acc.count.0;
    if count == 0 {
        return Err(cx.err(format!("{ap}/count"), "must be at least 1"));
    }
    let Some(view_index) = acc.buffer_view else {
        if count > MAX_ZERO_ELEMENTS {
            return Err(cx.err(format!("{ap}/count"), format!("{count} zero elements is too many")));
        }
        return Ok((Layout { data: &[], count: count as usize, stride: elem, elem }, ct));
    };
    let v = view_index.value();
    let view = root
        .buffer_views
        .get(v)
        .ok_or_else(|| cx.err(format!("{ap}/bufferView"), missing("bufferView", v, root.buffer_views.len())))?;
    let vp = format!("/bufferViews/{v}");
    let b = view.buffer.value();
    let buffer =
        doc.buffers.get(b).ok_or_else(|| cx.err(format!("{vp}/buffer"), missing("buffer", b, doc.buffers.len())))?;
    let v_off = view.byte_offset.map_or(0, |o| o.0);
    let v_len = view.byte_length.0;
    let v_end = v_off.checked_add(v_len).filter(|&e| e <= buffer.len() as u64).ok_or_else(|| {
        cx.err(&vp, format!("bytes {v_off} + {v_len} lie beyond buffer {b} ({} bytes)", buffer.len()))
    })?;
    let stride = match view.byte_stride {
        Some(s) if s.0 < elem || s.0 > 252 => {
            return Err(cx.err(format!("{vp}/byteStride"), format!("must lie in [{elem}, 252] for {at} (got {})", s.0)));
        }
        Some(s) => s.0,
        None => elem,
    };
    let a_off = acc.byte_offset.map_or(0, |o| o.0);
    let need = (count - 1)
        .checked_mul(stride as u64)
        .and_then(|x| x.checked_add(a_off))
        .and_then(|x| x.checked_add(elem as u64));
    match need {
        Some(n) if n <= v_len => {}
        _ => {
            return Err(cx.err(
                format!("{ap}/count"),
                format!("{count} elements of {elem} bytes every {stride} from byte {a_off} do not fit bufferView {v} ({v_len} bytes)"),
            ));
        }
    }
    let start = (v_off + a_off) as usize;
    let data = &buffer[start..v_end as usize];
    Ok((Layout { data, count: count as usize, stride, elem }, ct))
}

/// A VEC3 float accessor (positions, normals); every number finite.
pub(crate) fn read_vec3(cx: &Ctx, doc: &Document, index: Index<gltf::json::Accessor>, at: &str) -> Result<Vec<Vec3>> {
    let (l, _) = layout(cx, doc, index, at, &[(Type::Vec3, ComponentType::F32)])?;
    let mut out = Vec::with_capacity(l.count);
    for i in 0..l.count {
        let e = l.element(i);
        let f = |k: usize| f32::from_le_bytes([e[4 * k], e[4 * k + 1], e[4 * k + 2], e[4 * k + 3]]);
        let v = Vec3::new(f(0), f(1), f(2));
        if !v.is_finite() {
            return Err(cx.err(
                format!("/accessors/{}", index.value()),
                format!("element {i} is not finite ({v}), read by {at}"),
            ));
        }
        out.push(v);
    }
    Ok(out)
}

/// A SCALAR float accessor; every number finite.
pub(crate) fn read_scalars(cx: &Ctx, doc: &Document, index: Index<gltf::json::Accessor>, at: &str) -> Result<Vec<f32>> {
    let (l, _) = layout(cx, doc, index, at, &[(Type::Scalar, ComponentType::F32)])?;
    let mut out = Vec::with_capacity(l.count);
    for i in 0..l.count {
        let e = l.element(i);
        let x = f32::from_le_bytes([e[0], e[1], e[2], e[3]]);
        if !x.is_finite() {
            return Err(cx.err(
                format!("/accessors/{}", index.value()),
                format!("element {i} is not finite ({x}), read by {at}"),
            ));
        }
        out.push(x);
    }
    Ok(out)
}

/// A SCALAR unsigned-integer accessor (indices).
pub(crate) fn read_indices(cx: &Ctx, doc: &Document, index: Index<gltf::json::Accessor>, at: &str) -> Result<Vec<u32>> {
    let want =
        [(Type::Scalar, ComponentType::U8), (Type::Scalar, ComponentType::U16), (Type::Scalar, ComponentType::U32)];
    let (l, ct) = layout(cx, doc, index, at, &want)?;
    Ok((0..l.count)
        .map(|i| {
            let e = l.element(i);
            match ct {
                ComponentType::U8 => e[0] as u32,
                ComponentType::U16 => u16::from_le_bytes([e[0], e[1]]) as u32,
                _ => u32::from_le_bytes([e[0], e[1], e[2], e[3]]),
            }
        })
        .collect())
}

/// The placed meshes as objects: degenerate triangles dropped, and the warnings of the OBJ path (open dielectric meshes).
pub(crate) fn objects(
    cx: &mut Ctx,
    meshes: Vec<PlacedMesh>,
    remap: &HashMap<Option<usize>, usize>,
    materials: &[Material],
) -> Vec<Object> {
    let mut out = Vec::new();
    for PlacedMesh { material, mut mesh, at, what } in meshes {
        let dropped = mesh.drop_degenerate();
        if dropped > 0 {
            cx.warn(&at, format!("dropped {dropped} degenerate triangle(s) of {what}"));
        }
        if mesh.indices.is_empty() {
            cx.warn(&at, format!("{what} has no usable triangle: not drawn"));
            continue;
        }
        let material = remap[&material];
        if matches!(materials[material], Material::Dielectric { .. }) {
            let open = mesh.boundary_edges();
            if open > 0 {
                cx.warn(&at, format!("dielectric {what} is not closed ({open} boundary edges); refraction through its holes is undefined"));
            }
        }
        let caustic_caster = materials[material].is_specular();
        out.push(Object { shape: Shape::Mesh(Arc::new(mesh)), material, caustic_caster, waves: None });
    }
    out
}
