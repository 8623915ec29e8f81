//! The Lua side of the debugger: the line hook deciding whether to stop, the stopped decision
//! answering the client (frames, variables, evaluation) on its own thread, and stepping.
//!
//! The unsafe code reads a stopped frame's locals and upvalues with `lua_getlocal` and
//! `lua_getupvalue`, which mlua does not wrap; each block says why it is sound.
#![allow(unsafe_code)]

use std::ffi::{CStr, c_int};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::Ordering;

use mlua::debug::{Debug, DebugEvent};
use mlua::{Lua, MultiValue, Table, Value, VmState, ffi};
use serde_json::{Value as Json, json};

use super::{ActiveCall, Debugger, RequestError, StepMode, ToPaused, lock};
use crate::error::EvalError;
use crate::sandbox::ScriptRoot;
use shoal_core::world::FishId;

/// Locals, upvalues or table entries listed at most (the rest is cut off).
const MAX_VARS: c_int = 250;

/// The line hook: called (through the sandbox's hook) on each new line of a decision the
/// debugger armed. Stops the decision here if a breakpoint, a step or a pause says so.
pub(crate) fn on_hook(lua: &Lua, debug: &Debug) -> mlua::Result<VmState> {
    if !matches!(debug.event(), DebugEvent::Line) {
        return Ok(VmState::Continue);
    }
    let Some(debugger) = lua
        .app_data_ref::<ActiveCall>()
        .map(|c| Arc::clone(&c.debugger))
    else {
        return Ok(VmState::Continue);
    };
    let chunk: Option<String> = debug
        .source()
        .source
        .as_deref()
        .and_then(|s| s.strip_prefix('@'))
        .map(str::to_owned);
    let (Some(chunk), Some(line)) = (chunk, debug.current_line()) else {
        // Host chunks (`=shoal driver`) are no file a client can open.
        return Ok(VmState::Continue);
    };
    let Some(path) = path_of(lua, &chunk) else {
        return Ok(VmState::Continue);
    };
    if let Some((reason, ids)) = should_stop(lua, &debugger, &path, line) {
        stop_here(lua, &debugger, reason, ids);
    }
    Ok(VmState::Continue)
}

/// The canonical file of chunk `chunk` (`scripts/behaviors/forage.lua`), cached per call.
fn path_of(lua: &Lua, chunk: &str) -> Option<PathBuf> {
    if let Some(c) = lua.app_data_ref::<ActiveCall>()
        && let Some(p) = c.paths.get(chunk)
    {
        return p.clone();
    }
    let resolved = lua.app_data_ref::<ScriptRoot>().and_then(|r| {
        let path = match chunk
            .strip_prefix(r.display.as_str())
            .and_then(|rest| rest.strip_prefix('/'))
        {
            Some(rel) => r.dir.join(rel),
            None => PathBuf::from(chunk),
        };
        path.canonicalize().ok()
    });
    if let Some(mut c) = lua.app_data_mut::<ActiveCall>() {
        c.paths.insert(chunk.to_owned(), resolved.clone());
    }
    resolved
}

/// Number of frames on the stopped thread's stack.
fn depth(lua: &Lua) -> usize {
    let mut n = 0;
    while lua.inspect_stack(n, |_| ()).is_some() {
        n += 1;
    }
    n
}

