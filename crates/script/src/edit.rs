//! Saving tuned values into species and scene files without touching anything else
//! (`shoal set FILE KEY.PATH=VALUE …` and the panel's "save to species file" / "save to scene").
//!
//! The file is parsed with `full_moon`, a lossless Lua parser: it keeps every comment and space,
//! and it gives the byte range of each literal. An edit replaces exactly the bytes of the literal
//! it names (`motion.s = 60` → `70`); every other byte of the file stays as written. A key the file
//! does not have yet is inserted after the last field of the table it belongs in, on a line of its
//! own in that table's indentation (or `, key = value` in a one-line table); missing tables on the
//! way are created (`motion = { s = 70 }`).
//!
//! A value written as an expression (`max_amp = 80 * 0.16`) is the designer's arithmetic: it is
//! replaced only when asked ([`EditOptions::replace_expressions`]), and then the old expression
//! stays beside the new value in a comment (`max_amp = 12.5 --[[was: 80 * 0.16]],`).
//!
//! What cannot be edited this way is refused, naming the key and the line: a value that is not a
//! table literal where the path goes on (`motion = base.motion`), a key set twice, a key assigned
//! again after the table (`species.motion = …`), a file that does not return a table literal (or a
//! local holding one). After the edits the new text is loaded in the sandbox and read exactly as
//! the simulation reads it, so an unknown key gets the loader's "did you mean", a value of the
//! wrong type or out of range is refused, and nothing is written unless the result would load.

use std::path::{Path, PathBuf};

use full_moon::ast::{
    self, Expression, Field, LastStmt, Prefix, Stmt, Suffix, TableConstructor, UnOp, Var,
};
use full_moon::node::Node;
use full_moon::tokenizer::TokenType;

use crate::host::ScriptHost;
use crate::sandbox::Limits;

/// One step of a key path: a named key (`motion`) or a list position counted from 1 (`[2]`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Seg {
    /// `name = …`
    Key(String),
    /// The n-th positional item (1-based).
    Index(usize),
}

/// A key path such as `motion.s`, `obstacles[1].pos` or `fish[2].params.speed`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KeyPath(pub Vec<Seg>);

impl KeyPath {
    /// Parses `motion.s`, `obstacles[1].pos[2]`.
    pub fn parse(text: &str) -> Result<Self, EditError> {
        let bad = |why: &str| EditError::BadKey {
            key: text.to_owned(),
            why: why.to_owned(),
        };
        let mut segs = Vec::new();
        let mut rest = text.trim();
        if rest.is_empty() {
            return Err(bad("the key is empty"));
        }
        let mut first = true;
        while !rest.is_empty() {
            if let Some(r) = rest.strip_prefix('[') {
                let (num, after) = r.split_once(']').ok_or_else(|| bad("a `[` without `]`"))?;
                let n: usize = num
                    .trim()
                    .parse()
                    .ok()
                    .filter(|&n| n >= 1)
                    .ok_or_else(|| bad("list positions are whole numbers from 1, like [1]"))?;
                segs.push(Seg::Index(n));
                rest = after;
            } else {
                let r = if first {
                    rest
                } else {
                    rest.strip_prefix('.')
                        .ok_or_else(|| bad("expected `.name` or `[n]` between keys"))?
                };
                let end = r.find(['.', '[']).unwrap_or(r.len());
                let name = &r[..end];
                let is_name = name
                    .chars()
                    .next()
                    .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                    && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
                if !is_name {
                    return Err(bad(&format!("\"{name}\" is not a Lua name")));
                }
                segs.push(Seg::Key(name.to_owned()));
                rest = &r[end..];
            }
            first = false;
        }
        Ok(Self(segs))
    }

    /// A path of named keys (`["motion", "s"]`).
    pub fn keys(keys: &[&str]) -> Self {
        Self(keys.iter().map(|k| Seg::Key((*k).to_owned())).collect())
    }
}

