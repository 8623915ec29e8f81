//! Command-line interface: one file per subcommand, each with its `Args` and a `run`.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub mod asset;
pub mod bench;
pub mod bench_history;
pub mod bench_peer;
pub mod check;
pub mod compare;
pub mod export;
pub mod kinematics;
pub mod motion;
pub mod plot;
pub mod render;
pub mod run;
pub mod set;
pub mod skin;
pub mod test;
pub mod timeline;

/// shoal: script artificial fish in Lua and watch them swim.
#[derive(Debug, Parser)]
#[command(name = "shoal", version, about, long_about = None)]
pub struct Cli {
    /// The subcommand; none runs the aquarium.
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// Every subcommand. With none, `shoal` runs the aquarium (`shoal run`).
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Open the aquarium window with the tuning panel.
    Run(run::Args),
    /// Render a scene headless to a PNG, a GIF or a directory of frames.
    Render(render::Args),
    /// Print a sampled motion (Table 1 presets) as JSON or CSV.
    Motion(motion::Args),
    /// Plot a motion preset's body midlines (Fig. 4, 6-9 of the paper).
    Plot(plot::Args),
    /// Measure steady swimming as biologists do (frequency, envelope, wavelength, St).
    Kinematics(kinematics::Args),
    /// Skin a glTF model in a pose and write the skinned positions.
    Skin(skin::Args),
    /// Build assets: the generated black porgy and eel, or rig a static mesh.
    Asset(asset::Args),
    /// Run Lua behaviour tests headless.
    Test(test::Args),
    /// Write values into a species or scene file, changing only those literals.
    Set(set::Args),
    /// Check the Lua scripts' types (emmylua_check with the shipped definitions).
    Check(check::Args),
    /// Benchmarks: simulation and rendering.
    Bench(bench::Args),
    /// Record a run of a scene headless: every fish's pose at every tick, with the scene, seed
    /// and scripts needed to run it again.
    Record(timeline::RecordArgs),
    /// Re-run a recording from a moment with the current (edited) scripts.
    Replay(timeline::ReplayArgs),
    /// Compare two runs fish by fish: when they part and how far.
    Diff(timeline::DiffArgs),
    /// An A/B experiment: two versions of the scripts over many seeds, with the measures a
    /// designer tunes for, their 95 % intervals and which differences are significant.
    Compare(compare::Args),
    /// Export a recording as glTF skeletal animation (Blender, Unreal, Unity, Godot, three.js).
    Export(export::ExportArgs),
    /// What a recording holds and, at a time, every fish's root and joint positions.
    Inspect(export::InspectArgs),
}

/// `--dap [ADDR]` and `--dap-allow-remote` of `shoal run` and `shoal test`: debug the scripts
/// from an editor over the Debug Adapter Protocol (see `script::debug`).
#[derive(Debug, Default, Clone, clap::Args)]
pub struct DapArg {
    /// Serve the Debug Adapter Protocol on ADDR (HOST:PORT or a port; default 127.0.0.1:4711)
    /// and wait for a client (VS Code: see scripts/README.md) before simulating. Scripts then
    /// run in one lane; a breakpoint pauses the whole simulation.
    #[arg(long, value_name = "ADDR", num_args = 0..=1,
          default_missing_value = shoal_script::debug::DEFAULT_ADDR)]
    pub dap: Option<String>,
    /// Let --dap listen on an address that is not loopback (whoever connects can run Lua).
    #[arg(long, requires = "dap")]
    pub dap_allow_remote: bool,
}

impl DapArg {
    /// With `--dap`: listens, says where, waits for the client's `configurationDone`, and
    /// attaches the debugger to every simulation made from then on.
    pub fn start(&self) -> anyhow::Result<Option<std::sync::Arc<shoal_script::debug::Debugger>>> {
        use shoal_script::debug;
        let Some(spec) = &self.dap else {
            return Ok(None);
        };
        let addr = debug::parse_addr(spec, self.dap_allow_remote)?;
        let debugger = debug::Debugger::new();
        let local = debug::server::listen(addr, &debugger)?;
        debug::attach_globally(&debugger);
        println!(
            "DAP server listening on {local}: waiting for a debugger to attach (how: \
             scripts/README.md, \"Debugging behaviours from an editor\")"
        );
        debugger.wait_for_configuration();
        println!("DAP client attached: simulating");
        Ok(Some(debugger))
    }
}

