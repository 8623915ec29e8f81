//! The aquarium window (`shoal run`): winit 0.30 + the egui tuning panel over the wgpu
//! renderer. The per-frame logic that needs no window lives in [`super::aquarium`] and
//! `ui_state.rs`.
//!
//! Mouse: left drag orbits, right or middle drag pans, the wheel zooms, a left click (without
//! dragging) selects the fish under the cursor (ray against each fish's bounding sphere).

use std::sync::Arc;
use std::time::Instant;

use glam::Vec2;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Window, WindowId};

use super::aquarium::{AppOptions, Aquarium};
use super::pacing::{Pacer, ViewPlan, ViewSnapshot};
use super::showable::Showable;
use super::ui_state::{FrameTimes, advance, refresh_views};
use shoal_render::shaders::{ShaderSources, ShaderWatcher};
use shoal_render::{Gpu, GpuError, RenderError, Renderer};

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

/// The window's MSAA samples on an adapter of `device_type` when the user did not choose: 4,
/// except on a software renderer (lavapipe, llvmpipe, WARP), where 4× multiplies the frame time
/// by ~2.7 (255 against 92 ms a frame for 40 fish at 1280×760 on lavapipe, 2 cores) and a
/// designer would get 3–4 frames a second.
pub fn default_msaa(device_type: wgpu::DeviceType) -> u32 {
    if device_type == wgpu::DeviceType::Cpu {
        1
    } else {
        4
    }
}

/// Opens the aquarium window on `sim` and runs until it is closed (or `options.frames` are
/// presented). Returns the number of frames presented.
pub fn run_window(sim: Box<dyn Showable>, options: AppOptions) -> Result<u64, AppError> {
    run_aquarium(Aquarium::new(sim, options), options)
}

