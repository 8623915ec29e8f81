//! The sandbox's bounded string functions (crates/script/src/strings.rs) against Lua's own: the same
//! results for `find`, `match`, `gmatch` and `gsub` over a table of patterns and subjects, and
//! randomly generated patterns, run in the sandbox and in a plain Lua state.

use std::path::Path;

use proptest::prelude::*;
use shoal_script::Limits;
use shoal_script::host::{ScriptHost, value_to_json};

const SUBJECTS: &[&str] = &[
    "hello world",
    "  key = value  ",
    "aaa",
    "",
    "a,b,,c",
    "x=1, y=22",
    "(foo(bar))baz",
    "\u{ff}\\0\\1abc",
    "hello\\nworld\\t!",
    "THE (quick) fox_1 jumps: 3.14",
];

const PATTERNS: &[&str] = &[
    "o",
    "l+",
    "l*",
    "l-",
    "l?",
    "^h",
    "d$",
    "^$",
    ".-",
    "(%w+)",
    "(%w+)=(%w+)",
    "%s*(.-)%s*$",
    "^%s*(.-)%s*$",
    "()",
    "()ll()",
    "[aeiou]",
    "[^aeiou]+",
    "[%a_][%w_]*",
    "[a-c]+",
    "[]]",
    "[^]]",
    "%d+",
    "%D+",
    "%p",
    "%x+",
    "%u",
    "%l+",
    "a*",
    "x*",
    "[%-]",
    ".",
    "%.",
    "a-b",
    "[z-a]",
    "b*$",
    "%S+",
    "(a)(b)?",
    "^(%a+)",
    "[%s,]+",
    "%(",
    "(%()",
    "[.]",
    "%w-%s",
    "q*$",
    "^.*$",
    "o(.)",
    "[0-9.]+",
    "%c",
    "%g+",
    "[%]]",
    "^^",
    "$$",
    "a$b",
    "[a-]",
    "%%",
    "%z",
    "(h)(e)(l)(l)(o)",
];

/// Lua code comparing one call: its results as strings (errors only as "error").
fn call(expr: &str) -> String {
    format!(
        "local r = table.pack(pcall(function() return {expr} end))\nif not r[1] then return {{'error'}} end\nlocal out = {{}}\nfor i = 2, r.n do out[#out + 1] = type(r[i]) .. ':' .. tostring(r[i]) end\nreturn out"
    )
}

fn exprs(s: &str, p: &str) -> Vec<String> {
    let (s, p) = (format!("\"{s}\""), format!("{p:?}"));
    vec![
        format!("string.find({s}, {p})"),
        format!("string.find({s}, {p}, 3)"),
        format!("string.find({s}, {p}, -3)"),
        format!("string.find({s}, {p}, 1, true)"),
        format!("string.match({s}, {p})"),
        format!("string.match({s}, {p}, 2)"),
        format!(
            "(function() local r = {{}} for a, b in string.gmatch({s}, {p}) do r[#r + 1] = tostring(a) .. '|' .. tostring(b) end return table.concat(r, ';') end)()"
        ),
        format!("string.gsub({s}, {p}, '<%0>')"),
        format!("string.gsub({s}, {p}, '[%1]', 2)"),
        format!(
            "string.gsub({s}, {p}, function(x) return type(x) == 'string' and x:upper() or nil end)"
        ),
        format!("string.gsub({s}, {p}, {{ a = 'A', o = false, l = 7 }})"),
    ]
}

struct Pair {
    sandbox: ScriptHost,
    plain: mlua::Lua,
}

impl Pair {
    fn new() -> (tempfile::TempDir, Self) {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("scripts");
        std::fs::create_dir_all(&root).unwrap();
        let sandbox = ScriptHost::new(Path::new(&root), Limits::default()).unwrap();
        (
            dir,
            Self {
                sandbox,
                plain: mlua::Lua::new(),
            },
        )
    }

    fn check(&self, expr: &str) {
        let code = call(expr);
        let ours = self.sandbox.eval("t.lua", &code).unwrap();
        let theirs: mlua::Value = self.plain.load(&code).eval().unwrap();
        assert_eq!(ours, value_to_json(&theirs, 0), "{expr}");
    }
}

#[test]
fn test_pattern_functions_match_lua() {
    let (_d, pair) = Pair::new();
    for s in SUBJECTS {
        for p in PATTERNS {
            for e in exprs(s, p) {
                pair.check(&e);
            }
        }
    }
}

#[test]
fn test_balance_frontier_and_back_references_still_work() {
    // These run on Lua's matcher (cheap here).
    let (_d, pair) = Pair::new();
    for s in SUBJECTS {
        for p in [
            "%b()",
            "%f[%w]%w+",
            "(l)%1",
            "(%a)%1",
            "%f[%a]",
            "(o)(.-)%1",
        ] {
            for e in exprs(s, p) {
                pair.check(&e);
            }
        }
    }
}

fn pattern_strategy() -> impl Strategy<Value = String> {
    let item = prop::sample::select(vec![
        "a", "b", ".", "%a", "%d", "%s", "%W", "[ab]", "[^a]", "[a-c]", "(", ")", "()", "^", "$",
        "*", "+", "-", "?", "%%", "x",
    ]);
    prop::collection::vec(item, 0..8).prop_map(|v| v.concat())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]
    #[test]
    fn prop_random_patterns_match_lua(p in pattern_strategy(), s in "[ab1 x]{0,12}") {
        let (_d, pair) = Pair::new();
        for e in exprs(&s, &p) {
            pair.check(&e);
        }
    }
}

#[test]
fn test_rep_and_pack_match_lua() {
    let (_d, pair) = Pair::new();
    for e in [
        "string.rep('ab', 3)",
        "string.rep('ab', 3, ',')",
        "string.rep('ab', 0)",
        "string.rep('ab', -1, ',')",
        "string.rep('', 5, '-')",
        "string.rep('x', 1, ',')",
        "string.rep('', 5)",
        "string.rep(12, 2)",
        "string.rep('a', 2.0)",
        "string.rep('a', 2.5)",
        "string.rep()",
        "('xy'):rep(4, '')",
        "string.pack('c5', 'ab')",
        "string.pack('i4c3z', 7, 'x', 'end')",
        "string.unpack('c2', 'abc')",
    ] {
        pair.check(e);
    }
}
