//! The aquarium window (`shoal run`): winit 0.30 + egui tuning panel over the wgpu renderer.
//!
//! Mouse: left drag orbits, right or middle drag pans, the wheel zooms, a left click (without
//! dragging) selects the fish under the cursor (ray against each fish's bounding sphere).

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use glam::Vec2;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Window, WindowId};

use super::shaders::{ShaderSources, ShaderWatcher};
use super::{
    Camera, Gpu, GpuError, OverlayLine, OverlayToggles, RenderError, RenderTimings, Renderer,
    SceneDriver,
};
use crate::motion::{MotionRequest, Side, TurnKind};

/// Why the window could not run.
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// No display to open a window on.
    #[error(
        "cannot open a window: {0}. With no display, render headless instead: \
         `shoal render --seconds 5 --out aquarium.gif`"
    )]
    NoDisplay(String),
    /// No GPU adapter or device.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The renderer failed.
    #[error(transparent)]
    Render(#[from] RenderError),
}

/// Options of the window.
#[derive(Debug, Clone, Copy, Default)]
pub struct AppOptions {
    /// Draw this many frames, then close (for tests and scripted runs).
    pub frames: Option<u64>,
    /// Fish selected at start.
    pub select: Option<usize>,
    /// Overlays shown at start.
    pub overlays: OverlayToggles,
}

/// Opens the aquarium window on `scene` and runs until it is closed (or `options.frames` are
/// presented). Returns the number of frames presented.
pub fn run_window(scene: Box<dyn SceneDriver>, options: AppOptions) -> Result<u64, AppError> {
    let has_display = ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .any(|v| std::env::var_os(v).is_some_and(|s| !s.is_empty()));
    if !has_display {
        return Err(AppError::NoDisplay(
            "neither DISPLAY nor WAYLAND_DISPLAY is set".into(),
        ));
    }
    let event_loop = EventLoop::new().map_err(|e| AppError::NoDisplay(e.to_string()))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let camera = scene.default_camera();
    let mut scene = scene;
    let mut ui = UiState::new(camera);
    ui.toggles = options.overlays;
    if let Some(fish) = options.select.filter(|&f| f < scene.num_fish()) {
        ui.selected = Some(fish);
        ui.follow = true;
        scene.set_selected(Some(fish));
    }
    let mut app = App {
        scene,
        options,
        window: None,
        error: None,
        ui,
        presented: 0,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| AppError::NoDisplay(e.to_string()))?;
    if let Some(err) = app.error {
        return Err(err);
    }
    Ok(app.presented)
}

struct WindowState {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: Gpu,
    renderer: Renderer,
    egui_ctx: egui::Context,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
}

#[derive(Debug, Clone, Copy, Default)]
struct FrameTimes {
    sim_ms: f32,
    upload_ms: f32,
    draw_ms: f32,
    frame_ms: f32,
}

struct UiState {
    camera: Camera,
    follow: bool,
    selected: Option<usize>,
    species: usize,
    paused: bool,
    step_once: bool,
    speed: f32,
    toggles: OverlayToggles,
    overlay: Vec<OverlayLine>,
    log: VecDeque<String>,
    wave: Vec<[f64; 2]>,
    inspect: Vec<(String, String)>,
    times: VecDeque<FrameTimes>,
    /// The renderer's counts of the frame being drawn (fish drawn, culled, triangles …).
    render_counts: RenderTimings,
    cursor: Vec2,
    press: Option<(MouseButton, Vec2)>,
    dragged: bool,
    last_frame: Instant,
    watcher: Option<ShaderWatcher>,
    shader_error: Option<String>,
    scratch_log: Vec<String>,
    /// Set by the panel's "restart scene" button; handled at the start of the next frame.
    restart_requested: bool,
}