/// Opens the aquarium window on an [`Aquarium`] already set up (a recording opened in it, or a
/// split tank: [`Aquarium::new_split`]) and runs until it is closed (or `options.frames` are
/// presented). Returns the number of frames presented.
pub fn run_aquarium(aq: Aquarium, options: AppOptions) -> Result<u64, AppError> {
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
    let mut app = App {
        aq,
        options,
        window: None,
        error: None,
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
    /// The 3D view's textures, left of the panel: the aquarium's, or the split tank's two (A,
    /// B), each half the view wide.
    view_targets: Vec<wgpu::Texture>,
    /// Whether the surface can be copied to (the views are drawn at their own size and copied).
    surface_copyable: bool,
    /// The frame pacing: ticks a frame, and the view whole or a slice at a time.
    pacer: Pacer,
    /// A view drawn a slice at a time: the picture being drawn (shown, by swapping it with
    /// `view_targets[0]`, when complete) and the moment it shows.
    progressive: Option<(wgpu::Texture, ViewSnapshot)>,
    /// The last progressive view's moment, kept for the next one to reuse its instance list
    /// ([`ViewSnapshot::take`]).
    spare_snapshot: Option<ViewSnapshot>,
    /// `view_targets` hold a complete picture (else the one in progress is shown).
    shown_complete: bool,
}

impl WindowState {
    /// Forgets the view being drawn a slice at a time; the last complete one stays shown.
    fn drop_progress(&mut self) {
        self.pacer.restart_view();
        if let Some((_, snapshot)) = self.progressive.take() {
            self.spare_snapshot = Some(snapshot);
        }
    }
}

struct App {
    /// The simulation, selection, camera and panel state.
    aq: Aquarium,
    options: AppOptions,
    window: Option<WindowState>,
    error: Option<AppError>,
    presented: u64,
}

impl App {
    fn init(&mut self, event_loop: &ActiveEventLoop) -> Result<(), AppError> {
        // The monitor's size in logical pixels, where the platform tells it (X11 does; Wayland
        // gives no primary monitor, and there any monitor's size is only a hint).
        let monitor = event_loop
            .primary_monitor()
            .or_else(|| event_loop.available_monitors().next())
            .map(|m| {
                let size = m.size().to_logical::<f64>(m.scale_factor());
                (size.width, size.height)
            });
        let (width, height) = initial_window_size(monitor);
        let window = event_loop
            .create_window(
                Window::default_attributes()
                    .with_title("shoal — aquarium")
                    .with_inner_size(winit::dpi::LogicalSize::new(width, height)),
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
        // The 3D view left of the panel is drawn at its own size and copied onto the surface
        // (see `encode_views`). A surface that cannot be copied to gets the aquarium drawn
        // straight into the whole of it, under the panel too; the split tank needs the copy.
        let mut usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let copyable = caps.usages.contains(wgpu::TextureUsages::COPY_DST);
        if copyable {
            usage |= wgpu::TextureUsages::COPY_DST;
        } else if self.aq.ui.split.is_some() {
            return Err(GpuError::Surface(
                "this window surface cannot be copied to, which the split tank's two views need"
                    .into(),
            )
            .into());
        }
        let config = wgpu::SurfaceConfiguration {
            usage,
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
        let sources = match shoal_render::shaders::source_dir() {
            Some(dir) => {
                match ShaderWatcher::new(&dir) {
                    Ok(w) => {
                        self.aq
                            .ui
                            .log(format!("watching {} for shader edits", dir.display()));
                        self.aq.ui.watcher = Some(w);
                    }
                    Err(e) => self.aq.ui.log(e.to_string()),
                }
                ShaderSources::load_dir(&dir).unwrap_or_default()
            }
            None => ShaderSources::embedded(),
        };
        let info = gpu.adapter.get_info();
        let msaa = self
            .options
            .msaa
            .unwrap_or_else(|| default_msaa(info.device_type));
        let mut renderer = match Renderer::with_shaders_and_msaa(&gpu, format, sources, msaa) {
            Ok(r) => r,
            Err(e) => {
                self.aq
                    .ui
                    .log(format!("{e}\n(falling back to the built-in shaders)"));
                Renderer::with_shaders_and_msaa(&gpu, format, ShaderSources::embedded(), msaa)?
            }
        };
        upload_meshes(&mut renderer, &gpu, &mut self.aq)?;
        if let Err(e) = self.aq.scene.enable_hot_reload() {
            self.aq.ui.log(format!("script hot reload is off: {e}"));
        }
        if let Some(split) = &mut self.aq.ui.split
            && let Err(e) = split.scene.enable_hot_reload()
        {
            self.aq.ui.log(format!("B: script hot reload is off: {e}"));
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
        let pose = match self.aq.scene.world().gpu_pose_programs() {
            Ok(_) => "posed on the GPU".to_owned(),
            Err(why) => format!("posed on the CPU ({why})"),
        };
        let why = match self.options.msaa {
            Some(_) => " (--msaa)",
            None if default_msaa(info.device_type) == 1 => {
                " (a software renderer: --msaa 4 for smoother edges, ~2.7× the frame time)"
            }
            None => "",
        };
        self.aq.ui.log(format!(
            "{} fish, {pose}, MSAA {}×{why}, surface {format:?}",
            self.aq.scene.num_fish(),
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
            view_targets: Vec::new(),
            surface_copyable: copyable,
            pacer: Pacer::default(),
            progressive: None,
            spare_snapshot: None,
            shown_complete: false,
        });
        Ok(())
    }

    /// A click in the view at `at`: selects the fish there, or with shift held drops food.
    fn click(&mut self, at: Vec2) {
        let Some(ws) = &self.window else { return };
        let size = Vec2::new(views_width(ws, &self.aq) as f32, ws.config.height as f32);
        self.aq.view_click(at, size);
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
                let moved = self.aq.ui.pointer.moved(p);
                if let Some(ws) = &self.window {
                    let size = Vec2::new(views_width(ws, &self.aq) as f32, height);
                    if self.aq.drag_in_view(p, size) {
                        return;
                    }
                }
                match moved {
                    Some((MouseButton::Left, delta)) => self.aq.ui.camera.orbit(
                        delta.x / height * std::f32::consts::PI,
                        delta.y / height * std::f32::consts::PI,
                    ),
                    Some((MouseButton::Right | MouseButton::Middle, delta)) => {
                        self.aq.ui.follow = false;
                        self.aq.ui.camera.pan(delta.x / height, delta.y / height);
                    }
                    _ => {}
                }
            }
            WindowEvent::MouseInput { state, button, .. } => match state {
                ElementState::Pressed => {
                    self.aq.ui.pointer.pressed(*button, over_ui);
                    if *button == MouseButton::Left
                        && !over_ui
                        && let Some(ws) = &self.window
                    {
                        let size =
                            Vec2::new(views_width(ws, &self.aq) as f32, ws.config.height as f32);
                        let at = self.aq.ui.pointer.cursor;
                        self.aq.press_in_view(at, size);
                    }
                }
                ElementState::Released => {
                    if let Some(at) = self.aq.ui.pointer.released(*button) {
                        self.click(at);
                    }
                    self.aq.release_in_view();
                }
            },
            WindowEvent::ModifiersChanged(m) => self.aq.set_shift(m.state().shift_key()),
            WindowEvent::MouseWheel { .. } if over_ui => {}
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => *y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                self.aq.ui.camera.zoom(0.9f32.powf(lines));
            }
            _ => {}
        }
    }

    /// One frame: simulate, apply a requested restart and edited shaders, refresh the views,
    /// draw the aquarium and the panel, present.
    fn frame(&mut self, event_loop: &ActiveEventLoop) -> Result<(), AppError> {
        let now = Instant::now();
        let frame_dt = (now - self.aq.ui.last_frame).as_secs_f32();
        self.aq.ui.last_frame = now;

        if let Some(ws) = &self.window {
            self.aq.ui.max_ticks = ws.pacer.max_ticks();
        }
        let sim_start = Instant::now();
        let ticks_before = self.aq.scene.world().tick_count();
        advance(&mut self.aq.scene, &mut self.aq.ui, frame_dt);
        let sim_ms = sim_start.elapsed().as_secs_f32() * 1e3;
        let ticks = self
            .aq
            .scene
            .world()
            .tick_count()
            .saturating_sub(ticks_before);

        let Some(ws) = self.window.as_mut() else {
            return Ok(());
        };
        ws.pacer.simulated(ticks, sim_ms);
        if std::mem::take(&mut self.aq.ui.restart_requested) {
            ws.drop_progress();
            restart_scene(ws, &mut self.aq);
        }
        // A reloaded species may lay its palette out otherwise: its meshes follow.
        let a_changed = self.aq.scene.take_meshes_changed();
        let b_changed = (self.aq.ui.split.as_mut()).is_some_and(|s| s.scene.take_meshes_changed());
        if a_changed || b_changed {
            // A picture in progress names the old meshes.
            ws.drop_progress();
            if let Err(e) = upload_meshes(&mut ws.renderer, &ws.gpu, &mut self.aq) {
                self.aq.ui.log(format!("species reload: {e}"));
            }
        }
        reload_shaders(ws, &mut self.aq);
        refresh_views(&mut self.aq.scene, &mut self.aq.ui);

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
        let mut encoder = ws
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("window frame encoder"),
            });
        let (rt, fish_drawn) = encode_views(
            ws,
            &mut self.aq,
            &mut encoder,
            &surface_texture.texture,
            &view,
        )?;
        self.aq.ui.render_counts = rt;
        self.aq.ui.view_status = ws.pacer.status();
        let extra = draw_panel(ws, &mut self.aq, &mut encoder, &view);

        let submit = Instant::now();
        ws.gpu
            .queue
            .submit(extra.into_iter().chain([encoder.finish()]));
        ws.window.pre_present_notify();
        ws.gpu.queue.present(surface_texture);
        let draw_ms = rt.draw_ms + submit.elapsed().as_secs_f32() * 1e3;
        ws.pacer
            .frame_done(fish_drawn, now.elapsed().as_secs_f32() * 1e3, sim_ms);
        self.presented += 1;
        if self.aq.ui.trace {
            // End-to-end tests count frames instead of sleeping. A frame begun long after the
            // one before says so: egui takes a press and a release in frames more than 0.8 s
            // apart as no click, and a test that lost a click needs to see why.
            if frame_dt > 0.5 {
                println!(
                    "ui: frame {} ({frame_dt:.2} s after the one before)",
                    self.presented
                );
            } else {
                println!("ui: frame {}", self.presented);
            }
        }
        let times = &mut self.aq.ui.times;
        times.push_back(FrameTimes {
            sim_ms,
            upload_ms: rt.upload_ms,
            draw_ms,
            frame_ms: frame_dt * 1e3,
        });
        while times.len() > 120 {
            times.pop_front();
        }
        if self.options.frames.is_some_and(|n| self.presented >= n) {
            event_loop.exit();
        }
        Ok(())
    }
}

