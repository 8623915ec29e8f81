//! `shoal bench`: measured speed of the simulation (issue 7) and of rendering.
//!
//! `shoal bench sim --fish 1000,10000 [--seconds 5] [--json] [--driver lua|rust]` builds a scene
//! per fish count (constant density, [`shoal_core::world::bench::bench_tank`]), warms it up for a
//! second, then times each 60 Hz tick and reports the median and p99 milliseconds, fish-ticks per
//! second and the split by stage. `--driver lua` (default) runs the shipped behaviour scripts
//! through `script::Simulation`; `--driver rust` runs the built-in Rust wander/school driver, to
//! measure the Rust stages alone. Both tick through `world::step` as a `world::Pipeline`.
//!
//! `shoal bench peer --fish 1000,10000 [--engines luajit,luajit-tuned,lua5.4,mlua] [--peer PATH]`
//! runs `bench sim`'s Lua scene beside the pure-Lua peer of the same workload and prints the
//! ratios (see [`super::bench_peer`]).
//!
//! `shoal bench render --fish 1,100,1000,10000 [--size 1920x1080] [--frames 30]` renders the
//! real world (black porgies in [`shoal_core::world::bench::bench_world`], the built-in Rust driver,
//! through the window's adapter [`shoal_app::WorldScene`]) offscreen per fish count, with the
//! whole tank in view, waits for the GPU every frame, and reports the median
//! and p99 frame time, the CPU upload time (culling and level-of-detail choice included), the
//! draw calls (which do not grow with fish), the fish drawn and culled, the fish at each level of
//! detail and the triangles submitted per frame (fish, shadows and props).

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;

use super::PoseArg;
use shoal_app::WorldScene;
use shoal_core::world::bench::{SimBenchResult, bench_world, measure};
use shoal_core::world::driver::{WanderDriver, WanderPipeline};
use shoal_core::world::{Species, SpeciesDesc, SpeciesId, TICK_HZ};
use shoal_render::{Camera, Gpu, OffscreenTarget, Renderer};
use shoal_script::Simulation;
use shoal_script::sim::SAMPLE_EVERY;

/// Arguments of `shoal bench`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {
    /// What to measure.
    #[command(subcommand)]
    pub what: Option<What>,
}

/// The benchmarks.
#[derive(Debug, clap::Subcommand)]
pub enum What {
    /// Simulation ticks without rendering: behaviour, perception, motion, skeleton, palettes.
    Sim(SimArgs),
    /// Offscreen render frame times (median, p99) for several fish counts.
    Render(RenderArgs),
    /// `bench sim` beside the pure-Lua peer of the same workload (LuaJIT, Lua 5.4, shoal's own
    /// Lua), same minute, same fish counts, with the ratios.
    Peer(super::bench_peer::PeerArgs),
    /// What the window's time travel costs: the history's share of the tick at several fish
    /// counts, its memory per fish, and seeking in five minutes of the default aquarium.
    History(super::bench_history::HistoryArgs),
}