impl UiState {
    fn new(camera: Camera) -> Self {
        Self {
            camera,
            follow: false,
            selected: None,
            species: 0,
            paused: false,
            step_once: false,
            restart_requested: false,
            speed: 1.0,
            toggles: OverlayToggles::default(),
            overlay: Vec::new(),
            log: VecDeque::new(),
            wave: Vec::new(),
            inspect: Vec::new(),
            times: VecDeque::new(),
            render_counts: RenderTimings::default(),
            cursor: Vec2::ZERO,
            press: None,
            dragged: false,
            last_frame: Instant::now(),
            watcher: None,
            shader_error: None,
            scratch_log: Vec::new(),
        }
    }

    fn log(&mut self, line: impl Into<String>) {
        let line = line.into();
        log::info!("{line}");
        self.log.push_back(line);
        while self.log.len() > 300 {
            self.log.pop_front();
        }
    }
}

struct App {
    scene: Box<dyn SceneDriver>,
    options: AppOptions,
    window: Option<WindowState>,
    error: Option<AppError>,
    ui: UiState,
    presented: u64,
}

impl App {
    fn init(&mut self, event_loop: &ActiveEventLoop) -> Result<(), AppError> {
        let window = event_loop
            .create_window(
                Window::default_attributes()
                    .with_title("shoal — aquarium")
                    .with_inner_size(winit::dpi::LogicalSize::new(1280.0, 760.0)),
            )
            .map_err(|e| AppError::NoDisplay(e.to_string()))?;
        let window = Arc::new(window);
        let instance = Gpu::new_instance();
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| GpuError::Surface(e.to_string()))?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: Some(&surface),
            apply_limit_buckets: false,
        }))
        .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let gpu = Gpu::open(instance, adapter)?;
        println!("adapter: {}", gpu.adapter_summary());
        let caps = surface.get_capabilities(&gpu.adapter);
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| f.is_srgb())
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| GpuError::Surface("the surface supports no format".into()))?;
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps
                .alpha_modes
                .first()
                .copied()
                .unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
            color_space: wgpu::SurfaceColorSpace::Auto,
        };
        surface.configure(&gpu.device, &config);
        let sources = match super::shaders::source_dir() {
            Some(dir) => {
                match ShaderWatcher::new(&dir) {
                    Ok(w) => {
                        self.ui
                            .log(format!("watching {} for shader edits", dir.display()));
                        self.ui.watcher = Some(w);
                    }
                    Err(e) => self.ui.log(e),
                }
                ShaderSources::load_dir(&dir).unwrap_or_default()
            }
            None => ShaderSources::embedded(),
        };
        let mut renderer = match Renderer::with_shaders(&gpu, format, sources) {
            Ok(r) => r,
            Err(e) => {
                self.ui
                    .log(format!("{e}\n(falling back to the built-in shaders)"));
                Renderer::new(&gpu, format)?
            }
        };
        for mesh in self.scene.meshes() {
            renderer.upload_mesh(&gpu, &mesh)?;
        }
        if let Err(e) = self.scene.enable_hot_reload() {
            self.ui.log(format!("script hot reload is off: {e}"));
        }
        let egui_ctx = egui::Context::default();
        let egui_state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(gpu.device.limits().max_texture_dimension_2d as usize),
        );
        let egui_renderer =
            egui_wgpu::Renderer::new(&gpu.device, format, egui_wgpu::RendererOptions::default());
        self.ui.log(format!(
            "{} fish, MSAA {}×, surface {format:?}",
            self.scene.num_fish(),
            renderer.sample_count()
        ));
        self.window = Some(WindowState {
            window,
            surface,
            config,
            gpu,
            renderer,
            egui_ctx,
            egui_state,
            egui_renderer,
        });
        Ok(())
    }

    fn pick(&mut self) {
        let Some(ws) = &self.window else { return };
        let size = Vec2::new(ws.config.width as f32, ws.config.height as f32);
        self.ui.selected = pick_fish(&self.ui.camera, self.ui.cursor, size, &*self.scene);
        self.scene.set_selected(self.ui.selected);
        if let Some(i) = self.ui.selected {
            self.ui.species = self.scene.species_of(i).unwrap_or(0);
        }
    }

    fn handle_input(&mut self, event: &WindowEvent) {
        match event {
            WindowEvent::CursorMoved { position, .. } => {
                let p = Vec2::new(position.x as f32, position.y as f32);
                let delta = p - self.ui.cursor;
                self.ui.cursor = p;
                let height = self
                    .window
                    .as_ref()
                    .map_or(1.0, |w| w.config.height.max(1) as f32);
                if let Some((button, start)) = self.ui.press {
                    if (p - start).length() > 4.0 {
                        self.ui.dragged = true;
                    }
                    match button {
                        MouseButton::Left => self.ui.camera.orbit(
                            delta.x / height * std::f32::consts::PI,
                            delta.y / height * std::f32::consts::PI,
                        ),
                        MouseButton::Right | MouseButton::Middle => {
                            self.ui.follow = false;
                            self.ui.camera.pan(delta.x / height, delta.y / height);
                        }
                        _ => {}
                    }
                }
            }
            WindowEvent::MouseInput { state, button, .. } => match state {
                ElementState::Pressed => {
                    self.ui.press = Some((*button, self.ui.cursor));
                    self.ui.dragged = false;
                }
                ElementState::Released => {
                    if *button == MouseButton::Left && !self.ui.dragged {
                        self.pick();
                    }
                    self.ui.press = None;
                }
            },
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => *y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                self.ui.camera.zoom(0.9f32.powf(lines));
            }
            _ => {}
        }
    }

    fn frame(&mut self, event_loop: &ActiveEventLoop) -> Result<(), AppError> {
        let now = Instant::now();
        let frame_dt = (now - self.ui.last_frame).as_secs_f32();
        self.ui.last_frame = now;

        // Simulation.
        let sim_start = Instant::now();
        if !self.ui.paused || self.ui.step_once {
            let dt = if self.ui.paused {
                1.0 / 60.0
            } else {
                frame_dt.min(0.1)
            };
            self.scene.step(dt * self.ui.speed);
            self.ui.step_once = false;
        }
        let sim_ms = sim_start.elapsed().as_secs_f32() * 1e3;
        self.scene.drain_log(&mut self.ui.scratch_log);
        for line in std::mem::take(&mut self.ui.scratch_log) {
            self.ui.log(line);
        }

        let Some(ws) = self.window.as_mut() else {
            return Ok(());
        };
        // The scene file was edited and the designer asked for a restart.
        if std::mem::take(&mut self.ui.restart_requested) {
            match self.scene.restart_scene() {
                Ok(meshes_changed) => {
                    if meshes_changed {
                        ws.renderer.clear_meshes();
                        for mesh in self.scene.meshes() {
                            if let Err(e) = ws.renderer.upload_mesh(&ws.gpu, &mesh) {
                                self.ui.log(format!("scene restart: {e}"));
                            }
                        }
                    }
                    self.ui.selected = None;
                    self.ui
                        .log(format!("scene restarted: {} fish", self.scene.num_fish()));
                }
                Err(e) => self.ui.log(format!("scene restart failed: {e}")),
            }
        }
        // Shader hot reload: keep the old pipelines on error.
        if let Some(w) = &self.ui.watcher
            && w.changed()
        {
            let dir = w.dir().to_owned();
            let result = ShaderSources::load_dir(&dir)
                .map_err(|e| format!("cannot read shaders: {e}"))
                .and_then(|sources| {
                    ws.renderer
                        .reload_shaders(&ws.gpu, sources)
                        .map_err(|e| e.to_string())
                });
            let msg = match result {
                Ok(()) => {
                    self.ui.shader_error = None;
                    "shaders reloaded".to_owned()
                }
                Err(e) => {
                    self.ui.shader_error = Some(e.clone());
                    format!("{e}\n(keeping the previous pipelines)")
                }
            };
            self.ui.log(msg);
        }

        // Camera follow and overlays.
        if self.ui.follow
            && let Some(info) = self.ui.selected.and_then(|i| self.scene.fish_info(i))
        {
            self.ui.camera.target = self.ui.camera.target.lerp(info.center, 0.15);
        }
        self.ui.overlay.clear();
        if self.ui.toggles.any() {
            self.scene
                .overlay_lines(self.ui.toggles, &mut self.ui.overlay);
        }
        if let Some(i) = self.ui.selected {
            self.scene.body_wave(i, &mut self.ui.wave);
            self.scene.inspect(i, &mut self.ui.inspect);
        }

        let surface_texture = match ws.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                ws.surface.configure(&ws.gpu.device, &ws.config);
                return Ok(());
            }
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                return Ok(());
            }
            wgpu::CurrentSurfaceTexture::Validation => {
                return Err(GpuError::Surface("surface validation error".into()).into());
            }
        };
        let view = surface_texture
            .texture
            .create_view(&wgpu::TextureViewDescriptor::default());
        let size = (ws.config.width, ws.config.height);
        let mut encoder = ws
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("window frame encoder"),
            });
        {
            let mut input = self.scene.frame_input();
            input.camera = self.ui.camera;
            input.overlay = &self.ui.overlay;
            ws.renderer
                .encode(&ws.gpu, &mut encoder, &view, size, &input)?;
        }
        let rt = ws.renderer.timings();
        self.ui.render_counts = rt;

        // The panel.
        let raw_input = ws.egui_state.take_egui_input(&ws.window);
        let scene = &mut *self.scene;
        let ui_state = &mut self.ui;
        let full = ws.egui_ctx.run_ui(raw_input, |ui| {
            egui::Panel::right("tuning").resizable(true).show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| panel(ui, scene, ui_state));
            });
        });
        ws.egui_state
            .handle_platform_output(&ws.window, full.platform_output);
        let jobs = ws.egui_ctx.tessellate(full.shapes, full.pixels_per_point);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [size.0, size.1],
            pixels_per_point: full.pixels_per_point,
        };
        let mut textures = full.textures_delta;
        for (id, deltas) in textures.set.drain() {
            for delta in &deltas {
                ws.egui_renderer
                    .update_texture(&ws.gpu.device, &ws.gpu.queue, id, delta);
            }
        }
        let extra = ws.egui_renderer.update_buffers(
            &ws.gpu.device,
            &ws.gpu.queue,
            &mut encoder,
            &jobs,
            &screen,
        );
        {
            let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("egui pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            let mut pass = pass.forget_lifetime();
            ws.egui_renderer.render(&mut pass, &jobs, &screen);
        }
        for id in textures.free.drain() {
            ws.egui_renderer.free_texture(&id);
        }
        let submit = Instant::now();
        ws.gpu
            .queue
            .submit(extra.into_iter().chain([encoder.finish()]));
        ws.window.pre_present_notify();
        ws.gpu.queue.present(surface_texture);
        let draw_ms = rt.draw_ms + submit.elapsed().as_secs_f32() * 1e3;
        self.presented += 1;
        self.ui.times.push_back(FrameTimes {
            sim_ms,
            upload_ms: rt.upload_ms,
            draw_ms,
            frame_ms: frame_dt * 1e3,
        });
        while self.ui.times.len() > 120 {
            self.ui.times.pop_front();
        }
        if self.options.frames.is_some_and(|n| self.presented >= n) {
            event_loop.exit();
        }
        Ok(())
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        if let Err(e) = self.init(event_loop) {
            self.error = Some(e);
            event_loop.exit();
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(ws) = self.window.as_mut() else {
            return;
        };
        let response = ws.egui_state.on_window_event(&ws.window, &event);
        match &event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                ws.config.width = size.width.max(1);
                ws.config.height = size.height.max(1);
                ws.surface.configure(&ws.gpu.device, &ws.config);
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.frame(event_loop) {
                    self.error = Some(e);
                    event_loop.exit();
                }
            }
            _ => {
                let over_ui = ws.egui_ctx.is_pointer_over_egui();
                let releasing = matches!(
                    event,
                    WindowEvent::MouseInput {
                        state: ElementState::Released,
                        ..
                    }
                );
                let cursor = matches!(event, WindowEvent::CursorMoved { .. });
                if cursor || releasing || (!response.consumed && !over_ui) {
                    self.handle_input(&event);
                }
            }
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(ws) = &self.window {
            ws.window.request_redraw();
        }
    }
}

