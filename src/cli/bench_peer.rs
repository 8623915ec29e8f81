//! `shoal bench peer` (issue 18): shoal's `bench sim` beside a pure-Lua peer of the same workload,
//! in the same minute, on the same fish counts, with the ratios.
//!
//! The peer is a Lua script (by default `../shared/bench/peer_school.lua` beside the repository:
//! the shipped `school` behaviour written the way a designer would in a Lua-only engine), read
//! where it is. It runs under each engine asked for: `luajit` (LÖVE's default JIT limits),
//! `luajit-tuned` (one `jit.opt.start` line raising them), `lua5.4` (both as subprocesses, when
//! installed), and `mlua`, shoal's own embedded Lua 5.4, in-process and unsandboxed, so there is
//! always one peer figure without installing anything.
//!
//! The peer's interface, which this module relies on and checks: `peer.lua N [FOOD] [MODE] [JIT]`
//! (`arg[1]` …), a line `local WARM_S, MEAS_S = <warm-up s>, <measured s>` (rewritten in the
//! text handed to the interpreter to honour `--seconds`; the file itself is not changed), and
//! its report lines `engine=… fish=N …`, `ticks measured …`, `median ms/tick M (p99 P) …`,
//! `us/decision (mean CPU) U` and `us/fish/tick motion+grid (median) G`.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::sync::{Arc, Mutex};

use anyhow::Context;
use regex::Regex;

use shoal_core::world::TICK_HZ;
use shoal_core::world::bench::{SimBenchResult, measure};

/// The peer beside the repository when `--peer` and `SHOAL_PEER` are not given.
pub const DEFAULT_PEER: &str = "../shared/bench/peer_school.lua";

/// Arguments of `shoal bench peer`.
#[derive(Debug, clap::Args)]
pub struct PeerArgs {
    /// Fish counts to measure, comma-separated (each runs shoal, then every peer engine).
    #[arg(long, value_delimiter = ',', default_value = "1000,10000")]
    pub fish: Vec<usize>,
    /// Seconds measured per run (after one second of warm-up), for shoal and the peer alike.
    #[arg(long, default_value_t = 5.0)]
    pub seconds: f64,
    /// The pure-Lua peer script. Default: `../shared/bench/peer_school.lua` from `--root`.
    #[arg(long, env = "SHOAL_PEER", value_name = "PATH")]
    pub peer: Option<PathBuf>,
    /// Peer engines, comma-separated: `luajit` and `lua5.4` are run when installed;
    /// `mlua` is shoal's own Lua 5.4, always there.
    #[arg(
        long,
        value_delimiter = ',',
        value_enum,
        default_value = "luajit,luajit-tuned,lua5.4,mlua"
    )]
    pub engines: Vec<Engine>,
    /// Food pellets in the peer's tank (its FOOD argument).
    #[arg(long, default_value_t = 30)]
    pub food: usize,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Repository root holding `scripts/` and `assets/` (shoal's side), and from which the
    /// default peer path is taken.
    #[arg(long, default_value = ".")]
    pub root: PathBuf,
    /// Seed of shoal's scene.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Script lanes of shoal's side. Default: one per thread.
    #[arg(long)]
    pub lanes: Option<usize>,
    /// Rounds per fish count: shoal, then every engine, this many times over. Each round's
    /// ratios are taken within its own minute; with more than one round their medians (and
    /// range) are printed too, which holds still on a shared machine where one round may not.
    #[arg(long, default_value_t = 1)]
    pub repeat: usize,
    /// Where shoal's side poses the fish (see `shoal bench sim --pose`): `gpu` counts what the
    /// window's CPU does, the records for the GPU pose pass.
    #[arg(long, value_enum, default_value_t = super::PoseArg::Cpu)]
    pub pose: super::PoseArg,
}