/// Width of the 3D view (the split tank's two views together), physical pixels: the window
/// left of the panel (as it was last frame), so the camera looks at the middle of what is
/// seen and nothing is drawn under the panel — or the whole window where the surface cannot
/// be copied to (see `encode_views`).
fn views_width(ws: &WindowState, aq: &Aquarium) -> u32 {
    let whole = ws.config.width.max(2);
    if aq.ui.split.is_none() && !ws.surface_copyable {
        return whole;
    }
    let left = aq.ui.panel_rect_px.map_or(whole as f32, |r| r.left());
    (left.round() as u32).clamp(2, whole)
}

/// The 3D view left of the panel: the aquarium, or for the split tank A in the left half and
/// B in the right. Each view is drawn into a texture of its own size and submitted on its own
/// (the renderer's buffers hold one frame at a time, and queued writes land before the next
/// submission), then the surface is cleared and `encoder` copies the views onto it side by
/// side. Without a panel (before the first frame), or on a surface that cannot be copied to,
/// the aquarium is drawn straight onto the whole surface.
///
/// The aquarium alone, when the pacer finds it slower than a frame, is drawn a slice of the fish
/// at a time instead (see `pacing.rs`), and its last complete picture is copied meanwhile.
/// Returns A's render timings and the fish drawn this frame.
fn encode_views(
    ws: &mut WindowState,
    aq: &mut Aquarium,
    encoder: &mut wgpu::CommandEncoder,
    surface: &wgpu::Texture,
    surface_view: &wgpu::TextureView,
) -> Result<(shoal_render::RenderTimings, usize), AppError> {
    let height = ws.config.height.max(1);
    let width = views_width(ws, aq);
    let panel_left = aq.ui.panel_rect_px.map(|r| r.left().round());
    aq.ui.trace_line("3D view", || {
        format!("ui: 3D view {width}x{height}, panel from x={panel_left:?}")
    });
    aq.trace_rocks(glam::Vec2::new(width as f32, height as f32));
    if aq.ui.split.is_none() && width >= ws.config.width {
        let mut input = aq.scene.frame_input();
        input.camera = aq.ui.camera;
        input.overlay = &aq.ui.overlay;
        ws.renderer
            .encode(&ws.gpu, encoder, surface_view, (width, height), &input)?;
        ws.drop_progress();
        return Ok((ws.renderer.timings(), input.instances.len()));
    }
    let labels: &[&str] = match aq.ui.split {
        Some(_) => &["split view A", "split view B"],
        None => &["aquarium view"],
    };
    let each = (width / labels.len() as u32).max(1);
    let extent = wgpu::Extent3d {
        width: each,
        height,
        depth_or_array_layers: 1,
    };
    let (device, format) = (ws.gpu.device.clone(), ws.config.format);
    let new_target = |label: &str| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: extent,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        })
    };
    if ws.view_targets.len() != labels.len()
        || ws.view_targets.first().is_none_or(|t| t.size() != extent)
    {
        ws.view_targets = labels.iter().map(|&label| new_target(label)).collect();
        ws.drop_progress();
        ws.shown_complete = false;
    }
    let plan = match aq.ui.split {
        Some(_) => ViewPlan::Whole,
        None => ws.pacer.plan_view(aq.scene.num_fish()),
    };
    let mut timings = None;
    let mut fish_drawn = 0;
    if let ViewPlan::Slice { fish, part } = plan {
        // A slice of the aquarium into the picture in progress, from the moment it shows.
        if part.first {
            let mut input = aq.scene.frame_input();
            input.camera = aq.ui.camera;
            input.overlay = &aq.ui.overlay;
            let spare = match ws.progressive.take() {
                Some((_, snapshot)) => Some(snapshot),
                None => ws.spare_snapshot.take(),
            };
            let snapshot = ViewSnapshot::take(&input, spare);
            ws.progressive = Some((new_target("aquarium view in progress"), snapshot));
        }
        match &mut ws.progressive {
            Some((target, snapshot)) => {
                let total = snapshot.num_fish();
                let input = snapshot.slice(fish.clone(), part);
                fish_drawn = input.instances.len();
                let view = target.create_view(&wgpu::TextureViewDescriptor::default());
                let mut own =
                    ws.gpu
                        .device
                        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                            label: Some("view slice encoder"),
                        });
                ws.renderer
                    .encode_part(&ws.gpu, &mut own, &view, (each, height), &input, part)?;
                ws.gpu.queue.submit([own.finish()]);
                if part.last
                    && let Some((done, snapshot)) = ws.progressive.take()
                {
                    ws.spare_snapshot = Some(snapshot);
                    ws.view_targets[0] = done;
                    ws.shown_complete = true;
                }
                aq.ui.trace_line("view slice", || {
                    format!(
                        "ui: view slice {}..{} of {total}{}",
                        fish.start,
                        fish.end,
                        if part.last { " (shown)" } else { "" }
                    )
                });
            }
            // The picture was dropped (new meshes, a resize): the last complete one is shown
            // and the next frame starts another.
            None => ws.pacer.restart_view(),
        }
        timings = Some(ws.renderer.timings());
    }
    let whole_targets = if timings.is_some() {
        &[][..]
    } else {
        &ws.view_targets[..]
    };
    for (k, target) in whole_targets.iter().enumerate() {
        let (scene, overlay) = match (&aq.ui.split, k) {
            (Some(split), 1) => (&split.scene, split.overlay.as_slice()),
            _ => (&aq.scene, aq.ui.overlay.as_slice()),
        };
        let mut input = scene.frame_input();
        input.camera = aq.ui.camera;
        input.overlay = overlay;
        let view = target.create_view(&wgpu::TextureViewDescriptor::default());
        let mut own = ws
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("view encoder"),
            });
        ws.renderer
            .encode(&ws.gpu, &mut own, &view, (each, height), &input)?;
        ws.gpu.queue.submit([own.finish()]);
        fish_drawn += input.instances.len();
        ws.shown_complete = true;
        timings.get_or_insert(ws.renderer.timings());
    }
    // Under the panel and in an odd pixel column nothing is drawn: clear the surface first.
    drop(encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("view clear"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: surface_view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color {
                    r: 0.01,
                    g: 0.02,
                    b: 0.03,
                    a: 1.0,
                }),
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    }));
    // Until a first picture is complete, the one being drawn shows how far it got.
    let first_in_progress = match (&ws.progressive, ws.shown_complete) {
        (Some((drawing, _)), false) => Some(drawing),
        _ => None,
    };
    for (k, target) in ws.view_targets.iter().enumerate() {
        let target = first_in_progress.unwrap_or(target);
        encoder.copy_texture_to_texture(
            target.as_image_copy(),
            wgpu::TexelCopyTextureInfo {
                texture: surface,
                mip_level: 0,
                origin: wgpu::Origin3d {
                    x: each * k as u32,
                    y: 0,
                    z: 0,
                },
                aspect: wgpu::TextureAspect::All,
            },
            extent,
        );
    }
    Ok((timings.unwrap_or_default(), fish_drawn))
}