/// Arguments of `shoal bench sim`.
#[derive(Debug, clap::Args)]
pub struct SimArgs {
    /// Fish counts to measure, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1000,10000")]
    pub fish: Vec<usize>,
    /// Simulated seconds measured per fish count (after one second of warm-up).
    #[arg(long, default_value_t = 5.0, allow_negative_numbers = true)]
    pub seconds: f64,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Directory holding the species' assets (Rust driver). Default: as for `shoal run`, the
    /// models beside the scripts, else the working directory's, else the source tree's.
    #[arg(long)]
    pub assets: Option<PathBuf>,
    /// Seed of the scene.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Who decides what the fish do: the shipped Lua behaviours, or the built-in Rust driver
    /// (the Rust stages alone).
    #[arg(long, value_enum, default_value_t = Driver::Lua)]
    pub driver: Driver,
    /// Repository root holding `scripts/` and `assets/` (Lua driver). Default: the scripts
    /// found as `shoal run` finds them (`--scripts`, `SHOAL_SCRIPTS`, `./scripts`, the source
    /// tree's), each model from beside them or else from the source tree.
    #[arg(long, conflicts_with = "scripts")]
    pub root: Option<PathBuf>,
    /// Also draw milliseconds per tick against fish count into this PNG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Script lanes (Lua states deciding in parallel; Lua driver). Default: one per thread.
    #[arg(long)]
    pub lanes: Option<usize>,
    /// Threads: a rayon pool of N for the Rust stages (motion, pose records, grid, the
    /// schedule) and, unless `--lanes` says otherwise, N script lanes. Default: rayon's (one
    /// per core, or `RAYON_NUM_THREADS`). For the scaling: `--threads 1`, then 2, 4…
    #[arg(long)]
    pub threads: Option<usize>,
    /// Benchmark this Lua scene (a `.lua` file, or the name of one in `scripts/scenes/`: its fish
    /// and scripts) instead of the constant-density layout;
    /// `--fish` and `--driver` do not apply.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Sample the Lua stacks for the per-function profile (`--sample-functions=false` to turn
    /// it off). Default: on with `--scene`, off for the layouts.
    #[arg(long, num_args = 0..=1, default_missing_value = "true")]
    pub sample_functions: Option<bool>,
    /// Where the scripts come from (`--scripts DIR`, `SHOAL_SCRIPTS`).
    #[command(flatten)]
    pub scripts: super::ScriptsArg,
    /// Where the fish are posed: `cpu` (every palette on the CPU, each tick) or `gpu` (what
    /// the window does: the motion pass writes each fish's record for the renderer's pose pass
    /// as it moves the fish, so the records are in the motion column, and the GPU poses; no
    /// GPU is used here).
    #[arg(long, value_enum, default_value_t = PoseArg::Cpu)]
    pub pose: PoseArg,
    /// Behaviour level of detail (`--lod on|off`; Lua driver). Default: the scene's, off for
    /// the layouts. The layouts have no focus of their own: with it on, the focus is the tank's
    /// centre, where the window's camera starts.
    #[command(flatten)]
    pub lod: super::LodArg,
}

/// Who decides what the fish do in `shoal bench sim`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Driver {
    /// `script::Simulation` with the shipped behaviours: per 100 fish, 89 black porgies
    /// schooling, 10 foraging, one barracuda hunting.
    Lua,
    /// `world::driver::WanderDriver`: wander, school and avoid in Rust, no Lua.
    Rust,
}

/// Runs `shoal bench`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    match args.what {
        Some(What::Sim(sim)) => run_sim(sim),
        Some(What::Render(render)) => run_render(render),
        Some(What::Peer(peer)) => super::bench_peer::run(peer),
        Some(What::History(history)) => super::bench_history::run(history),
        None => anyhow::bail!(
            "say what to measure: `shoal bench sim --fish 1000,10000`, \
             `shoal bench render --fish 1,100,1000,10000` or `shoal bench peer --fish 1000,10000`"
        ),
    }
}