/// Why to stop at `path:line`, if at all: a breakpoint (its condition met and its hit count
/// reached; a logpoint prints instead), a step, or a pause.
fn should_stop(
    lua: &Lua,
    d: &Debugger,
    path: &Path,
    line: usize,
) -> Option<(&'static str, Vec<i64>)> {
    let (pause, step, points) = {
        let s = lock(&d.shared);
        let points: Vec<_> = s
            .breakpoints
            .get(path)
            .map(|v| v.iter().filter(|b| b.line == line).cloned().collect())
            .unwrap_or_default();
        (s.pause_requested, s.step, points)
    };
    let mut ids = Vec::new();
    for bp in points {
        if let Some(cond) = &bp.condition {
            match eval_here(lua, Some(0), cond) {
                Ok(v) if !matches!(v, Value::Nil | Value::Boolean(false)) => {}
                Ok(_) => continue,
                Err(e) => {
                    d.output(
                        "stderr",
                        &format!("breakpoint condition `{cond}` at line {line}: {e}"),
                    );
                    continue;
                }
            }
        }
        let hits = {
            let mut s = lock(&d.shared);
            let found = s
                .breakpoints
                .get_mut(path)
                .and_then(|v| v.iter_mut().find(|b| b.id == bp.id));
            match found {
                Some(b) => {
                    b.hits += 1;
                    b.hits
                }
                None => continue,
            }
        };
        if bp.hit.is_some_and(|h| !h.met(hits)) {
            continue;
        }
        if let Some(message) = &bp.log {
            let text = log_message(lua, message);
            let file = path.file_name().map(|f| f.to_string_lossy().into_owned());
            d.output(
                "console",
                &format!("{}:{line}: {text}", file.unwrap_or_default()),
            );
            continue;
        }
        ids.push(bp.id);
    }
    if !ids.is_empty() {
        return Some(("breakpoint", ids));
    }
    if let Some(step) = step {
        let stops = match (step.mode, step.depth) {
            (_, None) | (StepMode::In, _) => true,
            (StepMode::Over, Some(d0)) => depth(lua) <= d0,
            (StepMode::Out, Some(d0)) => depth(lua) < d0,
        };
        if stops {
            return Some(("step", Vec::new()));
        }
    }
    pause.then(|| ("pause", Vec::new()))
}

/// A logpoint's message with each `{expression}` evaluated in the stopped frame.
fn log_message(lua: &Lua, message: &str) -> String {
    let mut out = String::new();
    let mut rest = message;
    while let Some(open) = rest.find('{') {
        out.push_str(&rest[..open]);
        let after = &rest[open + 1..];
        let Some(close) = after.find('}') else {
            out.push_str(&rest[open..]);
            return out;
        };
        let expr = &after[..close];
        match eval_here(lua, Some(0), expr) {
            Ok(v) => out.push_str(&show(&v).0),
            Err(e) => out.push_str(&format!("<{expr}: {e}>")),
        }
        rest = &after[close + 1..];
    }
    out.push_str(rest);
    out
}

/// Stops the decision: tells the client, answers its requests until it says go on, then notes
/// where a step starts.
fn stop_here(lua: &Lua, d: &Arc<Debugger>, reason: &str, ids: Vec<i64>) {
    let _one_at_a_time = lock(&d.gate);
    let since = std::time::Instant::now();
    {
        let mut s = lock(&d.shared);
        s.step = None;
        s.pause_requested = false;
        d.update_active(&s);
    }
    let fish = lua.app_data_ref::<ActiveCall>().map(|c| c.fish);
    let mut session = Session {
        lua,
        fish,
        frames: frames(lua),
        refs: Vec::new(),
    };
    let receiver = lock(&d.from_server);
    d.paused.store(true, Ordering::SeqCst);
    let description = match fish {
        Some(f) => format!("fish #{} stopped ({reason})", f.index),
        None => format!("stopped ({reason})"),
    };
    d.send_event(
        "stopped",
        json!({
            "reason": reason,
            "description": description,
            "threadId": 1,
            "allThreadsStopped": true,
            "hitBreakpointIds": ids,
        }),
    );
    while let Ok(ToPaused::Request {
        command,
        args,
        reply,
    }) = receiver.recv()
    {
        let _ = reply.send(session.answer(&command, &args));
    }
    drop(receiver);
    if let Some(mut c) = lua.app_data_mut::<ActiveCall>() {
        c.stopped_ns += since.elapsed().as_nanos() as u64;
    }
    let here = depth(lua);
    let mut s = lock(&d.shared);
    if let Some(step) = &mut s.step
        && step.depth.is_none()
    {
        step.depth = Some(here);
    }
}

