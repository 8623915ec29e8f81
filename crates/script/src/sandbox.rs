//! The Lua state scripts run in: a trimmed standard library, `require` confined to `scripts/`,
//! text-only `load`, an instruction budget per call and a memory limit.
//!
//! What scripts get: `table`, `string` (without `string.dump`), `math`, `utf8`, `coroutine`,
//! `os.clock`, the safe base functions (`pairs`, `ipairs`, `select`, `type`, `tostring`,
//! `tonumber`, `pcall`, `xpcall`, `error`, `assert`, `setmetatable`, `getmetatable`, `rawget`,
//! `rawset`, `rawequal`, `rawlen`, `next`; `setmetatable` without `__gc`), `print` (into the
//! script console),
//! `collectgarbage("count")`, `load` of text chunks and `require` of modules under `scripts/`.
//! Everything else — `io`, the rest of `os`, `debug`, `package`, `dofile`, `loadfile`, binary
//! chunks — is absent.
//!
//! The budget and the soft memory limit are checked by a count hook. Behaviour calls run without
//! it until they have run [`Limits::metered_after`] (see [`super::watchdog`]): the hook is what
//! makes the interpreter slow, and only a runaway call needs it.
//!
//! Modules are kept apart: each gets its own copy of the globals and of every library table
//! ([`module_env`]), the string metatable is protected, `setmetatable` refuses finalizers, and
//! every call has a time limit ([`Limits::time_per_call`]) that also holds inside the string
//! library ([`super::strings`]). The threat model is `docs/sandbox.md`.

use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicI64, AtomicU8, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use mlua::chunk::ChunkMode;
use mlua::debug::DebugEvent;
use mlua::{Function, HookTriggers, Lua, LuaOptions, StdLib, Table, Value, VmState};

use super::error::{ScriptError, describe};
use super::log::ScriptLog;
use super::watchdog::Meter;
pub use crate::budget::{Abort, Budget, caller_location, time_message};

/// Most elements one `table.move` may copy.
pub const MAX_MOVE: u64 = 1 << 20;

/// Longest chunk `load` compiles, bytes: compiling runs in C, in time proportional to the chunk.
pub const MAX_CHUNK: usize = 1 << 20;

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
    /// CPU time one behaviour call may use before it is stopped (default 50 ms, some ten
    /// thousand times what a shipped behaviour takes), whatever it is doing: VM instructions,
    /// the string library, allocation. Measured on the call's thread by the watchdog, so a call
    /// that merely waits for a busy processor is not stopped (see [`super::watchdog`]).
    pub time_per_call: Duration,
    /// CPU time loading one file may use (default 2 s).
    pub time_per_load: Duration,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            instructions_per_call: 200_000,
            metered_after: Duration::from_millis(1),
            instructions_per_load: 5_000_000,
            memory_bytes: 256 << 20,
            time_per_call: Duration::from_millis(50),
            time_per_load: Duration::from_secs(2),
        }
    }
}

/// What the budget hook runs on a line event: the debugger's stop check, set as app data on a
/// state for the decisions it steps through (line events are armed only then). The sandbox
/// calls it without naming the debugger.
#[derive(Clone, Copy)]
pub struct LineHook(pub fn(&Lua, &mlua::debug::Debug) -> mlua::Result<VmState>);

/// Where scripts live, for `require` and chunk names.
#[derive(Debug, Clone)]
pub struct ScriptRoot {
    /// Canonical path of the `scripts/` directory.
    pub dir: PathBuf,
    /// Name shown in messages for that directory (its last component, `scripts`).
    pub display: String,
}

