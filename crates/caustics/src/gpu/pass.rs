//! Compute passes named once, with resources bound by their WGSL names.
//!
//! ```ignore
//! Pass::new(ctx, "caustic_mask")
//!     .bind("mp", &params)
//!     .bind("irradiance", &irradiance)
//!     .bind("mask", &mask)
//!     .dispatch(enc, timer, [n.div_ceil(8), n.div_ceil(8), faces]);
//! ```
//!
//! The stage's name gives the pipeline (from the context's cache, with the pipeline-overridable
//! constants of [`Pass::constants`]), the wgpu label and the timer's name ([`Pass::label`] names
//! a variant such as `medium_scatter_segments` otherwise). Each name is looked up in the stage's
//! reflected interface ([`Interface`]): a name the stage does not declare, a resource of the
//! wrong kind, a name bound twice or a binding its `main` uses left unbound panic, naming the
//! stage (a programmer's error, which the tests catch). Names the stage declares but its `main`
//! does not use are accepted and left out of the bind group (its layout has no such entry), so
//! one recording can bind what several variants read. The bind group comes from the context's
//! pool ([`super::pool`]); [`Pass::group`] keeps it for several dispatches and [`Bound::variant`]
//! dispatches it with another variant of the same stage.
//!
//! The groups above 0 are shared by many stages ([`SharedGroup`]): the scene's (group 1,
//! `shaders/shared/scene.wgsl`: materials, BVH, density grid, environment map) is made once per
//! geometry upload and given with [`Pass::shared`]. A stage that imports a shared group's module
//! must be given that group, and one that does not must not (both panic, naming the stage).

use super::layout::SHARED_GROUPS;
use super::pool::LayoutOf;
use super::{GpuContext, PassTimer};
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// What a binding of a stage holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    Uniform,
    Storage,
    /// A sampled or storage texture.
    Texture,
    Sampler,
}

/// One global of a stage's group 0.
#[derive(Debug, Clone)]
pub(crate) struct Global {
    pub name: String,
    pub binding: u32,
    pub kind: Kind,
    /// Read or written by the stage's `main` (else absent from its layout).
    pub used: bool,
}

/// The bindings a compute stage declares, by their WGSL names (naga reflection of the stage's
/// source; overridable constants do not change it, so one serves every variant of a stage).
#[derive(Debug)]
pub(crate) struct Interface {
    pub stage: String,
    /// Group 0.
    pub globals: Vec<Global>,
    /// The shared groups it declares (imports), in order.
    pub shared: Vec<u32>,
}

/// A bind group shared by many stages: group `index` of every pipeline whose stage imports the
/// shared WGSL module that declares it (`gpu::layout::SHARED_GROUPS`), with the one layout that
/// module gives it. Made once by its owner (the scene's: [`crate::geometry::Geometry::scene`]).
#[derive(Clone, Debug)]
pub(crate) struct SharedGroup {
    pub index: u32,
    pub group: wgpu::BindGroup,
}

impl SharedGroup {
    /// Shared group `index` over `entries` (counted, not pooled: its owner keeps it).
    pub fn new(ctx: &GpuContext, index: u32, entries: &[wgpu::BindGroupEntry]) -> SharedGroup {
        let label = SHARED_GROUPS.iter().find(|(g, _, _)| *g == index).map_or("shared group", |(_, m, _)| *m);
        SharedGroup { index, group: ctx.shared_bind_group(label, index, entries) }
    }
}

/// What shared group `index` is, for messages.
fn shared_name(index: u32) -> String {
    SHARED_GROUPS
        .iter()
        .find(|(g, _, _)| *g == index)
        .map_or(format!("group {index}"), |(_, _, what)| format!("{what} (group {index})"))
}

/// What a resource offered for a binding is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Offered {
    Buffer(wgpu::BufferUsages),
    View,
    Sampler,
}