fn run_sim(args: SimArgs) -> anyhow::Result<ExitCode> {
    let Some(threads) = args.threads else {
        return run_sim_here(args);
    };
    if threads == 0 {
        anyhow::bail!("--threads 0: expected at least 1 thread");
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .with_context(|| format!("starting a pool of {threads} threads"))?;
    // Everything inside, so the script lanes default to the pool's size too.
    pool.install(|| run_sim_here(args))
}

/// `shoal bench sim` in the current rayon pool.
fn run_sim_here(args: SimArgs) -> anyhow::Result<ExitCode> {
    if !(args.seconds.is_finite() && args.seconds > 0.0) {
        anyhow::bail!("--seconds {} must be a positive number", args.seconds);
    }
    if args.fish.is_empty() || args.fish.contains(&0) {
        anyhow::bail!("--fish needs positive counts, e.g. --fish 1000,10000");
    }
    let ticks = (args.seconds * TICK_HZ).round().max(1.0) as usize;
    let source = match &args.root {
        Some(root) => super::ScriptSource::of_root(root),
        None => args.scripts.resolve()?,
    };
    if !args.json {
        println!("{source}");
    }
    if let Some(scene) = &args.scene {
        return run_scene_bench(&args, &source, scene, ticks);
    }
    if args.lod.lod.is_some() && args.driver == Driver::Rust {
        anyhow::bail!(
            "--lod schedules the Lua behaviours; the Rust driver decides on its own schedule \
             (leave --lod out or use --driver lua)"
        );
    }
    let mut results: Vec<SimBenchResult> = Vec::new();
    let species = match args.driver {
        Driver::Rust => Some(
            Species::load(SpeciesDesc::black_porgy(), &bench_assets(&args, &source))
                .context("loading the benchmark species (is --assets right?)")?,
        ),
        Driver::Lua => None,
    };
    for &fish in &args.fish {
        let result = match &species {
            Some(species) => {
                let mut world = bench_world(species.clone(), fish, args.seed)?;
                world.set_pose_mode(args.pose.mode());
                let mut sim = WanderPipeline::new(world, WanderDriver::default());
                measure(&mut sim, TICK_HZ as usize, ticks)
            }
            None => {
                let mut sim = super::lua_sim(&source, fish, args.seed, args.lanes)?;
                sim.world_mut().set_pose_mode(args.pose.mode());
                if args.lod.on() == Some(true) {
                    let tank = *sim.world().tank();
                    sim.set_lod_focus(vec![(tank.min + tank.max) * 0.5]);
                }
                args.lod.apply(&mut sim);
                let sampling = args.sample_functions.unwrap_or(false);
                sim.set_function_sampling(sampling.then_some(SAMPLE_EVERY));
                if results.is_empty() && !args.json {
                    println!(
                        "script lanes: {}, function sampling {}, {}",
                        sim.num_lanes(),
                        if sampling { "on" } else { "off" },
                        args.pose.describe()
                    );
                }
                let result = measure(sim.pipeline_mut(), TICK_HZ as usize, ticks);
                if sampling {
                    let samples: u64 = sim.profile().iter().map(|m| m.samples).sum();
                    eprintln!("{fish} fish: {samples} stack samples taken");
                }
                if let Some(e) = sim.error_messages().first() {
                    eprintln!("script error during the bench: {e}");
                }
                result
            }
        };
        if !args.json {
            print_row(&result, results.is_empty(), args.driver);
        }
        results.push(result);
    }
    if !args.json && args.driver == Driver::Lua {
        for r in &results {
            print_decisions(r);
        }
    }
    let driver = match args.driver {
        Driver::Lua => "lua (shipped behaviours: school, forage, predator)",
        Driver::Rust => "rust-wander (built-in; no Lua)",
    };
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "driver": driver,
                "pose": args.pose.name(),
                "tick_hz": TICK_HZ,
                "results": results,
            }))?
        );
    } else if let [first, .., last] = results.as_slice() {
        println!(
            "cost per fish at {} fish is {:.2}× that at {} fish",
            last.fish,
            last.us_per_fish / first.us_per_fish,
            first.fish
        );
    }
    if let Some(path) = &args.plot {
        plot_sim(path, &results, &format!("shoal bench sim, driver {driver}"))
            .with_context(|| format!("drawing {}", path.display()))?;
        if !args.json {
            println!("plot written to {}", path.display());
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// The Rust driver's models: `--assets`, else the porgy beside the scripts, else the source
/// tree's.
fn bench_assets(args: &SimArgs, source: &super::ScriptSource) -> PathBuf {
    if let Some(dir) = &args.assets {
        return dir.clone();
    }
    let asset = SpeciesDesc::black_porgy().asset;
    [
        source.root.join("assets"),
        shoal_core::source_root().join("assets"),
    ]
    .into_iter()
    .find(|dir| dir.join(&asset).is_file())
    .unwrap_or_else(|| source.root.join("assets"))
}

/// `shoal bench sim --scene S`: the scene's own fish and scripts, timed like the layouts.
fn run_scene_bench(
    args: &SimArgs,
    source: &super::ScriptSource,
    scene: &Path,
    ticks: usize,
) -> anyhow::Result<ExitCode> {
    // A bare name is a scene in `scripts/scenes/`, as for `shoal run` and `shoal render`.
    let named = super::render::named_scene(&source.scripts, scene);
    let scene = match &named {
        Some(path) if !scene.exists() => path.as_path(),
        None if scene.extension().is_none() && !scene.exists() => {
            return Err(super::render::unknown_scene(scene, &source.scripts, false));
        }
        _ => scene,
    };
    let mut sim =
        Simulation::from_scene_with_scripts(&source.root, &source.scripts, scene, args.seed)
            .with_context(|| format!("loading scene `{}`", scene.display()))?;
    if let Some(line) = super::borrowed_models_line(&sim).filter(|_| !args.json) {
        println!("{line}");
    }
    if let Some(n) = args.lanes {
        if n == 0 {
            anyhow::bail!("--lanes must be at least 1");
        }
        sim.set_lanes(n)?;
    }
    sim.world_mut().set_pose_mode(args.pose.mode());
    args.lod.apply(&mut sim);
    let sampling = args.sample_functions.unwrap_or(true);
    sim.set_function_sampling(sampling.then_some(SAMPLE_EVERY));
    // One second of warm-up, then the per-module profile counts the measured ticks only.
    for _ in 0..TICK_HZ as usize {
        sim.step();
    }
    sim.reset_profile();
    let result = measure(sim.pipeline_mut(), 0, ticks);
    let modules = sim.profile();
    let memory = sim.script_memory();
    let errors = sim.error_messages();
    let switched_off = sim.switched_off();
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "scene": scene.display().to_string(),
                "tick_hz": TICK_HZ,
                "results": [result],
                "function_sampling": sampling,
                "script_memory_bytes": memory,
                "script_errors": errors.len(),
                "switched_off": switched_off.iter().map(|(n, _)| n).collect::<Vec<_>>(),
                "modules": modules
                    .iter()
                    .map(|m| Ok((m.module.clone(), serde_json::to_value(m)?)))
                    .collect::<Result<serde_json::Map<_, _>, serde_json::Error>>()?,
            }))?
        );
    } else {
        println!(
            "scene {}, script lanes: {}, {}",
            scene.display(),
            sim.num_lanes(),
            args.pose.describe()
        );
        print_row(&result, true, Driver::Lua);
        print_decisions(&result);
        print_profile(&modules, memory);
        if sampling {
            print_functions(&modules);
        }
        if !errors.is_empty() {
            println!(
                "{} distinct script errors; first: {}",
                errors.len(),
                errors[0]
            );
        }
        for (name, why) in &switched_off {
            println!("behaviour {name} switched off after {why}");
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn print_row(r: &SimBenchResult, header: bool, driver: Driver) {
    let us = |v: Option<f64>| v.map_or_else(|| "-".to_owned(), |v| format!("{v:.2}"));
    if header {
        let driver = match driver {
            Driver::Lua => "Lua, shipped behaviours",
            Driver::Rust => "built-in Rust wander/school (no Lua)",
        };
        println!(
            "driver: {driver}, {} threads; stage columns are medians, ms; decide/sense: CPU µs per decision (mean)",
            r.threads
        );
        println!(
            "{:>7} {:>9} {:>8} {:>10} {:>9} | {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} | {:>9} {:>9} | {:>7} {:>9}",
            "fish",
            "median ms",
            "p99 ms",
            "fish-tick/s",
            "µs/fish",
            "sched",
            "percep",
            "behav",
            "motion",
            "skel",
            "palette",
            "grid",
            "decide µs",
            "sense µs",
            "in view",
            "nearest L"
        );
    }
    let s = &r.stages;
    println!(
        "{:>7} {:>9.3} {:>8.3} {:>10.3e} {:>9.3} | {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3} | {:>9} {:>9} | {:>7.1} {:>9.2}",
        r.fish,
        r.median_ms,
        r.p99_ms,
        r.fish_ticks_per_s,
        r.us_per_fish,
        s.schedule,
        s.perception,
        s.behavior,
        s.motion,
        s.skeleton,
        s.palette,
        s.grid,
        us(r.decide_us_per_decision),
        us(r.sense_us_per_decision),
        r.mean_in_view,
        r.mean_nearest_lengths
    );
}

/// The decisions a tick made, per level-of-detail band: `10000 fish: 1001.3 decisions/tick
/// (level of detail on: band 1 120.0, band 2 300.5, band 3 580.8; 12.4 woken by events: 3.1 by
/// a predator or pellet in view, …)`.
fn print_decisions(r: &SimBenchResult) {
    let bands = r
        .band_decisions_per_tick
        .iter()
        .enumerate()
        .map(|(k, n)| format!("band {} {n:.1}", k + 1))
        .collect::<Vec<_>>()
        .join(", ");
    if r.lod {
        println!(
            "{} fish: {:.1} decisions/tick (level of detail on: {bands}; {:.1} woken by events: \
             {:.1} by a predator or pellet in view, {:.1} by a wall or rock, {:.1} by a \
             neighbour within half a body length)",
            r.fish,
            r.decisions_per_tick,
            r.woken_per_tick,
            r.woken_by_per_tick.seen,
            r.woken_by_per_tick.obstacle,
            r.woken_by_per_tick.neighbour
        );
    } else {
        println!(
            "{} fish: {:.1} decisions/tick (level of detail off)",
            r.fish, r.decisions_per_tick
        );
    }
}

/// Arguments of `shoal bench render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// Fish counts to measure, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "1,100,1000,10000")]
    pub fish: Vec<usize>,
    /// Image size, WIDTHxHEIGHT pixels.
    #[arg(long, default_value = "1920x1080", value_parser = super::render::parse_size)]
    pub size: (u32, u32),
    /// Measured frames per fish count (after one warm-up frame).
    #[arg(long, default_value_t = 30)]
    pub frames: usize,
    /// Largest projected error of a coarser level of detail, pixels; 0 draws every fish at full
    /// detail.
    #[arg(long, default_value_t = shoal_render::DEFAULT_LOD_TOLERANCE_PX, allow_negative_numbers = true)]
    pub lod_tolerance_px: f32,
    /// Draw this rigged model (joints spine_1 …, e.g. from `shoal asset rig`) instead of the
    /// black porgy, with its material and textures.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Ignore the model's material: vertex colours only, opaque (to time what textures cost).
    #[arg(long)]
    pub no_materials: bool,
    /// Where the fish are posed: `gpu` (the window's pose pass, the default) or `cpu` (every
    /// palette on the CPU, uploaded each frame).
    #[arg(long, value_enum, default_value_t = PoseArg::Gpu)]
    pub pose: PoseArg,
    /// Where the fish are culled and their levels chosen: `gpu` (a compute pass and indirect
    /// draws, the default; the counts are read back after the last frame) or `cpu`. An adapter
    /// without indirect draws culls on the CPU either way.
    #[arg(long, value_enum, default_value_t = super::CullingArg::Gpu)]
    pub culling: super::CullingArg,
}

fn run_render(args: RenderArgs) -> anyhow::Result<ExitCode> {
    if args.frames == 0 {
        anyhow::bail!("--frames must be at least 1");
    }
    super::render::check_lod_tolerance(args.lod_tolerance_px)?;
    let gpu = Gpu::headless()?;
    println!("adapter: {}", gpu.adapter_summary());
    let target = OffscreenTarget::new(&gpu, args.size.0, args.size.1);
    println!(
        "({}x{}, {} frames each, GPU work waited for every frame; counts are per frame, of the \
         last frame; LOD tolerance {} px; {}; culling: {}; pose ms: the tick's pose work, \
         CPU, median (--pose gpu: the motion stage, which writes the records as it moves the \
         fish; --pose cpu: skeletons and palettes); instances ms: the window's scene bringing its fish instances and props \
         up to the world, CPU, mean (kept while no fish comes, goes or changes species); \
         check ms: the renderer checking the frame (the instances once per revision, the pose \
         records every frame), mean; upload ms: the renderer's CPU work before recording the \
         draws, mean; pose up ms: of that, writing the pose pass's per-fish records, mean; cull \
         ms: of that, culling and levels of detail; records ms: of that, on the GPU path, \
         bringing the per-fish culling records up to date, mean; written: records written a \
         frame, mean (all of them in the warm-up frame, then only changed ones); draws: \
         recorded/that drew something)",
        args.size.0,
        args.size.1,
        args.frames,
        args.lod_tolerance_px,
        args.pose.describe(),
        if args.culling == super::CullingArg::Gpu && Renderer::gpu_culling_supported(&gpu) {
            "GPU (compute pass, indirect draws)"
        } else {
            "CPU"
        }
    );
    println!(
        "{:>7} {:>12} {:>10} {:>10} {:>12} {:>8} {:>10} {:>12} {:>8} {:>10} {:>8} {:>6} {:>7} {:>7} {:>24} {:>12}",
        "fish",
        "median ms",
        "p99 ms",
        "pose ms",
        "instances ms",
        "check ms",
        "upload ms",
        "pose up ms",
        "cull ms",
        "records ms",
        "written",
        "draws",
        "drawn",
        "culled",
        format!(
            "fish per LOD {}",
            (0..shoal_render::MAX_LODS)
                .map(|l| l.to_string())
                .collect::<Vec<_>>()
                .join("/")
        ),
        "triangles"
    );
    for &n in &args.fish {
        let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT)?;
        renderer.set_lod_tolerance_px(args.lod_tolerance_px);
        renderer.set_culling(args.culling.culling());
        let species = match &args.model {
            None => porgy_species()?,
            Some(path) => model_species(path)?,
        };
        let mut scene = WorldScene::new(WanderPipeline::new(
            bench_world(species, n, 1)?,
            WanderDriver::default(),
        ));
        scene.set_gpu_pose(args.pose == PoseArg::Gpu);
        let num_joints = scene
            .world()
            .species(SpeciesId(0))
            .model
            .skeleton
            .num_joints();
        // Species meshes only (the props come after them); a bench world has no rocks or food.
        let num_species = scene.world().num_species();
        for mut m in scene.meshes().into_iter().take(num_species) {
            if args.no_materials {
                m.materials = &[];
                m.parts = &[];
                m.uvs = &[];
                m.tangents = &[];
            }
            let id = renderer.upload_mesh(&gpu, &m)?;
            if n == args.fish[0] {
                let levels: Vec<String> = renderer
                    .mesh_lods(id)
                    .unwrap_or_default()
                    .iter()
                    .map(|l| format!("{} (error {:.3})", l.num_triangles(), l.error))
                    .collect();
                let shadow = renderer.mesh_shadow_level(id).map_or(String::new(), |l| {
                    format!("{} (error {:.3})", l.num_triangles(), l.error)
                });
                println!(
                    "mesh: {} ({num_joints} joints), triangles per level of detail: {}; \
                     shadow: {shadow}",
                    m.label,
                    levels.join(", ")
                );
            }
        }
        let camera = whole_tank_camera(scene.default_camera(), scene.world().tank(), args.size);
        let mut times = Vec::with_capacity(args.frames);
        let mut pose_ms = Vec::with_capacity(args.frames);
        let mut upload = 0.0;
        let mut instances = 0.0;
        let mut check = 0.0;
        let mut pose_upload = 0.0;
        let mut cull = 0.0;
        let mut records = 0.0;
        let mut written = 0.0;
        for frame in 0..args.frames + 1 {
            scene.step(1.0 / 60.0);
            let c = scene.world().counters();
            // On the GPU path the motion pass writes the records as it moves the fish, so the
            // CPU's pose work is inside the motion stage.
            let pose_ns = match args.pose {
                PoseArg::Gpu => c.motion_ns,
                PoseArg::Cpu => c.skeleton_ns + c.palette_ns,
            };
            pose_ms.push(pose_ns as f64 * 1e-6);
            let mut input = scene.frame_input();
            input.camera = camera;
            let start = Instant::now();
            renderer.render(&gpu, target.view(), target.size(), &input)?;
            gpu.wait_idle();
            let ms = start.elapsed().as_secs_f64() * 1e3;
            if frame >= 1 {
                times.push(ms);
                upload += f64::from(renderer.timings().upload_ms);
                instances += f64::from(scene.instances_ms());
                check += f64::from(renderer.timings().check_ms);
                pose_upload += f64::from(renderer.timings().pose_upload_ms);
                cull += f64::from(renderer.timings().cull_ms);
                records += f64::from(renderer.timings().records_ms);
                written += f64::from(renderer.timings().num_records_written);
            }
        }
        let (median, p99) = shoal_core::world::bench::median_p99(&mut times);
        let (pose, _) = shoal_core::world::bench::median_p99(&mut pose_ms);
        // Culled on the GPU, the counts are there until read back.
        let t = renderer.read_gpu_counts(&gpu)?;
        let per_lod = t
            .num_fish_per_lod
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join("/");
        println!(
            "{n:>7} {median:>12.2} {p99:>10.2} {pose:>10.3} {:>12.3} {:>8.3} {:>10.3} {:>12.3} {:>8.3} {:>10.3} {:>8.0} {:>6} {:>7} {:>7} {:>24} {:>12}",
            instances / args.frames as f64,
            check / args.frames as f64,
            upload / args.frames as f64,
            pose_upload / args.frames as f64,
            cull / args.frames as f64,
            records / args.frames as f64,
            written / args.frames as f64,
            format!("{}/{}", t.num_draw_calls, t.num_nonempty_draw_calls),
            t.num_fish_drawn,
            t.num_fish_culled,
            per_lod,
            t.num_triangles
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// Where the generated black porgy lives: `assets/black_porgy.glb` under the working directory
/// when it is there, else under the source tree.
fn porgy_asset_path() -> PathBuf {
    let local = PathBuf::from("assets/black_porgy.glb");
    if local.is_file() {
        local
    } else {
        shoal_core::source_root().join("assets/black_porgy.glb")
    }
}

/// The black porgy species on [`porgy_asset_path`].
fn porgy_species() -> anyhow::Result<Species> {
    let path = porgy_asset_path();
    let dir = path.parent().unwrap_or(Path::new("."));
    Ok(Species::load(SpeciesDesc::black_porgy(), dir)?)
}

/// A species for a rigged model file (joints spine_1 …), as `shoal asset species` would
/// suggest it.
fn model_species(path: &Path) -> anyhow::Result<Species> {
    let model = shoal_core::skin::FishModel::load(path)?;
    let file = path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let desc = shoal_core::asset::species_file::suggest("bench", &file, &model)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
        .desc;
    let dir = path.parent().unwrap_or(Path::new("."));
    Ok(Species::load(desc, dir)?)
}

/// `base` moved back along its view direction until the tank's bounding sphere fits the view of
/// a `size` image, so every fish is drawn (none culled) and the counts compare across fish
/// counts.
fn whole_tank_camera(base: Camera, tank: &shoal_core::world::Tank, size: (u32, u32)) -> Camera {
    let radius = tank.extent().length() * 0.5;
    let aspect = size.0 as f32 / size.1.max(1) as f32;
    let half_v = base.fov_y_rad * 0.5;
    let half_h = (half_v.tan() * aspect).atan();
    Camera {
        target: (tank.min + tank.max) * 0.5,
        distance: radius / half_v.min(half_h).sin() * 1.02,
        ..base
    }
}

/// Draws median and p99 milliseconds per tick against fish count (log–log), with the issue's
/// 8 ms target and the line of constant cost per fish through the smallest count.
fn plot_sim(path: &Path, results: &[SimBenchResult], title: &str) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let area = BitMapBackend::new(path, (900, 600)).into_drawing_area();
    area.fill(&WHITE)?;
    let fish_max = results.iter().map(|r| r.fish).max().unwrap_or(1) as f64;
    let fish_min = results.iter().map(|r| r.fish).min().unwrap_or(1) as f64;
    let ms_max = results.iter().map(|r| r.p99_ms).fold(8.0f64, f64::max);
    let ms_min = results.iter().map(|r| r.median_ms).fold(8.0f64, f64::min);
    let mut chart = ChartBuilder::on(&area)
        .caption(title, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(64)
        .build_cartesian_2d(
            (fish_min * 0.7..fish_max * 1.4).log_scale(),
            (ms_min * 0.5..ms_max * 2.0).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_desc("fish")
        .y_desc("milliseconds per 60 Hz tick")
        .x_labels(8)
        .y_labels(8)
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_label_formatter(&|y| format!("{y}"))
        .draw()?;
    let target = [(fish_min * 0.7, 8.0), (fish_max * 1.4, 8.0)];
    chart
        .draw_series(DashedLineSeries::new(target, 6, 4, RED.stroke_width(2)))?
        .label("8 ms: the target at 10,000 fish")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RED));
    if let Some(first) = results.iter().min_by_key(|r| r.fish) {
        let per_fish = first.median_ms / first.fish as f64;
        let linear = [
            (fish_min * 0.7, per_fish * fish_min * 0.7),
            (fish_max * 1.4, per_fish * fish_max * 1.4),
        ];
        chart
            .draw_series(DashedLineSeries::new(linear, 3, 5, BLACK.mix(0.4).into()))?
            .label("constant cost per fish")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.mix(0.4)));
    }
    let mut sorted: Vec<&SimBenchResult> = results.iter().collect();
    sorted.sort_by_key(|r| r.fish);
    for (series, color, pick) in [
        (
            "median",
            BLUE,
            (|r: &SimBenchResult| r.median_ms) as fn(&SimBenchResult) -> f64,
        ),
        ("p99", RGBColor(0, 150, 60), |r: &SimBenchResult| r.p99_ms),
    ] {
        let pts: Vec<(f64, f64)> = sorted.iter().map(|r| (r.fish as f64, pick(r))).collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?
            .label(series)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color));
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    area.present()?;
    Ok(())
}