/// Why a module name (`require`, a behaviour or species name) names no script file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ModuleError {
    /// An absolute path or an empty name.
    #[error("module name '{name}' must be relative to {root}/")]
    NotRelative {
        /// The name as given.
        name: String,
        /// The script root as shown (`scripts`).
        root: String,
    },
    /// A component that is empty, `..`, or has characters other than letters, digits, `_`, `-`.
    #[error(
        "module name '{name}' may only name files inside {root}/ (letters, digits, '_', '-', \
         separated by '.' or '/')"
    )]
    BadName {
        /// The name as given.
        name: String,
        /// The script root as shown.
        root: String,
    },
    /// No such file.
    #[error("module '{name}' not found (looked for {looked_for})")]
    NotFound {
        /// The name as given.
        name: String,
        /// The file looked for, as shown (`scripts/behaviors/forage.lua`).
        looked_for: String,
    },
    /// The file is outside the root (through a symbolic link).
    #[error("module '{name}' resolves outside {root}/")]
    Outside {
        /// The name as given.
        name: String,
        /// The script root as shown.
        root: String,
    },
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
    pub fn resolve_module(&self, name: &str) -> Result<PathBuf, ModuleError> {
        let trimmed = name.strip_suffix(".lua").unwrap_or(name);
        if trimmed.is_empty() || trimmed.starts_with('/') || trimmed.starts_with('\\') {
            return Err(ModuleError::NotRelative {
                name: name.to_owned(),
                root: self.display.clone(),
            });
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
                return Err(ModuleError::BadName {
                    name: name.to_owned(),
                    root: self.display.clone(),
                });
            }
            rel.push(part);
        }
        rel.set_extension("lua");
        let path = self.dir.join(&rel);
        let real = path.canonicalize().map_err(|_| ModuleError::NotFound {
            name: name.to_owned(),
            looked_for: self.display_of(&path),
        })?;
        if !real.starts_with(&self.dir) || real.components().any(|c| c == Component::ParentDir) {
            return Err(ModuleError::Outside {
                name: name.to_owned(),
                root: self.display.clone(),
            });
        }
        Ok(real)
    }
}

/// Registry key of the set of files loaded through `require` (path → true), by any module.
pub const LOADED_KEY: &str = "shoal.loaded";

/// Registry key of Lua's own `load`.
const RAW_LOAD_KEY: &str = "shoal.raw_load";

/// Creates the sandboxed state. The returned [`Budget`] must be armed before every call into
/// Lua ([`Budget::arm`]) and the call made while a [`Meter::call`] guard lives. The meter counts
/// the state's allocations: call [`Meter::stop_counting_allocations`] before dropping the state.
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
        slot: AtomicUsize::new(usize::MAX),
        time_limit_ns: AtomicU64::new(u64::MAX),
        started_ns: AtomicU64::new(0),
        message: Mutex::new(String::new()),
    });
    install(&lua, &root, &budget, limits).map_err(|e| ScriptError::Lua(describe(&e)))?;
    let mut meter =
        Meter::take_over(&lua, HOOK_INTERVAL).map_err(|e| ScriptError::Lua(describe(&e)))?;
    if let Some(slot) = meter.slot() {
        budget.slot.store(slot, Ordering::Relaxed);
    }
    lua.set_memory_limit(limits.memory_bytes)
        .map_err(|e| ScriptError::Lua(describe(&e)))?;
    // After the limit: mlua changes the limit only on its own allocator.
    meter
        .count_allocations(&lua)
        .map_err(|e| ScriptError::Lua(describe(&e)))?;
    lua.set_app_data(root);
    lua.set_app_data(ScriptLog::default());
    Ok((lua, budget, meter))
}

/// Makes the fresh state a sandbox, in this order: [`restrict_libraries`],
/// [`restrict_globals`], [`install_print`], `require` set aside for [`module_env`],
/// [`guard_protected_calls`], [`install_budget_hook`].
fn install(lua: &Lua, root: &ScriptRoot, budget: &Arc<Budget>, limits: Limits) -> mlua::Result<()> {
    let g = lua.globals();
    restrict_libraries(lua, &g, budget, limits)?;
    restrict_globals(lua, &g)?;
    install_print(lua, &g)?;
    super::logpoints::install(lua, &g)?;
    // require: per module (see `module_env`); the set of every file loaded through it.
    lua.set_named_registry_value(LOADED_KEY, lua.create_table()?)?;
    g.set("require", Value::Nil)?;
    guard_protected_calls(lua, &g, budget)?;
    install_budget_hook(lua, budget)?;
    let _ = root;
    Ok(())
}