impl std::fmt::Display for KeyPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (i, s) in self.0.iter().enumerate() {
            match s {
                Seg::Key(k) if i == 0 => write!(f, "{k}")?,
                Seg::Key(k) => write!(f, ".{k}")?,
                Seg::Index(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

/// A value to write: Lua literal text and its kind.
#[derive(Debug, Clone, PartialEq)]
pub enum LuaValue {
    /// A number, as written (`70`, `0.25`, `-120`).
    Number(String),
    /// `true` or `false`.
    Bool(bool),
    /// A string literal with its quotes (`"school"`).
    Str(String),
    /// A list of values (`{ 250, 60, -120 }`): a list of the same length in the file is edited
    /// item by item.
    List(Vec<LuaValue>),
    /// Any other table literal, written as given.
    Table(String),
    /// `nil`: the key or list item is removed from the file (with its line, when it has one of
    /// its own, trailing comment included); a later item of the list moves up one place.
    Nil,
}

impl LuaValue {
    /// A number as the shortest text that reads back as the same `f32` (the panel's values).
    pub fn from_f32(v: f32) -> Self {
        Self::Number(format!("{v}"))
    }

    /// A string, quoted and escaped for Lua.
    pub fn string(s: &str) -> Self {
        let mut out = String::from("\"");
        for c in s.chars() {
            match c {
                '"' => out.push_str("\\\""),
                '\\' => out.push_str("\\\\"),
                '\n' => out.push_str("\\n"),
                c => out.push(c),
            }
        }
        out.push('"');
        Self::Str(out)
    }

    /// Reads a value as typed on the command line: a Lua literal (`70`, `true`, `"school"`,
    /// `{1, 2, 3}`); a bare word that is not one is taken as a string (`behavior=school`).
    pub fn parse(text: &str) -> Result<Self, EditError> {
        let t = text.trim();
        let bad = |why: String| EditError::BadValue {
            value: text.to_owned(),
            why,
        };
        if t.is_empty() {
            return Err(bad("the value is empty".into()));
        }
        if t == "nil" {
            return Ok(Self::Nil);
        }
        let word = t
            .chars()
            .all(|c| c.is_alphanumeric() || "_-./ ".contains(c))
            && !matches!(t, "true" | "false" | "nil");
        let src = format!("return {t}\n");
        match full_moon::parse_fallible(&src, ast::LuaVersion::lua54()).into_result() {
            Ok(a) => {
                let Some(LastStmt::Return(r)) = a.nodes().last_stmt() else {
                    return Err(bad("not a value".into()));
                };
                if r.returns().len() != 1 || a.nodes().stmts().next().is_some() {
                    return Err(bad("one value, please".into()));
                }
                let e = r.returns().iter().next().expect("one value");
                match Self::from_expr(e) {
                    Some(v) => Ok(v),
                    None if word => Ok(Self::string(t)),
                    None => Err(bad(
                        "expected a number, true/false, a string or a table of those".into(),
                    )),
                }
            }
            Err(_) if word => Ok(Self::string(t)),
            Err(e) => Err(bad(e
                .first()
                .map(|e| e.error_message().into_owned())
                .unwrap_or_default())),
        }
    }

    fn from_expr(e: &Expression) -> Option<Self> {
        match literal_kind(e)? {
            Kind::Number => Some(Self::Number(e.to_string().trim().to_owned())),
            Kind::Bool => Some(Self::Bool(e.to_string().trim() == "true")),
            Kind::Str => Some(Self::Str(e.to_string().trim().to_owned())),
            Kind::Table => {
                let Expression::TableConstructor(t) = e else {
                    return None;
                };
                if t.fields().iter().all(|f| matches!(f, Field::NoKey(_))) {
                    t.fields()
                        .iter()
                        .map(|f| match f {
                            Field::NoKey(e) => Self::from_expr(e),
                            _ => None,
                        })
                        .collect::<Option<Vec<_>>>()
                        .map(Self::List)
                } else if table_is_literal(t) {
                    Some(Self::Table(e.to_string().trim().to_owned()))
                } else {
                    None
                }
            }
        }
    }

    /// The Lua text.
    pub fn text(&self) -> String {
        match self {
            Self::Number(t) | Self::Str(t) | Self::Table(t) => t.clone(),
            Self::Bool(b) => b.to_string(),
            Self::Nil => "nil".into(),
            Self::List(items) if items.is_empty() => "{}".into(),
            Self::List(items) => {
                let inner: Vec<String> = items.iter().map(Self::text).collect();
                format!("{{ {} }}", inner.join(", "))
            }
        }
    }

    fn kind(&self) -> Kind {
        match self {
            Self::Number(_) => Kind::Number,
            Self::Bool(_) => Kind::Bool,
            Self::Str(_) => Kind::Str,
            Self::List(_) | Self::Table(_) | Self::Nil => Kind::Table,
        }
    }
}

/// The kind of a literal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Number,
    Bool,
    Str,
    Table,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Number => "a number",
            Kind::Bool => "true or false",
            Kind::Str => "a string",
            Kind::Table => "a table",
        }
    }
}