/// One Lua frame of the stopped stack.
struct Frame {
    /// Level as the hook sees it (0: the function that stopped).
    level: usize,
    name: String,
    path: Option<PathBuf>,
    chunk: String,
    line: usize,
}

/// The frames of script files on the stopped stack, innermost first.
fn frames(lua: &Lua) -> Vec<Frame> {
    let mut out = Vec::new();
    for level in 0.. {
        let Some(frame) = lua.inspect_stack(level, |d| {
            let src = d.source();
            let chunk = src.source.as_deref()?.strip_prefix('@')?.to_owned();
            let name = d
                .names()
                .name
                .map(|n| n.into_owned())
                .unwrap_or_else(|| match src.what {
                    "main" => "main chunk".to_owned(),
                    _ => format!("function at line {}", src.line_defined.unwrap_or(0)),
                });
            Some((chunk, name, d.current_line().unwrap_or(0)))
        }) else {
            break;
        };
        if let Some((chunk, name, line)) = frame {
            out.push(Frame {
                level,
                path: path_of(lua, &chunk),
                name,
                chunk,
                line,
            });
        }
    }
    out
}

/// What a `variablesReference` stands for.
enum Ref {
    Locals(usize),
    Upvalues(usize),
    Value(Table),
}

/// The stopped decision answering requests.
struct Session<'a> {
    lua: &'a Lua,
    fish: Option<FishId>,
    frames: Vec<Frame>,
    refs: Vec<Ref>,
}

impl Session<'_> {
    fn answer(&mut self, command: &str, args: &Json) -> Result<Json, RequestError> {
        match command {
            "stackTrace" => Ok(self.stack_trace(args)),
            "scopes" => self.scopes(args),
            "variables" => self.variables(args),
            "evaluate" => self.evaluate(args),
            other => Err(RequestError::NotForStopped(other.to_owned())),
        }
    }

    fn stack_trace(&self, args: &Json) -> Json {
        let start = args["startFrame"].as_u64().unwrap_or(0) as usize;
        let levels = match args["levels"].as_u64() {
            Some(0) | None => usize::MAX,
            Some(n) => n as usize,
        };
        let frames: Vec<Json> = self
            .frames
            .iter()
            .enumerate()
            .skip(start)
            .take(levels)
            .map(|(i, f)| {
                let name = f
                    .path
                    .as_ref()
                    .and_then(|p| p.file_name())
                    .map_or(f.chunk.clone(), |n| n.to_string_lossy().into_owned());
                let path = f
                    .path
                    .as_ref()
                    .map_or(f.chunk.clone(), |p| p.display().to_string());
                json!({
                    "id": i + 1,
                    "name": f.name,
                    "source": {"name": name, "path": path},
                    "line": f.line,
                    "column": 1,
                })
            })
            .collect();
        json!({"stackFrames": frames, "totalFrames": self.frames.len()})
    }

    fn frame(&self, args: &Json) -> Result<&Frame, RequestError> {
        let id = args["frameId"].as_u64().ok_or(RequestError::Missing {
            name: "frameId",
            kind: "a number",
        })?;
        (id as usize)
            .checked_sub(1)
            .and_then(|i| self.frames.get(i))
            .ok_or(RequestError::NoFrame {
                id,
                count: self.frames.len(),
            })
    }

    fn new_ref(&mut self, r: Ref) -> usize {
        self.refs.push(r);
        self.refs.len()
    }

    fn fish_table(&self) -> Option<Table> {
        let fish = self.fish?;
        let tables: Table = self.lua.named_registry_value(crate::host::FISH_KEY).ok()?;
        tables.raw_get::<Option<Table>>(fish.index).ok().flatten()
    }

    fn scopes(&mut self, args: &Json) -> Result<Json, RequestError> {
        let level = self.frame(args)?.level;
        let locals = self.new_ref(Ref::Locals(level));
        let upvalues = self.new_ref(Ref::Upvalues(level));
        let mut scopes = vec![
            json!({"name": "Locals", "presentationHint": "locals", "variablesReference": locals, "expensive": false}),
            json!({"name": "Upvalues", "variablesReference": upvalues, "expensive": false}),
        ];
        if let Some(t) = self.fish_table() {
            let name = match self.fish {
                Some(f) => format!("Fish #{}", f.index),
                None => "Fish".to_owned(),
            };
            let r = self.new_ref(Ref::Value(t));
            scopes.push(json!({"name": name, "variablesReference": r, "expensive": false}));
        }
        Ok(json!({"scopes": scopes}))
    }

    fn variables(&mut self, args: &Json) -> Result<Json, RequestError> {
        let r = args["variablesReference"]
            .as_u64()
            .ok_or(RequestError::Missing {
                name: "variablesReference",
                kind: "a number",
            })? as usize;
        let entries = match r.checked_sub(1).and_then(|i| self.refs.get(i)) {
            Some(Ref::Locals(level)) => locals(self.lua, *level).map_err(RequestError::Inspect)?,
            Some(Ref::Upvalues(level)) => upvalues(self.lua, *level)
                .map_err(RequestError::Inspect)?
                .into_iter()
                .filter(|(n, _)| n != "_ENV")
                .collect(),
            Some(Ref::Value(t)) => table_entries(t),
            None => return Err(RequestError::NoReference(r)),
        };
        let variables: Vec<Json> = entries
            .into_iter()
            .map(|(name, v)| self.variable(name, v))
            .collect();
        Ok(json!({"variables": variables}))
    }

    fn variable(&mut self, name: String, v: Value) -> Json {
        let (value, ty) = show(&v);
        let r = match v {
            Value::Table(t) => self.new_ref(Ref::Value(t)),
            _ => 0,
        };
        json!({"name": name, "value": value, "type": ty, "variablesReference": r})
    }

    fn evaluate(&mut self, args: &Json) -> Result<Json, RequestError> {
        let expr = args["expression"].as_str().ok_or(RequestError::Missing {
            name: "expression",
            kind: "a string",
        })?;
        let level = match args.get("frameId") {
            Some(id) if !id.is_null() => Some(self.frame(args)?.level),
            _ => None,
        };
        let v = if level.is_some() {
            eval_here(self.lua, level, expr)?
        } else {
            // No frame: the fish's context, as the console's REPL has it.
            let fish = self.fish_table();
            eval_with(self.lua, None, fish, expr)?
        };
        let (result, ty) = show(&v);
        let r = match v {
            Value::Table(t) => self.new_ref(Ref::Value(t)),
            _ => 0,
        };
        Ok(json!({"result": result, "type": ty, "variablesReference": r}))
    }
}