/// The standard libraries cut down: `os` to its clock, `string` without `dump` and with bounded
/// pattern functions, a bounded `table.move`, and no `dofile`, `loadfile`, `io`, `debug`,
/// `package` or `require`.
fn restrict_libraries(
    lua: &Lua,
    g: &Table,
    budget: &Arc<Budget>,
    limits: Limits,
) -> mlua::Result<()> {
    // os: only the clock.
    let os: Table = g.get("os")?;
    let safe_os = lua.create_table()?;
    safe_os.set("clock", os.get::<Function>("clock")?)?;
    g.set("os", safe_os)?;

    // string.dump produces binary chunks: scripts have no use for it.
    let string: Table = g.get("string")?;
    string.set("dump", Value::Nil)?;
    // find, match, gmatch, gsub and rep: bounded (see `strings.rs`).
    super::strings::install(lua, &string, budget.clone(), limits.memory_bytes)?;

    // table.move copies element by element in C, however many there are (`table.move({}, 1,
    // math.maxinteger, 1)` never returns): a bound on the count.
    let table_lib: Table = g.get("table")?;
    let raw_move: Function = table_lib.get("move")?;
    table_lib.set(
        "move",
        lua.create_function(move |_, args: mlua::MultiValue| {
            let num = |v: Option<&Value>| match v {
                Some(Value::Integer(i)) => Some(*i as f64),
                Some(Value::Number(n)) => Some(*n),
                _ => None,
            };
            if let (Some(f), Some(e)) = (num(args.get(1)), num(args.get(2)))
                && e - f >= MAX_MOVE as f64
            {
                return Err(mlua::Error::RuntimeError(format!(
                    "table.move: too many elements to move ({} at most)",
                    MAX_MOVE
                )));
            }
            raw_move.call::<mlua::MultiValue>(args)
        })?,
    )?;

    for name in ["dofile", "loadfile", "io", "debug", "package", "require"] {
        g.set(name, Value::Nil)?;
    }
    Ok(())
}

/// The base functions that could escape the limits: `collectgarbage` (only "count"), `load` (set
/// aside for text chunks), `setmetatable` (no finalizers) and the shared string metatable.
fn restrict_globals(lua: &Lua, g: &Table) -> mlua::Result<()> {
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

    // load: text chunks only (the per-module `load` of `module_env` calls this one).
    let raw_load: Function = g.get("load")?;
    lua.set_named_registry_value(RAW_LOAD_KEY, raw_load)?;
    g.set("load", Value::Nil)?;

    // setmetatable: no finalizers. A `__gc` runs whenever the collector gets to the object, in
    // whatever call (or none) is running then, outside the budget of the script that made it.
    // Lua marks an object for finalization only if its metatable has a `__gc` field when it is
    // set, so refusing that field here is enough (adding one later has no effect).
    let raw_setmetatable: Function = g.get("setmetatable")?;
    g.set(
        "setmetatable",
        lua.create_function(move |_, (t, mt): (Value, Value)| {
            if !t.is_table() {
                return Err(mlua::Error::RuntimeError(format!(
                    "bad argument #1 to 'setmetatable' (table expected, got {})",
                    t.type_name()
                )));
            }
            if let Value::Table(m) = &mt
                && !m.raw_get::<Value>("__gc")?.is_nil()
            {
                return Err(mlua::Error::RuntimeError(
                    "setmetatable: __gc finalizers are not available to scripts".into(),
                ));
            }
            raw_setmetatable.call::<Value>((t, mt))
        })?,
    )?;

    // The string metatable is shared by every string of the state: scripts may not reach it
    // (its `__index` is the host's own `string` table, which no module sees). `getmetatable`
    // of a string returns false; string methods keep working.
    lua.load("getmetatable('').__metatable = false")
        .set_name("=shoal host")
        .exec()?;
    Ok(())
}

/// `print`: into the script console, with the caller's file:line.
fn install_print(lua: &Lua, g: &Table) -> mlua::Result<()> {
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
            super::logpoints::console_line(lua, &text);
            Ok(())
        })?,
    )?;
    Ok(())
}