impl Interface {
    /// Reflect compute stage `stage` (its `main`): group 0, and the shared groups above it.
    pub fn reflect(stage: &str) -> crate::error::Result<Interface> {
        let (module, info) = super::parse_stage(stage)?;
        let ep = module
            .entry_points
            .iter()
            .position(|e| e.name == "main")
            .ok_or_else(|| crate::error::Error::Shader { name: stage.into(), message: "no entry point main".into() })?;
        let uses = info.get_entry_point(ep);
        let mut globals = Vec::new();
        let mut shared = Vec::new();
        for (handle, var) in module.global_variables.iter() {
            let Some(binding) = &var.binding else { continue };
            let name = var.name.clone().unwrap_or_default();
            let used = !uses[handle].is_empty();
            if binding.group != 0 {
                if !SHARED_GROUPS.iter().any(|(g, _, _)| *g == binding.group) {
                    return Err(crate::error::Error::Shader {
                        name: stage.into(),
                        message: format!("{name}: group {} is no shared group", binding.group),
                    });
                }
                if !shared.contains(&binding.group) {
                    shared.push(binding.group);
                }
                continue;
            }
            let kind = match (&module.types[var.ty].inner, var.space) {
                (_, naga::AddressSpace::Uniform) => Kind::Uniform,
                (_, naga::AddressSpace::Storage { .. }) => Kind::Storage,
                (naga::TypeInner::Sampler { .. }, _) => Kind::Sampler,
                _ => Kind::Texture,
            };
            globals.push(Global { name, binding: binding.binding, kind, used });
        }
        globals.sort_by_key(|g| g.binding);
        shared.sort_unstable();
        Ok(Interface { stage: stage.into(), globals, shared })
    }

    /// The reflected interface of `stage`, reflected once per process (the sources are built in).
    pub fn of(stage: &str) -> Arc<Interface> {
        static CACHE: OnceLock<Mutex<HashMap<String, Arc<Interface>>>> = OnceLock::new();
        let mut cache = CACHE.get_or_init(Default::default).lock().unwrap_or_else(|e| e.into_inner());
        cache
            .entry(stage.to_string())
            .or_insert_with(|| Arc::new(Interface::reflect(stage).unwrap_or_else(|e| panic!("{e}"))))
            .clone()
    }

    /// The binding index of each offered (name, resource), None for a name whose binding `main`
    /// does not use; or why the list does not fit the stage.
    pub fn resolve(&self, offered: &[(&str, Offered)]) -> Result<Vec<Option<u32>>, String> {
        let stage = &self.stage;
        let mut out = Vec::with_capacity(offered.len());
        for (i, (name, what)) in offered.iter().enumerate() {
            let Some(g) = self.globals.iter().find(|g| g.name == *name) else {
                let names: Vec<&str> = self.globals.iter().map(|g| g.name.as_str()).collect();
                return Err(format!("stage {stage} has no binding named {name} (it has {})", names.join(", ")));
            };
            if offered[..i].iter().any(|(n, _)| n == name) {
                return Err(format!("stage {stage}: {name} is bound twice"));
            }
            let fits = match (g.kind, what) {
                (Kind::Uniform, Offered::Buffer(u)) => u.contains(wgpu::BufferUsages::UNIFORM),
                (Kind::Storage, Offered::Buffer(u)) => u.contains(wgpu::BufferUsages::STORAGE),
                (Kind::Texture, Offered::View) | (Kind::Sampler, Offered::Sampler) => true,
                _ => false,
            };
            if !fits {
                return Err(format!("stage {stage}: {name} is a {:?} binding, given {what:?}", g.kind));
            }
            out.push(g.used.then_some(g.binding));
        }
        let missing: Vec<&str> = self
            .globals
            .iter()
            .filter(|g| g.used && !offered.iter().any(|(n, _)| *n == g.name))
            .map(|g| g.name.as_str())
            .collect();
        if !missing.is_empty() {
            return Err(format!("stage {stage}: nothing bound to {}", missing.join(", ")));
        }
        Ok(out)
    }

