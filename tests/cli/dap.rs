//! The Debug Adapter Protocol server (issue 17), driven over TCP the way an editor drives it:
//! `shoal test --dap` with breakpoints in the shipped `forage` behaviour, and an in-process
//! simulation checked to run exactly as it would without the debugger.
//!
//! Waits are generous timeouts only against hangs; nothing here is timed.

use std::collections::VecDeque;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use serde_json::{Value, json};
use shoal_script::Simulation;
use shoal_script::debug::{Debugger, server};

use crate::xvfb_common;

/// Longest wait for any one message (only against hangs).
const PATIENCE: Duration = Duration::from_secs(120);

fn repo() -> &'static Path {
    shoal_core::source_root()
}

fn forage() -> PathBuf {
    repo().join("scripts/behaviors/forage.lua")
}

/// A DAP client: requests with responses, events queued until asked for.
struct Client {
    reader: BufReader<TcpStream>,
    writer: TcpStream,
    seq: i64,
    events: VecDeque<Value>,
}

impl Client {
    fn connect(addr: SocketAddr) -> Self {
        let stream = TcpStream::connect(addr).expect("connect to the DAP server");
        stream.set_read_timeout(Some(PATIENCE)).unwrap();
        Self {
            reader: BufReader::new(stream.try_clone().unwrap()),
            writer: stream,
            seq: 0,
            events: VecDeque::new(),
        }
    }

    fn send_raw(&mut self, bytes: &[u8]) {
        self.writer.write_all(bytes).unwrap();
    }

    fn send(&mut self, command: &str, arguments: Value) -> i64 {
        self.seq += 1;
        let body =
            json!({"seq": self.seq, "type": "request", "command": command, "arguments": arguments})
                .to_string();
        self.send_raw(format!("Content-Length: {}\r\n\r\n{body}", body.len()).as_bytes());
        self.seq
    }

    fn read(&mut self) -> Value {
        let mut length = None;
        loop {
            let mut line = String::new();
            let n = self.reader.read_line(&mut line).expect("read a header");
            assert!(n > 0, "the server closed the connection");
            let line = line.trim_end();
            if line.is_empty() {
                break;
            }
            if let Some(v) = line.strip_prefix("Content-Length: ") {
                length = Some(v.parse::<usize>().unwrap());
            }
        }
        let mut body = vec![0; length.expect("Content-Length")];
        self.reader.read_exact(&mut body).unwrap();
        serde_json::from_slice(&body).unwrap()
    }

    /// The response to request `seq` (events read meanwhile are kept).
    fn response_to(&mut self, seq: i64) -> Value {
        loop {
            let m = self.read();
            if m["type"] == "response" && m["request_seq"] == seq {
                return m;
            }
            if m["type"] == "event" {
                self.events.push_back(m);
            }
        }
    }

    /// Sends a request and returns its successful response's body.
    fn ok(&mut self, command: &str, arguments: Value) -> Value {
        let seq = self.send(command, arguments);
        let r = self.response_to(seq);
        assert_eq!(r["success"], true, "{command} failed: {r}");
        assert_eq!(r["command"], command);
        r["body"].clone()
    }

    /// Sends a request that must fail; returns the error message.
    fn fails(&mut self, command: &str, arguments: Value) -> String {
        let seq = self.send(command, arguments);
        let r = self.response_to(seq);
        assert_eq!(r["success"], false, "{command} should fail: {r}");
        r["message"].as_str().unwrap_or_default().to_owned()
    }

    fn event(&mut self, name: &str) -> Value {
        if let Some(i) = self.events.iter().position(|e| e["event"] == name) {
            return self.events.remove(i).unwrap();
        }
        loop {
            let m = self.read();
            if m["type"] == "event" && m["event"] == name {
                return m;
            }
            if m["type"] == "event" {
                self.events.push_back(m);
            }
        }
    }

    /// Output events seen so far (queued), as one text.
    fn output_so_far(&self) -> String {
        self.events
            .iter()
            .filter(|e| e["event"] == "output")
            .filter_map(|e| e["body"]["output"].as_str())
            .collect()
    }

    fn handshake(&mut self) {
        let caps = self.ok(
            "initialize",
            json!({"adapterID": "shoal", "clientID": "tests"}),
        );
        assert_eq!(caps["supportsConditionalBreakpoints"], true);
        assert_eq!(caps["supportsLogPoints"], true);
        self.event("initialized");
        self.ok("attach", json!({}));
    }