/// The kind of `e` if it is a literal (a negative number counts), `None` for an expression.
fn literal_kind(e: &Expression) -> Option<Kind> {
    match e {
        Expression::Number(_) => Some(Kind::Number),
        Expression::String(_) => Some(Kind::Str),
        Expression::Symbol(t) => match t.token().to_string().as_str() {
            "true" | "false" => Some(Kind::Bool),
            _ => None,
        },
        Expression::UnaryOperator {
            unop: UnOp::Minus(_),
            expression,
        } if matches!(**expression, Expression::Number(_)) => Some(Kind::Number),
        Expression::TableConstructor(_) => Some(Kind::Table),
        _ => None,
    }
}

fn expr_is_literal(e: &Expression) -> bool {
    match e {
        Expression::TableConstructor(t) => table_is_literal(t),
        e => literal_kind(e).is_some(),
    }
}

fn table_is_literal(t: &TableConstructor) -> bool {
    t.fields().iter().all(|f| match f {
        Field::NoKey(e) => expr_is_literal(e),
        Field::NameKey { value, .. } => expr_is_literal(value),
        _ => false,
    })
}

/// One edit: set `path` to `value`.
#[derive(Debug, Clone, PartialEq)]
pub struct Edit {
    /// Where.
    pub path: KeyPath,
    /// What.
    pub value: LuaValue,
}

impl Edit {
    /// Parses `KEY.PATH=VALUE` as typed on the command line.
    pub fn parse(arg: &str) -> Result<Self, EditError> {
        let (k, v) = arg.split_once('=').ok_or_else(|| EditError::BadKey {
            key: arg.to_owned(),
            why: "expected KEY.PATH=VALUE, like motion.s=70".into(),
        })?;
        Ok(Self {
            path: KeyPath::parse(k)?,
            value: LuaValue::parse(v)?,
        })
    }
}

/// How to edit.
#[derive(Debug, Clone, Copy, Default)]
pub struct EditOptions {
    /// Replace values written as expressions (`80 * 0.16`), keeping the old expression in a
    /// comment beside the new value.
    pub replace_expressions: bool,
}

/// Which loader checks the edited file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileKind {
    /// `scripts/species/*.lua`.
    Species,
    /// `scripts/scenes/*.lua`.
    Scene,
}

impl FileKind {
    /// The kind of `path` from its folder (`species/` or `scenes/`).
    pub fn of(path: &Path) -> Option<Self> {
        match path.parent()?.file_name()?.to_str()? {
            "species" => Some(Self::Species),
            "scenes" => Some(Self::Scene),
            _ => None,
        }
    }
}