    /// Whether the shared groups `given` (by index) are those the stage declares; else why not.
    pub fn check_shared(&self, given: &[u32]) -> Result<(), String> {
        let stage = &self.stage;
        for (i, g) in given.iter().enumerate() {
            if given[..i].contains(g) {
                return Err(format!("stage {stage}: {} is given twice", shared_name(*g)));
            }
            if !self.shared.contains(g) {
                return Err(format!("stage {stage} does not use {}, which is given", shared_name(*g)));
            }
        }
        match self.shared.iter().find(|g| !given.contains(g)) {
            Some(g) => Err(format!("stage {stage}: {} is not given", shared_name(*g))),
            None => Ok(()),
        }
    }
}

/// What can be bound: a whole buffer, a part of one, a texture view or a sampler.
pub(crate) trait Resource<'a> {
    fn resource(self) -> wgpu::BindingResource<'a>;
}

impl<'a> Resource<'a> for &'a wgpu::Buffer {
    fn resource(self) -> wgpu::BindingResource<'a> {
        self.as_entire_binding()
    }
}

impl<'a> Resource<'a> for wgpu::BufferBinding<'a> {
    fn resource(self) -> wgpu::BindingResource<'a> {
        wgpu::BindingResource::Buffer(self)
    }
}

impl<'a> Resource<'a> for &'a wgpu::TextureView {
    fn resource(self) -> wgpu::BindingResource<'a> {
        wgpu::BindingResource::TextureView(self)
    }
}

impl<'a> Resource<'a> for &'a wgpu::Sampler {
    fn resource(self) -> wgpu::BindingResource<'a> {
        wgpu::BindingResource::Sampler(self)
    }
}

impl<'a> Resource<'a> for wgpu::BindingResource<'a> {
    fn resource(self) -> wgpu::BindingResource<'a> {
        self
    }
}

fn offered(r: &wgpu::BindingResource) -> Offered {
    match r {
        wgpu::BindingResource::Buffer(b) => Offered::Buffer(b.buffer.usage()),
        wgpu::BindingResource::TextureView(_) => Offered::View,
        wgpu::BindingResource::Sampler(_) => Offered::Sampler,
        _ => unreachable!("the renderer binds buffers, texture views and samplers only"),
    }
}

/// A compute pass being described: its stage, variant and resources.
#[must_use = "a pass records nothing until it is dispatched"]
pub(crate) struct Pass<'a> {
    ctx: &'a GpuContext,
    stage: &'a str,
    label: &'a str,
    constants: Vec<(&'a str, f64)>,
    entries: Vec<(&'a str, wgpu::BindingResource<'a>)>,
    shared: Vec<&'a SharedGroup>,
}

