//! The string functions that can run long inside C, replaced by bounded ones.
//!
//! The instruction budget and the time limit are checked between VM instructions; a C function
//! that runs for seconds cannot be stopped. Lua's pattern matcher backtracks: `("a"):rep(2e5)
//! :find(("a-"):rep(30) .. "b")` never returns. So `string.find`, `match`, `gmatch` and `gsub`
//! run here instead, on a translation of the Lua pattern to the `regex` crate, whose matching
//! time is linear in the subject (it never backtracks) and which picks the same match a
//! backtracking matcher would (leftmost, then by the order of preference of `*`, `-`, `?`).
//! `gsub` and `gmatch` look at the call's time limit between matches.
//!
//! Three pattern items have no regular-expression equivalent: the balance `%bxy`, the frontier
//! `%f[set]` and back-references `%1`–`%9`. Patterns with them (and malformed ones, so that the
//! error is Lua's own) run on Lua's matcher, but only where a bound on its work is small:
//! (subject length + 1) to the power of (quantifiers + balances + back-references + 1) at most
//! [`FALLBACK_STEPS`]; anything larger is refused with an error naming the line.
//!
//! `string.rep` copies once per repetition in C (a byte at a time for `("x"):rep(2e8)`, some
//! 0.4 s, and forever for `(""):rep(1e18)`): it is done here by doubling, a few milliseconds per
//! hundred megabytes, with strings longer than the memory limit refused before any work.
//! `string.pack` pads `c<n>` items byte by byte: at most [`MAX_PACKED`] bytes of them. The other
//! string functions do work proportional to the strings they make, which the memory limit
//! bounds.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use mlua::{Function, Lua, LuaString, MultiValue, Table, Value};
use regex::bytes::{Captures, Regex, RegexBuilder};

use super::budget::{Abort, Budget, caller_location, time_message};

/// Largest bound on the work of Lua's own matcher the sandbox lets it run (about 10 ms).
pub const FALLBACK_STEPS: f64 = 1e7;

/// Most bytes of fixed-size strings (`c<n>`) one `string.pack` may write.
pub const MAX_PACKED: u64 = 1 << 24;

/// Compiled patterns kept per state (cleared when full).
const CACHE_SIZE: usize = 128;

/// Matches between two looks at the time limit in `gsub` and `gmatch`.
const POLL: u32 = 64;

/// Captures Lua allows in one pattern.
const MAX_CAPTURES: usize = 32;

/// Size limit of one compiled pattern (the `regex` crate's).
const REGEX_SIZE: usize = 4 << 20;

/// A Lua pattern, ready to run.
enum Pattern {
    /// Translated: `anchored` for a leading `^`, `positions[i]` for a position capture `()`.
    Regex {
        re: Regex,
        anchored: bool,
        positions: Vec<bool>,
    },
    /// For Lua's matcher: the number of items that multiply its work.
    Lua { factors: i32 },
}

/// Compiled patterns by (pattern, whether a leading `^` anchors).
type PatternCache = HashMap<(Vec<u8>, bool), Arc<Pattern>>;

/// What the bounded functions share: the state's budget, the original C functions and the
/// compiled patterns.
struct Strings {
    budget: Arc<Budget>,
    /// Longest string `gsub` may build (the state's memory limit).
    max_len: usize,
    c_find: Function,
    c_match: Function,
    c_gmatch: Function,
    c_gsub: Function,
    cache: Mutex<PatternCache>,
}

fn rt(msg: impl Into<String>) -> mlua::Error {
    mlua::Error::RuntimeError(msg.into())
}

impl Strings {
    /// The pattern `pat` compiled (cached); `anchor`: a leading `^` anchors (not in `gmatch`).
    fn pattern(&self, name: &str, pat: &[u8], anchor: bool) -> mlua::Result<Arc<Pattern>> {
        let key = (pat.to_vec(), anchor);
        if let Some(p) = self.cache.lock().ok().and_then(|c| c.get(&key).cloned()) {
            return Ok(p);
        }
        let p = Arc::new(match translate(pat, anchor) {
            Translated::Regex {
                source,
                anchored,
                positions,
            } => {
                let re = RegexBuilder::new(&source)
                    .size_limit(REGEX_SIZE)
                    .build()
                    .map_err(|e| rt(format!("string.{name}: pattern too large ({e})")))?;
                Pattern::Regex {
                    re,
                    anchored,
                    positions,
                }
            }
            Translated::Lua { factors } => Pattern::Lua { factors },
        });
        if let Ok(mut c) = self.cache.lock() {
            if c.len() >= CACHE_SIZE {
                c.clear();
            }
            c.insert(key, p.clone());
        }
        Ok(p)
    }