    fn set_breakpoints(&mut self, path: &Path, points: Value) -> Value {
        self.ok(
            "setBreakpoints",
            json!({"source": {"path": path.display().to_string()}, "breakpoints": points}),
        )
    }

    /// Top frame of the stopped decision: (file name, line, function name).
    fn top(&mut self) -> (String, u64, String) {
        let st = self.ok("stackTrace", json!({"threadId": 1}));
        let f = &st["stackFrames"][0];
        (
            f["source"]["name"].as_str().unwrap().to_owned(),
            f["line"].as_u64().unwrap(),
            f["name"].as_str().unwrap().to_owned(),
        )
    }

    fn variables(&mut self, reference: &Value) -> Vec<Value> {
        self.ok("variables", json!({"variablesReference": reference}))["variables"]
            .as_array()
            .unwrap()
            .clone()
    }

    fn evaluate(&mut self, expr: &str, frame: Option<u64>) -> String {
        let mut args = json!({"expression": expr, "context": "repl"});
        if let Some(f) = frame {
            args["frameId"] = json!(f);
        }
        self.ok("evaluate", args)["result"]
            .as_str()
            .unwrap()
            .to_owned()
    }
}

fn named<'a>(vars: &'a [Value], name: &str) -> &'a Value {
    vars.iter()
        .find(|v| v["name"] == name)
        .unwrap_or_else(|| panic!("no variable `{name}` among {vars:?}"))
}

/// `shoal test FILE --filter F --dap 127.0.0.1:0`, with the address it listens on and its
/// remaining standard output, read in a thread.
struct Shoal {
    child: Child,
    addr: SocketAddr,
    stdout: mpsc::Receiver<String>,
}

impl Shoal {
    fn test(file: &str, filter: &str) -> Self {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_shoal"));
        cmd.args(["test", file, "--filter", filter, "--dap", "127.0.0.1:0"]);
        Self::spawn(cmd)
    }

    fn spawn(mut cmd: Command) -> Self {
        let mut child = cmd
            .current_dir(repo())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("run shoal");
        let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let addr = loop {
            let line = lines
                .next()
                .expect("shoal printed where it listens")
                .unwrap();
            if let Some(rest) = line.strip_prefix("DAP server listening on ") {
                let addr = rest.split(':').take(2).collect::<Vec<_>>().join(":");
                break addr.parse().unwrap();
            }
        };
        let (tx, stdout) = mpsc::channel();
        std::thread::spawn(move || {
            for line in lines.map_while(Result::ok) {
                let _ = tx.send(line);
            }
        });
        Self {
            child,
            addr,
            stdout,
        }
    }

    /// Waits for the exit; its status and the rest of its output.
    fn finish(mut self) -> (bool, String) {
        let status = self.child.wait().unwrap();
        let out: Vec<String> = self.stdout.iter().collect();
        (status.success(), out.join("\n"))
    }
}

const FORAGE_TEST: &str = "tests/behavior/forage_test.lua";
const ONE_TEST: &str = "intention and percepts";

