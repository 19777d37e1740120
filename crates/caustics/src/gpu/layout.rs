//! Reflection of a stage's bindings into bind group layout entries (naga), for compute and
//! render stages: group 0 is the stage's own, from its WGSL; the groups above it are shared by
//! many stages ([`SHARED_GROUPS`]), each declared once in a shared WGSL module, and their layout
//! is that declaration whatever a stage reads of it.

use super::stages::{COMMON_WGSL, SHARED, parse_source, parse_stage};
use crate::error::{Error, Result};

/// The scene's bind group (`shaders/shared/scene.wgsl`: materials, BVH, density grid,
/// environment map), made once per geometry upload (`crate::geometry::Geometry::scene`).
pub(crate) const SCENE_GROUP: u32 = 1;

/// The shared bind groups: (group index, the shared WGSL module that declares it, what it is).
pub(crate) const SHARED_GROUPS: &[(u32, &str, &str)] = &[(SCENE_GROUP, "scene", "the scene group")];

/// What a shared group's bindings are visible to: the compute stages and the fragments of the
/// hull draws (`beam_raster`, `beam_surface_raster`).
const SHARED_VISIBILITY: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE.union(wgpu::ShaderStages::FRAGMENT);

/// Group 0 of compute stage `name` as layout entries: every binding its `main` uses, typed from
/// the WGSL (naga reflection). Float textures are non-filterable (the stages read them with
/// `textureLoad`; a stage with a filtering sampler is refused).
pub fn stage_bindings(name: &str) -> Result<Vec<wgpu::BindGroupLayoutEntry>> {
    compute_stage_layout(name).map(|(entries, _)| entries)
}

/// Group 0 of render stage `name` (entry points `vs_main` and `fs_main`) as layout entries,
/// every binding either uses, visible to those that use it (as [`stage_bindings`] for compute
/// stages).
pub fn render_stage_bindings(name: &str) -> Result<Vec<wgpu::BindGroupLayoutEntry>> {
    render_stage_layout(name).map(|(entries, _)| entries)
}

/// Group 0 of compute stage `name` ([`stage_bindings`]) and the shared groups it declares.
pub(crate) fn compute_stage_layout(name: &str) -> Result<(Vec<wgpu::BindGroupLayoutEntry>, Vec<u32>)> {
    entry_bindings(name, &[("main", wgpu::ShaderStages::COMPUTE)])
}

/// Group 0 of render stage `name` ([`render_stage_bindings`]) and the shared groups it declares.
pub(crate) fn render_stage_layout(name: &str) -> Result<(Vec<wgpu::BindGroupLayoutEntry>, Vec<u32>)> {
    entry_bindings(name, &[("vs_main", wgpu::ShaderStages::VERTEX), ("fs_main", wgpu::ShaderStages::FRAGMENT)])
}

/// Shared group `group` as layout entries: every binding its module declares.
pub(crate) fn shared_group_bindings(group: u32) -> Result<Vec<wgpu::BindGroupLayoutEntry>> {
    let &(_, module_name, _) =
        SHARED_GROUPS.iter().find(|(g, _, _)| *g == group).unwrap_or_else(|| panic!("no shared bind group {group}"));
    let (_, src) = SHARED.iter().find(|(n, _)| *n == module_name).expect("the shared group's module");
    let (module, _) = parse_source(module_name, &format!("{COMMON_WGSL}\n{src}"))?;
    let mut entries = Vec::new();
    for (_, var) in module.global_variables.iter() {
        let Some(binding) = &var.binding else { continue };
        if binding.group != group {
            return Err(Error::Shader {
                name: module_name.into(),
                message: format!("binding {}: declares group {} (not {group})", binding.binding, binding.group),
            });
        }
        let ty = binding_type(module_name, &module, var, binding.binding)?;
        entries.push(wgpu::BindGroupLayoutEntry {
            binding: binding.binding,
            visibility: SHARED_VISIBILITY,
            ty,
            count: None,
        });
    }
    entries.sort_by_key(|e| e.binding);
    Ok(entries)
}

