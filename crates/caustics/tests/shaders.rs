//! Every WGSL stage parses and validates with naga, and every GPU struct matches its WGSL
//! declaration in size and field offsets.

use caustics::gpu::{self, types::LAYOUTS};

#[test]
fn every_stage_validates() {
    for (name, _) in gpu::STAGES {
        if let Err(e) = gpu::validate_stage(name) {
            panic!("{e}");
        }
    }
}

#[test]
fn gpu_structs_match_wgsl() {
    let mut checked = 0;
    for (name, _) in gpu::STAGES {
        let module = gpu::validate_stage(name).unwrap();
        for (_, ty) in module.types.iter() {
            let Some(wgsl_name) = &ty.name else { continue };
            let naga::TypeInner::Struct { span, .. } = &ty.inner else { continue };
            for (rust, wgsl, size) in LAYOUTS {
                if wgsl == wgsl_name {
                    assert_eq!(*span as usize, *size, "{rust} is {size} bytes, WGSL {wgsl} in {name} is {span}");
                    checked += 1;
                }
            }
        }
    }
    // Every Rust struct is declared in at least one stage.
    for (rust, wgsl, _) in LAYOUTS {
        let found = gpu::STAGES
            .iter()
            .any(|(n, _)| gpu::validate_stage(n).unwrap().types.iter().any(|(_, t)| t.name.as_deref() == Some(*wgsl)));
        assert!(found, "{rust}: no WGSL struct {wgsl}");
    }
    assert!(checked >= LAYOUTS.len());
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