impl<'a> Pass<'a> {
    /// A pass of compute stage `stage` (also its label and timer name).
    pub fn new(ctx: &'a GpuContext, stage: &'a str) -> Pass<'a> {
        Pass { ctx, stage, label: stage, constants: Vec::new(), entries: Vec::new(), shared: Vec::new() }
    }

    /// The values of the stage's pipeline-overridable constants.
    pub fn constants(mut self, constants: &[(&'a str, f64)]) -> Pass<'a> {
        self.constants = constants.to_vec();
        self
    }

    /// Label and time the pass as `label` (a variant of the stage, or passes timed together).
    pub fn label(mut self, label: &'a str) -> Pass<'a> {
        self.label = label;
        self
    }

    /// Bind `resource` to the stage's global variable `name`.
    pub fn bind(mut self, name: &'a str, resource: impl Resource<'a>) -> Pass<'a> {
        self.entries.push((name, resource.resource()));
        self
    }

    /// Set shared bind group `group` (the scene's: `.shared(&geo.scene)`).
    pub fn shared(mut self, group: &'a SharedGroup) -> Pass<'a> {
        self.shared.push(group);
        self
    }

    /// Bind each (name, resource) of `pairs`.
    pub fn bind_all<R: Resource<'a>>(self, pairs: impl IntoIterator<Item = (&'a str, R)>) -> Pass<'a> {
        pairs.into_iter().fold(self, |pass, (name, resource)| pass.bind(name, resource))
    }

    /// The pipeline and bind group, checked against the stage's interface (panics on a
    /// mismatch, naming the stage and the binding).
    pub fn group(self) -> Bound {
        let interface = Interface::of(self.stage);
        let offers: Vec<(&str, Offered)> = self.entries.iter().map(|(n, r)| (*n, offered(r))).collect();
        let bindings = interface.resolve(&offers).unwrap_or_else(|e| panic!("{e}"));
        let given: Vec<u32> = self.shared.iter().map(|g| g.index).collect();
        interface.check_shared(&given).unwrap_or_else(|e| panic!("{e}"));
        let shared = self.shared.iter().map(|g| (g.index, g.group.clone())).collect();
        let mut entries: Vec<wgpu::BindGroupEntry> = bindings
            .into_iter()
            .zip(self.entries)
            .filter_map(|(b, (_, resource))| Some(wgpu::BindGroupEntry { binding: b?, resource }))
            .collect();
        entries.sort_by_key(|e| e.binding);
        let pipeline = self.ctx.compute_pipeline_with(self.stage, &self.constants);
        let group = self.ctx.bind_group(self.label, LayoutOf::Compute(pipeline.clone()), &entries);
        Bound {
            ctx: self.ctx.clone(),
            stage: self.stage.to_string(),
            label: self.label.to_string(),
            pipeline,
            group,
            shared,
        }
    }

    /// Record the pass: `groups` workgroups.
    pub fn dispatch(self, enc: &mut wgpu::CommandEncoder, timer: &mut PassTimer, groups: [u32; 3]) {
        self.group().dispatch(enc, timer, groups);
    }

    /// Record the pass, its workgroup counts read from `args` at byte `offset`.
    pub fn dispatch_indirect(
        self,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        args: &wgpu::Buffer,
        offset: u64,
    ) {
        self.group().dispatch_indirect(enc, timer, args, offset);
    }
}

/// A stage's pipeline with its bind group: dispatched once or many times, alone or in a pass
/// with others ([`begin`]).
#[derive(Clone)]
pub(crate) struct Bound {
    ctx: GpuContext,
    stage: String,
    label: String,
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    /// The shared groups, by index.
    shared: Vec<(u32, wgpu::BindGroup)>,
}

impl Bound {
    /// The same bindings for another variant of the stage (`constants`), labelled and timed as
    /// `label` (the layout does not depend on the constants).
    pub fn variant(&self, label: &str, constants: &[(&str, f64)]) -> Bound {
        let pipeline = self.ctx.compute_pipeline_with(&self.stage, constants);
        Bound { label: label.to_string(), pipeline, ..self.clone() }
    }

    /// What its passes are labelled and timed as.
    pub fn label(&self) -> &str {
        &self.label
    }

    /// Record a pass of its own: `groups` workgroups.
    pub fn dispatch(&self, enc: &mut wgpu::CommandEncoder, timer: &mut PassTimer, groups: [u32; 3]) {
        let mut cp = begin(enc, timer, &self.label);
        self.dispatch_in(&mut cp, groups);
    }

    /// Record a pass of its own, its workgroup counts read from `args` at byte `offset`.
    pub fn dispatch_indirect(
        &self,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        args: &wgpu::Buffer,
        offset: u64,
    ) {
        let mut cp = begin(enc, timer, &self.label);
        self.dispatch_indirect_in(&mut cp, args, offset);
    }

    /// Dispatch `groups` workgroups inside the open pass `cp`.
    pub fn dispatch_in(&self, cp: &mut wgpu::ComputePass, [x, y, z]: [u32; 3]) {
        self.set(cp);
        cp.dispatch_workgroups(x, y, z);
    }

    /// Dispatch indirectly (`args` at byte `offset`) inside the open pass `cp`.
    pub fn dispatch_indirect_in(&self, cp: &mut wgpu::ComputePass, args: &wgpu::Buffer, offset: u64) {
        self.set(cp);
        cp.dispatch_workgroups_indirect(args, offset);
    }