/// A value as the client shows it, and its Lua type.
fn show(v: &Value) -> (String, &'static str) {
    match v {
        Value::Nil => ("nil".into(), "nil"),
        Value::Boolean(b) => (b.to_string(), "boolean"),
        Value::Integer(i) => (i.to_string(), "number"),
        Value::Number(n) => (n.to_string(), "number"),
        Value::String(s) => (format!("{:?}", s.to_string_lossy()), "string"),
        Value::Table(t) => {
            let n = t.pairs::<Value, Value>().take(10_000).count();
            (format!("table ({n} entries)"), "table")
        }
        Value::Function(_) => ("function".into(), "function"),
        other => (other.type_name().into(), other.type_name()),
    }
}

/// A table's entries for the client: array part first (`[1]`, `[2]`…), then keys in order.
fn table_entries(t: &Table) -> Vec<(String, Value)> {
    let mut entries: Vec<(Value, Value)> = t
        .pairs::<Value, Value>()
        .flatten()
        .take(MAX_VARS as usize)
        .collect();
    let rank = |k: &Value| match k {
        Value::Integer(i) => (0, *i, String::new()),
        Value::String(s) => (1, 0, s.to_string_lossy()),
        other => (2, 0, other.type_name().to_owned()),
    };
    entries.sort_by_key(|a| rank(&a.0));
    entries
        .into_iter()
        .map(|(k, v)| {
            let name = match &k {
                Value::String(s) => s.to_string_lossy(),
                Value::Integer(i) => format!("[{i}]"),
                other => format!("[{}]", show(other).0),
            };
            (name, v)
        })
        .collect()
}

