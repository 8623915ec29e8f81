//! The Lua state scripts run in: a trimmed standard library, `require` confined to `scripts/`,
//! text-only `load`, an instruction budget per call and a memory limit.
//!
//! What scripts get: `table`, `string` (without `string.dump`), `math`, `utf8`, `coroutine`,
//! `os.clock`, the safe base functions (`pairs`, `ipairs`, `select`, `type`, `tostring`,
//! `tonumber`, `pcall`, `xpcall`, `error`, `assert`, `setmetatable`, `getmetatable`, `rawget`,
//! `rawset`, `rawequal`, `rawlen`, `next`), `print` (into the script console),
//! `collectgarbage("count")`, `load` of text chunks and `require` of modules under `scripts/`.
//! Everything else — `io`, the rest of `os`, `debug`, `package`, `dofile`, `loadfile`, binary
//! chunks — is absent.
//!
//! The budget and the soft memory limit are checked by a count hook. Behaviour calls run without
//! it until they have run [`Limits::metered_after`] (see [`super::watchdog`]): the hook is what
//! makes the interpreter slow, and only a runaway call needs it.

use std::path::{Component, Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicI64, AtomicU8, AtomicU64, Ordering};
use std::time::Duration;

use mlua::chunk::ChunkMode;
use mlua::{Function, HookTriggers, Lua, LuaOptions, StdLib, Table, Value, VmState};

use super::error::{ScriptError, describe};
use super::log::{LogLevel, ScriptLog};
use super::watchdog::Meter;

/// Instructions between two runs of the budget hook (once a call is metered). Small enough that
/// a runaway loop is caught within a few microseconds.
pub const HOOK_INTERVAL: u32 = 1000;

/// Resource limits of the Lua state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// VM instructions one behaviour call may run, once metered, before it is stopped (default
    /// 200,000: the shipped behaviours use a few hundred).
    pub instructions_per_call: u64,
    /// How long a behaviour call runs unmetered (default 1 ms, some hundred times what a shipped
    /// behaviour takes). After that the watchdog turns the budget hook on and the call may run
    /// `instructions_per_call` more instructions. Zero meters every call from its first
    /// instruction, so the budget is exact and deterministic (slower: Lua checks the hook before
    /// every instruction). Systems other than Linux always meter from the start.
    pub metered_after: Duration,
    /// VM instructions loading one file (running its top level) may take (default 5,000,000).
    pub instructions_per_load: u64,
    /// Bytes the whole Lua state may allocate (default 256 MiB). A call that grows the state past
    /// 15/16 of it is stopped with an error naming its line; the hard limit is a backstop.
    /// 0 disables both (for measurements only: a script could then exhaust the process).
    pub memory_bytes: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            instructions_per_call: 200_000,
            metered_after: Duration::from_millis(1),
            instructions_per_load: 5_000_000,
            memory_bytes: 256 << 20,
        }
    }
}

/// Why the running call was stopped by the host.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Abort {
    /// The instruction budget ran out.
    Budget,
    /// The state grew past the soft memory limit.
    Memory,
}

/// Budget state shared between the host and the hook.
#[derive(Debug)]
pub struct Budget {
    /// Instructions left in the current call (negative once exhausted).
    remaining: AtomicI64,
    /// The budget the current call started with (for the message).
    granted: AtomicU64,
    /// How long the current call runs before it is metered, microseconds (0: counted from its
    /// first instruction; for the message).
    unmetered_us: AtomicU64,
    /// Set when the hook stopped the call; `pcall` rethrows while it is set
    /// (0: running, 1: [`Abort::Budget`], 2: [`Abort::Memory`]).
    abort: AtomicU8,
    /// Soft memory limit, bytes.
    soft_memory: usize,
}

impl Budget {
    /// Arms the budget for a call of at most `instructions` instructions, counted from its first
    /// instruction.
    pub fn arm(&self, instructions: u64) {
        self.arm_after(instructions, Duration::ZERO);
    }

    /// Arms the budget for a call of at most `instructions` instructions counted once it has run
    /// `unmetered` (see [`Limits::metered_after`]).
    pub fn arm_after(&self, instructions: u64, unmetered: Duration) {
        self.remaining.store(
            i64::try_from(instructions).unwrap_or(i64::MAX),
            Ordering::Relaxed,
        );
        self.granted.store(instructions, Ordering::Relaxed);
        self.unmetered_us.store(
            u64::try_from(unmetered.as_micros()).unwrap_or(u64::MAX),
            Ordering::Relaxed,
        );
        self.abort.store(0, Ordering::Relaxed);
    }

