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
    let Aquarium { scene, ui } = Aquarium::new(scene, options);
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

/// The aquarium's panel and view logic without a window: the same panel, pointer routing, fish
/// picking and simulation advance that `shoal run` uses every frame, driven by UI tests
/// (`egui_kittest`) or any other host.
pub struct Aquarium {
    /// The simulation being shown.
    pub scene: Box<dyn SceneDriver>,
    ui: UiState,
}

impl Aquarium {
    /// Wraps `scene`, with `options.select` selected (and followed) and `options.overlays` on.
    pub fn new(mut scene: Box<dyn SceneDriver>, options: AppOptions) -> Self {
        let mut ui = UiState::new(scene.default_camera());
        ui.toggles = options.overlays;
        if let Some(fish) = options.select.filter(|&f| f < scene.num_fish()) {
            ui.selected = Some(fish);
            ui.follow = true;
            ui.species = scene.species_of(fish).unwrap_or(0);
            scene.set_selected(Some(fish));
        }
        Self { scene, ui }
    }

    /// Draws the tuning panel into `ui` (inspector and plot as of the last [`Aquarium::advance`]).
    pub fn panel(&mut self, ui: &mut egui::Ui) {
        panel(ui, &mut *self.scene, &mut self.ui);
    }

    /// One frame's simulation: `frame_dt_s` of real time at the panel's speed (or one tick
    /// after "step", or nothing while paused), then the console, inspector, plot and overlays.
    pub fn advance(&mut self, frame_dt_s: f32) {
        advance(&mut *self.scene, &mut self.ui, frame_dt_s);
        refresh_views(&*self.scene, &mut self.ui);
    }

    /// A left click at `at` (physical pixels in a `size` view); `over_ui` when the panel is
    /// under the pointer, as the window decides it. Picks a fish only in the view.
    pub fn click(&mut self, at: Vec2, size: Vec2, over_ui: bool) {
        self.ui.pointer.moved(at);
        self.ui.pointer.pressed(MouseButton::Left, over_ui);
        if let Some(at) = self.ui.pointer.released(MouseButton::Left) {
            select_at(&mut *self.scene, &mut self.ui, at, size);
        }
    }

    /// The selected fish.
    pub fn selected(&self) -> Option<usize> {
        self.ui.selected
    }
    /// Whether the camera follows the selected fish.
    pub fn following(&self) -> bool {
        self.ui.follow
    }
    /// Whether time is paused.
    pub fn paused(&self) -> bool {
        self.ui.paused
    }
    /// The overlays shown.
    pub fn overlays(&self) -> OverlayToggles {
        self.ui.toggles
    }
    /// The overlay segments of the last [`Aquarium::advance`].
    pub fn overlay_lines(&self) -> &[OverlayLine] {
        &self.ui.overlay
    }
    /// The camera.
    pub fn camera(&self) -> Camera {
        self.ui.camera
    }
    /// The console's lines, oldest first.
    pub fn console(&self) -> impl Iterator<Item = &str> {
        self.ui.log.iter().map(String::as_str)
    }
}