/// The hook level `level` as a stack level seen from inside `exec_raw`, whose protected call
/// is one C frame above the stopped function.
fn raw_level(level: usize) -> mlua::Result<c_int> {
    c_int::try_from(level + 1).map_err(|_| mlua::Error::runtime("stack level out of range"))
}

/// The active locals of the frame at hook level `level` (temporaries left out).
fn locals(lua: &Lua, level: usize) -> mlua::Result<Vec<(String, Value)>> {
    let level = raw_level(level)?;
    let mut names = Vec::new();
    // SAFETY: `exec_raw` runs the closure in a protected call on the current thread — the one the
    // hook stopped — with a valid state; `lua_getstack` fills `ar` only for a level that exists,
    // and `lua_getlocal` reads from it and pushes one value per name it returns (after we made
    // room with `lua_checkstack`). The values we leave pushed are what `exec_raw` returns.
    let values: MultiValue = unsafe {
        lua.exec_raw((), |state| {
            let mut ar: ffi::lua_Debug = std::mem::zeroed();
            if ffi::lua_getstack(state, level, &mut ar) == 0 {
                return;
            }
            for n in 1..=MAX_VARS {
                if ffi::lua_checkstack(state, 2) == 0 {
                    break;
                }
                let name = ffi::lua_getlocal(state, &ar, n);
                if name.is_null() {
                    break;
                }
                let name = CStr::from_ptr(name).to_string_lossy().into_owned();
                if name.starts_with('(') {
                    ffi::lua_pop(state, 1);
                    continue;
                }
                names.push(name);
            }
        })?
    };
    Ok(names.into_iter().zip(values).collect())
}

/// The upvalues of the function running at hook level `level` (`_ENV` included).
fn upvalues(lua: &Lua, level: usize) -> mlua::Result<Vec<(String, Value)>> {
    let level = raw_level(level)?;
    let mut names = Vec::new();
    // SAFETY: as in `locals`; `lua_getinfo` with "f" pushes the frame's function, whose index
    // we keep; `lua_getupvalue` pushes one value per name it returns; the function is removed
    // again so only the upvalues' values are returned.
    let values: MultiValue = unsafe {
        lua.exec_raw((), |state| {
            let mut ar: ffi::lua_Debug = std::mem::zeroed();
            if ffi::lua_getstack(state, level, &mut ar) == 0 || ffi::lua_checkstack(state, 2) == 0 {
                return;
            }
            if ffi::lua_getinfo(state, c"f".as_ptr(), &mut ar) == 0 {
                return;
            }
            let f = ffi::lua_gettop(state);
            for n in 1..=MAX_VARS {
                if ffi::lua_checkstack(state, 2) == 0 {
                    break;
                }
                let name = ffi::lua_getupvalue(state, f, n);
                if name.is_null() {
                    break;
                }
                names.push(CStr::from_ptr(name).to_string_lossy().into_owned());
            }
            ffi::lua_remove(state, f);
        })?
    };
    Ok(names.into_iter().zip(values).collect())
}

/// Evaluates `code` in the frame at hook level `level`, with the deciding fish as `fish` if the
/// frame has none.
fn eval_here(lua: &Lua, level: Option<usize>, code: &str) -> Result<Value, EvalError> {
    let fish = lua.app_data_ref::<ActiveCall>().and_then(|c| {
        let tables: Table = lua.named_registry_value(crate::host::FISH_KEY).ok()?;
        tables.raw_get::<Option<Table>>(c.fish.index).ok().flatten()
    });
    eval_with(lua, level, fish, code)
}

