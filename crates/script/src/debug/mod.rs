//! A Debug Adapter Protocol server (issue 17): VS Code, or any DAP client, sets breakpoints in
//! behaviour scripts, steps through a decision and looks at the deciding fish.
//!
//! ## How it pauses the aquarium without changing it
//!
//! A decision depends only on the world as its tick began and on the fish's own state (see
//! [`super::sim`]), so stopping a decision half-way and resuming it later changes nothing but the
//! wall clock. With a debugger attached the scripts run in **one lane** (on the simulation's own
//! thread); a breakpoint blocks that thread *inside Lua's line hook*, and while it is blocked
//! the thread itself answers the client's `stackTrace`, `scopes`, `variables` and `evaluate`
//! requests (a Lua state is single-threaded): the network thread ([`server`]) forwards them over
//! a channel. `continue` lets the hook return and the decision goes on from where it stopped.
//! Continuing therefore gives exactly the trajectories of a run without the debugger.
//!
//! ## What it costs
//!
//! With no breakpoint set (and no step or pause pending) a decision sets no hook at all: the
//! lane checks one atomic flag. With breakpoints, only decisions of fish whose behaviour file
//! holds one — or any decision, while a breakpoint sits in a library file outside
//! `behaviors/*.lua`, since any behaviour may `require` it — run with a line hook, for the
//! duration of that call, and are metered by the instruction budget from their first
//! instruction (the watchdog's delayed metering would replace the line hook).
//!
//! Measured (callgrind, `shoal bench sim --fish 1000 --seconds 0.5 --lanes 1`, 90 ticks, debug
//! build, 2026-11-27): the tick stage ran 1,751.9 M instructions before this module and 1,752.1 M
//! with it and no `--dap` (+0.009 %, about 10 instructions per decision — the size of the Lua
//! VM's own run-to-run variation: `luaV_execute` differed by as much).
//!
//! Files: [`wire`] (framing), [`server`] (the network thread and the requests it answers
//! itself), `paused.rs` (the Lua side: the hook, the paused stack, evaluation).

use std::collections::HashMap;
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicI64, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, Sender};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, OnceLock};

use serde_json::{Value, json};

use super::budget::Budget;
use super::host::{ModuleIndex, ScriptHost};
use super::sandbox::LineHook;
use shoal_core::world::FishId;

mod paused;
pub mod server;
pub mod wire;

use paused::on_hook;

/// The address `--dap` listens on when none is given.
pub const DEFAULT_ADDR: &str = "127.0.0.1:4711";

/// What can go wrong setting up or running a DAP session.
#[derive(Debug, thiserror::Error)]
pub enum DapError {
    /// `--dap ADDR` is not an address shoal may listen on.
    #[error("--dap {addr}: {why}")]
    Address {
        /// The address as given.
        addr: String,
        /// Why it is refused.
        why: String,
    },
    /// Listening failed (port in use, permission).
    #[error(
        "--dap {addr}: cannot listen there: {source} (is another shoal listening? pick another \
         port, or 0 for any free one)"
    )]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// The system's error.
        source: std::io::Error,
    },
    /// The client broke the `Content-Length` framing; the connection is closed.
    #[error("DAP framing: {0}")]
    Framing(String),
    /// Reading or writing the connection failed.
    #[error("DAP connection: {0}")]
    Io(#[from] std::io::Error),
}