/// Group 0 of stage `name` as its entry points (name, stage) use it, and the shared groups it
/// declares (each must be one of [`SHARED_GROUPS`]).
fn entry_bindings(
    name: &str,
    entries_of: &[(&str, wgpu::ShaderStages)],
) -> Result<(Vec<wgpu::BindGroupLayoutEntry>, Vec<u32>)> {
    let (module, info) = parse_stage(name)?;
    let mut uses = Vec::new();
    for (entry, stage) in entries_of {
        let ep = module
            .entry_points
            .iter()
            .position(|e| e.name == *entry)
            .ok_or_else(|| Error::Shader { name: name.into(), message: format!("no entry point {entry}") })?;
        uses.push((info.get_entry_point(ep), *stage));
    }
    let mut entries = Vec::new();
    let mut shared = Vec::new();
    for (handle, var) in module.global_variables.iter() {
        let Some(binding) = &var.binding else { continue };
        if binding.group != 0 {
            if !SHARED_GROUPS.iter().any(|(g, _, _)| *g == binding.group) {
                return Err(Error::Shader {
                    name: name.into(),
                    message: format!("binding {}: group {} is no shared group", binding.binding, binding.group),
                });
            }
            if !shared.contains(&binding.group) {
                shared.push(binding.group);
            }
            continue;
        }
        let visibility = uses
            .iter()
            .filter(|(u, _)| !u[handle].is_empty())
            .fold(wgpu::ShaderStages::NONE, |v, (_, stage)| v | *stage);
        if visibility.is_empty() {
            continue;
        }
        let ty = binding_type(name, &module, var, binding.binding)?;
        entries.push(wgpu::BindGroupLayoutEntry { binding: binding.binding, visibility, ty, count: None });
    }
    entries.sort_by_key(|e| e.binding);
    shared.sort_unstable();
    Ok((entries, shared))
}

/// The binding type of global `var` (binding `binding` of stage or module `name`).
fn binding_type(
    name: &str,
    module: &naga::Module,
    var: &naga::GlobalVariable,
    binding: u32,
) -> Result<wgpu::BindingType> {
    let bad = |m: &str| Error::Shader { name: name.into(), message: format!("binding {binding}: {m}") };
    Ok(match (&module.types[var.ty].inner, var.space) {
        (_, naga::AddressSpace::Uniform) => wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        (_, naga::AddressSpace::Storage { access }) => wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: access == naga::StorageAccess::LOAD },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        (naga::TypeInner::Sampler { comparison: true }, _) => {
            wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison)
        }
        (naga::TypeInner::Sampler { comparison: false }, _) => return Err(bad("filtering samplers are not used")),
        (naga::TypeInner::Image { dim, arrayed, class }, _) => {
            let view_dimension = match (dim, arrayed) {
                (naga::ImageDimension::D2, false) => wgpu::TextureViewDimension::D2,
                (naga::ImageDimension::D2, true) => wgpu::TextureViewDimension::D2Array,
                // A medium's density grid.
                (naga::ImageDimension::D3, false) => wgpu::TextureViewDimension::D3,
                _ => return Err(bad("only 2D textures, 2D arrays and 3D textures are used")),
            };
            match class {
                naga::ImageClass::Sampled { kind, multi } => wgpu::BindingType::Texture {
                    sample_type: match kind {
                        naga::ScalarKind::Float => wgpu::TextureSampleType::Float { filterable: false },
                        naga::ScalarKind::Uint => wgpu::TextureSampleType::Uint,
                        _ => wgpu::TextureSampleType::Sint,
                    },
                    view_dimension,
                    multisampled: *multi,
                },
                naga::ImageClass::Depth { multi } => wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Depth,
                    view_dimension,
                    multisampled: *multi,
                },
                naga::ImageClass::Storage { format: naga::StorageFormat::Rgba8Unorm, access }
                    if *access == naga::StorageAccess::STORE =>
                {
                    wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: wgpu::TextureFormat::Rgba8Unorm,
                        view_dimension,
                    }
                }
                _ => return Err(bad("unsupported texture class")),
            }
        }
        _ => return Err(bad("unsupported binding")),
    })
}