/// Why an edit was refused. Each names the file and, where there is one, the line.
#[derive(Debug, thiserror::Error)]
pub enum EditError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A key path as typed is malformed.
    #[error("bad key \"{key}\": {why}")]
    BadKey {
        /// As typed.
        key: String,
        /// Why.
        why: String,
    },
    /// A value as typed is not a literal.
    #[error("bad value `{value}`: {why}")]
    BadValue {
        /// As typed.
        value: String,
        /// Why.
        why: String,
    },
    /// Not a file of a kind shoal knows how to check.
    #[error(
        "{0}: not a species or scene file (expected scripts/species/*.lua or scripts/scenes/*.lua)"
    )]
    UnknownKind(PathBuf),
    /// The file does not parse as Lua.
    #[error("{file}:{line}:{col}: cannot parse the file: {why}")]
    Syntax {
        /// The file.
        file: String,
        /// Line, from 1.
        line: usize,
        /// Column, from 1.
        col: usize,
        /// The parser's message.
        why: String,
    },
    /// The file cannot be edited without changing something else in it.
    #[error("{file}:{line}: cannot edit {key} losslessly: {why}")]
    NotEditable {
        /// The file.
        file: String,
        /// The key path.
        key: String,
        /// Where the obstacle is.
        line: usize,
        /// What it is.
        why: String,
    },
    /// The value in the file is an expression and replacing it was not asked for.
    #[error(
        "{file}:{line}: {key} is written as an expression (`{expr}`); pass --replace-expressions \
         to replace it (the expression is kept in a comment beside the new value)"
    )]
    Expression {
        /// The file.
        file: String,
        /// The key path.
        key: String,
        /// Its line.
        line: usize,
        /// The expression as written.
        expr: String,
    },
    /// The new value has another type than the one in the file.
    #[error("{file}:{line}: {key} is {expected} in the file; refusing `{got}` ({got_kind})")]
    WrongType {
        /// The file.
        file: String,
        /// The key path.
        key: String,
        /// Its line.
        line: usize,
        /// The kind written there.
        expected: &'static str,
        /// The value given.
        got: String,
        /// Its kind.
        got_kind: &'static str,
    },
    /// The edited file would not load (unknown key with its "did you mean", type, range); nothing
    /// was written.
    #[error("{0} (nothing was written)")]
    Invalid(String),
}

/// Where an edit's bytes go: replace `range` of the source with `text`.
struct Splice {
    range: std::ops::Range<usize>,
    text: String,
}

fn start_byte(n: &impl Node) -> usize {
    n.start_position().map_or(0, |p| p.bytes())
}

fn end_byte(n: &impl Node) -> usize {
    n.end_position().map_or(0, |p| p.bytes())
}

fn line_of(n: &impl Node) -> usize {
    n.start_position().map_or(0, |p| p.line())
}

/// Applies `edits` to the Lua text `source` (named `file` in messages), one after the other;
/// returns the new text. Only syntax is checked here: [`save`] also loads the result.
pub fn edit_source(
    source: &str,
    file: &str,
    edits: &[Edit],
    opts: EditOptions,
) -> Result<String, EditError> {
    let mut text = source.to_owned();
    for e in edits {
        text = edit_once(&text, file, e, opts)?;
    }
    Ok(text)
}

fn parse(source: &str, file: &str) -> Result<ast::Ast, EditError> {
    let ast = full_moon::parse_fallible(source, ast::LuaVersion::lua54())
        .into_result()
        .map_err(|errs| {
            let e = &errs[0];
            let (start, _) = e.range();
            EditError::Syntax {
                file: file.to_owned(),
                line: start.line(),
                col: start.character(),
                why: e.error_message().into_owned(),
            }
        })?;
    // The parser's own guarantee, checked: printing the tree gives the file back byte for byte.
    if ast.to_string() != source {
        return Err(EditError::NotEditable {
            file: file.to_owned(),
            key: "the file".into(),
            line: 1,
            why: "the parser does not read it back byte for byte".into(),
        });
    }
    Ok(ast)
}

