//! The network thread: accepts one DAP client at a time on a TCP port, answers what needs no Lua
//! itself (breakpoints, threads, continue and steps, pause) and forwards the rest to the stopped
//! decision. A message it cannot read gets an error response and the session goes on; a client
//! that leaves lets the aquarium run on, and the next client may connect.

use std::io::BufReader;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use serde_json::{Value, json};

use super::wire::{self, Incoming};
use super::{Breakpoint, DapError, Debugger, HitCondition, RequestError, StepMode, ToPaused, lock};

/// How long a forwarded request waits for the stopped decision (only a hung evaluation takes
/// long; the per-load budget stops those first).
const ANSWER_TIMEOUT: Duration = Duration::from_secs(60);

/// Starts serving `debugger` on `addr` in a thread of its own; returns the address it listens on
/// (the port the system chose, for port 0).
pub fn listen(addr: SocketAddr, debugger: &Arc<Debugger>) -> Result<SocketAddr, DapError> {
    let listener = TcpListener::bind(addr).map_err(|source| DapError::Bind { addr, source })?;
    let local = listener.local_addr()?;
    let d = Arc::clone(debugger);
    std::thread::Builder::new()
        .name("shoal-dap".into())
        .spawn(move || serve(&listener, &d))?;
    Ok(local)
}

fn serve(listener: &TcpListener, d: &Arc<Debugger>) {
    for stream in listener.incoming() {
        let Ok(stream) = stream else {
            continue;
        };
        if let Err(e) = session(d, stream) {
            log::warn!("DAP client: {e}");
        }
        // The client left: the aquarium runs on without breakpoints.
        d.clear();
        *lock(&d.out) = None;
        d.set_configured();
    }
}

/// Whether the session goes on after a message.
#[derive(PartialEq, Eq)]
enum Flow {
    Go,
    Disconnect,
}

fn session(d: &Arc<Debugger>, stream: TcpStream) -> Result<(), DapError> {
    let _ = stream.set_nodelay(true);
    *lock(&d.out) = Some(stream.try_clone()?);
    let mut reader = BufReader::new(stream);
    loop {
        match wire::read_message(&mut reader) {
            Ok(None) => return Ok(()),
            Ok(Some(Incoming::Malformed(e))) => respond(d, 0, "", Err(RequestError::NotJson(e))),
            Ok(Some(Incoming::Message(msg))) => {
                if handle(d, &msg) == Flow::Disconnect {
                    return Ok(());
                }
            }
            Err(DapError::Framing(why)) => {
                respond(d, 0, "", Err(RequestError::Closing(why.clone())));
                return Err(DapError::Framing(why));
            }
            Err(e) => return Err(e),
        }
    }
}

fn respond(d: &Debugger, request_seq: i64, command: &str, result: Result<Value, RequestError>) {
    let mut msg = json!({
        "type": "response",
        "request_seq": request_seq,
        "command": command,
        "success": result.is_ok(),
    });
    match result {
        Ok(Value::Null) => {}
        Ok(body) => msg["body"] = body,
        Err(e) => {
            let why = e.to_string();
            msg["message"] = json!(why);
            msg["body"] = json!({"error": {"id": 1, "format": why, "showUser": true}});
        }
    }
    d.send(msg);
}

/// Answers one message.
fn handle(d: &Arc<Debugger>, msg: &Value) -> Flow {
    let seq = msg["seq"].as_i64().unwrap_or(0);
    let command = match (msg["type"].as_str(), msg["command"].as_str()) {
        (Some("request"), Some(c)) => c,
        _ => {
            respond(
                d,
                seq,
                msg["command"].as_str().unwrap_or(""),
                Err(RequestError::NotARequest),
            );
            return Flow::Go;
        }
    };
    let args = match msg.get("arguments") {
        Some(a) if a.is_object() => a.clone(),
        _ => json!({}),
    };
    let result = match command {
        "initialize" => {
            respond(d, seq, command, Ok(capabilities()));
            d.send_event("initialized", json!({}));
            return Flow::Go;
        }
        "launch" | "attach" => Ok(Value::Null),
        "setBreakpoints" => set_breakpoints(d, &args),
        "setExceptionBreakpoints" => Ok(json!({"breakpoints": []})),
        // The protocol's order: a request's response first, then the events it causes
        // (`stopped`, `terminated`…). Each request that lets the aquarium run answers before
        // it lets go, or its events could overtake the answer and leave the client waiting
        // for it (Microsoft's test client hung so after `next`).
        "configurationDone" => {
            respond(d, seq, command, Ok(Value::Null));
            d.set_configured();
            return Flow::Go;
        }
        "threads" => Ok(json!({"threads": [{"id": 1, "name": "aquarium"}]})),
        "stackTrace" | "scopes" | "variables" | "evaluate" => forward(d, command, args),
        "continue" => {
            respond(d, seq, command, Ok(json!({"allThreadsContinued": true})));
            d.resume(None);
            return Flow::Go;
        }
        "next" | "stepIn" | "stepOut" => {
            let mode = match command {
                "next" => StepMode::Over,
                "stepIn" => StepMode::In,
                _ => StepMode::Out,
            };
            if !d.is_paused() {
                Err(RequestError::NotStopped)
            } else {
                respond(d, seq, command, Ok(Value::Null));
                d.resume(Some(mode));
                return Flow::Go;
            }
        }
        "pause" => {
            respond(d, seq, command, Ok(Value::Null));
            d.request_pause();
            return Flow::Go;
        }
        "disconnect" | "terminate" => {
            respond(d, seq, command, Ok(Value::Null));
            return Flow::Disconnect;
        }
        other => Err(RequestError::Unknown(other.to_owned())),
    };
    respond(d, seq, command, result);
    Flow::Go
}