/// Uploads, in place of any before, the meshes of the views: A's, then, for the split tank, B's
/// own when B's palette layout differs from A's (its instances then name them, see
/// [`super::scene::WorldScene::set_mesh_base`]); otherwise B draws with A's.
fn upload_meshes(renderer: &mut Renderer, gpu: &Gpu, aq: &mut Aquarium) -> Result<(), RenderError> {
    renderer.clear_meshes();
    let mut count = 0;
    for mesh in aq.scene.meshes() {
        renderer.upload_mesh(gpu, &mesh)?;
        count += 1;
    }
    if let Some(split) = &mut aq.ui.split {
        let base = if split.scene.palette_layout() == aq.scene.palette_layout() {
            0
        } else {
            for mesh in split.scene.meshes() {
                renderer.upload_mesh(gpu, &mesh)?;
            }
            count
        };
        split.scene.set_mesh_base(base);
    }
    Ok(())
}

/// The scene file was edited and the designer asked for a restart: reload it and upload its
/// meshes again.
fn restart_scene(ws: &mut WindowState, aq: &mut Aquarium) {
    match aq.scene.restart_scene() {
        Ok(meshes_changed) => {
            aq.ui.select(&mut aq.scene, None);
            aq.ui.timeline.clear();
            if let Some(line) = aq.ui.timeline.record(aq.scene.sim()) {
                aq.ui.log(line);
            }
            if let Some(split) = &mut aq.ui.split {
                let line = match split.scene.restart_scene() {
                    Ok(_) => split.restarted().map(|l| format!("B: {l}")),
                    Err(e) => Some(format!("B: scene restart failed: {e}")),
                };
                if let Some(line) = line {
                    aq.ui.log(line);
                }
            }
            if meshes_changed && let Err(e) = upload_meshes(&mut ws.renderer, &ws.gpu, aq) {
                aq.ui.log(format!("scene restart: {e}"));
            }
            let fish = aq.scene.num_fish();
            aq.ui.log(format!("scene restarted: {fish} fish"));
        }
        Err(e) => aq.ui.log(format!("scene restart failed: {e}")),
    }
}

