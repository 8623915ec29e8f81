//! One line per Lua error: [`describe`] turns an mlua error into `file:line: message`, the form
//! the console, the log and every error of this crate show. A module of its own so that the
//! error types (`error.rs`) and the modules whose errors they wrap (`scene.rs`, `logpoints.rs`)
//! both use it without importing each other.

/// Formats an mlua error as one line `file:line: message`, without mlua's wrapping
/// ("runtime error: ", "callback error", tracebacks). Errors raised inside a Rust callback carry
/// no position of their own: the first `scripts/…:line:` frame of the traceback names it.
pub fn describe(err: &mlua::Error) -> String {
    match err {
        mlua::Error::SyntaxError { message, .. } => message.clone(),
        mlua::Error::RuntimeError(m) | mlua::Error::MemoryError(m) => {
            // mlua appends a traceback to errors raised in Lua; the console wants one line.
            m.split("\nstack traceback:").next().unwrap_or(m).to_owned()
        }
        mlua::Error::CallbackError { traceback, cause } => {
            let inner = describe(cause);
            if has_location(&inner) {
                return inner;
            }
            match script_frame(traceback) {
                Some(loc) => format!("{loc}: {inner}"),
                None => inner,
            }
        }
        mlua::Error::WithContext { context, cause } => format!("{context}: {}", describe(cause)),
        mlua::Error::BadArgument { to, pos, cause, .. } => {
            let f = to.as_deref().unwrap_or("function");
            format!("bad argument #{pos} to '{f}': {}", describe(cause))
        }
        other => other.to_string(),
    }
}

/// True when `msg` starts with `something.lua:NUMBER:`.
pub(crate) fn has_location(msg: &str) -> bool {
    let Some(i) = msg.find(".lua:") else {
        return false;
    };
    if msg[..i].contains(' ') {
        return false;
    }
    let rest = &msg[i + 5..];
    let digits = rest.bytes().take_while(u8::is_ascii_digit).count();
    digits > 0 && rest[digits..].starts_with(':')
}

/// The first `file.lua:line` frame of a Lua traceback.
fn script_frame(traceback: &str) -> Option<&str> {
    traceback.lines().map(str::trim).find_map(|l| {
        let end = l.find(".lua:")? + 5;
        let digits = l[end..].bytes().take_while(u8::is_ascii_digit).count();
        (digits > 0).then(|| &l[..end + digits])
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn location_detection() {
        assert!(has_location("scripts/a.lua:3: boom"));
        assert!(!has_location("bad argument #1: x.lua:3: y"));
        assert!(!has_location("nothing here"));
        let tb = "stack traceback:\n\t[C]: in function 'shoal.swim'\n\tscripts/behaviors/x.lua:7: in function 'behave'";
        assert_eq!(script_frame(tb), Some("scripts/behaviors/x.lua:7"));
    }
}