/// The table literal the file returns: `return { … }`, or `return name` of a `local name = { … }`.
/// Also the name, when it is a local, so later assignments to it can be found.
fn data_table<'a>(
    ast: &'a ast::Ast,
    file: &str,
) -> Result<(&'a TableConstructor, Option<String>), EditError> {
    let refuse = |line: usize, why: String| EditError::NotEditable {
        file: file.to_owned(),
        key: "the file".into(),
        line,
        why,
    };
    let block = ast.nodes();
    let Some(LastStmt::Return(ret)) = block.last_stmt() else {
        return Err(refuse(
            line_of(ast.eof()),
            "it does not end with `return { … }` (a species or scene table)".into(),
        ));
    };
    let Some(value) = ret.returns().iter().next() else {
        return Err(refuse(line_of(ret), "`return` returns nothing".into()));
    };
    match value {
        Expression::TableConstructor(t) => Ok((t, None)),
        Expression::Var(Var::Name(name)) => {
            let name = name.token().to_string();
            let mut found = None;
            for stmt in block.stmts() {
                if let Stmt::LocalAssignment(l) = stmt
                    && let Some(i) = l.names().iter().position(|n| n.token().to_string() == name)
                {
                    found = Some(l.expressions().iter().nth(i).ok_or_else(|| {
                        refuse(line_of(l), format!("`local {name}` has no value"))
                    })?);
                }
            }
            match found {
                Some(Expression::TableConstructor(t)) => Ok((t, Some(name))),
                Some(e) => Err(refuse(
                    line_of(e),
                    format!(
                        "`{name}` is not a table literal (`{}`)",
                        e.to_string().trim()
                    ),
                )),
                None => Err(refuse(
                    line_of(value),
                    format!("`return {name}` but no `local {name} = {{ … }}` above it"),
                )),
            }
        }
        e => Err(refuse(
            line_of(e),
            format!("it returns `{}`, not a table literal", e.to_string().trim()),
        )),
    }
}

/// Statements that assign into the data table after it is built (`species.motion = …`): the key
/// they set first and their line.
fn later_assignments(ast: &ast::Ast, name: &str) -> Vec<(Option<String>, usize)> {
    let mut out = Vec::new();
    for stmt in ast.nodes().stmts() {
        let Stmt::Assignment(a) = stmt else { continue };
        for var in a.variables() {
            let Var::Expression(ve) = var else { continue };
            let Prefix::Name(n) = ve.prefix() else {
                continue;
            };
            if n.token().to_string() != name {
                continue;
            }
            let key = match ve.suffixes().next() {
                Some(Suffix::Index(ast::Index::Dot { name, .. })) => Some(name.token().to_string()),
                _ => None,
            };
            out.push((key, line_of(a)));
        }
    }
    out
}

/// The name of a field's key if it is `name = …` or `["name"] = …`.
fn field_name(f: &Field) -> Option<String> {
    match f {
        Field::NameKey { key, .. } => Some(key.token().to_string()),
        Field::ExpressionKey { key, .. } => match &**key {
            Expression::String(s) => match s.token().token_type() {
                TokenType::StringLiteral { literal, .. } => Some(literal.to_string()),
                _ => None,
            },
            _ => None,
        },
        _ => None,
    }
}

fn field_value(f: &Field) -> Option<&Expression> {
    match f {
        Field::NameKey { value, .. } | Field::ExpressionKey { value, .. } => Some(value),
        Field::NoKey(e) => Some(e),
        _ => None,
    }
}

/// The fields of `t` that `seg` names (more than one is an error the caller reports).
fn matching<'a>(t: &'a TableConstructor, seg: &Seg) -> Vec<&'a Field> {
    match seg {
        Seg::Key(k) => t
            .fields()
            .iter()
            .filter(|f| field_name(f).as_deref() == Some(k.as_str()))
            .collect(),
        Seg::Index(n) => t
            .fields()
            .iter()
            .filter(|f| matches!(f, Field::NoKey(_)))
            .nth(n - 1)
            .into_iter()
            .collect(),
    }
}

