//! Every WGSL stage parses and validates with naga; every GPU struct (`gpu::types::LAYOUTS`)
//! matches its WGSL declaration in every stage, member by member (name, offset, size, element
//! stride, scalar type), and no struct shared by host and shader is left out of the list; every
//! shared constant is declared with the Rust value.

use caustics::gpu::{
    self,
    types::{FieldLayout, LAYOUTS, StructLayout},
};

#[test]
fn every_stage_validates() {
    for (name, _) in gpu::STAGES {
        if let Err(e) = gpu::validate_stage(name) {
            panic!("{e}");
        }
    }
}

/// The scalar under a WGSL type's arrays (`f32`, `u32`, `i32`), or a struct's name.
fn wgsl_leaf(module: &naga::Module, ty: naga::Handle<naga::Type>) -> String {
    let scalar = |s: naga::Scalar| match s.kind {
        naga::ScalarKind::Float => format!("f{}", s.width * 8),
        naga::ScalarKind::Uint => format!("u{}", s.width * 8),
        naga::ScalarKind::Sint => format!("i{}", s.width * 8),
        k => format!("{k:?}"),
    };
    match &module.types[ty].inner {
        naga::TypeInner::Scalar(s)
        | naga::TypeInner::Atomic(s)
        | naga::TypeInner::Vector { scalar: s, .. }
        | naga::TypeInner::Matrix { scalar: s, .. } => scalar(*s),
        naga::TypeInner::Array { base, .. } => wgsl_leaf(module, *base),
        naga::TypeInner::Struct { .. } => module.types[ty].name.clone().unwrap_or_default(),
        t => format!("{t:?}"),
    }
}

/// Bytes from one element of a WGSL type to the next, as [`FieldLayout::element`] counts them: an
/// array's stride, a vector's scalar, a matrix's column; the whole type otherwise.
fn wgsl_element(module: &naga::Module, layouter: &naga::proc::Layouter, ty: naga::Handle<naga::Type>) -> usize {
    (match &module.types[ty].inner {
        naga::TypeInner::Array { stride, .. } => *stride,
        naga::TypeInner::Vector { scalar, .. } => scalar.width.into(),
        // A column is a vector aligned as one: vec2 to 2 scalars, vec3 and vec4 to 4.
        naga::TypeInner::Matrix { rows, scalar, .. } => {
            u32::from(scalar.width) * if *rows == naga::VectorSize::Bi { 2 } else { 4 }
        }
        _ => layouter[ty].size,
    }) as usize
}

/// What a WGSL member should be, from the Rust field it mirrors (or one element of it).
struct Expected<'a> {
    field: &'a FieldLayout,
    /// The element of `field` this member mirrors, when WGSL spells the array member by member.
    index: Option<usize>,
    name: &'a str,
    offset: usize,
    size: usize,
    /// `None` where the member is one element and the element's own inner stride is unknown.
    element: Option<usize>,
}

impl Expected<'_> {
    fn rust(&self) -> String {
        match self.index {
            Some(i) => format!("{}[{i}]", self.field.name),
            None => self.field.name.to_string(),
        }
    }
}

/// The WGSL members `layout` expects, in order: one per field, or one per element of a field
/// that WGSL spells member by member.
fn expected_members(layout: &StructLayout) -> Vec<Expected<'_>> {
    let mut out = Vec::new();
    for f in layout.fields {
        if let [name] = f.wgsl {
            out.push(Expected {
                field: f,
                index: None,
                name,
                offset: f.offset,
                size: f.size,
                element: Some(f.element),
            });
        } else {
            for (i, name) in f.wgsl.iter().enumerate() {
                let (offset, size) = (f.offset + i * f.element, f.element);
                out.push(Expected { field: f, index: Some(i), name, offset, size, element: None });
            }
        }
    }
    out
}