    /// Why the last call was stopped, if it was.
    pub fn aborted(&self) -> Option<Abort> {
        match self.abort.load(Ordering::Relaxed) {
            1 => Some(Abort::Budget),
            2 => Some(Abort::Memory),
            _ => None,
        }
    }

    fn set_aborted(&self, why: Abort) {
        let v = match why {
            Abort::Budget => 1,
            Abort::Memory => 2,
        };
        self.abort.store(v, Ordering::Relaxed);
    }
}

/// Where scripts live, for `require` and chunk names.
#[derive(Debug, Clone)]
pub struct ScriptRoot {
    /// Canonical path of the `scripts/` directory.
    pub dir: PathBuf,
    /// Name shown in messages for that directory (its last component, `scripts`).
    pub display: String,
}

impl ScriptRoot {
    /// `root` must exist.
    pub fn new(root: &Path) -> Result<Self, ScriptError> {
        let dir = root.canonicalize().map_err(|source| ScriptError::Io {
            path: root.to_path_buf(),
            source,
        })?;
        let display = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scripts".to_owned());
        Ok(Self { dir, display })
    }

    /// The name a file under the root is shown by: `scripts/behaviors/forage.lua`.
    pub fn display_of(&self, path: &Path) -> String {
        // A file outside the root (a scene given by absolute path) is shown as it was given.
        let Ok(rel) = path.strip_prefix(&self.dir) else {
            return path.display().to_string();
        };
        let mut s = self.display.clone();
        for c in rel.components() {
            s.push('/');
            s.push_str(&c.as_os_str().to_string_lossy());
        }
        s
    }

    /// Resolves a module name (`behaviors.lib.util` or `behaviors/lib/util`) to a file inside the
    /// root. Rejects absolute paths, `..`, empty components and anything outside the root
    /// (symbolic links included).
    pub fn resolve_module(&self, name: &str) -> Result<PathBuf, String> {
        let trimmed = name.strip_suffix(".lua").unwrap_or(name);
        if trimmed.is_empty() || trimmed.starts_with('/') || trimmed.starts_with('\\') {
            return Err(format!(
                "module name '{name}' must be relative to {}/",
                self.display
            ));
        }
        let mut rel = PathBuf::new();
        let separated = if trimmed.contains('/') {
            trimmed.split('/').collect::<Vec<_>>()
        } else {
            trimmed.split('.').collect::<Vec<_>>()
        };
        for part in separated {
            let ok = !part.is_empty()
                && part != ".."
                && part
                    .bytes()
                    .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
            if !ok {
                return Err(format!(
                    "module name '{name}' may only name files inside {}/ (letters, digits, '_', '-', separated by '.' or '/')",
                    self.display
                ));
            }
            rel.push(part);
        }
        rel.set_extension("lua");
        let path = self.dir.join(&rel);
        let real = path.canonicalize().map_err(|_| {
            format!(
                "module '{name}' not found (looked for {})",
                self.display_of(&path)
            )
        })?;
        if !real.starts_with(&self.dir) || real.components().any(|c| c == Component::ParentDir) {
            return Err(format!(
                "module '{name}' resolves outside {}/",
                self.display
            ));
        }
        Ok(real)
    }
}

/// Registry key of the table of modules loaded through `require` (name → value).
pub const LOADED_KEY: &str = "shoal.loaded";

/// Creates the sandboxed state. The returned [`Budget`] must be armed before every call into
/// Lua ([`Budget::arm`]) and the call made while a [`Meter::call`] guard lives.
pub fn new_state(root: &Path, limits: Limits) -> Result<(Lua, Arc<Budget>, Meter), ScriptError> {
    let root = ScriptRoot::new(root)?;
    let libs = StdLib::TABLE
        | StdLib::STRING
        | StdLib::MATH
        | StdLib::UTF8
        | StdLib::COROUTINE
        | StdLib::OS;
    let lua =
        Lua::new_with(libs, LuaOptions::default()).map_err(|e| ScriptError::Lua(describe(&e)))?;
    let budget = Arc::new(Budget {
        remaining: AtomicI64::new(0),
        granted: AtomicU64::new(0),
        unmetered_us: AtomicU64::new(0),
        abort: AtomicU8::new(0),
        soft_memory: if limits.memory_bytes == 0 {
            usize::MAX
        } else {
            limits.memory_bytes / 16 * 15
        },
    });
    install(&lua, &root, &budget).map_err(|e| ScriptError::Lua(describe(&e)))?;
    let meter =
        Meter::take_over(&lua, HOOK_INTERVAL).map_err(|e| ScriptError::Lua(describe(&e)))?;
    lua.set_memory_limit(limits.memory_bytes)
        .map_err(|e| ScriptError::Lua(describe(&e)))?;
    lua.set_app_data(root);
    lua.set_app_data(ScriptLog::default());
    Ok((lua, budget, meter))
}