    /// Stops the call if it ran past its time limit.
    fn check_time(&self, lua: &Lua) -> mlua::Result<()> {
        if self.budget.time_expired() {
            let loc = caller_location(lua);
            return Err(self.budget.stop(
                Abort::Time,
                format!("{loc} {}", time_message(self.budget.time_limit())),
            ));
        }
        Ok(())
    }

    /// Refuses a pattern for Lua's matcher whose work could be large.
    fn check_fallback(&self, name: &str, factors: i32, len: usize) -> mlua::Result<()> {
        let bound = (len as f64 + 1.0).powi(factors + 1);
        if bound <= FALLBACK_STEPS {
            return Ok(());
        }
        Err(rt(format!(
            "string.{name}: pattern too complex for a subject of {len} bytes (%b, %f and back-references run on Lua's matcher, which the sandbox allows only where its work is small)"
        )))
    }
}

/// The outcome of translating a Lua pattern.
enum Translated {
    Regex {
        source: String,
        anchored: bool,
        positions: Vec<bool>,
    },
    Lua {
        factors: i32,
    },
}

/// The regular-expression class of the Lua class letter `c` (`%a` …), if it is one.
fn class(c: u8) -> Option<String> {
    let set = match c.to_ascii_lowercase() {
        b'a' => r"A-Za-z",
        b'c' => r"\x00-\x1F\x7F",
        b'd' => r"0-9",
        b'g' => r"\x21-\x7E",
        b'l' => r"a-z",
        b'p' => r"\x21-\x2F\x3A-\x40\x5B-\x60\x7B-\x7E",
        b's' => r"\t\n\x0B\x0C\r ",
        b'u' => r"A-Z",
        b'w' => r"0-9A-Za-z",
        b'x' => r"0-9A-Fa-f",
        // Deprecated in Lua 5.2, still in 5.4: the zero byte.
        b'z' => r"\x00",
        _ => return None,
    };
    let neg = if c.is_ascii_uppercase() { "^" } else { "" };
    Some(format!("[{neg}{set}]"))
}

fn literal(c: u8) -> String {
    format!(r"\x{c:02X}")
}

/// Translates Lua pattern `p` (see the Lua manual, §6.4.1) to the `regex` crate's syntax, or
/// says it needs Lua's matcher.
fn translate(p: &[u8], anchor: bool) -> Translated {
    let mut factors = 0i32;
    let mut out = String::from("(?s-u)");
    let mut i = 0;
    let anchored = anchor && p.first() == Some(&b'^');
    if anchored {
        out.push_str(r"\A");
        i = 1;
    }
    let mut positions = Vec::new();
    let mut open = 0usize;
    let mut lua = false;
    while i < p.len() {
        match p[i] {
            b'(' if p.get(i + 1) == Some(&b')') => {
                positions.push(true);
                out.push_str("()");
                i += 2;
                continue;
            }
            b'(' => {
                positions.push(false);
                open += 1;
                out.push('(');
                i += 1;
                continue;
            }
            b')' => {
                if open == 0 {
                    lua = true;
                }
                open = open.saturating_sub(1);
                out.push(')');
                i += 1;
                continue;
            }
            b'$' if i + 1 == p.len() => {
                out.push_str(r"\z");
                i += 1;
                continue;
            }
            b'%' => match p.get(i + 1) {
                None => {
                    lua = true;
                    break;
                }
                Some(b'b') => {
                    lua = true;
                    factors += 1;
                    i += 4;
                    continue;
                }
                Some(b'f') => {
                    lua = true;
                    i += 2;
                    continue;
                }
                Some(d) if d.is_ascii_digit() => {
                    lua = true;
                    factors += 1;
                    i += 2;
                    continue;
                }
                _ => {}
            },
            _ => {}
        }
        // A single-character class, then perhaps a quantifier.
        let item = match p[i] {
            b'%' => {
                let c = p[i + 1];
                i += 2;
                class(c).unwrap_or_else(|| literal(c))
            }
            b'[' => match set(p, i) {
                Some((s, next)) => {
                    i = next;
                    s
                }
                None => {
                    lua = true;
                    break;
                }
            },
            b'.' => {
                i += 1;
                ".".to_owned()
            }
            c => {
                i += 1;
                literal(c)
            }
        };
        out.push_str(&item);
        match p.get(i) {
            Some(b'*') => out.push('*'),
            Some(b'+') => out.push('+'),
            Some(b'-') => out.push_str("*?"),
            Some(b'?') => out.push('?'),
            _ => continue,
        }
        factors += 1;
        i += 1;
    }
    if lua || open != 0 || positions.len() > MAX_CAPTURES {
        // Count what is left for the bound on Lua's matcher.
        factors += p[i.min(p.len())..]
            .iter()
            .filter(|&&c| matches!(c, b'*' | b'+' | b'-' | b'?'))
            .count() as i32;
        return Translated::Lua { factors };
    }
    Translated::Regex {
        source: out,
        anchored,
        positions,
    }
}