/// Every difference between `layout` and the WGSL struct `members` (spanning `span` bytes), one
/// sentence per member.
fn compare_struct(
    module: &naga::Module,
    layouter: &naga::proc::Layouter,
    layout: &StructLayout,
    members: &[naga::StructMember],
    span: u32,
) -> Vec<String> {
    let (rust, wgsl) = (layout.rust, layout.wgsl);
    let mut errors = Vec::new();
    if span as usize != layout.size {
        errors.push(format!("WGSL {wgsl} spans {span} bytes, Rust {rust} is {} bytes", layout.size));
    }
    let expected = expected_members(layout);
    for (i, m) in members.iter().enumerate() {
        let member = m.name.as_deref().unwrap_or("?");
        let (offset, size) = (m.offset as usize, layouter[m.ty].size as usize);
        let Some(e) = expected.get(i) else {
            errors.push(format!(
                "WGSL {wgsl}.{member} (member {i}, offset {offset}) has no Rust field: {rust} gives {} members",
                expected.len()
            ));
            continue;
        };
        let mut wrong = Vec::new();
        if member != e.name {
            wrong.push("names differ".to_string());
        }
        if offset != e.offset {
            wrong.push("offsets differ".to_string());
        }
        if size != e.size {
            wrong.push("sizes differ".to_string());
        }
        let element = wgsl_element(module, layouter, m.ty);
        if e.element.is_some_and(|r| r != element) {
            wrong.push(format!("elements of {} bytes in Rust, {element} in WGSL", e.field.element));
        }
        let leaf = wgsl_leaf(module, m.ty);
        let nested = LAYOUTS.iter().any(|l| l.rust == e.field.leaf && l.wgsl == leaf);
        if leaf != e.field.leaf && !nested {
            wrong.push(format!("{} in Rust, {leaf} in WGSL", e.field.leaf));
        }
        if !wrong.is_empty() {
            errors.push(format!(
                "Rust {rust}.{} (offset {}, {} bytes) against WGSL {wgsl}.{member} (offset {offset}, {size} bytes): {}",
                e.rust(),
                e.offset,
                e.size,
                wrong.join("; ")
            ));
        }
    }
    for e in expected.iter().skip(members.len()) {
        errors.push(format!(
            "Rust {rust}.{} (offset {}) has no WGSL member: {wgsl} has {} members",
            e.rust(),
            e.offset,
            members.len()
        ));
    }
    errors
}

#[test]
fn gpu_structs_match_wgsl() {
    let mut errors = Vec::new();
    // Each Rust struct lists its fields in declaration order, back to back (`Pod` has no
    // padding, and `layouts!` fails to compile without every field).
    for l in LAYOUTS {
        let mut end = 0;
        for f in l.fields {
            if f.offset != end {
                errors
                    .push(format!("{}.{} at offset {}, expected {end}: fields out of order", l.rust, f.name, f.offset));
            }
            end = f.offset + f.size;
            if f.wgsl.len() > 1 && f.size != f.wgsl.len() * f.element {
                errors.push(format!(
                    "{}.{}: {} WGSL members for {} elements",
                    l.rust,
                    f.name,
                    f.wgsl.len(),
                    f.size / f.element
                ));
            }
        }
        if end != l.size {
            errors.push(format!("{}: fields end at {end}, the struct at {}", l.rust, l.size));
        }
    }
    // Each mismatch once, with the stages whose declaration has it (the shared modules are in
    // many).
    let mut mismatches: Vec<(String, Vec<&str>)> = Vec::new();
    let mut found = vec![0; LAYOUTS.len()];
    let mut members = 0;
    for (stage, _) in gpu::STAGES {
        let module = gpu::validate_stage(stage).unwrap();
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        for (_, ty) in module.types.iter() {
            let Some(wgsl_name) = &ty.name else { continue };
            let naga::TypeInner::Struct { members: m, span } = &ty.inner else { continue };
            for (i, l) in LAYOUTS.iter().enumerate() {
                if l.wgsl != wgsl_name {
                    continue;
                }
                for e in compare_struct(&module, &layouter, l, m, *span) {
                    match mismatches.iter_mut().find(|(x, _)| *x == e) {
                        Some((_, stages)) => stages.push(stage),
                        None => mismatches.push((e, vec![stage])),
                    }
                }
                found[i] += 1;
                members += m.len();
            }
        }
    }
    for (e, stages) in mismatches {
        let n = stages.len();
        let stages =
            if n > 3 { format!("{} and {} more stages", stages[..3].join(", "), n - 3) } else { stages.join(", ") };
        errors.push(format!("{e} (in {stages})"));
    }
    for (l, n) in LAYOUTS.iter().zip(&found) {
        if *n == 0 {
            errors.push(format!("{}: no stage declares WGSL struct {}", l.rust, l.wgsl));
        }
    }
    assert!(errors.is_empty(), "{} layout mismatches:\n{}", errors.len(), errors.join("\n"));
    eprintln!(
        "{} structs checked in {} stage declarations, {members} members",
        LAYOUTS.len(),
        found.iter().sum::<usize>()
    );
}