/// `--scripts DIR` (or `SHOAL_SCRIPTS`): where behaviours, species and scenes come from.
#[derive(Debug, Default, Clone, clap::Args)]
pub struct ScriptsArg {
    /// Scripts directory (behaviors/, species/, scenes/). Default: ./scripts when the working
    /// directory has one, else the scripts of the source tree shoal was built from.
    #[arg(long, value_name = "DIR", env = "SHOAL_SCRIPTS")]
    pub scripts: Option<std::path::PathBuf>,
}

/// On or off, as `--lod` takes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OnOff {
    /// On.
    On,
    /// Off.
    Off,
}

impl OnOff {
    /// `true` for on.
    pub fn on(self) -> bool {
        self == OnOff::On
    }
}

/// `--lod on|off`: behaviour level of detail (default: the scene's `lod.on`, else off).
#[derive(Debug, Default, Clone, clap::Args)]
pub struct LodArg {
    /// Behaviour level of detail: fish far from the focus decide less often, and events wake
    /// them (docs/lod.md). Default: the scene's `lod.on`, else off.
    #[arg(long, value_name = "on|off")]
    pub lod: Option<OnOff>,
}

impl LodArg {
    /// Applies the flag to `sim`, if given.
    pub fn apply(&self, sim: &mut shoal_script::Simulation) {
        if let Some(v) = self.lod {
            sim.set_lod_on(v.on());
        }
    }

    /// The flag as on/off, if given.
    pub fn on(&self) -> Option<bool> {
        self.lod.map(OnOff::on)
    }
}

/// Where the scripts come from, and the root the assets are found under.
#[derive(Debug, Clone, PartialEq)]
pub struct ScriptSource {
    /// The repository root (`assets/` lives here).
    pub root: std::path::PathBuf,
    /// The scripts directory.
    pub scripts: std::path::PathBuf,
    /// Why this directory: "--scripts", "./scripts", "the source tree".
    pub why: &'static str,
}

impl std::fmt::Display for ScriptSource {
    /// `scripts: /path/to/scripts (from --scripts or SHOAL_SCRIPTS)`, and where the assets come
    /// from when that is not beside the scripts.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "scripts: {} ({})", self.scripts.display(), self.why)?;
        if self.scripts.parent() != Some(self.root.as_path()) {
            write!(
                f,
                "\nassets: {} (none beside the scripts)",
                self.root.join("assets").display()
            )?;
        }
        Ok(())
    }
}

impl ScriptSource {
    /// The scripts and models of the repository root `root` given with `--root`.
    pub fn of_root(root: &std::path::Path) -> Self {
        ScriptSource {
            root: root.to_path_buf(),
            scripts: root.join("scripts"),
            why: "--root",
        }
    }
}

impl ScriptsArg {
    /// Resolves the scripts directory: `--scripts`/`SHOAL_SCRIPTS`, else `./scripts`, else the
    /// source tree's. An explicit directory that does not exist is an error.
    pub fn resolve(&self) -> anyhow::Result<ScriptSource> {
        let built = shoal_core::source_root().to_path_buf();
        let cwd = std::env::current_dir().unwrap_or_else(|_| ".".into());
        self.resolve_in(&cwd, &built)
    }

    /// [`ScriptsArg::resolve`] from working directory `cwd`, with the source tree at `built`.
    fn resolve_in(
        &self,
        cwd: &std::path::Path,
        built: &std::path::Path,
    ) -> anyhow::Result<ScriptSource> {
        let (cwd, built) = (cwd.to_path_buf(), built.to_path_buf());
        if let Some(dir) = &self.scripts {
            if !dir.is_dir() {
                anyhow::bail!(
                    "--scripts {}: no such directory (it should hold behaviors/, species/ and \
                     scenes/)",
                    dir.display()
                );
            }
            let dir = dir.canonicalize().unwrap_or_else(|_| dir.clone());
            return Ok(ScriptSource {
                root: assets_root(&dir, &cwd, built),
                scripts: dir,
                why: "from --scripts or SHOAL_SCRIPTS",
            });
        }
        if cwd.join("scripts").is_dir() {
            let scripts = cwd.join("scripts");
            return Ok(ScriptSource {
                root: assets_root(&scripts, &cwd, built),
                scripts,
                why: "the working directory's scripts/",
            });
        }
        Ok(ScriptSource {
            scripts: built.join("scripts"),
            root: built,
            why: "the source tree shoal was built from; choose with --scripts DIR or SHOAL_SCRIPTS",
        })
    }
}