/// The fish under `cursor` (physical pixels from the top-left of a `size` view): the nearest
/// whose bounding sphere (shrunk to 80 %, the body is thinner than its sphere) the ray through
/// the pixel hits. CPU only; linear in the number of fish, run on clicks.
pub fn pick_fish(
    camera: &Camera,
    cursor: Vec2,
    size: Vec2,
    scene: &dyn SceneDriver,
) -> Option<usize> {
    let ray = camera.ray_through_pixel(cursor, size);
    let mut best: Option<(usize, f32)> = None;
    for i in 0..scene.num_fish() {
        if let Some(info) = scene.fish_info(i)
            && let Some(t) = ray.hit_sphere(info.center, info.radius * 0.8)
            && best.is_none_or(|(_, bt)| t < bt)
        {
            best = Some((i, t));
        }
    }
    best.map(|(i, _)| i)
}

/// Picks one stage's time out of a frame's timings.
type StageOf = fn(&FrameTimes) -> f32;

fn mean_max(times: &VecDeque<FrameTimes>, f: impl Fn(&FrameTimes) -> f32) -> (f32, f32) {
    if times.is_empty() {
        return (0.0, 0.0);
    }
    let sum: f32 = times.iter().map(&f).sum();
    let max = times.iter().map(&f).fold(0.0, f32::max);
    (sum / times.len() as f32, max)
}