/// The per-frame views of the simulation: camera follow, overlay segments, and the selected
/// fish's body wave and inspector.
fn refresh_views(scene: &dyn SceneDriver, ui: &mut UiState) {
    if ui.follow
        && let Some(info) = ui.selected.and_then(|i| scene.fish_info(i))
    {
        ui.camera.target = ui.camera.target.lerp(info.center, 0.15);
    }
    ui.overlay.clear();
    if ui.toggles.any() {
        scene.overlay_lines(ui.toggles, &mut ui.overlay);
    }
    if let Some(i) = ui.selected {
        scene.body_wave(i, &mut ui.wave);
        scene.inspect(i, &mut ui.inspect);
    }
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
    pointer: Pointer,
    last_frame: Instant,
    /// Simulated and real seconds of the last frames, for the "behind real time" warning.
    pace: VecDeque<(f32, f32)>,
    watcher: Option<ShaderWatcher>,
    shader_error: Option<String>,
    scratch_log: Vec<String>,
    /// Set by the panel's "restart scene" button; handled at the start of the next frame.
    restart_requested: bool,
    /// `SHOAL_UI_TRACE` is set: console lines, selection changes and the panel's button
    /// rectangles are also printed on stdout, so an end-to-end test can click by label.
    trace: bool,
    /// The last line printed for each traced button.
    traced: Vec<(String, String)>,
    /// The panel's rectangle in the last frame, physical pixels.
    panel_rect_px: Option<egui::Rect>,
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
            pointer: Pointer::default(),
            last_frame: Instant::now(),
            pace: VecDeque::new(),
            watcher: None,
            shader_error: None,
            scratch_log: Vec::new(),
            trace: std::env::var_os("SHOAL_UI_TRACE").is_some_and(|v| !v.is_empty()),
            traced: Vec::new(),
            panel_rect_px: None,
        }
    }

    /// With [`UiState::trace`], prints a widget's centre and size in physical pixels whenever it
    /// is drawn somewhere new: `ui: button "quick turn left" at X,Y size WxH`.
    fn trace_widget(&mut self, ui: &egui::Ui, label: &str, response: &egui::Response) {
        if !self.trace {
            return;
        }
        let ppp = ui.ctx().pixels_per_point();
        let r = response.rect * ppp;
        let line = format!(
            "ui: button {label:?} at {:.0},{:.0} size {:.0}x{:.0}",
            r.center().x,
            r.center().y,
            r.width(),
            r.height()
        );
        match self.traced.iter_mut().find(|(l, _)| l == label) {
            Some((_, last)) if *last == line => return,
            Some((_, last)) => *last = line.clone(),
            None => self.traced.push((label.to_owned(), line.clone())),
        }
        println!("{line}");
    }

    fn log(&mut self, line: impl Into<String>) {
        let line = line.into();
        if self.trace {
            println!("console: {line}");
        }
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

    fn pick(&mut self, at: Vec2) {
        let Some(ws) = &self.window else { return };
        let size = Vec2::new(ws.config.width as f32, ws.config.height as f32);
        select_at(&mut *self.scene, &mut self.ui, at, size);
    }

    /// Mouse input for the 3D view. `over_ui`: egui has the pointer (over the panel, or a panel
    /// widget is being dragged), so a press there starts nothing in the view and its release
    /// picks no fish.
    fn handle_input(&mut self, event: &WindowEvent, over_ui: bool) {
        match event {
            WindowEvent::CursorMoved { position, .. } => {
                let p = Vec2::new(position.x as f32, position.y as f32);
                let height = self
                    .window
                    .as_ref()
                    .map_or(1.0, |w| w.config.height.max(1) as f32);
                match self.ui.pointer.moved(p) {
                    Some((MouseButton::Left, delta)) => self.ui.camera.orbit(
                        delta.x / height * std::f32::consts::PI,
                        delta.y / height * std::f32::consts::PI,
                    ),
                    Some((MouseButton::Right | MouseButton::Middle, delta)) => {
                        self.ui.follow = false;
                        self.ui.camera.pan(delta.x / height, delta.y / height);
                    }
                    _ => {}
                }
            }
            WindowEvent::MouseInput { state, button, .. } => match state {
                ElementState::Pressed => self.ui.pointer.pressed(*button, over_ui),
                ElementState::Released => {
                    if let Some(at) = self.ui.pointer.released(*button) {
                        self.pick(at);
                    }
                }
            },
            WindowEvent::MouseWheel { .. } if over_ui => {}
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

        let sim_start = Instant::now();
        advance(&mut *self.scene, &mut self.ui, frame_dt);
        let sim_ms = sim_start.elapsed().as_secs_f32() * 1e3;

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

        refresh_views(&*self.scene, &mut self.ui);

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
            let shown = egui::Panel::right("tuning").resizable(true).show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| panel(ui, scene, ui_state));
            });
            // Where the panel is, in physical pixels: a press there is the panel's even when
            // it comes before egui has seen the pointer arrive (a fast click).
            ui_state.panel_rect_px = Some(shown.response.rect * ui.ctx().pixels_per_point());
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
                // egui sees every event first; the view only gets the pointer where egui does
                // not want it (a click on a panel button must not also pick a fish).
                let cursor = self.ui.pointer.cursor;
                let over_panel = self
                    .ui
                    .panel_rect_px
                    .is_some_and(|r| r.contains(egui::pos2(cursor.x, cursor.y)));
                let over_ui = response.consumed
                    || over_panel
                    || ws.egui_ctx.is_pointer_over_egui()
                    || ws.egui_ctx.egui_wants_pointer_input();
                self.handle_input(&event, over_ui);
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