/// The set `[...]` starting at `p[start]` as a regular-expression class, and the index after
/// its `]`; `None` if it is malformed.
fn set(p: &[u8], start: usize) -> Option<(String, usize)> {
    let mut i = start + 1;
    let neg = p.get(i) == Some(&b'^');
    if neg {
        i += 1;
    }
    let first = i;
    // The closing `]`: the first character (after a `^`) never closes the set, nor does an
    // escaped one.
    loop {
        let c = *p.get(i)?;
        i += 1;
        if c == b'%' && i < p.len() {
            i += 1;
        }
        if p.get(i) == Some(&b']') {
            break;
        }
    }
    let end = i;
    let mut items = String::new();
    let mut j = first;
    while j < end {
        if p[j] == b'%' && j + 1 < end {
            let c = p[j + 1];
            items.push_str(&class(c).unwrap_or_else(|| literal(c)));
            j += 2;
        } else if p.get(j + 1) == Some(&b'-') && j + 2 < end {
            let (lo, hi) = (p[j], p[j + 2]);
            if lo <= hi {
                items.push_str(&format!("{}-{}", literal(lo), literal(hi)));
            }
            j += 3;
        } else {
            items.push_str(&literal(p[j]));
            j += 1;
        }
    }
    let class = match (items.is_empty(), neg) {
        (true, false) => r"[^\x00-\xFF]".to_owned(),
        (true, true) => r"[\x00-\xFF]".to_owned(),
        (false, n) => format!("[{}{items}]", if n { "^" } else { "" }),
    };
    Some((class, end + 1))
}

/// Lua's `posrelat` for a start position: 1-based, negative from the end, clamped to 1.
fn start_index(init: Option<i64>, len: usize) -> usize {
    let len_i = i64::try_from(len).unwrap_or(i64::MAX);
    let pos = match init.unwrap_or(1) {
        p if p > 0 => p,
        0 => 1,
        p if p < -len_i => 1,
        p => len_i + p + 1,
    };
    usize::try_from(pos - 1).unwrap_or(usize::MAX)
}

/// The captures of a match at `offset` in the subject, as Lua returns them: strings, or
/// positions for `()`; the whole match if the pattern has none.
fn capture_values(
    lua: &Lua,
    caps: &Captures<'_>,
    positions: &[bool],
    offset: usize,
    whole_if_none: bool,
) -> mlua::Result<Vec<Value>> {
    let mut out = Vec::with_capacity(positions.len().max(1));
    if positions.is_empty() {
        if whole_if_none {
            out.push(Value::String(lua.create_string(&caps[0])?));
        }
        return Ok(out);
    }
    for (k, &pos) in positions.iter().enumerate() {
        let v = match caps.get(k + 1) {
            Some(m) if pos => Value::Integer((offset + m.start() + 1) as i64),
            Some(m) => Value::String(lua.create_string(m.as_bytes())?),
            None => Value::Nil,
        };
        out.push(v);
    }
    Ok(out)
}

/// No character of `p` is special (the `plain` search applies).
fn no_specials(p: &[u8]) -> bool {
    !p.iter().any(|c| b"^$*+?.([%-".contains(c))
}