/// Why a DAP request got an error response (the session goes on). The message is what the
/// client shows.
#[derive(Debug, thiserror::Error)]
pub enum RequestError {
    /// A well-framed message whose body is not JSON.
    #[error("the message is not JSON: {0}")]
    NotJson(#[source] serde_json::Error),
    /// The framing broke: this is the last response before the connection closes.
    #[error("{0}; closing the connection")]
    Closing(String),
    /// JSON, but not a request.
    #[error("expected a request: {{\"seq\": N, \"type\": \"request\", \"command\": …}}")]
    NotARequest,
    /// A request shoal does not answer.
    #[error(
        "unknown request `{0}` (shoal answers initialize, attach/launch, setBreakpoints, \
         configurationDone, threads, stackTrace, scopes, variables, evaluate, continue, next, \
         stepIn, stepOut, pause, disconnect)"
    )]
    Unknown(String),
    /// A step asked for while no decision is stopped.
    #[error("the aquarium is running: steps start from a stopped decision")]
    NotStopped,
    /// A request about the stopped state while none is stopped.
    #[error(
        "`{0}`: the aquarium is running; stack, variables and evaluation are there while it is \
         stopped (a breakpoint, a step or pause)"
    )]
    Running(String),
    /// The stopped decision went on before it could be asked.
    #[error("the stopped decision is gone")]
    Gone,
    /// The stopped decision did not answer in time.
    #[error("the stopped decision did not answer")]
    NoAnswer,
    /// A request the stopped decision does not answer.
    #[error("`{0}` is not answered by a stopped decision")]
    NotForStopped(String),
    /// A required argument is missing or of the wrong type.
    #[error("`{name}` ({kind}) is missing")]
    Missing {
        /// The argument.
        name: &'static str,
        /// What it should be (`a number`).
        kind: &'static str,
    },
    /// `setBreakpoints` without `source.path`.
    #[error("setBreakpoints: `source.path` (the script's file path) is missing")]
    NoSourcePath,
    /// `setBreakpoints` for a file that cannot be read.
    #[error("setBreakpoints: {path}: {source}")]
    Source {
        /// The path as the client gave it.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// No such frame on the stopped stack.
    #[error("no frame {id} (there are {count})")]
    NoFrame {
        /// The frame id asked for.
        id: u64,
        /// Frames on the stack.
        count: usize,
    },
    /// No such `variablesReference`.
    #[error("no variables reference {0}")]
    NoReference(usize),
    /// Reading a frame's locals or upvalues failed.
    #[error("{0}")]
    Inspect(mlua::Error),
    /// Evaluating an expression failed.
    #[error(transparent)]
    Eval(#[from] crate::error::EvalError),
}

/// Resolves `--dap ADDR` (`host:port`, or a port alone for the loopback address). Anyone who
/// can reach the server can run Lua in the aquarium, so an address that is not loopback is
/// refused unless `allow_remote` (`--dap-allow-remote`).
pub fn parse_addr(spec: &str, allow_remote: bool) -> Result<SocketAddr, DapError> {
    let refuse = |why: String| DapError::Address {
        addr: spec.to_owned(),
        why,
    };
    let spec_full = if spec.parse::<u16>().is_ok() {
        format!("127.0.0.1:{spec}")
    } else {
        spec.to_owned()
    };
    if spec.ends_with(".lua") || spec.contains('/') {
        return Err(refuse(format!(
            "this looks like a path, not an address: write the paths first \
             (`shoal test PATH --dap`) or give the address (`--dap {DEFAULT_ADDR} PATH`)"
        )));
    }
    let addr = spec_full
        .to_socket_addrs()
        .map_err(|e| {
            refuse(format!(
                "not an address (expected HOST:PORT, e.g. {DEFAULT_ADDR}): {e}"
            ))
        })?
        .next()
        .ok_or_else(|| refuse("the name resolves to no address".into()))?;
    if !addr.ip().is_loopback() && !allow_remote {
        return Err(refuse(format!(
            "{} is not a loopback address: anyone who can reach it could run Lua in the \
             aquarium. Use 127.0.0.1, or add --dap-allow-remote if you mean it",
            addr.ip()
        )));
    }
    Ok(addr)
}

/// `hitCondition` of a breakpoint: when, counting the times its line is reached (its condition
/// met), it stops. `N` or `==N`: the Nth time; `>=N`, `>N`, `<N`, `<=N`; `%N`: every Nth time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HitCondition {
    /// The Nth time only.
    Eq(u64),
    /// From the Nth time on.
    Ge(u64),
    /// After the Nth time.
    Gt(u64),
    /// Before the Nth time.
    Lt(u64),
    /// Up to the Nth time.
    Le(u64),
    /// Every Nth time.
    Every(u64),
}