/// Longest real time one frame may simulate, seconds: after a stall (a window drag, a debugger)
/// the aquarium goes on instead of racing to catch up.
const MAX_FRAME_DT_S: f32 = 0.1;

/// The simulation part of a frame: advances the scene by the frame's real time × the speed
/// slider (all of it: no tick is dropped), by exactly one tick after "step", or not at all while
/// paused; then moves the scene's new log lines into the console.
fn advance(scene: &mut dyn SceneDriver, ui: &mut UiState, frame_dt_s: f32) {
    let frame_dt_s = if frame_dt_s.is_finite() {
        frame_dt_s.max(0.0)
    } else {
        0.0
    };
    let before = scene.time_s();
    if ui.step_once {
        scene.step(1.0 / crate::world::TICK_HZ as f32);
        ui.step_once = false;
    } else if !ui.paused {
        let wanted = frame_dt_s.min(MAX_FRAME_DT_S) * ui.speed;
        scene.step(wanted);
        ui.pace
            .push_back((scene.time_s() - before, frame_dt_s * ui.speed));
        while ui.pace.len() > 120 {
            ui.pace.pop_front();
        }
    }
    scene.drain_log(&mut ui.scratch_log);
    for line in std::mem::take(&mut ui.scratch_log) {
        ui.log(line);
    }
}

/// Simulated seconds per requested simulated second over the last frames (1 when keeping up).
fn pace_ratio(pace: &VecDeque<(f32, f32)>) -> f32 {
    let (done, wanted) = pace
        .iter()
        .fold((0.0, 0.0), |(d, w), (a, b)| (d + a, w + b));
    if wanted > 0.0 {
        (done / wanted).min(1.0)
    } else {
        1.0
    }
}

/// Selects the fish under `at` (see [`pick_fish`]), or none on open water, and shows its species'
/// parameters in the panel.
fn select_at(scene: &mut dyn SceneDriver, ui: &mut UiState, at: Vec2, size: Vec2) {
    ui.selected = pick_fish(&ui.camera, at, size, scene);
    if ui.trace {
        println!("selected: {:?}", ui.selected);
    }
    scene.set_selected(ui.selected);
    if let Some(i) = ui.selected {
        ui.species = scene.species_of(i).unwrap_or(0);
    } else {
        ui.follow = false;
    }
}

/// Distance in physical pixels a press may move and still count as a click.
const CLICK_SLOP_PX: f32 = 4.0;

/// The mouse as the 3D view sees it: where it is and which button went down in the view.
///
/// A press that egui took (over the panel) is not the view's: its drag does not orbit and its
/// release picks no fish. A release picks only when its press was the view's, with the left
/// button, and the pointer did not move further than [`CLICK_SLOP_PX`] in between.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Pointer {
    /// Last cursor position, physical pixels from the top-left.
    pub cursor: Vec2,
    /// The button pressed in the view and where.
    press: Option<(MouseButton, Vec2)>,
    dragged: bool,
}

impl Pointer {
    /// The cursor moved to `p`; returns the button held in the view and the move, if dragging.
    pub fn moved(&mut self, p: Vec2) -> Option<(MouseButton, Vec2)> {
        let delta = p - self.cursor;
        self.cursor = p;
        let (button, start) = self.press?;
        if (p - start).length() > CLICK_SLOP_PX {
            self.dragged = true;
        }
        Some((button, delta))
    }