/// An interpreter the peer runs under.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum Engine {
    /// `luajit` with its default trace limits (LÖVE as shipped).
    #[value(name = "luajit")]
    #[serde(rename = "luajit")]
    Luajit,
    /// `luajit` with `jit.opt.start("maxtrace=8000", "maxmcode=16384")` (the peer's `big`).
    #[value(name = "luajit-tuned")]
    #[serde(rename = "luajit-tuned")]
    LuajitTuned,
    /// The `lua5.4` interpreter.
    #[value(name = "lua5.4")]
    #[serde(rename = "lua5.4")]
    Lua54,
    /// shoal's embedded Lua 5.4 (mlua), in this process, unsandboxed.
    #[value(name = "mlua")]
    #[serde(rename = "mlua")]
    Mlua,
}

impl Engine {
    fn name(self) -> &'static str {
        match self {
            Engine::Luajit => "luajit",
            Engine::LuajitTuned => "luajit-tuned",
            Engine::Lua54 => "lua5.4",
            Engine::Mlua => "mlua",
        }
    }

    /// The program for a subprocess engine; `None` for the in-process one.
    fn program(self) -> Option<&'static str> {
        match self {
            Engine::Luajit | Engine::LuajitTuned => Some("luajit"),
            Engine::Lua54 => Some("lua5.4"),
            Engine::Mlua => None,
        }
    }
}

/// What one peer run reported.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PeerResult {
    /// The engine asked for.
    pub engine: Engine,
    /// What the peer said it ran on (`LuaJIT 2.1…`, `Lua 5.4`).
    pub version: String,
    /// Fish in the peer's tank.
    pub fish: usize,
    /// Ticks measured.
    pub ticks: usize,
    /// Median milliseconds per tick (one thread).
    pub median_ms: f64,
    /// 99th-percentile milliseconds per tick.
    pub p99_ms: f64,
    /// Mean CPU microseconds per decision, sensing included.
    pub us_per_decision: f64,
    /// Median microseconds per fish-tick of the peer's grid and motion.
    pub us_per_fish_tick_grid_motion: f64,
}

/// Parses a peer's report. `origin` names the file and engine in errors.
pub fn parse_peer_output(text: &str, origin: &str) -> anyhow::Result<PeerResult> {
    let grab = |pattern: &str, what: &str| -> anyhow::Result<regex::Captures<'_>> {
        let re = Regex::new(pattern).expect("a valid pattern");
        re.captures(text).ok_or_else(|| {
            let head: String = text.lines().take(4).collect::<Vec<_>>().join("\n    ");
            anyhow::anyhow!(
                "{origin}: expected a line like `{what}` in the peer's output, got:\n    {}",
                if head.trim().is_empty() {
                    "(nothing)".to_owned()
                } else {
                    head
                }
            )
        })
    };
    let num = |c: &regex::Captures<'_>, i: usize| -> anyhow::Result<f64> {
        c[i].parse::<f64>()
            .with_context(|| format!("{origin}: `{}` is not a number", &c[i]))
    };
    let head = grab(
        r"(?m)^engine=(.+?)\s+jit=\S+\s+fish=(\d+)",
        "engine=LuaJIT 2.1  jit=big  fish=10000 (predators 100) ...",
    )?;
    let ticks = grab(
        r"(?m)^ticks measured (\d+)",
        "ticks measured 300 after 60 warm-up; ...",
    )?;
    let tick = grab(
        r"(?m)^median ms/tick ([0-9.eE+-]+)\s+\(p99 ([0-9.eE+-]+)\)",
        "median ms/tick 6.24  (p99 7.1) ...",
    )?;
    let dec = grab(
        r"(?m)^us/decision \(mean CPU\) ([0-9.eE+-]+)",
        "us/decision (mean CPU) 3.33",
    )?;
    let grid = grab(
        r"(?m)^us/fish/tick motion\+grid \(median\) ([0-9.eE+-]+)",
        "us/fish/tick motion+grid (median) 0.079 ...",
    )?;
    Ok(PeerResult {
        engine: Engine::Mlua,
        version: head[1].trim().to_owned(),
        fish: head[2]
            .parse()
            .with_context(|| format!("{origin}: fish count `{}`", &head[2]))?,
        ticks: ticks[1]
            .parse()
            .with_context(|| format!("{origin}: tick count `{}`", &ticks[1]))?,
        median_ms: num(&tick, 1)?,
        p99_ms: num(&tick, 2)?,
        us_per_decision: num(&dec, 1)?,
        us_per_fish_tick_grid_motion: num(&grid, 1)?,
    })
}