/// The root whose `assets/` the fish models come from, for the scripts directory `scripts`:
/// beside the scripts when there is one, else the working directory's, else the source tree's
/// (`built`). So a designer's own folder holding a copy of the scripts and no `assets/` gets
/// the source tree's fish.
fn assets_root(
    scripts: &std::path::Path,
    cwd: &std::path::Path,
    built: std::path::PathBuf,
) -> std::path::PathBuf {
    [scripts.parent(), Some(cwd)]
        .into_iter()
        .flatten()
        .find(|r| r.join("assets").is_dir())
        .map_or(built, std::path::Path::to_path_buf)
}

/// The startup line for the models a simulation took from the source tree because the
/// folder's own `assets/` lacks them: `models: black_porgy.glb, eel.glb from /src/assets (not
/// in ./assets)`; nothing when every model is the folder's own.
pub fn borrowed_models_line(sim: &shoal_script::Simulation) -> Option<String> {
    let borrowed = sim.borrowed_models();
    let first = borrowed.first()?;
    let names: Vec<&str> = borrowed.iter().map(|b| b.asset.as_str()).collect();
    Some(format!(
        "models: {} from {} (not in {})",
        names.join(", "),
        first.dir.display(),
        sim.assets_dir().display()
    ))
}

/// An error and its causes on one line, `context: cause: cause`, leaving out a cause whose text
/// the line already holds (errors that print their source in their own message).
pub fn error_chain(err: &anyhow::Error) -> String {
    let mut line = err.to_string();
    for cause in err.chain().skip(1) {
        let text = cause.to_string();
        if !line.contains(&text) {
            line.push_str(": ");
            line.push_str(&text);
        }
    }
    line
}

impl Cli {
    /// The log filter where `RUST_LOG` does not set one. `shoal test` shows what scripts print
    /// and the errors they raise under each test on stdout, so there the script console's echo
    /// on stderr is off.
    pub fn default_log_filter(&self) -> &'static str {
        match self.command {
            Some(Command::Test(_)) => "info,shoal::script::log=off",
            _ => "info",
        }
    }
}

/// Runs the parsed command line and returns the process exit code.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        None => run::run(run::Args::default()),
        Some(Command::Run(args)) => run::run(args),
        Some(Command::Render(args)) => render::run(args),
        Some(Command::Motion(args)) => motion::run(args),
        Some(Command::Plot(args)) => plot::run(args),
        Some(Command::Kinematics(args)) => kinematics::run(args),
        Some(Command::Skin(args)) => skin::run(args),
        Some(Command::Asset(args)) => asset::run(args),
        Some(Command::Test(args)) => test::run(args),
        Some(Command::Check(args)) => check::run(args),
        Some(Command::Set(args)) => set::run(args),
        Some(Command::Bench(args)) => bench::run(args),
        Some(Command::Record(args)) => timeline::record(args),
        Some(Command::Replay(args)) => timeline::replay(args),
        Some(Command::Diff(args)) => timeline::diff(args),
        Some(Command::Compare(args)) => compare::run(args),
        Some(Command::Export(args)) => export::run_export(args),
        Some(Command::Inspect(args)) => export::run_inspect(args),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A working directory with `scripts/` and no `assets/` (a designer's copy of the scripts)
    /// takes its assets from the source tree, and says so; with `assets/` it uses its own.
    #[test]
    fn working_directory_scripts_without_assets_use_the_source_tree_s() {
        let built = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(built.path().join("assets")).unwrap();
        let cwd = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(cwd.path().join("scripts")).unwrap();
        let source = ScriptsArg::default()
            .resolve_in(cwd.path(), built.path())
            .unwrap();
        assert_eq!(source.scripts, cwd.path().join("scripts"));
        assert_eq!(source.root, built.path());
        let shown = source.to_string();
        assert!(
            shown.contains(&format!(
                "assets: {} (none beside the scripts)",
                built.path().join("assets").display()
            )),
            "{shown}"
        );
        std::fs::create_dir_all(cwd.path().join("assets")).unwrap();
        let source = ScriptsArg::default()
            .resolve_in(cwd.path(), built.path())
            .unwrap();
        assert_eq!(source.root, cwd.path());
        assert!(!source.to_string().contains("assets:"), "{source}");
    }

    #[test]
    fn error_chain_names_each_cause_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "scene file not found");
        let err = anyhow::Error::new(shoal_script::ScriptError::Io {
            path: "x.lua".into(),
            source: io,
        })
        .context("loading scene `x.lua`");
        assert_eq!(
            error_chain(&err),
            "loading scene `x.lua`: cannot read x.lua: scene file not found"
        );
    }
}