/// The tuning panel.
fn panel(ui: &mut egui::Ui, scene: &mut dyn SceneDriver, st: &mut UiState) {
    ui.heading("shoal");
    if scene.scene_changed() {
        ui.horizontal(|ui| {
            ui.colored_label(
                egui::Color32::from_rgb(255, 210, 90),
                "the scene file changed",
            );
            if ui.button("restart scene").clicked() {
                st.restart_requested = true;
            }
        });
    }
    if let Some(err) = &st.shader_error {
        ui.colored_label(
            egui::Color32::from_rgb(255, 110, 90),
            format!("shader error (previous pipelines still drawing):\n{err}"),
        );
    }
    egui::CollapsingHeader::new("Time")
        .default_open(true)
        .show(ui, |ui| {
            ui.horizontal(|ui| {
                let label = if st.paused { "play" } else { "pause" };
                if ui.button(label).clicked() {
                    st.paused = !st.paused;
                }
                if ui.button("step").clicked() {
                    st.paused = true;
                    st.step_once = true;
                }
            });
            ui.add(
                egui::Slider::new(&mut st.speed, 0.1..=4.0)
                    .logarithmic(true)
                    .text("speed ×"),
            );
        });
    egui::CollapsingHeader::new("Selected fish")
        .default_open(true)
        .show(ui, |ui| {
            let Some(fish) = st.selected else {
                ui.label("click a fish to select it");
                return;
            };
            ui.horizontal(|ui| {
                ui.label(format!("fish #{fish}"));
                ui.checkbox(&mut st.follow, "follow");
                if ui.button("deselect").clicked() {
                    st.selected = None;
                    st.follow = false;
                    scene.set_selected(None);
                }
            });
            let params = scene.motion_params(scene.species_of(fish).unwrap_or(0));
            let (s, angle, l) = params.map_or((40.0, std::f32::consts::FRAC_PI_2, 50.0), |p| {
                (p.s, p.turn_angle, p.l)
            });
            let turn = |kind, side| MotionRequest::Turn { kind, angle, side };
            let buttons: [(&str, MotionRequest); 11] = [
                ("swim", MotionRequest::Swim { speed: s }),
                (
                    "accelerate",
                    MotionRequest::Accelerate {
                        speed: 2.0 * s,
                        duration: 1.0,
                    },
                ),
                ("stop", MotionRequest::Stop { duration: 1.0 }),
                ("normal turn left", turn(TurnKind::Normal, Side::Left)),
                ("normal turn right", turn(TurnKind::Normal, Side::Right)),
                ("quick turn left", turn(TurnKind::Quick, Side::Left)),
                ("quick turn right", turn(TurnKind::Quick, Side::Right)),
                ("serial turn left", turn(TurnKind::Serial, Side::Left)),
                ("serial turn right", turn(TurnKind::Serial, Side::Right)),
                ("ascend", MotionRequest::Ascend { height: l }),
                ("descend", MotionRequest::Descend { depth: l }),
            ];
            ui.horizontal_wrapped(|ui| {
                for (label, request) in buttons {
                    if ui.button(label).clicked()
                        && let Err(e) = scene.request_motion(fish, request)
                    {
                        st.log(format!("fish #{fish}: {e}"));
                    }
                }
            });
            ui.label("body wave (lateral displacement vs position along body)");
            egui_plot::Plot::new("body wave")
                .height(140.0)
                .include_x(0.0)
                .include_x(1.0)
                .include_y(-10.0)
                .include_y(10.0)
                .allow_drag(false)
                .allow_zoom(false)
                .allow_scroll(false)
                .show(ui, |plot| {
                    plot.line(egui_plot::Line::new(
                        "lateral",
                        egui_plot::PlotPoints::from(st.wave.clone()),
                    ));
                });
            egui::Grid::new("inspector").striped(true).show(ui, |ui| {
                for (k, v) in &st.inspect {
                    ui.label(k);
                    ui.label(v);
                    ui.end_row();
                }
            });
        });
    let species = scene.species_names();
    egui::CollapsingHeader::new("Motion parameters")
        .default_open(true)
        .show(ui, |ui| {
            if !species.is_empty() {
                egui::ComboBox::from_label("species")
                    .selected_text(species.get(st.species).cloned().unwrap_or_default())
                    .show_ui(ui, |ui| {
                        for (i, name) in species.iter().enumerate() {
                            ui.selectable_value(&mut st.species, i, name);
                        }
                    });
            }
            let Some(mut p) = scene.motion_params(st.species) else {
                ui.label("(this scene has no tunable motion)");
                return;
            };
            let before = p;
            ui.add(egui::Slider::new(&mut p.p, 0.0..=0.9).text("p (pivot, body fraction)"));
            ui.add(egui::Slider::new(&mut p.s, 0.0..=200.0).text("s (speed, units/s)"));
            ui.add(egui::Slider::new(&mut p.l, 5.0..=200.0).text("l (body length)"));
            ui.add(egui::Slider::new(&mut p.max_amp, 0.0..=30.0).text("maxAmp"));
            ui.add(egui::Slider::new(&mut p.lambda, 5.0..=200.0).text("λ (wavelength)"));
            ui.add(egui::Slider::new(&mut p.omega, 0.0..=40.0).text("ω (frequency)"));
            ui.add(egui::Slider::new(&mut p.tt, 0.05..=5.0).text("Tt (turn time, s)"));
            ui.add(egui::Slider::new(&mut p.f, 1.0..=2.0).text("f (turn weight)"));
            let mut deg = p.turn_angle.to_degrees();
            ui.add(egui::Slider::new(&mut deg, 0.0..=180.0).text("turn angle (°)"));
            p.turn_angle = deg.to_radians();
            if p != before
                && let Err(e) = scene.set_motion_params(st.species, p)
            {
                st.log(e);
            }
        });
    egui::CollapsingHeader::new("Overlays")
        .default_open(true)
        .show(ui, |ui| {
            ui.checkbox(&mut st.toggles.skeleton, "skeleton and joints");
            ui.checkbox(&mut st.toggles.midline, "body midline");
            ui.checkbox(&mut st.toggles.velocity, "velocity and heading");
            ui.checkbox(&mut st.toggles.sensors, "sensor ranges");
        });
    egui::CollapsingHeader::new("Timings (last 120 frames, ms)")
        .default_open(true)
        .show(ui, |ui| {
            egui::Grid::new("timings").striped(true).show(ui, |ui| {
                ui.label("stage");
                ui.label("mean");
                ui.label("max");
                ui.end_row();
                let rows: [(&str, StageOf); 4] = [
                    ("simulation", |t| t.sim_ms),
                    ("skinning upload", |t| t.upload_ms),
                    ("draw (encode+submit)", |t| t.draw_ms),
                    ("frame", |t| t.frame_ms),
                ];
                for (name, f) in rows {
                    let (mean, max) = mean_max(&st.times, f);
                    ui.label(name);
                    ui.label(format!("{mean:.2}"));
                    ui.label(format!("{max:.2}"));
                    ui.end_row();
                }
                for (name, ms) in scene.stage_timings_ms() {
                    ui.label(format!("  sim: {name}"));
                    ui.label(format!("{ms:.2}"));
                    ui.end_row();
                }
            });
            let c = &st.render_counts;
            ui.label(format!(
                "fish drawn {} (per level of detail, full first: {:?}), culled {}; shadows {}",
                c.num_fish_drawn, c.num_fish_per_lod, c.num_fish_culled, c.num_shadows_drawn
            ));
            ui.label(format!(
                "{} triangles, {} draw calls",
                c.num_triangles, c.num_draw_calls
            ));
        });
    egui::CollapsingHeader::new("Console")
        .default_open(true)
        .show(ui, |ui| {
            if ui.button("clear").clicked() {
                st.log.clear();
            }
            egui::ScrollArea::vertical()
                .max_height(180.0)
                .stick_to_bottom(true)
                .show(ui, |ui| {
                    for line in &st.log {
                        ui.monospace(line);
                    }
                });
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::{DemoMesh, DemoScene, DemoSceneConfig};

    #[test]
    fn clicking_a_fish_centre_picks_that_fish_and_empty_water_picks_none() {
        let scene = DemoScene::new(DemoSceneConfig {
            fish: 6,
            mesh: DemoMesh::Procedural,
            ..DemoSceneConfig::default()
        });
        let camera = scene.default_camera();
        let size = Vec2::new(800.0, 600.0);
        let view_proj = camera.view_proj(size.x / size.y);
        let mut picked_any = false;
        for i in 0..scene.num_fish() {
            let c = scene.fish_info(i).unwrap().center;
            let ndc = view_proj.project_point3(c);
            let px = Vec2::new((ndc.x + 1.0) * 0.5 * size.x, (1.0 - ndc.y) * 0.5 * size.y);
            let got = pick_fish(&camera, px, size, &scene);
            // Another fish may sit in front; whatever is picked must be on the ray, and when
            // it is not this fish, that one must be nearer the eye.
            let got = got.expect("a fish centre hits at least that fish");
            if got == i {
                picked_any = true;
            } else {
                let eye = camera.eye();
                let d_got = (scene.fish_info(got).unwrap().center - eye).length();
                assert!(d_got < (c - eye).length() + 60.0, "picked {got} behind {i}");
            }
        }
        assert!(picked_any);
        // Straight up from the top-left corner: open water.
        assert_eq!(pick_fish(&camera, Vec2::new(1.0, 1.0), size, &scene), None);
    }
}
