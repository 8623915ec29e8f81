//! The Debug Adapter Protocol's wire format: `Content-Length: N\r\n\r\n` and N bytes of JSON.

use std::io::{BufRead, Read, Write};

use serde_json::Value;

use super::DapError;

/// The longest message accepted (a client sending more is cut off rather than trusted).
pub const MAX_MESSAGE_BYTES: usize = 16 << 20;

/// The longest header line accepted.
const MAX_HEADER_BYTES: usize = 1024;

/// One message read off the wire.
#[derive(Debug)]
pub enum Incoming {
    /// A JSON value (not yet checked to be a request).
    Message(Value),
    /// A well-framed message whose body is not JSON: answered with an error, the session goes on.
    Malformed(serde_json::Error),
}

/// Reads the next message; `Ok(None)` at the end of the stream. An error means the framing itself
/// is broken (the stream cannot be resynchronised): the caller closes the connection.
pub fn read_message(r: &mut impl BufRead) -> Result<Option<Incoming>, DapError> {
    let mut length: Option<usize> = None;
    let mut line = Vec::new();
    let mut any = false;
    loop {
        line.clear();
        let n = Read::take(&mut *r, MAX_HEADER_BYTES as u64).read_until(b'\n', &mut line)?;
        if n == 0 {
            return if any {
                Err(DapError::Framing("the stream ended inside a header".into()))
            } else {
                Ok(None)
            };
        }
        if !line.ends_with(b"\n") {
            return Err(DapError::Framing(format!(
                "a header line longer than {MAX_HEADER_BYTES} bytes"
            )));
        }
        any = true;
        let text = String::from_utf8_lossy(&line);
        let text = text.trim_end_matches(['\r', '\n']);
        if text.is_empty() {
            break;
        }
        let Some((name, value)) = text.split_once(':') else {
            return Err(DapError::Framing(format!(
                "expected `Content-Length: N`, got `{text}`"
            )));
        };
        if name.trim().eq_ignore_ascii_case("content-length") {
            let n: usize = value.trim().parse().map_err(|_| {
                DapError::Framing(format!("Content-Length `{}` is not a number", value.trim()))
            })?;
            length = Some(n);
        }
    }
    let Some(length) = length else {
        return Err(DapError::Framing("a message without Content-Length".into()));
    };
    if length > MAX_MESSAGE_BYTES {
        return Err(DapError::Framing(format!(
            "a message of {length} bytes (at most {MAX_MESSAGE_BYTES})"
        )));
    }
    let mut body = vec![0; length];
    r.read_exact(&mut body)?;
    Ok(Some(match serde_json::from_slice::<Value>(&body) {
        Ok(v) => Incoming::Message(v),
        Err(e) => Incoming::Malformed(e),
    }))
}

/// Writes one message.
pub fn write_message(w: &mut impl Write, message: &Value) -> std::io::Result<()> {
    let body = message.to_string();
    write!(w, "Content-Length: {}\r\n\r\n", body.len())?;
    w.write_all(body.as_bytes())?;
    w.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(bytes: &[u8]) -> Result<Option<Incoming>, DapError> {
        read_message(&mut std::io::BufReader::new(bytes))
    }

    #[test]
    fn a_framed_message_round_trips() {
        let mut out = Vec::new();
        write_message(&mut out, &serde_json::json!({"seq": 1, "type": "request"})).unwrap();
        let text = String::from_utf8(out.clone()).unwrap();
        let (head, body) = text.split_once("\r\n\r\n").unwrap();
        assert_eq!(head, format!("Content-Length: {}", body.len()));
        let Some(Incoming::Message(v)) = read(&out).unwrap() else {
            panic!("no message");
        };
        assert_eq!(v["seq"], 1);
    }

    #[test]
    fn bad_json_is_malformed_but_bad_framing_is_an_error() {
        assert!(matches!(
            read(b"Content-Length: 3\r\n\r\n{x}").unwrap(),
            Some(Incoming::Malformed(_))
        ));
        assert!(read(b"Content-Length: ten\r\n\r\n").is_err());
        assert!(read(b"hello\r\n\r\n").is_err());
        assert!(read(b"\r\n").is_err());
        assert!(read(b"Content-Length: 99999999999\r\n\r\n").is_err());
        assert!(read(b"").unwrap().is_none());
        // Other headers are allowed and ignored.
        assert!(matches!(
            read(b"Content-Type: x\r\nContent-Length: 2\r\n\r\n{}").unwrap(),
            Some(Incoming::Message(_))
        ));
    }
}