fn edit_once(
    source: &str,
    file: &str,
    edit: &Edit,
    opts: EditOptions,
) -> Result<String, EditError> {
    let ast = parse(source, file)?;
    let (mut table, local) = data_table(&ast, file)?;
    let key = edit.path.to_string();
    let refuse = |line: usize, why: String| EditError::NotEditable {
        file: file.to_owned(),
        key: key.clone(),
        line,
        why,
    };
    if let (Some(name), Some(Seg::Key(first))) = (&local, edit.path.0.first()) {
        for (k, line) in later_assignments(&ast, name) {
            if k.is_none() || k.as_deref() == Some(first.as_str()) {
                return Err(refuse(
                    line,
                    format!("line {line} assigns into `{name}` after its table; edit that by hand"),
                ));
            }
        }
    }
    let segs = &edit.path.0;
    let mut splices = Vec::new();
    for (i, seg) in segs.iter().enumerate() {
        let found = matching(table, seg);
        if found.len() > 1 {
            let lines: Vec<String> = found.iter().map(|f| line_of(*f).to_string()).collect();
            return Err(refuse(
                line_of(found[1]),
                format!("it is set more than once (lines {})", lines.join(", ")),
            ));
        }
        let Some(field) = found.first() else {
            if edit.value != LuaValue::Nil {
                splices.push(insert(source, file, &key, table, &segs[i..], &edit.value)?);
            }
            break;
        };
        if i + 1 == segs.len() && edit.value == LuaValue::Nil {
            splices.push(removal(source, table, field));
            break;
        }
        let value = field_value(field).expect("matching fields have values");
        if i + 1 < segs.len() {
            match value {
                Expression::TableConstructor(t) => table = t,
                e => {
                    return Err(refuse(
                        line_of(e),
                        format!(
                            "{} is `{}`, not a table literal",
                            KeyPath(segs[..=i].to_vec()),
                            e.to_string().trim()
                        ),
                    ));
                }
            }
        } else {
            replace(file, &key, value, &edit.value, opts, &mut splices)?;
        }
    }
    splices.sort_by_key(|s| std::cmp::Reverse(s.range.start));
    let mut out = source.to_owned();
    for s in splices {
        out.replace_range(s.range, &s.text);
    }
    Ok(out)
}

/// Removes `field` of `table`: its whole line (trailing comment included) when it has lines of
/// its own, else the field and its separator.
fn removal(source: &str, table: &TableConstructor, field: &Field) -> Splice {
    let pairs: Vec<_> = table.fields().pairs().collect();
    let at = start_byte(field);
    let k = pairs
        .iter()
        .position(|p| start_byte(p.value()) == at)
        .unwrap_or(0);
    let end = pairs[k].punctuation().map_or(end_byte(field), end_byte);
    let line_start = source[..at].rfind('\n').map_or(0, |i| i + 1);
    let line_end = source[end..].find('\n').map_or(source.len(), |i| end + i);
    let rest = source[end..line_end].trim_start();
    let own_line = source[line_start..at].trim().is_empty()
        && (rest.is_empty() || (rest.starts_with("--") && !rest.starts_with("--[")));
    if own_line {
        return Splice {
            range: line_start..(line_end + 1).min(source.len()),
            text: String::new(),
        };
    }
    if pairs[k].punctuation().is_none() && k > 0 {
        // The last field without a separator: the previous one's goes with it.
        let prev = pairs[k - 1]
            .punctuation()
            .map_or(end_byte(pairs[k - 1].value()), start_byte);
        return Splice {
            range: prev..end,
            text: String::new(),
        };
    }
    let spaces = source[end..].len() - source[end..].trim_start_matches([' ', '\t']).len();
    Splice {
        range: at..end + spaces,
        text: String::new(),
    }
}