fn find_or_match(
    lua: &Lua,
    st: &Strings,
    find: bool,
    args: MultiValue,
) -> mlua::Result<MultiValue> {
    st.check_time(lua)?;
    let name = if find { "find" } else { "match" };
    let mut it = args.clone().into_iter();
    let s: LuaString = lua.unpack(it.next().unwrap_or(Value::Nil))?;
    let pat: LuaString = lua.unpack(it.next().unwrap_or(Value::Nil))?;
    let init: Option<i64> = lua.unpack(it.next().unwrap_or(Value::Nil))?;
    let plain = it
        .next()
        .is_some_and(|v| v.as_boolean() != Some(false) && !v.is_nil());
    let (sb, pb) = (s.as_bytes(), pat.as_bytes());
    let init = start_index(init, sb.len());
    if init > sb.len() {
        return Ok(MultiValue::from_vec(vec![Value::Nil]));
    }
    if find && (plain || no_specials(&pb)) {
        return Ok(MultiValue::from_vec(
            match memchr::memmem::find(&sb[init..], &pb) {
                Some(at) => vec![
                    Value::Integer((init + at + 1) as i64),
                    Value::Integer((init + at + pb.len()) as i64),
                ],
                None => vec![Value::Nil],
            },
        ));
    }
    match &*st.pattern(name, &pb, true)? {
        Pattern::Lua { factors } => {
            st.check_fallback(name, *factors, sb.len() - init)?;
            let c = if find { &st.c_find } else { &st.c_match };
            c.call(args)
        }
        Pattern::Regex { re, positions, .. } => {
            let Some(caps) = re.captures(&sb[init..]) else {
                return Ok(MultiValue::from_vec(vec![Value::Nil]));
            };
            let whole = caps.get(0).map(|m| (m.start(), m.end())).unwrap_or((0, 0));
            let mut out = Vec::new();
            if find {
                out.push(Value::Integer((init + whole.0 + 1) as i64));
                out.push(Value::Integer((init + whole.1) as i64));
            }
            out.extend(capture_values(lua, &caps, positions, init, !find)?);
            Ok(MultiValue::from_vec(out))
        }
    }
}

fn gmatch(lua: &Lua, st: &Arc<Strings>, args: MultiValue) -> mlua::Result<Value> {
    st.check_time(lua)?;
    let mut it = args.clone().into_iter();
    let s: LuaString = lua.unpack(it.next().unwrap_or(Value::Nil))?;
    let pat: LuaString = lua.unpack(it.next().unwrap_or(Value::Nil))?;
    let init: Option<i64> = lua.unpack(it.next().unwrap_or(Value::Nil))?;
    let len = s.as_bytes().len();
    let pattern = st.pattern("gmatch", &pat.as_bytes(), false)?;
    if let Pattern::Lua { factors } = &*pattern {
        st.check_fallback("gmatch", *factors, len)?;
        return st.c_gmatch.call(args);
    }
    let start = start_index(init, len);
    // Position of the next search and end of the last match (an empty match there is skipped).
    let state = Mutex::new((start, None::<usize>));
    let st = st.clone();
    let iter = lua.create_function(move |lua, ()| {
        st.check_time(lua)?;
        let Pattern::Regex { re, positions, .. } = &*pattern else {
            return Ok(MultiValue::new());
        };
        let sb = s.as_bytes();
        let mut guard = state
            .lock()
            .map_err(|_| rt("string.gmatch: iterator poisoned"))?;
        let (pos, last) = &mut *guard;
        let mut looks = 0u32;
        while *pos <= sb.len() {
            looks += 1;
            if looks.is_multiple_of(POLL) {
                st.check_time(lua)?;
            }
            let Some(caps) = re.captures(&sb[*pos..]) else {
                *pos = sb.len() + 1;
                break;
            };
            let m = caps.get(0).map(|m| (m.start(), m.end())).unwrap_or((0, 0));
            let (ms, me) = (*pos + m.0, *pos + m.1);
            if ms == me && *last == Some(me) {
                *pos = ms + 1;
                continue;
            }
            let offset = *pos;
            *pos = me;
            *last = Some(me);
            return Ok(MultiValue::from_vec(capture_values(
                lua, &caps, positions, offset, true,
            )?));
        }
        Ok(MultiValue::new())
    })?;
    Ok(Value::Function(iter))
}

