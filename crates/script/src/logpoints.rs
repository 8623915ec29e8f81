//! Logpoints (issue 17): `file:line` plus a message with `{expressions}`, printed to the console
//! each time a fish's decision reaches that line, without pausing.
//!
//! No debug hook is involved: a file that holds logpoints is reloaded with a call injected at the
//! start of each logpoint's line (`do __shoal_logpoint("hunger ", (fish.memory.hunger)) end …`), so
//! the expressions see the line's locals and upvalues, the line numbers stay the same, and only
//! fish running that file pay anything. A logpoint on a line that does not start a statement (the
//! middle of a table or of a long expression) is refused, naming the line.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use mlua::{Lua, Table, Value};

/// The global the injected calls use.
pub const LOGPOINT_FN: &str = "__shoal_logpoint";

/// One logpoint.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Logpoint {
    /// 1-based line.
    pub line: usize,
    /// The message: text with `{expressions}` evaluated where the line runs.
    pub message: String,
}

/// The logpoints of each file (canonical path), kept as a Lua state's app data.
#[derive(Debug, Default, Clone)]
pub struct Logpoints(pub HashMap<PathBuf, Vec<Logpoint>>);

/// Why logpoints cannot be put into a file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LogpointError {
    /// A `{` in the message has no `}` after it.
    #[error("`{message}`: a `{{` without its `}}`")]
    Unclosed {
        /// The message.
        message: String,
    },
    /// A `{}` with no expression in it.
    #[error("`{message}`: an empty `{{}}`")]
    EmptyExpression {
        /// The message.
        message: String,
    },
    /// The logpoint's line is not in the file.
    #[error("line {line}: the file has {lines} lines")]
    PastEnd {
        /// The logpoint's line.
        line: usize,
        /// The file's lines.
        lines: usize,
    },
    /// The file is not text, so nothing can be injected into it.
    #[error("not UTF-8 text")]
    NotUtf8,
}

/// Why a file's logpoints were not set (see [`crate::Simulation::set_logpoints`]); the file keeps
/// the ones it had. Each names the file.
#[derive(Debug, thiserror::Error)]
pub enum SetLogpointsError {
    /// No such file under the scripts directory.
    #[error("{file}: no such script under {}", dir.display())]
    NoSuchScript {
        /// The file as given.
        file: String,
        /// The scripts directory.
        dir: PathBuf,
    },
    /// The file resolves outside the scripts directory.
    #[error("{file}: not inside the scripts directory")]
    OutsideScripts {
        /// The file as given.
        file: String,
    },
    /// The file could not be read.
    #[error("{file}: {source}")]
    Read {
        /// The file as shown (`scripts/behaviors/forage.lua`).
        file: String,
        /// Why.
        source: std::io::Error,
    },
    /// A logpoint's line or message is wrong.
    #[error("{file}: {source}")]
    Logpoint {
        /// The file as shown.
        file: String,
        /// What is wrong.
        source: LogpointError,
    },
    /// The file compiles, but not with the logpoints in it: one sits inside a statement.
    #[error(
        "{file}: a logpoint must sit on a line where a statement starts (line {} continues one, \
         or its message is not Lua)",
        lines.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")
    )]
    NotAStatement {
        /// The file as shown.
        file: String,
        /// The lines of the file's logpoints.
        lines: Vec<usize>,
    },
}

/// The message as Lua call arguments: literal text as strings, `{expr}` as `(expr)`.
fn message_args(message: &str) -> Result<String, LogpointError> {
    let mut args = Vec::new();
    let mut rest = message;
    while let Some(open) = rest.find('{') {
        if open > 0 {
            args.push(format!("{:?}", &rest[..open]));
        }
        let after = &rest[open + 1..];
        let close = after.find('}').ok_or_else(|| LogpointError::Unclosed {
            message: message.to_owned(),
        })?;
        let expr = after[..close].trim();
        if expr.is_empty() {
            return Err(LogpointError::EmptyExpression {
                message: message.to_owned(),
            });
        }
        // Each expression is a closure (it still sees the line's locals and upvalues) followed
        // by its text, so that one that fails fails inside the logpoint, not in the behaviour.
        args.push(format!("function() return ({expr}) end, {expr:?}"));
        rest = &after[close + 1..];
    }
    if !rest.is_empty() || args.is_empty() {
        args.push(format!("{rest:?}"));
    }
    Ok(args.join(", "))
}

/// `source` with each logpoint's call put at the start of its line.
pub fn inject(source: &str, points: &[Logpoint]) -> Result<String, LogpointError> {
    let lines: Vec<&str> = source.split('\n').collect();
    let mut by_line: HashMap<usize, Vec<&Logpoint>> = HashMap::new();
    for p in points {
        if p.line == 0 || p.line > lines.len() {
            return Err(LogpointError::PastEnd {
                line: p.line,
                lines: lines.len(),
            });
        }
        by_line.entry(p.line).or_default().push(p);
    }
    let mut out = String::with_capacity(source.len() + 64 * points.len());
    for (i, line) in lines.iter().enumerate() {
        if i > 0 {
            out.push('\n');
        }
        for p in by_line.get(&(i + 1)).into_iter().flatten() {
            // `do … end` is a statement only: inside a table constructor or an expression it
            // does not compile, so a misplaced logpoint is refused instead of becoming data.
            out.push_str(&format!(
                "do {LOGPOINT_FN}({}) end ",
                message_args(&p.message)?
            ));
        }
        out.push_str(line);
    }
    Ok(out)
}