impl HitCondition {
    /// Parses a `hitCondition`; the error says what is expected.
    pub fn parse(text: &str) -> Result<Self, HitConditionError> {
        let t = text.trim();
        let (op, n) = ["==", ">=", "<=", ">", "<", "%", "="]
            .iter()
            .find_map(|op| t.strip_prefix(op).map(|rest| (*op, rest)))
            .unwrap_or(("==", t));
        let n: u64 = n
            .trim()
            .parse()
            .map_err(|_| HitConditionError::NotACount(text.to_owned()))?;
        Ok(match op {
            ">=" => Self::Ge(n),
            ">" => Self::Gt(n),
            "<=" => Self::Le(n),
            "<" => Self::Lt(n),
            "%" if n == 0 => return Err(HitConditionError::EveryZero(text.to_owned())),
            "%" => Self::Every(n),
            _ => Self::Eq(n),
        })
    }

    /// Whether the `hits`th time (1-based) stops.
    pub fn met(self, hits: u64) -> bool {
        match self {
            Self::Eq(n) => hits == n,
            Self::Ge(n) => hits >= n,
            Self::Gt(n) => hits > n,
            Self::Lt(n) => hits < n,
            Self::Le(n) => hits <= n,
            Self::Every(n) => hits.is_multiple_of(n),
        }
    }
}

/// Why a `hitCondition` was not understood (the breakpoint is answered unverified, with this).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum HitConditionError {
    /// Not a count with an optional operator.
    #[error("hit condition `{0}`: expected a count like `3`, `>= 3` or `% 2`")]
    NotACount(String),
    /// `% 0`.
    #[error("hit condition `{0}`: `% 0` never stops")]
    EveryZero(String),
}

/// One breakpoint of a file, as the client set it.
#[derive(Clone, Debug)]
pub struct Breakpoint {
    /// The id the client knows it by.
    pub id: i64,
    /// 1-based line.
    pub line: usize,
    /// Lua expression; stops only where it is truthy (evaluated in the stopped frame).
    pub condition: Option<String>,
    /// When to stop, counting the times the line is reached with its condition met.
    pub hit: Option<HitCondition>,
    /// A logpoint's message (`{expressions}` evaluated in the frame): printed, never stops.
    pub log: Option<String>,
    /// Times reached with the condition met.
    hits: u64,
}

/// A step the client asked for, pending until a line stops it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum StepMode {
    /// `next`: the next line at the same call depth or shallower.
    Over,
    /// `stepIn`: the next line anywhere.
    In,
    /// `stepOut`: the next line shallower than here.
    Out,
}

#[derive(Clone, Copy, Debug)]
struct Step {
    mode: StepMode,
    /// Lua call depth where the step began; `None` once that decision ended (the step then
    /// stops at the next line of a behaviour file anywhere).
    depth: Option<usize>,
}

/// What the paused thread is told by the network thread.
enum ToPaused {
    /// A request about the paused state, answered on `reply` (a body or an error message).
    Request {
        command: String,
        args: Value,
        reply: Sender<Result<Value, RequestError>>,
    },
    /// Go on (after setting up any step).
    Resume,
}

#[derive(Default)]
struct Shared {
    /// Breakpoints by canonical file path.
    breakpoints: HashMap<PathBuf, Vec<Breakpoint>>,
    /// A breakpoint is in a file that is not a behaviour module (a library any may require).
    in_library: bool,
    step: Option<Step>,
    pause_requested: bool,
    next_id: i64,
}