#[test]
fn breakpoint_stack_variables_steps_conditions_logpoints_and_the_end_of_a_test() {
    let shoal = Shoal::test(FORAGE_TEST, ONE_TEST);
    let mut c = Client::connect(shoal.addr);
    c.handshake();
    // forage.lua:19 is `local dt = common.elapsed(fish)`, the first line of M.intend.
    let set = c.set_breakpoints(&forage(), json!([{"line": 19}, {"line": 999}]));
    assert_eq!(set["breakpoints"][0]["verified"], true);
    assert_eq!(
        set["breakpoints"][1]["verified"], false,
        "past the end: {set}"
    );
    c.ok("configurationDone", json!({}));

    let stopped = c.event("stopped");
    assert_eq!(stopped["body"]["reason"], "breakpoint");
    let threads = c.ok("threads", json!({}));
    assert_eq!(threads["threads"][0]["id"], 1);
    let st = c.ok("stackTrace", json!({"threadId": 1}));
    let top = &st["stackFrames"][0];
    assert_eq!(top["line"], 19);
    assert_eq!(top["name"], "intend");
    let path = PathBuf::from(top["source"]["path"].as_str().unwrap());
    assert_eq!(
        path,
        forage().canonicalize().unwrap(),
        "a path the editor can open"
    );

    // Locals of intend: the fish and its percepts; the fish scope: its memory and percepts.
    let scopes = c.ok("scopes", json!({"frameId": top["id"]}));
    let scopes = scopes["scopes"].as_array().unwrap().clone();
    let locals = c.variables(&scopes[0]["variablesReference"]);
    assert_eq!(named(&locals, "fish")["type"], "table");
    let p = named(&locals, "p");
    assert_eq!(p["type"], "table");
    let percepts = c.variables(&p["variablesReference"]);
    assert!(
        percepts.iter().any(|v| v["name"] == "food_id"),
        "the percepts hold the food: {percepts:?}"
    );
    let upvalues = c.variables(&scopes[1]["variablesReference"]);
    assert_eq!(named(&upvalues, "common")["type"], "table");
    let fish_scope = scopes
        .iter()
        .find(|s| s["name"].as_str().unwrap().starts_with("Fish #"))
        .expect("a Fish scope");
    let fish = c.variables(&fish_scope["variablesReference"]);
    let memory = named(&fish, "memory");
    assert_eq!(memory["type"], "table");
    c.variables(&memory["variablesReference"]);

    // Evaluation in the frame (locals, upvalues, fish) and in the fish's context.
    let frame = top["id"].as_u64();
    assert_eq!(c.evaluate("p.food_x", frame), "150");
    assert_eq!(c.evaluate("common.HUNGRY", frame), "0.3");
    assert_eq!(c.evaluate("type(fish.memory)", None), "\"table\"");
    let unknown = c.fails(
        "evaluate",
        json!({"expression": "nope()", "frameId": frame}),
    );
    assert!(unknown.contains("nope"), "{unknown}");
    let syntax = c.fails("evaluate", json!({"expression": "1 +", "frameId": frame}));
    assert!(syntax.contains("debug console"), "{syntax}");
    // The sandbox's budget applies to evaluations too.
    let runaway = c.fails(
        "evaluate",
        json!({"expression": "(function() while true do end end)()", "frameId": frame}),
    );
    assert!(runaway.contains("budget"), "{runaway}");

    // Steps: over to line 20; into common.hunger; out back to intend's next line.
    c.ok("next", json!({"threadId": 1}));
    assert_eq!(c.event("stopped")["body"]["reason"], "step");
    assert_eq!(c.top(), ("forage.lua".into(), 20, "intend".into()));
    c.ok("stepIn", json!({"threadId": 1}));
    c.event("stopped");
    let (file, _, name) = c.top();
    assert_eq!((file.as_str(), name.as_str()), ("common.lua", "hunger"));
    c.ok("stepOut", json!({"threadId": 1}));
    c.event("stopped");
    assert_eq!(c.top(), ("forage.lua".into(), 21, "intend".into()));

    // A conditional breakpoint that never holds, one that holds on its 2nd hit, a logpoint.
    c.set_breakpoints(
        &forage(),
        json!([
            {"line": 23, "condition": "fear > 100"},
            {"line": 24, "condition": "hunger >= 0", "hitCondition": "2"},
            {"line": 20, "logMessage": "dt is {dt}"},
        ]),
    );
    c.ok("continue", json!({"threadId": 1}));
    let stopped = c.event("stopped");
    assert_eq!(stopped["body"]["reason"], "breakpoint");
    assert_eq!(c.top().1, 24);
    assert_eq!(c.evaluate("hunger >= 0", Some(1)), "true");
    assert!(
        c.output_so_far().contains("forage.lua:20: dt is "),
        "{}",
        c.output_so_far()
    );

    // Continue to the end of the test: it passes, the client hears it, shoal exits.
    c.set_breakpoints(&forage(), json!([]));
    c.ok("continue", json!({"threadId": 1}));
    c.event("terminated");
    assert!(c.output_so_far().contains("PASS"), "{}", c.output_so_far());
    let (ok, out) = shoal.finish();
    assert!(ok, "the behaviour test passes under the debugger:\n{out}");
}

#[test]
fn malformed_and_unknown_messages_get_errors_and_disconnect_resumes() {
    let shoal = Shoal::test(FORAGE_TEST, ONE_TEST);
    let mut c = Client::connect(shoal.addr);
    c.send_raw(b"Content-Length: 9\r\n\r\n{not json");
    let r = c.read();
    assert_eq!(
        (r["type"].as_str(), r["success"].as_bool()),
        (Some("response"), Some(false))
    );
    assert!(r["message"].as_str().unwrap().contains("not JSON"), "{r}");
    assert!(c.fails("frobnicate", json!({})).contains("unknown request"));
    let no_path = c.fails("setBreakpoints", json!({"breakpoints": [{"line": 1}]}));
    assert!(no_path.contains("source.path"), "{no_path}");
    assert!(
        c.fails("stackTrace", json!({"threadId": 1}))
            .contains("running")
    );
    // The session lives on.
    c.handshake();
    c.set_breakpoints(&forage(), json!([{"line": 19}]));
    c.ok("configurationDone", json!({}));
    c.event("stopped");
    assert_eq!(c.top().1, 19);
    // Leaving while stopped lets the aquarium run on to the end.
    c.ok("disconnect", json!({}));
    let (ok, out) = shoal.finish();
    assert!(ok, "{out}");
    assert!(out.contains("1 passed"), "{out}");
}