/// The source to compile for `path`: the file as it is, or with its logpoints injected. The
/// error names the logpoint's line when the injection does not compile.
pub fn source_for(lua: &Lua, path: &Path, source: Vec<u8>) -> Result<Vec<u8>, LogpointError> {
    let real = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    let points = match lua.app_data_ref::<Logpoints>() {
        Some(lp) => match lp.0.get(&real) {
            Some(p) if !p.is_empty() => p.clone(),
            _ => return Ok(source),
        },
        None => return Ok(source),
    };
    let text = String::from_utf8(source).map_err(|_| LogpointError::NotUtf8)?;
    Ok(inject(&text, &points)?.into_bytes())
}

/// Installs the function the injected calls use: into the console, with the line's file:line,
/// the deciding fish and the time. An expression that fails is the logpoint's failure, not the
/// behaviour's: the logpoint prints nothing that time, and the console shows one warning for it
/// (`file:line: logpoint {m.rock[1]} failed: …`, kept once however often it fails); the
/// behaviour runs on and no error is counted against it.
pub fn install(lua: &Lua, globals: &Table) -> mlua::Result<()> {
    globals.set(
        LOGPOINT_FN,
        lua.create_function(|lua, args: mlua::Variadic<Value>| {
            let location = crate::budget::caller_location(lua);
            let mut text = format!("{location} logpoint: ");
            let mut args = args.iter();
            while let Some(v) = args.next() {
                let v = match v {
                    Value::Function(expr) => {
                        let source = args
                            .next()
                            .and_then(|s| s.to_string().ok())
                            .unwrap_or_default();
                        match expr.call::<Value>(()) {
                            Ok(v) => v,
                            Err(e) => {
                                logpoint_failed(lua, &location, &source, &e);
                                return Ok(());
                            }
                        }
                    }
                    other => other.clone(),
                };
                text.push_str(&v.to_string().unwrap_or_else(|_| format!("{v:?}")));
            }
            console_line(lua, &text);
            Ok(())
        })?,
    )
}

/// The console's warning for a logpoint whose `{source}` failed (deduplicated by the log).
fn logpoint_failed(lua: &Lua, location: &str, source: &str, err: &mlua::Error) {
    let why = crate::lua_error::describe(err);
    // The error's own position is the logpoint's line, already named in front.
    let why = why
        .strip_prefix(location)
        .map_or(why.as_str(), str::trim_start);
    let text = format!(
        "{location} logpoint {{{source}}} failed: {why} (the logpoint prints nothing while it \
         fails; the behaviour is not affected)"
    );
    let (fish, time_s) = lua
        .app_data_ref::<crate::api::Ctx>()
        .map_or((None, 0.0), |c| {
            (c.fish, c.world.as_ref().map_or(0.0, |w| w.time()))
        });
    if let Some(mut log) = lua.app_data_mut::<crate::log::ScriptLog>() {
        log.push(crate::log::LogLevel::Warning, &text, fish, time_s);
    }
}

/// Puts `text` in the script console as a print, with the deciding fish and the world's time
/// when a behaviour stage is running (`print` and logpoints).
pub fn console_line(lua: &Lua, text: &str) {
    let (fish, time_s) = lua
        .app_data_ref::<crate::api::Ctx>()
        .map_or((None, 0.0), |c| {
            (c.fish, c.world.as_ref().map_or(0.0, |w| w.time()))
        });
    if let Some(mut log) = lua.app_data_mut::<crate::log::ScriptLog>() {
        log.push(crate::log::LogLevel::Info, text, fish, time_s);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_message_becomes_text_and_expressions() {
        assert_eq!(
            message_args("hunger {m.hunger} at {fish.id}").unwrap(),
            r#""hunger ", function() return (m.hunger) end, "m.hunger", " at ", function() return (fish.id) end, "fish.id""#
        );
        assert_eq!(message_args("plain").unwrap(), r#""plain""#);
        assert_eq!(
            message_args("{x}").unwrap(),
            r#"function() return (x) end, "x""#
        );
        assert!(message_args("open {x").is_err());
        assert!(message_args("empty {}").is_err());
        // Quotes and backslashes stay text.
        assert_eq!(
            message_args(r#"say "hi" \ "#).unwrap(),
            r#""say \"hi\" \\ ""#
        );
    }

    #[test]
    fn the_call_goes_at_the_start_of_its_line_and_lines_keep_their_numbers() {
        let src = "local a = 1\nlocal b = a + 1\nreturn b";
        let out = inject(
            src,
            &[Logpoint {
                line: 2,
                message: "a is {a}".into(),
            }],
        )
        .unwrap();
        assert_eq!(
            out,
            "local a = 1\ndo __shoal_logpoint(\"a is \", function() return (a) end, \"a\") end local b = a + 1\nreturn b"
        );
        assert!(
            inject(
                src,
                &[Logpoint {
                    line: 9,
                    message: "x".into()
                }]
            )
            .is_err()
        );
    }
}