/// The per-module table of `shoal bench sim --scene`: what each behaviour costs, the most
/// expensive first, with what it allocates; `memory` is what the Lua states hold at the end.
fn print_profile(modules: &[shoal_script::sim::ModuleProfile], memory: usize) {
    if modules.is_empty() {
        return;
    }
    println!("\nper behaviour module (CPU time over every lane, measured ticks):");
    println!(
        "  {:<14} {:>9} {:>12} {:>11} {:>10} {:>13} {:>11} {:>11} {:>7} {:>7}",
        "module",
        "calls",
        "behaviour ms",
        "sensing ms",
        "µs/call",
        "ms per sim s",
        "B alloc/call",
        "KiB/sim s",
        "errors",
        "limits"
    );
    for m in modules {
        println!(
            "  {:<14} {:>9} {:>12.2} {:>11.2} {:>10.2} {:>13.2} {:>11.0} {:>11.1} {:>7} {:>7}",
            m.module,
            m.calls,
            m.behavior_ms,
            m.sensing_ms,
            m.us_per_call,
            m.ms_per_sim_s,
            m.alloc_bytes_per_call,
            m.alloc_kib_per_sim_s,
            m.errors,
            m.limit_stops
        );
    }
    println!(
        "  (allocated: bytes the decisions asked Lua's allocator for; the Lua states hold {:.1} MiB now)",
        memory as f64 / (1024.0 * 1024.0)
    );
}