/// Replaces the literal `old` with `new` (item by item for two lists of the same length).
fn replace(
    file: &str,
    key: &str,
    old: &Expression,
    new: &LuaValue,
    opts: EditOptions,
    splices: &mut Vec<Splice>,
) -> Result<(), EditError> {
    let range = start_byte(old)..end_byte(old);
    let Some(kind) = literal_kind(old) else {
        let expr = old.to_string().trim().to_owned();
        if !opts.replace_expressions {
            return Err(EditError::Expression {
                file: file.to_owned(),
                key: key.to_owned(),
                line: line_of(old),
                expr,
            });
        }
        // The closing of a long comment that the expression cannot contain.
        let mut level = 0;
        while expr.contains(&format!("]{}]", "=".repeat(level))) {
            level += 1;
        }
        let eq = "=".repeat(level);
        splices.push(Splice {
            range,
            text: format!("{} --[{eq}[was: {expr}]{eq}]", new.text()),
        });
        return Ok(());
    };
    if kind != new.kind() {
        return Err(EditError::WrongType {
            file: file.to_owned(),
            key: key.to_owned(),
            line: line_of(old),
            expected: kind.name(),
            got: new.text(),
            got_kind: new.kind().name(),
        });
    }
    if let (Expression::TableConstructor(t), LuaValue::List(items)) = (old, new) {
        let olds: Vec<&Expression> = t
            .fields()
            .iter()
            .filter_map(|f| match f {
                Field::NoKey(e) => Some(e),
                _ => None,
            })
            .collect();
        if olds.len() == items.len() && olds.len() == t.fields().len() {
            for (i, (o, n)) in olds.iter().zip(items).enumerate() {
                replace(file, &format!("{key}[{}]", i + 1), o, n, opts, splices)?;
            }
            return Ok(());
        }
    }
    splices.push(Splice {
        range,
        text: new.text(),
    });
    Ok(())
}

/// The text of a value nested under `segs` (`{ s = 70 }` for `[s]`).
fn nested(file: &str, key: &str, segs: &[Seg], value: &LuaValue) -> Result<String, EditError> {
    match segs.first() {
        None => Ok(value.text()),
        Some(Seg::Key(k)) => Ok(format!(
            "{{ {k} = {} }}",
            nested(file, key, &segs[1..], value)?
        )),
        Some(Seg::Index(1)) => Ok(format!("{{ {} }}", nested(file, key, &segs[1..], value)?)),
        Some(Seg::Index(n)) => Err(EditError::NotEditable {
            file: file.to_owned(),
            key: key.to_owned(),
            line: 0,
            why: format!("a new list starts at [1], not [{n}]"),
        }),
    }
}

/// The leading spaces and tabs of the line holding byte `at`.
fn indent_at(source: &str, at: usize) -> &str {
    let line_start = source[..at].rfind('\n').map_or(0, |i| i + 1);
    let line = &source[line_start..];
    &line[..line.len() - line.trim_start_matches([' ', '\t']).len()]
}