#[test]
fn every_buffer_struct_is_in_layouts() {
    // The other way round: every struct a stage binds as a uniform or storage buffer, or nests
    // in one, has its Rust mirror in `LAYOUTS`.
    fn structs(module: &naga::Module, ty: naga::Handle<naga::Type>, out: &mut Vec<String>) {
        match &module.types[ty].inner {
            naga::TypeInner::Array { base, .. } => structs(module, *base, out),
            naga::TypeInner::Struct { members, .. } => {
                out.push(module.types[ty].name.clone().unwrap_or_default());
                members.iter().for_each(|m| structs(module, m.ty, out));
            }
            _ => {}
        }
    }
    let mut missing = Vec::new();
    for (stage, _) in gpu::STAGES {
        let module = gpu::validate_stage(stage).unwrap();
        for (_, g) in module.global_variables.iter() {
            if !matches!(g.space, naga::AddressSpace::Uniform | naga::AddressSpace::Storage { .. }) {
                continue;
            }
            let mut found = Vec::new();
            structs(&module, g.ty, &mut found);
            for s in found.into_iter().filter(|s| !LAYOUTS.iter().any(|l| l.wgsl == s)) {
                missing.push(format!("{stage}: {s} ({})", g.name.as_deref().unwrap_or("?")));
            }
        }
    }
    assert!(missing.is_empty(), "WGSL buffer structs without a Rust mirror in LAYOUTS: {}", missing.join(", "));
}

#[test]
fn every_pod_struct_is_in_layouts() {
    // Every struct of the crate that derives `Pod` (what the host uploads to or reads back
    // from a shader) mirrors a WGSL struct listed in `LAYOUTS`, but these.
    const NOT_WGSL: &[(&str, &str)] =
        &[("Vertex", "the raster stages' vertex buffer: vs_main reads it by location, not as a struct")];
    fn visit(dir: &std::path::Path, out: &mut Vec<(String, String)>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                visit(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let text = std::fs::read_to_string(&path).unwrap();
                let mut lines = text.lines();
                while let Some(line) = lines.next() {
                    let line = line.trim();
                    if !(line.starts_with("#[derive(")
                        && line.split(|c: char| !c.is_alphanumeric()).any(|w| w == "Pod"))
                    {
                        continue;
                    }
                    let decl = lines.find(|l| l.contains("struct ")).unwrap_or_else(|| panic!("{path:?}: {line}"));
                    let name = decl.split("struct ").nth(1).unwrap();
                    let name = name.split(|c: char| !c.is_alphanumeric() && c != '_').next().unwrap();
                    out.push((name.to_string(), path.display().to_string()));
                }
            }
        }
    }
    let mut pods = Vec::new();
    visit(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src"), &mut pods);
    assert!(pods.len() > LAYOUTS.len() / 2, "found only {} Pod structs", pods.len());
    let missing: Vec<_> = pods
        .iter()
        .filter(|(n, _)| !LAYOUTS.iter().any(|l| l.rust == n) && !NOT_WGSL.iter().any(|(x, _)| x == n))
        .map(|(n, file)| format!("{n} ({file})"))
        .collect();
    assert!(missing.is_empty(), "Pod structs missing from gpu::types::LAYOUTS: {}", missing.join(", "));
}

#[test]
fn every_constant_is_declared_in_a_stage() {
    let mut declared = std::collections::HashSet::new();
    for (name, _) in gpu::STAGES {
        let module = gpu::validate_stage(name).unwrap();
        declared.extend(module.constants.iter().filter_map(|(_, c)| c.name.clone()));
    }
    for (name, _) in gpu::types::CONSTANTS {
        assert!(declared.contains(*name), "gpu::types::CONSTANTS: no stage declares {name}");
    }
}