/// Appends the replacement of one match to `out` (Lua's `add_value`).
fn add_value(
    lua: &Lua,
    out: &mut Vec<u8>,
    repl: &Value,
    caps: &Captures<'_>,
    positions: &[bool],
    offset: usize,
) -> mlua::Result<()> {
    let whole = caps.get(0).map(|m| m.as_bytes()).unwrap_or_default();
    let value = match repl {
        Value::String(r) => {
            let r = r.as_bytes();
            let mut k = 0;
            while k < r.len() {
                let c = r[k];
                k += 1;
                if c != b'%' {
                    out.push(c);
                    continue;
                }
                let Some(&d) = r.get(k) else {
                    return Err(rt("invalid use of '%' in replacement string"));
                };
                k += 1;
                if d == b'%' {
                    out.push(b'%');
                } else if d.is_ascii_digit() {
                    let n = usize::from(d - b'0');
                    if n == 0 || (n == 1 && positions.is_empty()) {
                        out.extend_from_slice(whole);
                    } else if n <= positions.len() {
                        match caps.get(n) {
                            Some(m) if positions[n - 1] => out
                                .extend_from_slice((offset + m.start() + 1).to_string().as_bytes()),
                            Some(m) => out.extend_from_slice(m.as_bytes()),
                            None => {}
                        }
                    } else {
                        return Err(rt(format!(
                            "invalid capture index %{n} in replacement string"
                        )));
                    }
                } else {
                    return Err(rt("invalid use of '%' in replacement string"));
                }
            }
            return Ok(());
        }
        Value::Integer(_) | Value::Number(_) => {
            let s: LuaString = lua.unpack(repl.clone())?;
            out.extend_from_slice(&s.as_bytes());
            return Ok(());
        }
        Value::Table(t) => {
            let key = capture_values(lua, caps, positions, offset, true)?
                .into_iter()
                .next()
                .unwrap_or(Value::Nil);
            t.get::<Value>(key)?
        }
        Value::Function(f) => {
            let args = capture_values(lua, caps, positions, offset, true)?;
            f.call::<Value>(MultiValue::from_vec(args))?
        }
        other => {
            return Err(rt(format!(
                "bad argument #3 to 'gsub' (string/function/table expected, got {})",
                other.type_name()
            )));
        }
    };
    match value {
        Value::Nil | Value::Boolean(false) => out.extend_from_slice(whole),
        Value::String(s) => out.extend_from_slice(&s.as_bytes()),
        v @ (Value::Integer(_) | Value::Number(_)) => {
            let s: LuaString = lua.unpack(v)?;
            out.extend_from_slice(&s.as_bytes());
        }
        other => {
            return Err(rt(format!(
                "invalid replacement value (a {})",
                other.type_name()
            )));
        }
    }
    Ok(())
}

fn gsub(lua: &Lua, st: &Strings, args: MultiValue) -> mlua::Result<(LuaString, i64)> {
    st.check_time(lua)?;
    let mut it = args.clone().into_iter();
    let s: LuaString = lua.unpack(it.next().unwrap_or(Value::Nil))?;
    let pat: LuaString = lua.unpack(it.next().unwrap_or(Value::Nil))?;
    let repl = it.next().unwrap_or(Value::Nil);
    let max_n: Option<i64> = lua.unpack(it.next().unwrap_or(Value::Nil))?;
    let sb = s.as_bytes();
    let pattern = st.pattern("gsub", &pat.as_bytes(), true)?;
    let (re, anchored, positions) = match &*pattern {
        Pattern::Lua { factors } => {
            st.check_fallback("gsub", *factors, sb.len())?;
            return st.c_gsub.call(args);
        }
        Pattern::Regex {
            re,
            anchored,
            positions,
        } => (re, *anchored, positions),
    };
    if !matches!(
        repl,
        Value::String(_)
            | Value::Integer(_)
            | Value::Number(_)
            | Value::Table(_)
            | Value::Function(_)
    ) {
        return Err(rt(format!(
            "bad argument #3 to 'gsub' (string/function/table expected, got {})",
            repl.type_name()
        )));
    }
    let max_n = max_n.unwrap_or(i64::MAX);
    let mut out = Vec::with_capacity(sb.len());
    let (mut src, mut last, mut n) = (0usize, None::<usize>, 0i64);
    while n < max_n && src <= sb.len() {
        if (n as u32).is_multiple_of(POLL) {
            st.check_time(lua)?;
        }
        let Some(caps) = re.captures(&sb[src..]) else {
            break;
        };
        let m = caps.get(0).map(|m| (m.start(), m.end())).unwrap_or((0, 0));
        let (ms, me) = (src + m.0, src + m.1);
        if ms == me && last == Some(me) {
            // An empty match where the last one ended: Lua copies one character and goes on.
            if ms < sb.len() {
                out.extend_from_slice(&sb[src..=ms]);
                src = ms + 1;
            } else {
                out.extend_from_slice(&sb[src..ms]);
                src = ms;
                break;
            }
        } else {
            out.extend_from_slice(&sb[src..ms]);
            add_value(lua, &mut out, &repl, &caps, positions, src)?;
            n += 1;
            src = me;
            last = Some(me);
        }
        if out.len() > st.max_len {
            return Err(rt("string.gsub: resulting string too large"));
        }
        if anchored {
            break;
        }
    }
    out.extend_from_slice(&sb[src.min(sb.len())..]);
    Ok((lua.create_string(&out)?, n))
}