fn install(lua: &Lua, root: &ScriptRoot, budget: &Arc<Budget>) -> mlua::Result<()> {
    let g = lua.globals();

    // os: only the clock.
    let os: Table = g.get("os")?;
    let safe_os = lua.create_table()?;
    safe_os.set("clock", os.get::<Function>("clock")?)?;
    g.set("os", safe_os)?;

    // string.dump produces binary chunks: scripts have no use for it.
    let string: Table = g.get("string")?;
    string.set("dump", Value::Nil)?;

    for name in ["dofile", "loadfile", "io", "debug", "package", "require"] {
        g.set(name, Value::Nil)?;
    }

    // collectgarbage: only "count" (stopping the collector would defeat the memory limit).
    let raw_gc: Function = g.get("collectgarbage")?;
    g.set(
        "collectgarbage",
        lua.create_function(move |_, opt: Option<mlua::LuaString>| {
            let ok = opt
                .as_ref()
                .is_none_or(|o| o.as_bytes() == b"count".as_slice());
            if !ok {
                return Err(mlua::Error::RuntimeError(
                    "collectgarbage: scripts may only ask for \"count\"".into(),
                ));
            }
            raw_gc.call::<Value>("count")
        })?,
    )?;

    // load: text chunks only, in the caller's sandbox unless an environment is given.
    let raw_load: Function = g.get("load")?;
    g.set(
        "load",
        lua.create_function(
            move |lua, (chunk, name, _mode, env): (Value, Option<String>, Value, Option<Table>)| {
                let env = match env {
                    Some(e) => e,
                    None => module_env(lua)?,
                };
                raw_load.call::<mlua::MultiValue>((chunk, name, "t", env))
            },
        )?,
    )?;

    // print: into the script console, with the caller's file:line.
    g.set(
        "print",
        lua.create_function(|lua, args: mlua::Variadic<Value>| {
            let mut text = caller_location(lua);
            text.push(' ');
            for (i, v) in args.iter().enumerate() {
                if i > 0 {
                    text.push('\t');
                }
                text.push_str(&v.to_string().unwrap_or_else(|_| format!("{v:?}")));
            }
            // The deciding fish and the world's time, when a behaviour stage is running.
            let (fish, time_s) = lua
                .app_data_ref::<super::api::Ctx>()
                .map_or((None, 0.0), |c| {
                    (c.fish, c.world.as_ref().map_or(0.0, |w| w.time()))
                });
            if let Some(mut log) = lua.app_data_mut::<ScriptLog>() {
                log.push(LogLevel::Info, &text, fish, time_s);
            }
            Ok(())
        })?,
    )?;

    // require: modules under scripts/ only.
    lua.set_named_registry_value(LOADED_KEY, lua.create_table()?)?;
    g.set(
        "require",
        lua.create_function(|lua, name: String| {
            let loaded: Table = lua.named_registry_value(LOADED_KEY)?;
            let path = {
                let root = lua
                    .app_data_ref::<ScriptRoot>()
                    .ok_or_else(|| mlua::Error::RuntimeError("no script root".into()))?;
                root.resolve_module(&name)
                    .map_err(|why| mlua::Error::RuntimeError(format!("require: {why}")))?
            };
            let key = path.to_string_lossy().into_owned();
            let cached: Value = loaded.raw_get(key.as_str())?;
            if !cached.is_nil() {
                return Ok(cached);
            }
            let f = load_file(lua, &path).map_err(|e| mlua::Error::RuntimeError(e.to_string()))?;
            let v: Value = f.call(())?;
            let v = if v.is_nil() { Value::Boolean(true) } else { v };
            loaded.raw_set(key.as_str(), v.clone())?;
            Ok(v)
        })?,
    )?;

    // pcall / xpcall / coroutine.resume must not swallow the host's stop: rethrow while set.
    // Coroutines are created by mlua, which gives each the budget hook for good (the watchdog
    // turns the hook on for the main thread only).
    let b = budget.clone();
    let aborted = lua.create_function(move |_, ()| Ok(b.aborted().is_some()))?;
    let create = lua.create_function(|lua, f: Value| match f {
        Value::Function(f) => lua.create_thread(f),
        other => Err(mlua::Error::runtime(format!(
            "bad argument #1 to 'create' (function expected, got {})",
            other.type_name()
        ))),
    })?;
    let wrap: Function = lua
        .load(
            r#"
            local aborted, raw_pcall, raw_xpcall, raw_resume, error, create = ...
            local function pass(ok, ...)
              if not ok and aborted() then error((...), 0) end
              return ok, ...
            end
            local function unwrap(ok, ...)
              if ok then return ... end
              error((...), 0)
            end
            local resume = function(co, ...) return pass(raw_resume(co, ...)) end
            pcall = function(f, ...) return pass(raw_pcall(f, ...)) end
            xpcall = function(f, h, ...) return pass(raw_xpcall(f, h, ...)) end
            coroutine.resume = resume
            coroutine.create = create
            coroutine.wrap = function(f)
              local co = create(f)
              return function(...) return unwrap(resume(co, ...)) end
            end
            "#,
        )
        .set_name("=shoal host")
        .into_function()?;
    let co: Table = g.get("coroutine")?;
    wrap.call::<()>((
        aborted,
        g.get::<Function>("pcall")?,
        g.get::<Function>("xpcall")?,
        co.get::<Function>("resume")?,
        g.get::<Function>("error")?,
        create,
    ))?;

    // The budget hook.
    let b = budget.clone();
    let _ = root;
    lua.set_global_hook(
        HookTriggers::new().every_nth_instruction(HOOK_INTERVAL),
        move |lua, debug| {
            let left = b.remaining.load(Ordering::Relaxed) - i64::from(HOOK_INTERVAL);
            b.remaining.store(left, Ordering::Relaxed);
            let over_memory = lua.used_memory() > b.soft_memory;
            if left >= 0 && !over_memory && b.aborted().is_none() {
                return Ok(VmState::Continue);
            }
            let src = debug.source();
            let file = src.short_src.as_deref().unwrap_or("?").to_owned();
            let line = debug.current_line().unwrap_or(0);
            let (kind, what) = if over_memory {
                (
                    Abort::Memory,
                    format!(
                        "memory limit exceeded ({} KiB in use)",
                        lua.used_memory() / 1024
                    ),
                )
            } else {
                let granted = b.granted.load(Ordering::Relaxed);
                let unmetered_us = b.unmetered_us.load(Ordering::Relaxed);
                let what = if unmetered_us == 0 {
                    format!("instruction budget exceeded ({granted} instructions per call)")
                } else {
                    format!(
                        "instruction budget exceeded ({granted} instructions per call, counted once a call has run {} ms)",
                        unmetered_us as f64 / 1000.0
                    )
                };
                (Abort::Budget, what)
            };
            b.set_aborted(kind);
            Err(mlua::Error::RuntimeError(format!("{file}:{line}: {what}")))
        },
    )?;
    Ok(())
}