fn capabilities() -> Value {
    json!({
        "supportsConfigurationDoneRequest": true,
        "supportsConditionalBreakpoints": true,
        "supportsHitConditionalBreakpoints": true,
        "supportsLogPoints": true,
        "supportsEvaluateForHovers": true,
        "supportsTerminateRequest": true,
    })
}

/// Hands a request to the stopped decision and waits for its answer.
fn forward(d: &Debugger, command: &str, args: Value) -> Result<Value, RequestError> {
    if !d.is_paused() {
        return Err(RequestError::Running(command.to_owned()));
    }
    let (reply, answer) = std::sync::mpsc::channel();
    d.to_paused
        .send(ToPaused::Request {
            command: command.to_owned(),
            args,
            reply,
        })
        .map_err(|_| RequestError::Gone)?;
    answer
        .recv_timeout(ANSWER_TIMEOUT)
        .map_err(|_| RequestError::NoAnswer)?
}

/// `setBreakpoints`: replaces a file's breakpoints. Each comes back verified, or not with why
/// (a line past the end, an unreadable hit condition).
fn set_breakpoints(d: &Debugger, args: &Value) -> Result<Value, RequestError> {
    let path = args["source"]["path"]
        .as_str()
        .ok_or(RequestError::NoSourcePath)?;
    let unreadable = |source| RequestError::Source {
        path: path.to_owned(),
        source,
    };
    let real = Path::new(path).canonicalize().map_err(unreadable)?;
    let num_lines = std::fs::read_to_string(&real)
        .map_err(unreadable)?
        .lines()
        .count();
    let requested: Vec<Value> = match &args["breakpoints"] {
        Value::Array(a) => a.clone(),
        _ => match &args["lines"] {
            Value::Array(lines) => lines.iter().map(|l| json!({"line": l})).collect(),
            _ => Vec::new(),
        },
    };
    let text = |v: &Value| {
        v.as_str()
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(str::to_owned)
    };
    let mut checked = Vec::new();
    for b in &requested {
        let line = b["line"].as_u64().unwrap_or(0) as usize;
        let hit = text(&b["hitCondition"]).map(|h| HitCondition::parse(&h));
        let problem = if line == 0 || line > num_lines {
            Some(format!("line {line}: {path} has {num_lines} lines"))
        } else if let Some(Err(why)) = &hit {
            Some(why.to_string())
        } else {
            None
        };
        let bp = Breakpoint {
            id: 0,
            line,
            condition: text(&b["condition"]),
            hit: hit.and_then(Result::ok),
            log: text(&b["logMessage"]),
            hits: 0,
        };
        checked.push((bp, problem));
    }
    let valid: Vec<Breakpoint> = checked
        .iter()
        .filter(|(_, p)| p.is_none())
        .map(|(b, _)| b.clone())
        .collect();
    let mut stored = d.set_breakpoints(real.clone(), valid).into_iter();
    let source = json!({"path": real.display().to_string()});
    let answers: Vec<Value> = checked
        .into_iter()
        .map(|(b, problem)| match problem {
            None => {
                let id = stored.next().map_or(0, |s| s.id);
                json!({"id": id, "verified": true, "line": b.line, "source": source})
            }
            Some(why) => json!({"verified": false, "line": b.line, "message": why}),
        })
        .collect();
    Ok(json!({"breakpoints": answers}))
}
