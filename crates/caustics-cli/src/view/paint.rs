//! Painting egui and the renderer's display texture with egui-wgpu into any colour target (the
//! window's surface texture, or an offscreen texture in the tests).

/// egui-wgpu's renderer and the display texture's egui id.
pub struct Painter {
    renderer: egui_wgpu::Renderer,
    display_id: Option<egui::TextureId>,
    /// The texture registered under `display_id` (a persistent renderer keeps the same one:
    /// then nothing is re-registered).
    display: Option<wgpu::Texture>,
}

impl Painter {
    /// A painter for targets of `format` (preferably a non-sRGB 8-bit format: egui blends in
    /// gamma space, and the display texture holds sRGB-encoded values).
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Painter {
        Painter {
            renderer: egui_wgpu::Renderer::new(device, format, egui_wgpu::RendererOptions::default()),
            display_id: None,
            display: None,
        }
    }

    /// The display texture's id for the UI (None before the first frame).
    pub fn display_id(&self) -> Option<egui::TextureId> {
        self.display_id
    }

    /// Show `display` (the renderer's Rgba8Unorm display texture) under the display id.
    pub fn set_display(&mut self, device: &wgpu::Device, display: &wgpu::Texture) {
        if self.display.as_ref() == Some(display) {
            return;
        }
        self.display = Some(display.clone());
        let view = display.create_view(&wgpu::TextureViewDescriptor::default());
        match self.display_id {
            Some(id) => {
                self.renderer.update_egui_texture_from_wgpu_texture(device, &view, wgpu::FilterMode::Linear, id)
            }
            None => {
                self.display_id = Some(self.renderer.register_native_texture(device, &view, wgpu::FilterMode::Linear))
            }
        }
    }

    /// Paint one egui output into `target` (`size` pixels), cleared first, and submit.
    pub fn paint(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        target: &wgpu::TextureView,
        size: [u32; 2],
        ctx: &egui::Context,
        output: egui::FullOutput,
    ) {
        let ppp = output.pixels_per_point;
        let clipped = ctx.tessellate(output.shapes, ppp);
        let sd = egui_wgpu::ScreenDescriptor { size_in_pixels: size, pixels_per_point: ppp };
        for (id, deltas) in &output.textures_delta.set {
            for d in deltas {
                self.renderer.update_texture(device, queue, *id, d);
            }
        }
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("egui") });
        let extra = self.renderer.update_buffers(device, queue, &mut enc, &clipped, &sd);
        {
            let mut pass = enc
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("egui"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: target,
                        resolve_target: None,
                        depth_slice: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color { r: 0.05, g: 0.05, b: 0.05, a: 1.0 }),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    ..Default::default()
                })
                .forget_lifetime();
            self.renderer.render(&mut pass, &clipped, &sd);
        }
        queue.submit(extra.into_iter().chain([enc.finish()]));
        for id in &output.textures_delta.free {
            self.renderer.free_texture(id);
        }
    }
}