/// `shoal run --dap` on the default scene (its forage fish) in a window: stop, look, go on, and
/// the window presents its frames and says so; the client hears `terminated`.
#[test]
fn shoal_run_dap_stops_in_the_window_and_goes_on() {
    let xvfb = xvfb_common::start(400..700);
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_shoal"));
    cmd.args(["run", "--frames", "20", "--dap", "127.0.0.1:0"])
        .env("DISPLAY", format!(":{}", xvfb.display))
        .env_remove("WAYLAND_DISPLAY");
    let shoal = Shoal::spawn(cmd);
    let mut c = Client::connect(shoal.addr);
    c.handshake();
    c.set_breakpoints(&forage(), json!([{"line": 19}]));
    c.ok("configurationDone", json!({}));
    assert_eq!(c.event("stopped")["body"]["reason"], "breakpoint");
    assert_eq!(c.top(), ("forage.lua".into(), 19, "intend".into()));
    assert_eq!(c.evaluate("fish.behavior", None), "\"forage\"");
    c.set_breakpoints(&forage(), json!([]));
    c.ok("continue", json!({"threadId": 1}));
    c.event("terminated");
    let (ok, out) = shoal.finish();
    assert!(ok, "{out}");
    assert!(out.contains("presented 20 frames"), "{out}");
}