/// The peer's source with its measured seconds set to `seconds`: the line
/// `local WARM_S, MEAS_S = <warm-up>, <measured>` rewritten (line numbers unchanged).
pub fn peer_source_for(text: &str, seconds: f64, path: &Path) -> anyhow::Result<String> {
    let re = Regex::new(r"(?m)^local WARM_S, MEAS_S = ([0-9.]+), [0-9.]+[ \t]*(--.*)?$")
        .expect("a valid pattern");
    if !re.is_match(text) {
        anyhow::bail!(
            "{}: expected a line `local WARM_S, MEAS_S = <warm-up s>, <measured s>` (how \
             `shoal bench peer --seconds` sets the peer's run length); is this the peer script?",
            path.display()
        );
    }
    Ok(re
        .replacen(text, 1, format!("local WARM_S, MEAS_S = ${{1}}, {seconds}"))
        .into_owned())
}

/// Runs the peer under one subprocess engine: the source on stdin, loaded under the file's own
/// name so its errors say `path:line`.
fn run_subprocess(
    program: &str,
    engine: Engine,
    source: &str,
    path: &Path,
    fish: usize,
    food: usize,
) -> anyhow::Result<String> {
    let jit = if engine == Engine::LuajitTuned {
        "big"
    } else {
        "default"
    };
    // Arguments as the peer's command line would give them (`arg[1]` ...).
    let loader = format!(
        "local p = os.getenv('SHOAL_PEER_FILE'); local src = io.read('*a'); \
         arg = {{ [0] = p, '{fish}', '{food}', 'shoal', '{jit}' }}; \
         local f, e = load(src, '@' .. p); if not f then error(e, 0) end; f()"
    );
    let mut child = Command::new(program)
        .arg("-e")
        .arg(loader)
        .env("SHOAL_PEER_FILE", path)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .with_context(|| format!("starting {program}"))?;
    if let Some(mut stdin) = child.stdin.take() {
        stdin
            .write_all(source.as_bytes())
            .with_context(|| format!("handing {} to {program}", path.display()))?;
    }
    let out = child
        .wait_with_output()
        .with_context(|| format!("running {program}"))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        anyhow::bail!(
            "{} under {} failed ({}): {}",
            path.display(),
            engine.name(),
            out.status,
            err.trim()
        );
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Runs the peer in this process under shoal's own Lua 5.4 (mlua), unsandboxed, its `print`
/// captured.
fn run_in_process(source: &str, path: &Path, fish: usize, food: usize) -> anyhow::Result<String> {
    let lua = mlua::Lua::new();
    let printed = Arc::new(Mutex::new(String::new()));
    let sink = printed.clone();
    let run = || -> mlua::Result<()> {
        let g = lua.globals();
        let arg = lua.create_table()?;
        arg.raw_set(0, path.display().to_string())?;
        for (i, a) in [fish.to_string(), food.to_string(), "shoal".to_owned()]
            .into_iter()
            .enumerate()
        {
            arg.raw_set(i + 1, a)?;
        }
        g.set("arg", arg)?;
        let tostring: mlua::Function = g.get("tostring")?;
        g.set(
            "print",
            lua.create_function(move |_, args: mlua::MultiValue| {
                let mut line = Vec::new();
                for v in args {
                    line.push(tostring.call::<String>(v)?);
                }
                let mut out = sink.lock().unwrap_or_else(|e| e.into_inner());
                out.push_str(&line.join("\t"));
                out.push('\n');
                Ok(())
            })?,
        )?;
        lua.load(source)
            .set_name(format!("@{}", path.display()))
            .exec()
    };
    run().map_err(|e| anyhow::anyhow!("{} under mlua failed: {e}", path.display()))?;
    let out = printed.lock().unwrap_or_else(|e| e.into_inner()).clone();
    Ok(out)
}

/// Whether `program` starts (`program -v`).
fn installed(program: &str) -> bool {
    Command::new(program)
        .arg("-v")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok()
}

/// The peer path from `--peer` / `SHOAL_PEER`, else the default beside the repository; a clear
/// error naming it when it is not a file.
fn resolve_peer(args: &PeerArgs) -> anyhow::Result<PathBuf> {
    let (path, how) = match &args.peer {
        Some(p) => (p.clone(), "--peer or SHOAL_PEER"),
        None => (
            if args.root == Path::new(".") {
                PathBuf::from(DEFAULT_PEER)
            } else {
                args.root.join(DEFAULT_PEER)
            },
            "the default, ../shared/bench/peer_school.lua from --root; give --peer PATH or set SHOAL_PEER",
        ),
    };
    if !path.is_file() {
        anyhow::bail!("peer script {}: no such file ({how})", path.display());
    }
    Ok(path.canonicalize().unwrap_or(path))
}

/// Runs `shoal bench peer`.
pub fn run(args: PeerArgs) -> anyhow::Result<ExitCode> {
    if !(args.seconds.is_finite() && args.seconds > 0.0) {
        anyhow::bail!("--seconds {} must be a positive number", args.seconds);
    }
    if args.fish.is_empty() || args.fish.contains(&0) {
        anyhow::bail!("--fish needs positive counts, e.g. --fish 1000,10000");
    }
    if args.engines.is_empty() {
        anyhow::bail!("--engines needs at least one of luajit, luajit-tuned, lua5.4, mlua");
    }
    if args.repeat == 0 {
        anyhow::bail!("--repeat 0: give at least one round, e.g. --repeat 5");
    }
    let peer = resolve_peer(&args)?;
    let text = std::fs::read_to_string(&peer)
        .with_context(|| format!("reading the peer script {}", peer.display()))?;
    let source = peer_source_for(&text, args.seconds, &peer)?;

    let mut engines: Vec<Engine> = Vec::new();
    let mut missing: Vec<(Engine, String)> = Vec::new();
    for &e in &args.engines {
        if engines.contains(&e) {
            continue;
        }
        match e.program() {
            Some(p) if !installed(p) => {
                let package = if p == "luajit" { "luajit" } else { "lua5.4" };
                missing.push((
                    e,
                    format!(
                        "`{p}` is not installed (Debian/Ubuntu: apt-get install {package}); \
                         going on without {}",
                        e.name()
                    ),
                ));
            }
            _ => engines.push(e),
        }
    }
    for (_, why) in &missing {
        eprintln!("shoal bench peer: {why}");
    }
    if engines.is_empty() {
        anyhow::bail!(
            "no peer engine can run; add `mlua` (shoal's own Lua 5.4, always there) to --engines"
        );
    }
    let profile = if cfg!(debug_assertions) {
        eprintln!(
            "shoal bench peer: this is a debug build of shoal: its own figures are several times \
             slower than a release build's; compare with `cargo run --release -- bench peer`"
        );
        "debug"
    } else {
        "release"
    };
    let ticks = (args.seconds * TICK_HZ).round().max(1.0) as usize;

    let mut rows: Vec<Round> = Vec::new();
    if !args.json {
        println!(
            "peer: {} (mode shoal, food {}); {} s measured after 1 s of warm-up per run; \
             shoal {} build, {}{}",
            peer.display(),
            args.food,
            args.seconds,
            profile,
            args.pose.describe(),
            if args.repeat > 1 {
                format!("; {} rounds per fish count", args.repeat)
            } else {
                String::new()
            }
        );
    }
    for &fish in &args.fish {
        for round in 1..=args.repeat {
            let mut sim = super::lua_sim(
                &super::ScriptSource::of_root(&args.root),
                fish,
                args.seed,
                args.lanes,
            )?;
            sim.world_mut().set_pose_mode(args.pose.mode());
            let lanes = sim.num_lanes();
            let shoal = measure(sim.pipeline_mut(), TICK_HZ as usize, ticks);
            if let Some(e) = sim.error_messages().first() {
                eprintln!("script error during the bench: {e}");
            }
            drop(sim);
            let mut peers = Vec::new();
            for &engine in &engines {
                let origin = format!("{} under {}", peer.display(), engine.name());
                let out = match engine.program() {
                    Some(p) => run_subprocess(p, engine, &source, &peer, fish, args.food)?,
                    None => run_in_process(&source, &peer, fish, args.food)?,
                };
                let mut r = parse_peer_output(&out, &origin)?;
                r.engine = engine;
                if r.fish != fish {
                    anyhow::bail!(
                        "{origin}: asked for {fish} fish, the peer reported fish={} (does it \
                         read its fish count from arg[1]?)",
                        r.fish
                    );
                }
                peers.push(r);
            }
            if !args.json {
                print_rows(&shoal, lanes, &peers, rows.is_empty());
            }
            rows.push(Round {
                round,
                shoal,
                lanes,
                peers,
            });
        }
    }
    let summary = summarize(&rows);
    if !args.json && args.repeat > 1 {
        print_summary(&summary, args.repeat);
    }
    if args.json {
        let results: Vec<serde_json::Value> = rows
            .iter()
            .map(
                |Round {
                     round,
                     shoal: s,
                     lanes,
                     peers,
                 }| {
                    let decision = shoal_us_per_decision(s);
                    serde_json::json!({
                        "fish": s.fish,
                        "round": round,
                        "shoal": {
                            "median_ms": s.median_ms,
                            "p99_ms": s.p99_ms,
                            "us_per_decision": decision,
                            "decide_us_per_decision": s.decide_us_per_decision,
                            "sense_us_per_decision": s.sense_us_per_decision,
                            "threads": s.threads,
                            "stages_ms": s.stages,
                            "lanes": lanes,
                            "ticks": s.ticks,
                        },
                        "peers": peers.iter().map(|p| {
                            let mut v = serde_json::to_value(p).unwrap_or_default();
                            v["tick_ratio"] = serde_json::json!(s.median_ms / p.median_ms);
                            v["decision_ratio"] =
                                serde_json::json!(decision.map(|d| d / p.us_per_decision));
                            v["stages_ratio"] = serde_json::json!(stages_ratio(s, p));
                            v
                        }).collect::<Vec<_>>(),
                    })
                },
            )
            .collect();
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "peer": peer.display().to_string(),
                "seconds": args.seconds,
                "food": args.food,
                "shoal_build": profile,
                "pose": args.pose.name(),
                "missing": missing.iter().map(|(e, why)| serde_json::json!({
                    "engine": e, "why": why })).collect::<Vec<_>>(),
                "results": results,
                "summary": summary,
            }))?
        );
    } else {
        println!(
            "ratios are shoal ÷ peer: above 1 shoal is slower. shoal's tick is wall time on {} \
             threads; the peer runs on one. µs/decision is CPU: shoal's behaviour + sensing, the \
             peer's whole decision.",
            rows.first().map_or(0, |r| r.shoal.threads)
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// One round at one fish count: shoal's run and each engine's, in that order.
struct Round {
    round: usize,
    shoal: SimBenchResult,
    lanes: usize,
    peers: Vec<PeerResult>,
}

/// One engine at one fish count over every round: the medians of the per-round figures and
/// ratios (each ratio taken within its round), with the ratios' smallest and largest.
#[derive(Debug, Clone, serde::Serialize)]
struct Summary {
    fish: usize,
    engine: Engine,
    rounds: usize,
    shoal_median_ms: f64,
    peer_median_ms: f64,
    tick_ratio: Spread,
    decision_ratio: Option<Spread>,
    stages_ratio: Option<Spread>,
}

/// Median, smallest and largest of a set of ratios.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
struct Spread {
    median: f64,
    min: f64,
    max: f64,
}

impl Spread {
    /// `None` for no values (or any that is not finite).
    fn of(values: &[f64]) -> Option<Self> {
        if values.is_empty() || values.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let mut v = values.to_vec();
        // Sorts `v` too.
        let (median, _) = shoal_core::world::bench::median_p99(&mut v);
        Some(Self {
            median,
            min: v[0],
            max: v[v.len() - 1],
        })
    }
}

/// Issue 18's second figure: shoal's grid + motion + pose (skeleton and palette) per fish-tick
/// against the peer's grid + motion. shoal's stages run on every thread, so their wall time
/// times the thread count stands in for their CPU time (an upper bound).
fn stages_ratio(s: &SimBenchResult, p: &PeerResult) -> Option<f64> {
    if s.fish == 0 || p.us_per_fish_tick_grid_motion <= 0.0 {
        return None;
    }
    let st = &s.stages;
    let ms = st.grid + st.motion + st.skeleton + st.palette;
    let us_per_fish_tick = ms * 1000.0 * s.threads.max(1) as f64 / s.fish as f64;
    Some(us_per_fish_tick / p.us_per_fish_tick_grid_motion)
}

/// Per fish count and engine, over the rounds (in the order they first appear).
fn summarize(rows: &[Round]) -> Vec<Summary> {
    let mut keys: Vec<(usize, Engine)> = Vec::new();
    for r in rows {
        for p in &r.peers {
            if !keys.contains(&(r.shoal.fish, p.engine)) {
                keys.push((r.shoal.fish, p.engine));
            }
        }
    }
    keys.into_iter()
        .filter_map(|(fish, engine)| {
            let pairs: Vec<(&SimBenchResult, &PeerResult)> = rows
                .iter()
                .filter(|r| r.shoal.fish == fish)
                .filter_map(|r| {
                    r.peers
                        .iter()
                        .find(|p| p.engine == engine)
                        .map(|p| (&r.shoal, p))
                })
                .collect();
            let collect = |f: &dyn Fn(&SimBenchResult, &PeerResult) -> Option<f64>| {
                pairs
                    .iter()
                    .map(|(s, p)| f(s, p))
                    .collect::<Option<Vec<f64>>>()
                    .and_then(|v| Spread::of(&v))
            };
            Some(Summary {
                fish,
                engine,
                rounds: pairs.len(),
                shoal_median_ms: Spread::of(
                    &pairs.iter().map(|(s, _)| s.median_ms).collect::<Vec<_>>(),
                )?
                .median,
                peer_median_ms: Spread::of(
                    &pairs.iter().map(|(_, p)| p.median_ms).collect::<Vec<_>>(),
                )?
                .median,
                tick_ratio: collect(&|s, p| Some(s.median_ms / p.median_ms))?,
                decision_ratio: collect(&|s, p| {
                    shoal_us_per_decision(s).map(|d| d / p.us_per_decision)
                }),
                stages_ratio: collect(&stages_ratio),
            })
        })
        .collect()
}

fn print_summary(summary: &[Summary], rounds: usize) {
    println!("medians over {rounds} rounds (each ratio taken within its round; smallest–largest):");
    println!(
        "{:>7}  {:<14} {:>11} {:>11}  {:>20} {:>20} {:>24}",
        "fish",
        "engine",
        "shoal ms",
        "peer ms",
        "tick ratio",
        "decision ratio",
        "grid+motion+pose ratio"
    );
    let show = |s: Option<Spread>| {
        s.map_or_else(
            || "-".to_owned(),
            |s| format!("{:.2}× ({:.2}–{:.2})", s.median, s.min, s.max),
        )
    };
    for s in summary {
        println!(
            "{:>7}  {:<14} {:>11.3} {:>11.3}  {:>20} {:>20} {:>24}",
            s.fish,
            s.engine.name(),
            s.shoal_median_ms,
            s.peer_median_ms,
            show(Some(s.tick_ratio)),
            show(s.decision_ratio),
            show(s.stages_ratio)
        );
    }
    println!(
        "grid+motion+pose ratio: shoal's grid, motion, skeleton and palette stages (wall × \
         threads; with --pose gpu the motion stage writes the GPU pass's records) per fish-tick \
         against the peer's grid + motion per fish-tick."
    );
}

/// shoal's CPU µs per decision: behaviour plus sensing.
fn shoal_us_per_decision(s: &SimBenchResult) -> Option<f64> {
    s.decide_us_per_decision
        .map(|d| d + s.sense_us_per_decision.unwrap_or(0.0))
}

fn print_rows(shoal: &SimBenchResult, lanes: usize, peers: &[PeerResult], header: bool) {
    if header {
        println!(
            "{:>7}  {:<34} {:>9} {:>8} {:>20}  | {:>10} {:>14}",
            "fish", "engine", "ms/tick", "p99 ms", "µs/decision", "tick ratio", "decision ratio"
        );
    }
    let decision = shoal_us_per_decision(shoal);
    let split = match (shoal.decide_us_per_decision, shoal.sense_us_per_decision) {
        (Some(d), Some(s)) => format!(" ({d:.2}+{s:.2})"),
        _ => String::new(),
    };
    println!(
        "{:>7}  {:<34} {:>9.3} {:>8.3} {:>20}  |",
        shoal.fish,
        format!("shoal ({lanes} lanes)"),
        shoal.median_ms,
        shoal.p99_ms,
        decision.map_or_else(|| "-".to_owned(), |d| format!("{d:.2}{split}"))
    );
    for p in peers {
        let version = p.version.split_whitespace().take(2).collect::<Vec<_>>();
        println!(
            "{:>7}  {:<34} {:>9.3} {:>8.3} {:>20.2}  | {:>9.2}× {:>14}",
            p.fish,
            format!("{} ({})", p.engine.name(), version.join(" ")),
            p.median_ms,
            p.p99_ms,
            p.us_per_decision,
            shoal.median_ms / p.median_ms,
            decision.map_or_else(
                || "-".to_owned(),
                |d| format!("{:.2}×", d / p.us_per_decision)
            )
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const REPORT: &str = "engine=LuaJIT 2.1.0-beta3  jit=big  fish=1000 (predators 10)  food=30  mode=shoal
tank 25.2 x 12.6 x 12.6 L  (1260 x 630 x 630 units), 8.00 L^3 per fish; grid 5x3x3 cells of 250 units
ticks measured 300 after 60 warm-up; decisions/tick 166.7
median ms/tick 0.612  (p99 1.020)   [grid 0.100  decide 0.400  motion 0.100 ms medians]
us/decision (mean CPU) 2.500
us/fish/tick motion+grid (median) 0.2000   [grid 0.1000  motion 0.1000]
";

    #[test]
    fn reads_the_peers_report() {
        let r = parse_peer_output(REPORT, "peer.lua under luajit").unwrap();
        assert_eq!(r.version, "LuaJIT 2.1.0-beta3");
        assert_eq!((r.fish, r.ticks), (1000, 300));
        assert_eq!((r.median_ms, r.p99_ms), (0.612, 1.020));
        assert_eq!(r.us_per_decision, 2.5);
        assert_eq!(r.us_per_fish_tick_grid_motion, 0.2);
    }

    #[test]
    fn a_report_without_a_figure_is_an_error_naming_the_file_and_the_line() {
        let broken = REPORT.replace("us/decision (mean CPU) 2.500\n", "");
        let e = parse_peer_output(&broken, "peer.lua under luajit")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("peer.lua under luajit: expected"), "{e}");
        assert!(e.contains("us/decision (mean CPU)"), "{e}");
        let e = parse_peer_output("", "p.lua under mlua")
            .unwrap_err()
            .to_string();
        assert!(e.contains("(nothing)"), "{e}");
    }

    #[test]
    fn seconds_rewrite_the_measured_duration_only() {
        let text = "local N = 1\nlocal WARM_S, MEAS_S = 1, 5\nprint(N)\n";
        let out = peer_source_for(text, 0.25, Path::new("p.lua")).unwrap();
        assert_eq!(
            out,
            "local N = 1\nlocal WARM_S, MEAS_S = 1, 0.25\nprint(N)\n"
        );
        let e = peer_source_for("print(1)\n", 1.0, Path::new("p.lua"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("p.lua: expected a line `local WARM_S, MEAS_S"),
            "{e}"
        );
    }
}