/// Shader hot reload: new pipelines from the edited files, or the old ones kept on error.
fn reload_shaders(ws: &mut WindowState, aq: &mut Aquarium) {
    let Some(w) = &aq.ui.watcher else { return };
    if !w.changed() {
        return;
    }
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
            aq.ui.shader_error = None;
            "shaders reloaded".to_owned()
        }
        Err(e) => {
            aq.ui.shader_error = Some(e.clone());
            format!("{e}\n(keeping the previous pipelines)")
        }
    };
    aq.ui.log(msg);
}

/// The window's first inner size, logical pixels: 1280×760, or less on a monitor too small
/// for that (`monitor`: its logical size, when known), leaving room for the title bar, the
/// window's borders and a task bar, so that the panel on the right and the bottom of the view
/// are on screen. Never below 480×360.
fn initial_window_size(monitor: Option<(f64, f64)>) -> (f64, f64) {
    const PREFERRED: (f64, f64) = (1280.0, 760.0);
    const MIN: (f64, f64) = (480.0, 360.0);
    let Some((w, h)) = monitor.filter(|(w, h)| w.is_finite() && h.is_finite()) else {
        return PREFERRED;
    };
    (
        PREFERRED.0.min(w - 32.0).max(MIN.0),
        PREFERRED.1.min(h - 96.0).max(MIN.1),
    )
}

