//! The window: winit's event loop, a wgpu surface on the renderer's device, egui-winit for
//! input and egui-wgpu for painting the panels and the renderer's display texture.

use super::Start;
use super::paint::Painter;
use super::session::Session;
use super::ui::{self, UiState};
use anyhow::{Context as _, Result, anyhow};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Window, WindowId};

struct Running {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    device: wgpu::Device,
    queue: wgpu::Queue,
    session: Session,
    ui_state: UiState,
    egui_ctx: egui::Context,
    egui_state: egui_winit::State,
    painter: Painter,
    next_repaint: Option<Instant>,
    /// GPU errors outside the renderer's error scopes (shown in the panel instead of wgpu's
    /// default panic).
    gpu_error: Arc<Mutex<Option<String>>>,
}

struct App {
    start: Option<Start>,
    running: Option<Running>,
    error: Option<anyhow::Error>,
}

pub fn run(start: Start) -> Result<()> {
    let event_loop = EventLoop::new().map_err(|e| {
        anyhow!(
            "cannot open a window: {e} (the viewer needs a display: set DISPLAY or WAYLAND_DISPLAY, or run under Xvfb)"
        )
    })?;
    event_loop.set_control_flow(ControlFlow::Wait);
    let mut app = App { start: Some(start), running: None, error: None };
    event_loop.run_app(&mut app).context("window event loop")?;
    match app.error.take() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

impl Running {
    fn new(event_loop: &ActiveEventLoop, start: Start) -> Result<Running> {
        let Start { scene, settings, caustic_map_given, spheres, args } = start;
        let (w, h) = args.size;
        let window = Arc::new(
            event_loop
                .create_window(
                    Window::default_attributes()
                        .with_title(format!("caustics — {}", scene.name))
                        .with_inner_size(winit::dpi::LogicalSize::new(w as f64, h as f64)),
                )
                .context("cannot create the window")?,
        );
        let instance = super::instance();
        let surface = instance.create_surface(window.clone()).context("cannot create a surface for the window")?;
        let (adapter, device, queue) = super::open_device(&instance, args.adapter.as_deref(), Some(&surface))?;
        let info = adapter.get_info();
        eprintln!("adapter: {} ({:?})", info.name, info.backend);
        let gpu_error = Arc::new(Mutex::new(None::<String>));
        {
            let slot = gpu_error.clone();
            device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
                eprintln!("GPU error: {e}");
                if let Ok(mut s) = slot.lock() {
                    *s = Some(e.to_string());
                }
            }));
        }
        let caps = surface.get_capabilities(&adapter);
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| matches!(f, wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Rgba8Unorm))
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| anyhow!("the surface offers no format"))?;
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            color_space: wgpu::SurfaceColorSpace::Auto,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
        };
        surface.configure(&device, &config);
        let mut settings = settings;
        if !caustic_map_given {
            let ctx = caustics::gpu::GpuContext::from_device(&device, &queue);
            settings.photons.caustic_map_size = caustics::render::RenderSettings::fitting_caustic_map_size(
                &ctx,
                &scene,
                settings.photons.caustic_map_size,
            );
        }
        let mut session = Session::new(&device, &queue, scene, settings, args.screenshot_dir.clone())?;
        session.sphere_args = spheres;
        if let Some(t) = args.time {
            session.act(crate::view::session::Action::SetTime(t))?;
        }
        if args.play {
            session.act(crate::view::session::Action::Play(true))?;
        }
        let egui_ctx = egui::Context::default();
        let egui_state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            window.theme(),
            Some(device.limits().max_texture_dimension_2d as usize),
        );
        let painter = Painter::new(&device, format);
        Ok(Running {
            window,
            surface,
            config,
            device,
            queue,
            session,
            ui_state: UiState::new(args.scale),
            egui_ctx,
            egui_state,
            painter,
            next_repaint: Some(Instant::now()),
            gpu_error,
        })
    }

    fn resize(&mut self, size: winit::dpi::PhysicalSize<u32>) {
        self.config.width = size.width.max(1);
        self.config.height = size.height.max(1);
        self.surface.configure(&self.device, &self.config);
    }

    fn redraw(&mut self) {
        self.session.update();
        if let Some(e) = self.gpu_error.lock().ok().and_then(|mut s| s.take()) {
            self.session.error = Some(format!("GPU error: {e}"));
        }
        let raw = self.egui_state.take_egui_input(&self.window);
        let (session, state, display) = (&mut self.session, &mut self.ui_state, self.painter.display_id());
        let mut full = self.egui_ctx.run_ui(raw, |ui| ui::draw(ui, state, session, display));
        self.egui_state.handle_platform_output(&self.window, std::mem::take(&mut full.platform_output));
        // A frame of the renderer when something changed; its display texture is shown in this
        // same paint. (Not before egui's second pass: the first one does not know the panel's
        // width yet, and a frame at the wrong size costs a full frame.)
        let settled = self.egui_ctx.cumulative_pass_nr() >= 2;
        if settled
            && let Ok(true) = self.session.render()
            && let Some(tex) = self.session.display()
        {
            let first = self.painter.display_id().is_none();
            self.painter.set_display(&self.device, tex);
            if first {
                // The UI pass did not know the first frame's texture: paint again.
                self.next_repaint = Some(Instant::now());
            }
        }
        let delay = full.viewport_output.get(&egui::ViewportId::ROOT).map(|v| v.repaint_delay).unwrap_or(Duration::MAX);
        self.paint(full);
        let mut next = (delay < Duration::from_secs(3600)).then(|| Instant::now() + delay);
        if self.session.needs_frame() {
            next = Some(Instant::now());
        }
        if self.session.awaiting_gpu() {
            // The frame's statistics and completion time arrive asynchronously.
            let t = Instant::now() + Duration::from_millis(30);
            next = Some(next.map_or(t, |n| n.min(t)));
        }
        if self.session.reference_progress().is_some() {
            // The progress bar and the finished reference.
            let t = Instant::now() + Duration::from_millis(150);
            next = Some(next.map_or(t, |n| n.min(t)));
        }
        if let Some(n) = next {
            self.next_repaint = Some(self.next_repaint.map_or(n, |m| m.min(n)));
        }
    }

    fn paint(&mut self, full: egui::FullOutput) {
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.device, &self.config);
                self.next_repaint = Some(Instant::now());
                return;
            }
            _ => return,
        };
        let view = frame.texture.create_view(&wgpu::TextureViewDescriptor::default());
        let size = [self.config.width, self.config.height];
        self.painter.paint(&self.device, &self.queue, &view, size, &self.egui_ctx, full);
        self.window.pre_present_notify();
        self.queue.present(frame);
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        let Some(start) = self.start.take() else { return };
        match Running::new(event_loop, start) {
            Ok(r) => {
                r.window.request_redraw();
                self.running = Some(r);
            }
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(r) = self.running.as_mut() else { return };
        let response = r.egui_state.on_window_event(&r.window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::DroppedFile(path) => {
                // A failure stays in the panel (`Session::error`); the scene is kept.
                let _ = r.session.act(crate::view::session::Action::Open(path));
                r.window.request_redraw();
            }
            WindowEvent::Resized(size) => {
                r.resize(size);
                r.window.request_redraw();
            }
            WindowEvent::RedrawRequested => {
                r.next_repaint = None;
                r.redraw();
            }
            _ => {
                if response.repaint {
                    r.window.request_redraw();
                }
            }
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let Some(r) = self.running.as_mut() else { return };
        match r.next_repaint {
            Some(t) if t <= Instant::now() => {
                r.next_repaint = None;
                r.window.request_redraw();
                event_loop.set_control_flow(ControlFlow::Wait);
            }
            Some(t) => event_loop.set_control_flow(ControlFlow::WaitUntil(t)),
            None => event_loop.set_control_flow(ControlFlow::Wait),
        }
    }
}