/// A fresh environment for one module: its own globals, reading through to the shared ones.
pub fn module_env(lua: &Lua) -> mlua::Result<Table> {
    let env = lua.create_table()?;
    let meta = lua.create_table()?;
    meta.raw_set("__index", lua.globals())?;
    env.set_metatable(Some(meta))?;
    Ok(env)
}

/// Compiles `path` (a file under the script root) as a text chunk named after the file, in a
/// fresh module environment. Syntax errors read `scripts/…/file.lua:LINE: message`.
pub fn load_file(lua: &Lua, path: &Path) -> Result<Function, ScriptError> {
    let display = lua
        .app_data_ref::<ScriptRoot>()
        .map(|r| r.display_of(path))
        .unwrap_or_else(|| path.display().to_string());
    let source = std::fs::read(path).map_err(|source| ScriptError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let env = module_env(lua).map_err(|e| ScriptError::Lua(describe(&e)))?;
    lua.load(source)
        .set_name(format!("@{display}"))
        .set_mode(ChunkMode::Text)
        .set_environment(env)
        .into_function()
        .map_err(|e| ScriptError::Lua(describe(&e)))
}

/// `file:line` of the Lua function calling the current Rust callback (or `?`).
pub fn caller_location(lua: &Lua) -> String {
    for level in 1..4 {
        let loc = lua.inspect_stack(level, |d| {
            let src = d.source();
            let file = src.short_src.as_deref().unwrap_or("?").to_owned();
            (src.what != "C").then(|| format!("{file}:{}:", d.current_line().unwrap_or(0)))
        });
        match loc {
            Some(Some(s)) => return s,
            Some(None) => continue,
            None => break,
        }
    }
    "?:".to_owned()
}