#[test]
fn gpu_constants_match_wgsl() {
    // Every named constant (material kinds, shapes, light kinds) has the Rust value in every
    // stage that declares it.
    let mut checked = 0;
    for (name, _) in gpu::STAGES {
        let module = gpu::validate_stage(name).unwrap();
        for (_, c) in module.constants.iter() {
            let Some(cname) = &c.name else { continue };
            let Some((_, want)) = gpu::types::CONSTANTS.iter().find(|(n, _)| n == cname) else { continue };
            let naga::Expression::Literal(naga::Literal::U32(v)) = module.global_expressions[c.init] else {
                panic!("{name}: {cname} is not a u32 literal");
            };
            assert_eq!(v, *want, "{name}: WGSL {cname} = {v}, Rust {want}");
            checked += 1;
        }
    }
    assert!(checked >= gpu::types::CONSTANTS.len() * 10, "only {checked} constants checked");
}

#[test]
fn every_compute_stage_has_an_explicit_layout() {
    // Group 0 of every compute stage is derived from its WGSL; stages with the same interface
    // share one bind group layout.
    let mut distinct: Vec<Vec<wgpu::BindGroupLayoutEntry>> = Vec::new();
    let mut stages = 0;
    for (name, _) in gpu::STAGES {
        if name.starts_with("raster") {
            continue;
        }
        // (the beams' hull draws: render stages whose layouts are derived the same way)
        let render = *name == "beam_raster" || *name == "beam_surface_raster";
        let entries = if render { gpu::render_stage_bindings(name) } else { gpu::stage_bindings(name) }
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(!entries.is_empty(), "{name} binds nothing");
        assert!(entries.windows(2).all(|w| w[0].binding < w[1].binding), "{name}: bindings out of order");
        stages += 1;
        if !distinct.contains(&entries) {
            distinct.push(entries);
        }
    }
    eprintln!("{stages} compute stages, {} distinct bind group layouts", distinct.len());
    assert!(distinct.len() <= stages);
}

/// The expressions of `f` once every call in it is inlined, as a GPU's shader compiler does
/// (memoised by function).
fn inlined_size(
    m: &naga::Module,
    f: &naga::Function,
    memo: &mut std::collections::HashMap<naga::Handle<naga::Function>, usize>,
) -> usize {
    fn calls(block: &naga::Block, out: &mut Vec<naga::Handle<naga::Function>>) {
        for st in block.iter() {
            match st {
                naga::Statement::Call { function, .. } => out.push(*function),
                naga::Statement::Block(b) => calls(b, out),
                naga::Statement::If { accept, reject, .. } => {
                    calls(accept, out);
                    calls(reject, out);
                }
                naga::Statement::Switch { cases, .. } => cases.iter().for_each(|c| calls(&c.body, out)),
                naga::Statement::Loop { body, continuing, .. } => {
                    calls(body, out);
                    calls(continuing, out);
                }
                _ => {}
            }
        }
    }
    let mut callees = Vec::new();
    calls(&f.body, &mut callees);
    let mut n = f.expressions.len();
    for h in callees {
        let size = match memo.get(&h) {
            Some(&s) => s,
            None => {
                let s = inlined_size(m, &m.functions[h], memo);
                memo.insert(h, s);
                s
            }
        };
        n += size;
    }
    n
}

#[test]
fn no_stage_inlines_to_more_than_a_driver_compiles_quickly() {
    // A GPU's shader compiler inlines every function call, so a stage that calls the BVH
    // traversal (`scene_hit`) or the photon tracer from many places compiles to many copies of
    // it. beam_refine did, 28 copies of its edge tracer: NVIDIA's compiler (driver 580 on an
    // H200) had not finished building it after a minute (docs/benchmarks.md), while the
    // photon tracer's stage, a few copies, built in well under the 5 s that the whole built-in
    // scene's first render took there. The bound is a multiple of the photon tracer's size.
    let mut sizes = Vec::new();
    for (name, _) in gpu::STAGES {
        let module = gpu::validate_stage(name).unwrap();
        let mut memo = Default::default();
        for ep in &module.entry_points {
            sizes.push((format!("{name}::{}", ep.name), inlined_size(&module, &ep.function, &mut memo)));
        }
    }
    sizes.sort_by_key(|(_, s)| std::cmp::Reverse(*s));
    for (n, s) in &sizes {
        println!("{s:>9} {n}");
    }
    let photon = sizes.iter().find(|(n, _)| n == "photon_trace::main").expect("photon_trace::main").1;
    for (n, s) in &sizes {
        assert!(*s <= 3 * photon, "{n} inlines to {s} expressions, more than 3x photon_trace's {photon}");
    }
}