/// Evaluates `code` (an expression, else a statement) with the frame's locals and upvalues (if
/// `level`) and `fish` in scope, falling back to the frame's `_ENV` (or a fresh sandbox
/// environment). Assignments to locals do not write back. Runs in a coroutine under the
/// per-call instruction budget: a hook cannot meter code it runs itself, a coroutine has its
/// own hook.
fn eval_with(
    lua: &Lua,
    level: Option<usize>,
    fish: Option<Table>,
    code: &str,
) -> Result<Value, EvalError> {
    let err = EvalError::Setup;
    let env = lua.create_table().map_err(err)?;
    let mut fallback = None;
    if let Some(level) = level {
        for (name, v) in upvalues(lua, level).map_err(err)? {
            if name == "_ENV" {
                fallback = Some(v);
            } else {
                env.raw_set(name, v).map_err(err)?;
            }
        }
        for (name, v) in locals(lua, level).map_err(err)? {
            env.raw_set(name, v).map_err(err)?;
        }
    }
    if let Some(fish) = fish
        && env.raw_get::<Value>("fish").map_err(err)?.is_nil()
    {
        env.raw_set("fish", fish).map_err(err)?;
    }
    let fallback = match fallback {
        Some(v) => v,
        None => Value::Table(crate::sandbox::module_env(lua).map_err(err)?),
    };
    let meta = lua.create_table().map_err(err)?;
    meta.raw_set("__index", fallback).map_err(err)?;
    env.set_metatable(Some(meta)).map_err(err)?;
    let compile = |src: &str| {
        lua.load(src)
            .set_name("=debug console")
            .set_mode(mlua::chunk::ChunkMode::Text)
            .set_environment(env.clone())
            .into_function()
    };
    let f = compile(&format!("return {code}"))
        .or_else(|_| compile(code))
        .map_err(EvalError::Syntax)?;
    let budget = lua
        .app_data_ref::<ActiveCall>()
        .map(|c| (Arc::clone(&c.budget), c.eval_instructions));
    let saved = budget.as_ref().map(|(b, n)| {
        let saved = b.remaining();
        b.arm(*n);
        saved
    });
    let result = lua
        .create_thread(f)
        .and_then(|t| t.resume::<MultiValue>(()));
    if let (Some((b, _)), Some(saved)) = (&budget, saved) {
        b.restore(saved);
    }
    let values = result.map_err(EvalError::Runtime)?;
    Ok(values.into_iter().next().unwrap_or(Value::Nil))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The frame arithmetic of `locals`/`upvalues` (one C frame between the hook and the stopped
    /// function inside `exec_raw`), checked with a plain hook.
    #[test]
    fn locals_and_upvalues_of_the_hooked_frame() {
        let lua = Lua::new();
        let seen = Arc::new(std::sync::Mutex::new(Vec::new()));
        let s = Arc::clone(&seen);
        lua.set_hook(mlua::HookTriggers::new().every_line(), move |lua, d| {
            if d.current_line() == Some(4) {
                let l = locals(lua, 0)?;
                let u = upvalues(lua, 0)?;
                let mut s = s.lock().unwrap();
                for (n, v) in l.into_iter().chain(u).filter(|(n, _)| n != "_ENV") {
                    s.push(format!("{n}={}", show(&v).0));
                }
                let v = eval_with(lua, Some(0), None, "a + b * up").unwrap();
                s.push(format!("eval={}", show(&v).0));
            }
            Ok(VmState::Continue)
        })
        .unwrap();
        lua.load(
            "local up = 10\nlocal function f(a)\n  local b = math.floor(a * 2)\n  return a + b + up\nend\nreturn f(3)",
        )
        .exec()
        .unwrap();
        let seen = seen.lock().unwrap().clone();
        assert_eq!(seen, ["a=3", "b=6", "up=10", "eval=63"]);
    }

    #[test]
    fn tables_list_their_array_part_first() {
        let lua = Lua::new();
        let t: Table = lua
            .load("return {z = 1, 'one', 'two', a = {}}")
            .eval()
            .unwrap();
        let names: Vec<_> = table_entries(&t).into_iter().map(|(n, _)| n).collect();
        assert_eq!(names, ["[1]", "[2]", "a", "z"]);
        assert_eq!(show(&Value::Table(t)).0, "table (4 entries)");
    }
}