/// `pcall`, `xpcall`, `coroutine.resume`/`wrap`/`create`: they must not swallow the host's
/// stop.
fn guard_protected_calls(lua: &Lua, g: &Table, budget: &Arc<Budget>) -> mlua::Result<()> {
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
    Ok(())
}

/// The budget hook: every [`HOOK_INTERVAL`] instructions, stops the call that is over its
/// instruction budget, its time limit or the memory limit.
fn install_budget_hook(lua: &Lua, budget: &Arc<Budget>) -> mlua::Result<()> {
    let b = budget.clone();
    lua.set_global_hook(
        HookTriggers::new().every_nth_instruction(HOOK_INTERVAL),
        move |lua, debug| {
            if !matches!(debug.event(), DebugEvent::Count) {
                // Line events exist only while the debugger steps through a decision, and it
                // sets the line hook for that decision.
                let line_hook = lua.app_data_ref::<LineHook>().map(|h| h.0);
                return match line_hook {
                    Some(hook) => hook(lua, debug),
                    None => Ok(VmState::Continue),
                };
            }
            let left = b.remaining.load(Ordering::Relaxed) - i64::from(HOOK_INTERVAL);
            b.remaining.store(left, Ordering::Relaxed);
            if let Some(e) = b.stopped() {
                return Err(e);
            }
            let over_memory = lua.used_memory() > b.soft_memory;
            let over_time = b.time_expired();
            if left >= 0 && !over_memory && !over_time {
                return Ok(VmState::Continue);
            }
            let src = debug.source();
            let file = src.short_src.as_deref().unwrap_or("?").to_owned();
            let line = debug.current_line().unwrap_or(0);
            let (kind, what) = if over_time {
                (Abort::Time, time_message(b.time_limit()))
            } else if over_memory {
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
            Err(b.stop(kind, format!("{file}:{line}: {what}")))
        },
    )?;
    Ok(())
}

/// A fresh environment for one module, with a `require` cache of its own.
///
/// Every module gets its own copy of the globals and of each library table (`math`, `string`,
/// `table`, `utf8`, `coroutine`, `os`, `shoal`): nothing a module writes — `math.sqrt = nil`,
/// `shoal.wander = nil`, a global — is seen by another. The copies are made once, when the
/// module loads, and are plain tables: a lookup costs what it costs in an unsandboxed state.
pub fn module_env(lua: &Lua) -> mlua::Result<Table> {
    family_env(lua, &lua.create_table()?)
}

/// An environment whose `require` shares `cache` (name → value): the behaviour module and the
/// libraries it requires, and their `load`ed chunks.
fn family_env(lua: &Lua, cache: &Table) -> mlua::Result<Table> {
    let globals = lua.globals();
    let env = lua.create_table_with_capacity(0, 40)?;
    for pair in globals.pairs::<Value, Value>() {
        let (k, v) = pair?;
        if k.as_string()
            .is_some_and(|k| k.as_bytes().as_ref() == b"_G")
        {
            continue;
        }
        let v = match v {
            Value::Table(lib) => {
                let copy = lua.create_table_with_capacity(0, 40)?;
                for pair in lib.pairs::<Value, Value>() {
                    let (name, f) = pair?;
                    copy.raw_set(name, f)?;
                }
                Value::Table(copy)
            }
            other => other,
        };
        env.raw_set(k, v)?;
    }
    env.raw_set("_G", &env)?;

    // load: text chunks only, in this module's family unless an environment is given.
    let raw_load: Function = lua.named_registry_value(RAW_LOAD_KEY)?;
    let family = cache.clone();
    env.raw_set(
        "load",
        lua.create_function(
            move |lua, (chunk, name, _mode, env): (Value, Option<String>, Value, Option<Table>)| {
                let env = match env {
                    Some(e) => e,
                    None => family_env(lua, &family)?,
                };
                let chunk = match chunk {
                    // A reader function is read here, so the compiler gets one bounded string.
                    Value::Function(read) => {
                        let mut text = Vec::new();
                        loop {
                            match read.call::<Value>(())? {
                                Value::Nil => break,
                                Value::String(s) if s.as_bytes().is_empty() => break,
                                Value::String(s) => text.extend_from_slice(&s.as_bytes()),
                                _ => {
                                    return Err(mlua::Error::RuntimeError(
                                        "load: reader function must return a string".into(),
                                    ));
                                }
                            }
                            if text.len() > MAX_CHUNK {
                                break;
                            }
                        }
                        Value::String(lua.create_string(&text)?)
                    }
                    other => other,
                };
                if let Value::String(s) = &chunk
                    && s.as_bytes().len() > MAX_CHUNK
                {
                    return Err(mlua::Error::RuntimeError(format!(
                        "load: chunk too large ({} bytes at most)",
                        MAX_CHUNK
                    )));
                }
                raw_load.call::<mlua::MultiValue>((chunk, name, "t", env))
            },
        )?,
    )?;

    // require: modules under scripts/ only, loaded once per module family.
    let family = cache.clone();
    env.raw_set(
        "require",
        lua.create_function(move |lua, name: String| {
            let path = {
                let root = lua
                    .app_data_ref::<ScriptRoot>()
                    .ok_or_else(|| mlua::Error::RuntimeError("no script root".into()))?;
                root.resolve_module(&name)
                    .map_err(|why| mlua::Error::RuntimeError(format!("require: {why}")))?
            };
            let key = path.to_string_lossy().into_owned();
            let cached: Value = family.raw_get(key.as_str())?;
            if !cached.is_nil() {
                return Ok(cached);
            }
            let f = load_in_family(lua, &path, &family)
                .map_err(|e| mlua::Error::RuntimeError(e.to_string()))?;
            let v: Value = f.call(())?;
            let v = if v.is_nil() { Value::Boolean(true) } else { v };
            family.raw_set(key.as_str(), v.clone())?;
            let loaded: Table = lua.named_registry_value(LOADED_KEY)?;
            loaded.raw_set(key.as_str(), true)?;
            Ok(v)
        })?,
    )?;
    Ok(env)
}

/// Compiles `path` (a file under the script root) as a text chunk named after the file, in a
/// fresh module environment. Syntax errors read `scripts/…/file.lua:LINE: message`.
pub fn load_file(lua: &Lua, path: &Path) -> Result<Function, ScriptError> {
    let cache = lua
        .create_table()
        .map_err(|e| ScriptError::Lua(describe(&e)))?;
    load_in_family(lua, path, &cache)
}

/// [`load_file`] for text that is not (yet) on disk: `source` loads as the file `display` would,
/// in a fresh sandboxed environment (the edited text of a data file, checked before it is saved).
pub fn load_source(lua: &Lua, display: &str, source: &str) -> Result<Function, ScriptError> {
    let cache = lua
        .create_table()
        .map_err(|e| ScriptError::Lua(describe(&e)))?;
    load_text(lua, display, source.as_bytes(), &cache)
}

/// [`load_file`] in the family of `cache` (see `family_env`).
fn load_in_family(lua: &Lua, path: &Path, cache: &Table) -> Result<Function, ScriptError> {
    let display = lua
        .app_data_ref::<ScriptRoot>()
        .map(|r| r.display_of(path))
        .unwrap_or_else(|| path.display().to_string());
    let source = std::fs::read(path).map_err(|source| ScriptError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let source = super::logpoints::source_for(lua, path, source).map_err(|source| {
        ScriptError::Logpoint {
            file: display.clone(),
            source,
        }
    })?;
    load_text(lua, &display, &source, cache)
}

/// Loads `source` as the text chunk named `display`, in a fresh environment of `cache`'s family:
/// what [`load_file`] and [`load_source`] share.
fn load_text(
    lua: &Lua,
    display: &str,
    source: &[u8],
    cache: &Table,
) -> Result<Function, ScriptError> {
    let env = family_env(lua, cache).map_err(|e| ScriptError::Lua(describe(&e)))?;
    lua.load(source)
        .set_name(format!("@{display}"))
        .set_mode(ChunkMode::Text)
        .set_environment(env)
        .into_function()
        .map_err(|e| ScriptError::Lua(describe(&e)))
}
