//! Reflection of a stage's group 0 into bind group layout entries (naga), for compute and
//! render stages.

use super::stages::parse_stage;
use crate::error::{Error, Result};

/// Group 0 of compute stage `name` as layout entries: every binding its `main` uses, typed from
/// the WGSL (naga reflection). Float textures are non-filterable (the stages read them with
/// `textureLoad`; a stage with a filtering sampler is refused).
pub fn stage_bindings(name: &str) -> Result<Vec<wgpu::BindGroupLayoutEntry>> {
    entry_bindings(name, &[("main", wgpu::ShaderStages::COMPUTE)])
}

/// Group 0 of render stage `name` (entry points `vs_main` and `fs_main`) as layout entries,
/// every binding either uses, visible to those that use it (as [`stage_bindings`] for compute
/// stages).
pub fn render_stage_bindings(name: &str) -> Result<Vec<wgpu::BindGroupLayoutEntry>> {
    entry_bindings(name, &[("vs_main", wgpu::ShaderStages::VERTEX), ("fs_main", wgpu::ShaderStages::FRAGMENT)])
}

/// Group 0 of stage `name` as its entry points (name, stage) use it.
fn entry_bindings(name: &str, entries_of: &[(&str, wgpu::ShaderStages)]) -> Result<Vec<wgpu::BindGroupLayoutEntry>> {
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
    for (handle, var) in module.global_variables.iter() {
        let Some(binding) = &var.binding else { continue };
        let visibility = uses
            .iter()
            .filter(|(u, _)| !u[handle].is_empty())
            .fold(wgpu::ShaderStages::NONE, |v, (_, stage)| v | *stage);
        if visibility.is_empty() {
            continue;
        }
        let bad = |m: &str| Error::Shader { name: name.into(), message: format!("binding {}: {m}", binding.binding) };
        if binding.group != 0 {
            return Err(bad("only group 0 is used"));
        }
        let ty = match (&module.types[var.ty].inner, var.space) {
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
        };
        entries.push(wgpu::BindGroupLayoutEntry { binding: binding.binding, visibility, ty, count: None });
    }
    entries.sort_by_key(|e| e.binding);
    Ok(entries)
}