/// Runs the panel and encodes it over the aquarium in `view`. Returns the command buffers
/// egui's renderer needs submitted before `encoder`.
fn draw_panel(
    ws: &mut WindowState,
    aq: &mut Aquarium,
    encoder: &mut wgpu::CommandEncoder,
    view: &wgpu::TextureView,
) -> Vec<wgpu::CommandBuffer> {
    let raw_input = ws.egui_state.take_egui_input(&ws.window);
    let full = ws.egui_ctx.run_ui(raw_input, |ui| {
        // It also keeps where the panel is, in physical pixels: a press there is the panel's
        // even when it comes before egui has seen the pointer arrive (a fast click).
        let panel = aq.side_panel(ui);
        if let Some(split) = &aq.ui.split {
            split_labels(ui.ctx(), split, panel.left());
        }
    });
    ws.egui_state
        .handle_platform_output(&ws.window, full.platform_output);
    let jobs = ws.egui_ctx.tessellate(full.shapes, full.pixels_per_point);
    let screen = egui_wgpu::ScreenDescriptor {
        size_in_pixels: [ws.config.width, ws.config.height],
        pixels_per_point: full.pixels_per_point,
    };
    let mut textures = full.textures_delta;
    for (id, deltas) in textures.set.drain() {
        for delta in &deltas {
            ws.egui_renderer
                .update_texture(&ws.gpu.device, &ws.gpu.queue, id, delta);
        }
    }
    let extra =
        ws.egui_renderer
            .update_buffers(&ws.gpu.device, &ws.gpu.queue, encoder, &jobs, &screen);
    {
        let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("egui pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view,
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
    extra
}

/// Over each view of the split tank, its version and the script files that differ.
fn split_labels(ctx: &egui::Context, split: &super::split::Split, views_width: f32) {
    let changed = if split.changed.is_empty() {
        "no script file differs".to_owned()
    } else {
        format!("differs in {}", split.changed.join(", "))
    };
    let diverged = split.divergences.len();
    let sides = [
        ("A", &split.versions.a, 0.0),
        ("B", &split.versions.b, (views_width * 0.5).round()),
    ];
    for (name, version, x) in sides {
        egui::Area::new(egui::Id::unique(("split label", name)))
            .fixed_pos(egui::pos2(x + 8.0, 8.0))
            .interactable(false)
            .show(ctx, |ui| {
                egui::Frame::popup(ui.style()).show(ui, |ui| {
                    ui.set_max_width((views_width * 0.5 - 24.0).max(80.0));
                    ui.strong(format!("{name}: {version}"));
                    ui.label(&changed);
                    ui.label(format!("{diverged} fish differ"));
                });
            });
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
                // not want it (a click on a panel button must not also pick a fish). Where the
                // pointer is comes from the events, not from egui's last frame (see
                // `pointer_over_ui`).
                // (A cursor move needs no answer: a drag belongs to whoever had its press.)
                let over_ui = match &event {
                    WindowEvent::MouseInput { .. } | WindowEvent::MouseWheel { .. } => {
                        super::pointer::pointer_over_ui(
                            &ws.egui_ctx,
                            self.aq.ui.pointer.cursor,
                            self.aq.ui.panel_rect_px,
                            ws.egui_ctx.pixels_per_point(),
                        )
                    }
                    _ => response.consumed,
                };
                if self.aq.ui.trace {
                    // End-to-end tests wait for these lines, so the frames they count after an
                    // `xdotool` step are frames that had its event.
                    trace_pointer_event(&event, over_ui);
                }
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

/// Prints what the window received of the pointer (`ui: pointer at X,Y`, `ui: pointer Pressed
/// Left`, `ui: wheel`), for `SHOAL_UI_TRACE`.
fn trace_pointer_event(event: &WindowEvent, over_ui: bool) {
    match event {
        WindowEvent::CursorMoved { position, .. } => {
            println!("ui: pointer at {:.0},{:.0}", position.x, position.y);
        }
        WindowEvent::MouseInput { state, button, .. } => {
            let on = if over_ui { " on the panel" } else { "" };
            println!("ui: pointer {state:?} {button:?}{on}");
        }
        WindowEvent::MouseWheel { .. } => println!("ui: wheel"),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::initial_window_size;

    #[test]
    fn the_first_window_fits_the_monitor() {
        // Large monitors, or none known: the preferred size.
        assert_eq!(initial_window_size(None), (1280.0, 760.0));
        assert_eq!(initial_window_size(Some((2560.0, 1440.0))), (1280.0, 760.0));
        // A 1366×768 laptop: the full width, the height less the title and task bars.
        assert_eq!(initial_window_size(Some((1366.0, 768.0))), (1280.0, 672.0));
        // A 1024×640 display: inside it on both axes.
        let (w, h) = initial_window_size(Some((1024.0, 640.0)));
        assert!(w <= 1024.0 - 32.0 && h <= 640.0 - 96.0, "{w}×{h}");
        // Tiny or nonsense sizes: never below the smallest usable window.
        assert_eq!(initial_window_size(Some((320.0, 240.0))), (480.0, 360.0));
        assert_eq!(
            initial_window_size(Some((f64::NAN, 900.0))),
            (1280.0, 760.0)
        );
    }
}