/// Rows of the top-functions table of `shoal bench sim --scene`.
const TOP_FUNCTIONS: usize = 15;

/// The top functions of every module by the stack samples, most estimated self time first.
fn print_functions(modules: &[shoal_script::sim::ModuleProfile]) {
    let samples: u64 = modules.iter().map(|m| m.samples).sum();
    println!(
        "\ntop functions ({samples} stack samples; time estimated as the share of its module's samples):"
    );
    if samples == 0 {
        println!("  none: no decision was running when the watchdog looked (or not on Linux)");
        return;
    }
    if samples < 300 {
        println!(
            "  (few samples, so the shares are rough: a longer --seconds gives about one per ms of Lua)"
        );
    }
    let mut rows: Vec<(&str, &shoal_script::profiler::FunctionProfile)> = modules
        .iter()
        .flat_map(|m| m.functions.iter().map(move |f| (m.module.as_str(), f)))
        .collect();
    rows.sort_by(|a, b| b.1.self_ms_per_sim_s.total_cmp(&a.1.self_ms_per_sim_s));
    let width = rows
        .iter()
        .take(TOP_FUNCTIONS)
        .map(|(_, f)| f.frame.file.len() + 6)
        .max()
        .unwrap_or(10)
        .max(10);
    println!(
        "  {:<24} {:<12} {:<width$} {:>7} {:>10} {:>10} {:>8}",
        "function", "module", "file:line", "share", "self ms/s", "total ms/s", "samples"
    );
    for (module, f) in rows.into_iter().take(TOP_FUNCTIONS) {
        let place = format!("{}:{}", f.frame.file, f.frame.line);
        println!(
            "  {:<24} {:<12} {:<width$} {:>6.1}% {:>10.3} {:>10.3} {:>8}",
            f.frame.name,
            module,
            place,
            100.0 * f.self_share,
            f.self_ms_per_sim_s,
            f.total_ms_per_sim_s,
            f.self_samples
        );
    }
}