    /// A button went down at the cursor; `over_ui` when egui has the pointer there.
    pub fn pressed(&mut self, button: MouseButton, over_ui: bool) {
        self.press = (!over_ui).then_some((button, self.cursor));
        self.dragged = false;
    }

    /// A button came up; returns where to pick a fish when this ends a click in the view.
    pub fn released(&mut self, button: MouseButton) -> Option<Vec2> {
        let press = self.press.take()?;
        (press.0 == button && button == MouseButton::Left && !self.dragged).then_some(self.cursor)
    }
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
                let toggle = ui.button(label);
                st.trace_widget(ui, label, &toggle);
                if toggle.clicked() {
                    st.paused = !st.paused;
                }
                let step = ui.button("step");
                st.trace_widget(ui, "step", &step);
                if step.clicked() {
                    st.paused = true;
                    st.step_once = true;
                }
            });
            ui.add(
                egui::Slider::new(&mut st.speed, 0.1..=4.0)
                    .logarithmic(true)
                    .text("speed ×"),
            );
            let pace = pace_ratio(&st.pace);
            if !st.paused && pace < 0.95 {
                ui.colored_label(
                    egui::Color32::from_rgb(255, 210, 90),
                    format!(
                        "behind real time: simulating {:.0} % of the requested speed \
                         (frames are slower than {:.0} ms)",
                        pace * 100.0,
                        MAX_FRAME_DT_S * 1e3
                    ),
                );
            }
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
                let follow = ui.checkbox(&mut st.follow, "follow");
                st.trace_widget(ui, "follow", &follow);
                let deselect = ui.button("deselect");
                st.trace_widget(ui, "deselect", &deselect);
                if deselect.clicked() {
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
                    let button = ui.button(label);
                    st.trace_widget(ui, label, &button);
                    if button.clicked() {
                        match scene.request_motion(fish, request) {
                            Ok(()) => st.log(format!("fish #{fish}: {label} requested")),
                            Err(e) => st.log(format!("fish #{fish}: {label}: {e}")),
                        }
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

    #[test]
    fn a_click_in_the_view_picks_and_a_click_egui_took_does_not() {
        let mut p = Pointer::default();
        p.moved(Vec2::new(100.0, 100.0));
        p.pressed(MouseButton::Left, false);
        assert_eq!(p.released(MouseButton::Left), Some(Vec2::new(100.0, 100.0)));
        // Over the panel: the press is egui's, so its release picks nothing.
        p.pressed(MouseButton::Left, true);
        assert_eq!(p.released(MouseButton::Left), None);
        // A press on the panel dragged into the view neither orbits nor picks.
        p.pressed(MouseButton::Left, true);
        assert_eq!(p.moved(Vec2::new(300.0, 100.0)), None);
        assert_eq!(p.released(MouseButton::Left), None);
    }

    #[test]
    fn a_drag_in_the_view_orbits_and_does_not_pick() {
        let mut p = Pointer::default();
        p.moved(Vec2::new(10.0, 10.0));
        p.pressed(MouseButton::Left, false);
        assert_eq!(
            p.moved(Vec2::new(40.0, 10.0)),
            Some((MouseButton::Left, Vec2::new(30.0, 0.0)))
        );
        assert_eq!(p.released(MouseButton::Left), None, "a drag is not a click");
        // A right click never picks.
        p.pressed(MouseButton::Right, false);
        assert_eq!(p.released(MouseButton::Right), None);
        // Moving less than the slop still clicks.
        p.pressed(MouseButton::Left, false);
        p.moved(Vec2::new(42.0, 11.0));
        assert_eq!(p.released(MouseButton::Left), Some(Vec2::new(42.0, 11.0)));
    }

    #[test]
    fn pace_is_one_when_keeping_up_and_the_share_done_when_behind() {
        let mut pace = VecDeque::new();
        assert_eq!(pace_ratio(&pace), 1.0);
        pace.push_back((0.1, 0.1));
        assert_eq!(pace_ratio(&pace), 1.0);
        pace.push_back((0.1, 0.3));
        assert!((pace_ratio(&pace) - 0.5).abs() < 1e-6);
    }
}