#[test]
fn a_remote_address_is_refused_without_the_flag() {
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .current_dir(repo())
        .args(["test", FORAGE_TEST, "--dap", "0.0.0.0:0"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--dap-allow-remote"), "{err}");
}

/// Every fish's root state, exactly.
fn fingerprint(sim: &Simulation) -> Vec<String> {
    let w = sim.world();
    w.fish_ids()
        .map(|id| format!("{id:?} {:?}", w.fish(id).unwrap().root()))
        .collect()
}

const TICKS: u64 = 150;

fn default_scene(seed: u64) -> Simulation {
    Simulation::from_scene(repo(), Path::new("scripts/scenes/default.lua"), seed).unwrap()
}

/// A breakpoint hit, looked at, stepped and continued from leaves the world exactly as a run
/// without the debugger (several lanes) leaves it; with no breakpoint no decision is hooked.
#[test]
fn continuing_from_a_breakpoint_changes_nothing() {
    let mut plain = default_scene(11);
    for _ in 0..TICKS {
        plain.step();
    }

    let debugger = Debugger::new();
    let addr = server::listen("127.0.0.1:0".parse().unwrap(), &debugger).unwrap();
    let mut sim = default_scene(11);
    sim.attach_debugger(debugger.clone()).unwrap();
    assert_eq!(sim.num_lanes(), 1);
    // No breakpoint: no hook.
    for _ in 0..30 {
        sim.step();
    }
    assert_eq!(debugger.hooked_decisions(), 0);

    let client = std::thread::spawn(move || {
        let mut c = Client::connect(addr);
        c.handshake();
        c.ok("configurationDone", json!({}));
        // Pause stops the next decision that starts, at its first line.
        c.ok("pause", json!({"threadId": 1}));
        assert_eq!(c.event("stopped")["body"]["reason"], "pause");
        c.set_breakpoints(&forage(), json!([{"line": 19}]));
        c.ok("continue", json!({"threadId": 1}));
        assert_eq!(c.event("stopped")["body"]["reason"], "breakpoint");
        let (_, line, _) = c.top();
        assert_eq!(line, 19);
        assert_eq!(c.evaluate("fish.memory ~= nil", Some(1)), "true");
        c.ok("next", json!({"threadId": 1}));
        c.event("stopped");
        c.set_breakpoints(&forage(), json!([]));
        c.ok("continue", json!({"threadId": 1}));
        c
    });
    debugger.wait_for_configuration();
    for _ in 30..TICKS {
        sim.step();
    }
    let c = client.join().unwrap();
    assert!(debugger.hooked_decisions() > 0);
    assert_eq!(fingerprint(&sim), fingerprint(&plain));
    drop(c);

    // Only the fish running the file that holds a breakpoint pay for the hook: of the scene's
    // 37 fish (370 decisions a second), its 4 foragers (40).
    let mut c = Client::connect(addr);
    c.handshake();
    c.set_breakpoints(&forage(), json!([{"line": 19, "condition": "false"}]));
    let before = debugger.hooked_decisions();
    for _ in 0..60 {
        sim.step();
    }
    let hooked = debugger.hooked_decisions() - before;
    assert!(
        (1..=40).contains(&hooked),
        "{hooked} decisions hooked in a second"
    );
}

/// A script error reaches the client's debug console (once), without stopping anything.
#[test]
fn script_errors_are_shown_in_the_debug_console() {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(&repo().join("scripts"), &dir.path().join("scripts"));
    copy_dir(&repo().join("assets"), &dir.path().join("assets"));
    std::fs::write(
        dir.path().join("scripts/behaviors/broken.lua"),
        "local M = {}\nfunction M.tick(fish)\n  error(\"boom\")\nend\nreturn M\n",
    )
    .unwrap();
    let debugger = Debugger::new();
    let addr = server::listen("127.0.0.1:0".parse().unwrap(), &debugger).unwrap();
    let mut sim = Simulation::empty(dir.path(), 1).unwrap();
    sim.attach_debugger(debugger.clone()).unwrap();
    sim.spawn(
        "black_porgy",
        glam::Vec3::new(0.0, 200.0, 0.0),
        0.0,
        0.0,
        None,
        Some("broken"),
    )
    .unwrap();
    let mut c = Client::connect(addr);
    c.handshake();
    c.ok("configurationDone", json!({}));
    debugger.wait_for_configuration();
    for _ in 0..30 {
        sim.step();
    }
    let out = c.event("output");
    assert_eq!(out["body"]["category"], "stderr");
    let text = out["body"]["output"].as_str().unwrap();
    assert!(
        text.contains("broken.lua:3") && text.contains("boom"),
        "{text}"
    );
    // Shown once, not once per decision.
    c.ok("threads", json!({}));
    assert!(!c.output_so_far().contains("boom"), "{}", c.output_so_far());
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}

/// Microsoft's own adapter test client (`@vscode/debugadapter-testsupport`, installed in
/// `tools/` by `npm ci` as the glTF validator is) drives five sessions in a row, alternating
/// `attach` and `launch`: a conditional breakpoint, a logpoint, stack, scopes, locals, evaluate,
/// two `next`s, continue to `terminated`, disconnect. Each completes; every response comes
/// before the events it causes (`tools/dap-session.mjs` checks the order on the wire); the
/// connection is never reset under the client (issue 36).
#[test]
fn microsofts_test_client_completes_five_sessions_in_a_row() {
    let tools = repo().join("tools");
    assert!(
        tools
            .join("node_modules/@vscode/debugadapter-testsupport")
            .is_dir(),
        "the DAP test client is not installed: run `npm ci` in tools/ (needs node and npm)"
    );
    for session in 0..5 {
        let mode = if session % 2 == 0 { "attach" } else { "launch" };
        let shoal = Shoal::test(FORAGE_TEST, ONE_TEST);
        let out = Command::new("node")
            .arg(tools.join("dap-session.mjs"))
            .arg(shoal.addr.port().to_string())
            .arg(mode)
            .arg(forage())
            .output()
            .expect("run node");
        let text = String::from_utf8_lossy(&out.stdout);
        let seen: Value = serde_json::from_str(text.trim()).unwrap_or_else(|e| {
            panic!(
                "session {session}: no report ({e}): {text}\n{}",
                String::from_utf8_lossy(&out.stderr)
            )
        });
        assert_eq!(seen["ok"], true, "session {session} ({mode}): {seen}");
        assert_eq!(seen["stoppedAt"], "forage.lua:19", "{seen}");
        assert_eq!(
            seen["evaluated"], "true",
            "the condition, evaluated: {seen}"
        );
        assert_eq!(
            seen["steps"],
            json!(["step@forage.lua:20", "step@forage.lua:21"]),
            "{seen}"
        );
        assert!(
            seen["logpoint"]
                .as_str()
                .is_some_and(|l| l.starts_with("forage.lua:20: dt is ")),
            "{seen}"
        );
        assert_eq!(seen["passed"], true, "{seen}");
        assert_eq!(seen["socketErrors"], json!([]), "no ECONNRESET: {seen}");
        let (ok, out) = shoal.finish();
        assert!(ok, "session {session}: {out}");
    }
}