/// Inserts the missing `segs` (with `value` at the end) into `table`, after its last field.
fn insert(
    source: &str,
    file: &str,
    key: &str,
    table: &TableConstructor,
    segs: &[Seg],
    value: &LuaValue,
) -> Result<Splice, EditError> {
    let item = match &segs[0] {
        Seg::Key(k) => format!("{k} = {}", nested(file, key, &segs[1..], value)?),
        Seg::Index(n) => {
            let have = table
                .fields()
                .iter()
                .filter(|f| matches!(f, Field::NoKey(_)))
                .count();
            if *n != have + 1 {
                return Err(EditError::NotEditable {
                    file: file.to_owned(),
                    key: key.to_owned(),
                    line: line_of(table),
                    why: format!(
                        "the list has {have} item(s); a new one goes at [{}], not [{n}]",
                        have + 1
                    ),
                });
            }
            nested(file, key, &segs[1..], value)?
        }
    };
    let (open, close) = table.braces().tokens();
    let open_end = end_byte(open);
    let close_start = start_byte(close);
    let Some(last) = table.fields().pairs().last() else {
        // An empty table: `{}` becomes `{ item }`.
        let inside = &source[open_end..close_start];
        return Ok(Splice {
            range: open_end..close_start,
            text: if inside.contains('\n') {
                let indent = indent_at(source, close_start);
                format!("\n{indent}  {item},\n{indent}")
            } else {
                format!(" {item} ")
            },
        });
    };
    let field_end = end_byte(last.value());
    let after = match last.punctuation() {
        Some(p) => end_byte(p),
        None => field_end,
    };
    let comma = if last.punctuation().is_some() {
        ""
    } else {
        ","
    };
    let multiline = source[field_end..close_start].contains('\n');
    if multiline {
        // A line of its own after the last field's line (its trailing comment stays with it),
        // indented like that field.
        let indent = indent_at(source, start_byte(last.value()));
        let line_end = source[after..close_start]
            .find('\n')
            .map_or(close_start, |i| after + i);
        if comma.is_empty() {
            Ok(Splice {
                range: line_end..line_end,
                text: format!("\n{indent}{item},"),
            })
        } else {
            // The missing comma goes right after the last field; the new line after its line.
            // Two splices would be needed: do it as one over the bytes between.
            let between = &source[field_end..line_end];
            Ok(Splice {
                range: field_end..line_end,
                text: format!("{comma}{between}\n{indent}{item}"),
            })
        }
    } else {
        Ok(Splice {
            range: after..after,
            text: if comma.is_empty() {
                format!(" {item},")
            } else {
                format!(", {item}")
            },
        })
    }
}

/// What a save did.
#[derive(Debug, Clone)]
pub struct Saved {
    /// The file written.
    pub path: PathBuf,
    /// Whether its text changed (setting a value to what is written already changes nothing).
    pub changed: bool,
}

/// The `scripts/` directory a species or scene file belongs to.
fn scripts_dir_of(path: &Path) -> Option<&Path> {
    path.parent()?.parent()
}

/// Checks that `text` (the edited file `path`) loads as the simulation would load it.
pub fn validate(path: &Path, kind: FileKind, text: &str) -> Result<(), EditError> {
    let scripts = scripts_dir_of(path).ok_or_else(|| EditError::UnknownKind(path.to_owned()))?;
    let host = ScriptHost::new(scripts, Limits::default())
        .map_err(|e| EditError::Invalid(e.to_string()))?;
    let display = host.root().display_of(path);
    let value = host
        .load_data_source(&display, text)
        .map_err(|e| EditError::Invalid(e.to_string()))?;
    match kind {
        FileKind::Species => crate::sim::species_from_value(&host, value, &display).map(|_| ()),
        FileKind::Scene => crate::sim::scene_from_value(&host, value, &display).map(|_| ()),
    }
    .map_err(|e| EditError::Invalid(e.to_string()))
}

/// Edits the file at `path` (a species or scene file) and writes it back if the result loads.
/// The write goes to a temporary file beside it, renamed over it, so a watcher never sees half a
/// file.
pub fn save(path: &Path, edits: &[Edit], opts: EditOptions) -> Result<Saved, EditError> {
    let kind = FileKind::of(path).ok_or_else(|| EditError::UnknownKind(path.to_owned()))?;
    let io = |source| EditError::Io {
        path: path.to_owned(),
        source,
    };
    let source = std::fs::read_to_string(path).map_err(io)?;
    let display = path.display().to_string();
    let text = edit_source(&source, &display, edits, opts)?;
    validate(path, kind, &text)?;
    if text == source {
        return Ok(Saved {
            path: path.to_owned(),
            changed: false,
        });
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut tmp = tempfile::Builder::new()
        .prefix(".shoal-save-")
        .suffix(".tmp")
        .tempfile_in(dir)
        .map_err(io)?;
    std::io::Write::write_all(&mut tmp, text.as_bytes()).map_err(io)?;
    if let Ok(meta) = std::fs::metadata(path) {
        let _ = std::fs::set_permissions(tmp.path(), meta.permissions());
    }
    tmp.persist(path).map_err(|e| io(e.error))?;
    Ok(Saved {
        path: path.to_owned(),
        changed: true,
    })
}