    /// Set the pipeline, its own group and the shared ones.
    fn set(&self, cp: &mut wgpu::ComputePass) {
        cp.set_pipeline(&self.pipeline);
        cp.set_bind_group(0, &self.group, &[]);
        for (index, group) in &self.shared {
            cp.set_bind_group(*index, group, &[]);
        }
    }
}

/// Open a compute pass labelled and timed as `label`, for several dispatches
/// ([`Bound::dispatch_in`]).
pub(crate) fn begin<'e>(
    enc: &'e mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
    label: &str,
) -> wgpu::ComputePass<'e> {
    enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: timer.compute(label) })
}

#[cfg(test)]
mod tests {
    use super::*;

    const UNIFORM: Offered = Offered::Buffer(wgpu::BufferUsages::UNIFORM);
    const STORAGE: Offered = Offered::Buffer(wgpu::BufferUsages::STORAGE);

    fn mask() -> Arc<Interface> {
        Interface::of("caustic_mask")
    }

    #[test]
    fn names_resolve_to_their_bindings_in_any_order() {
        let b = mask().resolve(&[("mask", STORAGE), ("mp", UNIFORM), ("irradiance", STORAGE)]).unwrap();
        assert_eq!(b, [Some(2), Some(0), Some(1)]);
    }

    #[test]
    fn a_wrong_name_is_refused_with_the_stage_and_the_name() {
        let e = mask().resolve(&[("mp", UNIFORM), ("irradiance", STORAGE), ("maks", STORAGE)]).unwrap_err();
        assert!(e.contains("caustic_mask") && e.contains("maks") && e.contains("mask"), "{e}");
    }

    #[test]
    #[should_panic(expected = "stage caustic_mask: nothing bound to irradiance")]
    fn a_missing_binding_panics() {
        mask().resolve(&[("mp", UNIFORM), ("mask", STORAGE)]).unwrap_or_else(|e| panic!("{e}"));
    }

    #[test]
    fn a_binding_twice_or_of_the_wrong_kind_is_refused() {
        let twice = mask().resolve(&[("mp", UNIFORM), ("irradiance", STORAGE), ("mask", STORAGE), ("mp", UNIFORM)]);
        assert!(twice.unwrap_err().contains("mp is bound twice"));
        let kind = mask().resolve(&[("mp", STORAGE), ("irradiance", STORAGE), ("mask", STORAGE)]);
        assert!(kind.unwrap_err().contains("mp is a Uniform binding"));
        let view = mask().resolve(&[("mp", UNIFORM), ("irradiance", Offered::View), ("mask", STORAGE)]);
        assert!(view.unwrap_err().contains("irradiance"));
    }

    #[test]
    fn a_shared_group_missing_extra_or_twice_is_refused_with_the_stage() {
        let trace = Interface::of("photon_trace");
        assert_eq!(trace.shared, [1]);
        assert!(trace.check_shared(&[1]).is_ok());
        let missing = trace.check_shared(&[]).unwrap_err();
        assert!(
            missing.contains("photon_trace") && missing.contains("scene group (group 1) is not given"),
            "{missing}"
        );
        assert!(trace.check_shared(&[1, 1]).unwrap_err().contains("given twice"));
        let extra = mask().check_shared(&[1]).unwrap_err();
        assert!(extra.contains("caustic_mask does not use the scene group"), "{extra}");
    }

    #[test]
    fn every_stage_reflects_and_its_used_bindings_match_its_layout() {
        for (name, _) in super::super::STAGES {
            if name.starts_with("raster") || name.ends_with("_raster") {
                continue;
            }
            let i = Interface::of(name);
            let used: Vec<u32> = i.globals.iter().filter(|g| g.used).map(|g| g.binding).collect();
            let layout: Vec<u32> = super::super::stage_bindings(name).unwrap().iter().map(|e| e.binding).collect();
            assert_eq!(used, layout, "{name}");
        }
    }
}