/// A debugger the simulation's script lanes consult, served to one DAP client at a time by
/// [`server::listen`].
pub struct Debugger {
    shared: Mutex<Shared>,
    /// Anything to hook for: a breakpoint, a step or a pause. Read once per decision.
    active: AtomicBool,
    /// A decision is stopped and serving requests.
    paused: AtomicBool,
    to_paused: Sender<ToPaused>,
    from_server: Mutex<Receiver<ToPaused>>,
    /// One stopped decision at a time (simulations in several threads share one debugger).
    gate: Mutex<()>,
    /// The client connection's writing half.
    out: Mutex<Option<TcpStream>>,
    seq: AtomicI64,
    configured: Mutex<bool>,
    configured_cv: Condvar,
    /// Decisions run with the line hook (for tests and cost checks).
    hooked_decisions: AtomicU64,
    /// Script errors already shown in the client's console (each once, as the console does).
    errors_shown: Mutex<std::collections::HashSet<String>>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A panic elsewhere while holding the lock leaves plain data behind: keep going.
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Debugger {
    /// A debugger with no client yet.
    pub fn new() -> Arc<Self> {
        let (to_paused, from_server) = std::sync::mpsc::channel();
        Arc::new(Self {
            shared: Mutex::new(Shared::default()),
            active: AtomicBool::new(false),
            paused: AtomicBool::new(false),
            to_paused,
            from_server: Mutex::new(from_server),
            gate: Mutex::new(()),
            out: Mutex::new(None),
            seq: AtomicI64::new(1),
            configured: Mutex::new(false),
            configured_cv: Condvar::new(),
            hooked_decisions: AtomicU64::new(0),
            errors_shown: Mutex::new(std::collections::HashSet::new()),
        })
    }

    /// Blocks until a client has sent `configurationDone` (or connected and left): `--dap`
    /// waits here before simulating, so breakpoints are in place from the first tick.
    pub fn wait_for_configuration(&self) {
        let mut done = lock(&self.configured);
        while !*done {
            done = self
                .configured_cv
                .wait(done)
                .unwrap_or_else(|e| e.into_inner());
        }
    }

    fn set_configured(&self) {
        *lock(&self.configured) = true;
        self.configured_cv.notify_all();
    }

    /// Decisions that ran with the line hook so far.
    pub fn hooked_decisions(&self) -> u64 {
        self.hooked_decisions.load(Ordering::Relaxed)
    }

    /// Whether a decision is stopped.
    pub fn is_paused(&self) -> bool {
        self.paused.load(Ordering::SeqCst)
    }

    fn update_active(&self, s: &Shared) {
        let active = !s.breakpoints.is_empty() || s.step.is_some() || s.pause_requested;
        self.active.store(active, Ordering::SeqCst);
    }

    /// Replaces the breakpoints of `path` (canonical); returns them with their ids.
    fn set_breakpoints(&self, path: PathBuf, mut points: Vec<Breakpoint>) -> Vec<Breakpoint> {
        let mut s = lock(&self.shared);
        for p in &mut points {
            s.next_id += 1;
            p.id = s.next_id;
        }
        if points.is_empty() {
            s.breakpoints.remove(&path);
        } else {
            s.breakpoints.insert(path, points.clone());
        }
        s.in_library = s.breakpoints.keys().any(|p| !is_behavior_file(p));
        self.update_active(&s);
        points
    }

    fn request_pause(&self) {
        let mut s = lock(&self.shared);
        s.pause_requested = true;
        self.update_active(&s);
    }

    /// Forgets breakpoints and steps and lets a stopped decision go on (the client left).
    fn clear(&self) {
        {
            let mut s = lock(&self.shared);
            *s = Shared {
                next_id: s.next_id,
                ..Shared::default()
            };
            self.update_active(&s);
        }
        lock(&self.errors_shown).clear();
        self.resume(None);
    }

    /// Lets a stopped decision go on, stepping if `step` says so.
    fn resume(&self, step: Option<StepMode>) {
        {
            // The stopped thread fills in the depth it stopped at when it goes on.
            let mut s = lock(&self.shared);
            s.step = step.map(|mode| Step { mode, depth: None });
            self.update_active(&s);
        }
        if self.paused.swap(false, Ordering::SeqCst) {
            let _ = self.to_paused.send(ToPaused::Resume);
        }
    }

    /// Whether a decision of the behaviour in `module_path` needs the line hook.
    fn wants_hook(&self, module_path: &Path) -> bool {
        if !self.active.load(Ordering::Relaxed) {
            return false;
        }
        let s = lock(&self.shared);
        s.step.is_some()
            || s.pause_requested
            || s.in_library
            || s.breakpoints.contains_key(module_path)
    }

    /// Sends an event to the client, if one is connected.
    pub fn send_event(&self, event: &str, body: Value) {
        self.send(json!({"type": "event", "event": event, "body": body}));
    }

    /// Prints `text` in the client's debug console (an `output` event).
    pub fn output(&self, category: &str, text: &str) {
        let mut text = text.to_owned();
        if !text.ends_with('\n') {
            text.push('\n');
        }
        self.send_event("output", json!({"category": category, "output": text}));
    }

    /// Shows a script error (`file:line: message`) in the client's console, once per distinct
    /// message.
    pub fn script_error(&self, message: &str) {
        if lock(&self.errors_shown).insert(message.to_owned()) {
            self.output("stderr", message);
        }
    }

    fn send(&self, mut message: Value) {
        let mut out = lock(&self.out);
        let Some(stream) = out.as_mut() else {
            return;
        };
        message["seq"] = json!(self.seq.fetch_add(1, Ordering::SeqCst));
        if wire::write_message(stream, &message).is_err() {
            *out = None;
        }
    }

    /// Tells the client the run is over (`terminated`, then `exited` with `exit_code`) and lets
    /// any stopped decision go on. Then waits (at most [`GOODBYE_WAIT`]) for the client to send
    /// its `disconnect` and leave: a process that exits with the client's last request unread
    /// resets the connection under it (`ECONNRESET` after `terminated`).
    pub fn finish(&self, exit_code: i32) {
        self.send_event("exited", json!({"exitCode": exit_code}));
        self.send_event("terminated", json!({}));
        self.clear();
        // The server thread drops `out` when the session ends, then notifies `configured_cv`
        // (under `configured`): checked under that lock, no wake-up is lost.
        let guard = lock(&self.configured);
        let _ = self
            .configured_cv
            .wait_timeout_while(guard, GOODBYE_WAIT, |_| lock(&self.out).is_some());
    }
}

/// How long [`Debugger::finish`] waits for the client to disconnect.
pub const GOODBYE_WAIT: std::time::Duration = std::time::Duration::from_secs(3);

/// Whether `path` is a behaviour module's own file (`…/behaviors/NAME.lua`), not a library.
fn is_behavior_file(path: &Path) -> bool {
    path.parent()
        .and_then(Path::file_name)
        .is_some_and(|d| d == "behaviors")
}

/// The debugger every simulation made from now on in this process attaches to (`--dap`).
static GLOBAL: OnceLock<Arc<Debugger>> = OnceLock::new();

/// Makes `debugger` the one every [`super::Simulation`] created from now on attaches to (the
/// CLI's `--dap`; behaviour tests make their simulations themselves). False if one was
/// attached already.
pub fn attach_globally(debugger: &Arc<Debugger>) -> bool {
    GLOBAL.set(Arc::clone(debugger)).is_ok()
}

/// The debugger of [`attach_globally`], if any.
pub fn global() -> Option<Arc<Debugger>> {
    GLOBAL.get().cloned()
}

/// The decision in progress, while it runs with the line hook (a Lua app data).
struct ActiveCall {
    debugger: Arc<Debugger>,
    fish: FishId,
    /// The state's budget, and the instructions one evaluation may use (a decision's: the
    /// paused call's time limit, which keeps counting CPU time, is then never reached).
    budget: Arc<Budget>,
    eval_instructions: u64,
    /// Chunk name → canonical path, for the files seen in this call.
    paths: HashMap<String, Option<PathBuf>>,
    /// Wall time the call has been held stopped.
    stopped_ns: u64,
}

/// Before a decision of `module` for `fish`: arms the line hook if the debugger wants it.
/// True if it did; then call [`end_decision`] after.
pub(crate) fn begin_decision(
    debugger: &Arc<Debugger>,
    host: &mut ScriptHost,
    module: ModuleIndex,
    fish: FishId,
) -> bool {
    if !debugger.active.load(Ordering::Relaxed) {
        return false;
    }
    let Some(path) = host.module_path(module) else {
        return false;
    };
    if !debugger.wants_hook(path) {
        return false;
    }
    debugger.hooked_decisions.fetch_add(1, Ordering::Relaxed);
    host.lua().set_app_data(ActiveCall {
        debugger: Arc::clone(debugger),
        fish,
        budget: Arc::clone(host.budget()),
        eval_instructions: host.limits().instructions_per_call,
        paths: HashMap::new(),
        stopped_ns: 0,
    });
    host.lua().set_app_data(LineHook(on_hook));
    host.set_line_hook(true);
    true
}

/// After a decision [`begin_decision`] hooked: the hook is off again; a step that did not stop
/// in this decision stops at the next behaviour line anywhere. Returns the nanoseconds the
/// decision was held stopped (no cost of the script's, for the profile).
pub(crate) fn end_decision(debugger: &Debugger, host: &mut ScriptHost) -> u64 {
    host.set_line_hook(false);
    host.lua().remove_app_data::<LineHook>();
    let call = host.lua().remove_app_data::<ActiveCall>();
    let mut s = lock(&debugger.shared);
    if let Some(step) = &mut s.step {
        step.depth = None;
    }
    call.map_or(0, |c| c.stopped_ns)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_only_unless_allowed() {
        assert_eq!(parse_addr("127.0.0.1:4711", false).unwrap().port(), 4711);
        assert!(parse_addr("4712", false).unwrap().ip().is_loopback());
        assert!(parse_addr("[::1]:4711", false).is_ok());
        let e = parse_addr("0.0.0.0:4711", false).unwrap_err().to_string();
        assert!(e.contains("--dap-allow-remote"), "{e}");
        assert!(parse_addr("0.0.0.0:4711", true).is_ok());
        assert!(parse_addr("nonsense", false).is_err());
        let path = parse_addr("tests/behavior/forage_test.lua", false).unwrap_err();
        assert!(path.to_string().contains("paths first"), "{path}");
    }

    #[test]
    fn hit_conditions() {
        assert_eq!(HitCondition::parse("3"), Ok(HitCondition::Eq(3)));
        assert_eq!(HitCondition::parse(">= 2"), Ok(HitCondition::Ge(2)));
        assert_eq!(HitCondition::parse("%2"), Ok(HitCondition::Every(2)));
        assert!(HitCondition::parse("% 0").is_err());
        assert!(HitCondition::parse("often").is_err());
        let every2 = HitCondition::Every(2);
        assert_eq!(
            (1..=5).filter(|&h| every2.met(h)).collect::<Vec<_>>(),
            [2, 4]
        );
        assert!(HitCondition::Eq(3).met(3) && !HitCondition::Eq(3).met(4));
        assert!(HitCondition::Gt(1).met(2) && !HitCondition::Gt(1).met(1));
    }

    #[test]
    fn no_breakpoint_means_no_hook() {
        let d = Debugger::new();
        let forage = PathBuf::from("/s/behaviors/forage.lua");
        assert!(!d.wants_hook(&forage));
        let bp = Breakpoint {
            id: 0,
            line: 3,
            condition: None,
            hit: None,
            log: None,
            hits: 0,
        };
        d.set_breakpoints(forage.clone(), vec![bp.clone()]);
        assert!(d.wants_hook(&forage));
        assert!(!d.wants_hook(Path::new("/s/behaviors/school.lua")));
        // A library may be required by any behaviour.
        d.set_breakpoints(PathBuf::from("/s/behaviors/lib/common.lua"), vec![bp]);
        assert!(d.wants_hook(Path::new("/s/behaviors/school.lua")));
        d.clear();
        assert!(!d.wants_hook(&forage));
    }
}