/// Where `shoal bench render` culls the fish and picks their levels of detail.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CullingArg {
    /// The CPU sorts the instances by draw each frame and uploads them.
    Cpu,
    /// A compute pass and indirect draws (the default where the adapter runs indirect draws).
    Gpu,
}

impl CullingArg {
    /// The renderer's setting for it.
    pub fn culling(self) -> shoal_render::Culling {
        match self {
            CullingArg::Cpu => shoal_render::Culling::Cpu,
            CullingArg::Gpu => shoal_render::Culling::Gpu,
        }
    }
}

/// Where `shoal bench sim` and `shoal bench peer` pose the fish.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PoseArg {
    /// The CPU pose stage: skeletons and every palette (tests, CPU skinning).
    Cpu,
    /// The window's: one record per fish for the GPU pose pass.
    Gpu,
}

impl PoseArg {
    /// The world's mode for it.
    pub fn mode(self) -> shoal_core::world::PoseMode {
        match self {
            PoseArg::Cpu => shoal_core::world::PoseMode::Cpu,
            PoseArg::Gpu => shoal_core::world::PoseMode::Gpu,
        }
    }

    /// Its name on the command line (and in the JSON reports).
    pub fn name(self) -> &'static str {
        match self {
            PoseArg::Cpu => "cpu",
            PoseArg::Gpu => "gpu",
        }
    }

    /// How the table's header names it.
    pub fn describe(self) -> &'static str {
        match self {
            PoseArg::Cpu => "pose: CPU (skeletons and palettes)",
            PoseArg::Gpu => {
                "pose: GPU pass (the motion pass writes its records: no palette column)"
            }
        }
    }
}

/// The constant-density bench school through the Lua simulation with the shipped behaviours
/// ([`shoal_script::sim::bench_school`]); `--lanes` checked.
pub(crate) fn lua_sim(
    source: &ScriptSource,
    fish: usize,
    seed: u64,
    lanes: Option<usize>,
) -> anyhow::Result<shoal_script::Simulation> {
    if lanes == Some(0) {
        anyhow::bail!("--lanes must be at least 1");
    }
    use anyhow::Context as _;
    shoal_script::sim::bench_school(&source.root, &source.scripts, fish, seed, lanes)
        .with_context(|| format!("loading the scripts under {}", source.scripts.display()))
}

/// Whether `err` comes from writing to a pipe whose reader has gone (`shoal … | head -1`).
pub fn is_closed_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// Whether a panic's message is the standard library's for a print into a closed pipe
/// (`failed printing to stdout: Broken pipe (os error 32)`): `print!` panics where `write!`
/// would return the error, and the message is all the hook is given.
pub fn is_closed_pipe_panic(message: &str) -> bool {
    let broken = std::io::Error::from(std::io::ErrorKind::BrokenPipe).to_string();
    message.starts_with("failed printing to std")
        && (message.contains(&broken) || message.contains("os error 32"))
}

/// The set-up of a large Lua scene, shown on stderr (see [`SpawnProgress::new`]).
pub struct SpawnProgress {
    bar: Option<indicatif::ProgressBar>,
    started: std::time::Instant,
    shown: bool,
}

impl SpawnProgress {
    /// Fish from which a scene's set-up is shown: it takes seconds from here.
    pub const FROM_FISH: u64 = 10_000;

    /// A bar on a terminal; elsewhere (a log, a pipe) one line when the spawning starts and
    /// one when it is done.
    pub fn new() -> Self {
        Self {
            bar: None,
            started: std::time::Instant::now(),
            shown: false,
        }
    }
}

impl Default for SpawnProgress {
    fn default() -> Self {
        Self::new()
    }
}

impl shoal_script::SetupProgress for SpawnProgress {
    fn start(&mut self, total: u64) {
        use std::io::IsTerminal;
        if total < Self::FROM_FISH {
            return;
        }
        self.shown = true;
        self.started = std::time::Instant::now();
        if std::io::stderr().is_terminal() {
            let bar = indicatif::ProgressBar::new(total);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "setting up: {bar:40} {pos}/{len} fish spawned ({eta} left)",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            self.bar = Some(bar);
        } else {
            eprintln!(
                "setting up {total} fish (about {} of memory)…",
                shoal_core::world::footprint::human(shoal_core::world::footprint::estimate_bytes(
                    total
                ))
            );
        }
    }

    fn spawned(&mut self, done: u64) {
        if let Some(bar) = &self.bar {
            bar.set_position(done);
        }
    }

    fn finish(&mut self, total: u64) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
        if self.shown {
            eprintln!(
                "set up {total} fish in {:.1} s",
                self.started.elapsed().as_secs_f64()
            );
        }
    }
}