/// The bytes the `c<n>` items of a `string.pack` format ask for, in all.
fn fixed_string_bytes(fmt: &[u8]) -> u64 {
    let mut total = 0u64;
    let mut i = 0;
    while i < fmt.len() {
        if fmt[i] == b'c' {
            let mut n = 0u64;
            i += 1;
            while let Some(d) = fmt.get(i).filter(|d| d.is_ascii_digit()) {
                n = n.saturating_mul(10).saturating_add(u64::from(d - b'0'));
                i += 1;
            }
            total = total.saturating_add(n);
        } else {
            i += 1;
        }
    }
    total
}

/// `string.rep`: Lua's copies the string once per repetition in C (a byte at a time for a
/// one-byte string, and forever for an empty one); this one doubles what it has built.
fn rep(lua: &Lua, st: &Strings, s: &[u8], n: i64, sep: Option<&[u8]>) -> mlua::Result<LuaString> {
    st.check_time(lua)?;
    let sep = sep.unwrap_or_default();
    if n <= 0 || (s.is_empty() && sep.is_empty()) {
        return lua.create_string("");
    }
    let n = usize::try_from(n).map_err(|_| rt("resulting string too large"))?;
    let unit = s.len() + sep.len();
    let total = unit
        .checked_mul(n)
        .map(|t| t - sep.len())
        .ok_or_else(|| rt("resulting string too large"))?;
    if total > st.max_len {
        return Err(mlua::Error::MemoryError("not enough memory".into()));
    }
    let mut one = Vec::with_capacity(unit);
    one.extend_from_slice(s);
    one.extend_from_slice(sep);
    let mut out = one.repeat(n);
    out.truncate(total);
    lua.create_string(&out)
}

/// Replaces the long-running functions of the state's `string` table (which is also the
/// `__index` of the string metatable) by bounded ones.
pub fn install(
    lua: &Lua,
    string: &Table,
    budget: Arc<Budget>,
    memory_bytes: usize,
) -> mlua::Result<()> {
    let st = Arc::new(Strings {
        budget,
        max_len: if memory_bytes == 0 {
            usize::MAX
        } else {
            memory_bytes
        },
        c_find: string.get("find")?,
        c_match: string.get("match")?,
        c_gmatch: string.get("gmatch")?,
        c_gsub: string.get("gsub")?,
        cache: Mutex::new(HashMap::new()),
    });
    let s = st.clone();
    string.set(
        "find",
        lua.create_function(move |lua, args: MultiValue| find_or_match(lua, &s, true, args))?,
    )?;
    let s = st.clone();
    string.set(
        "match",
        lua.create_function(move |lua, args: MultiValue| find_or_match(lua, &s, false, args))?,
    )?;
    let s = st.clone();
    string.set(
        "gmatch",
        lua.create_function(move |lua, args: MultiValue| gmatch(lua, &s, args))?,
    )?;
    let s = st.clone();
    string.set(
        "gsub",
        lua.create_function(move |lua, args: MultiValue| gsub(lua, &s, args))?,
    )?;
    let s = st.clone();
    string.set(
        "rep",
        lua.create_function(
            move |lua, (text, n, sep): (LuaString, i64, Option<LuaString>)| {
                rep(
                    lua,
                    &s,
                    &text.as_bytes(),
                    n,
                    sep.as_ref().map(|s| s.as_bytes()).as_deref(),
                )
            },
        )?,
    )?;
    let c_pack: Function = string.get("pack")?;
    string.set(
        "pack",
        lua.create_function(move |_, args: MultiValue| {
            // `c<n>` pads a fixed-size string byte by byte in C: bound the sizes.
            if let Some(Value::String(fmt)) = args.front() {
                let total = fixed_string_bytes(&fmt.as_bytes());
                if total > MAX_PACKED {
                    return Err(rt(format!(
                        "string.pack: fixed-size strings ('c<n>') of more than {MAX_PACKED} bytes in all"
                    )));
                }
            }
            c_pack.call::<MultiValue>(args)
        })?,
    )?;
    Ok(())
}
