//! Hostile behaviour scripts, one test per attack class of the sandbox's threat model
//! (docs/sandbox.md): each is contained with an error naming its file and line, the host keeps
//! running, and the fish of other modules keep deciding.
//!
//! Attacks that used to hang the host run in a thread with a generous deadline, so a regression
//! fails the test instead of hanging the suite. The deadlines are not measurements (those are in
//! `shoal bench`): they only tell "stopped" from "still running".

use crate::common;

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use glam::Vec3;
use shoal_core::world::FishId;
use shoal_script::api;
use shoal_script::host::{ModuleIndex, ScriptHost};
use shoal_script::{DecisionError, Limits, Simulation};

/// Far more than any bounded attack takes, even in a debug build on a busy machine.
const DEADLINE: Duration = Duration::from_secs(60);

fn scripts(files: &[(&str, &str)]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("scripts");
    std::fs::create_dir_all(&root).unwrap();
    for (name, src) in files {
        let p = root.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, src).unwrap();
    }
    (dir, root)
}

fn fish(i: u32) -> FishId {
    FishId {
        index: i,
        generation: 0,
    }
}

/// A host with the `shoal` API registered, as a simulation lane has it.
fn host(root: &Path, limits: Limits) -> ScriptHost {
    let h = ScriptHost::new(root, limits).unwrap();
    api::register(h.lua()).unwrap();
    h
}

fn run(host: &mut ScriptHost, m: ModuleIndex, i: u32) -> Result<(), DecisionError> {
    let t = host.fish_table(fish(i), "porgy", "test").unwrap();
    host.run(m, fish(i), &t, 0.0)
}

/// Runs `attack` (file `behaviors/attack.lua`) once for fish 0 and `fine.lua` (which counts its
/// decisions) for fish 1, on a thread, under `limits`; returns the attack's result, how long
/// it took and fish 1's memory. Fails if the attack is not stopped within [`DEADLINE`].
fn attack(src: &str, limits: Limits) -> (Result<(), DecisionError>, Duration, serde_json::Value) {
    let src = src.to_owned();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let (_d, root) = scripts(&[
            ("behaviors/attack.lua", &src),
            (
                "behaviors/fine.lua",
                "return { tick = function(fish)\n  fish.memory.ticks = (fish.memory.ticks or 0) + 1\n  fish.memory.root = math.sqrt(16)\nend }\n",
            ),
        ]);
        let mut h = host(&root, limits);
        let a = h.module("attack", 0.0).expect("the attack loads");
        let f = h.module("fine", 0.0).unwrap();
        run(&mut h, f, 1).unwrap();
        let start = Instant::now();
        let r = run(&mut h, a, 0);
        let took = start.elapsed();
        run(&mut h, f, 1).unwrap();
        let _ = tx.send((r, took, h.memory_json(fish(1))));
    });
    let out = rx
        .recv_timeout(DEADLINE)
        .expect("the attack was not stopped: the host hangs");
    assert_eq!(
        out.2,
        serde_json::json!({"ticks": 2, "root": 4.0}),
        "the other module's fish keeps deciding"
    );
    out
}

fn assert_stopped_at(r: &Result<(), DecisionError>, file_line: &str, why: &str) {
    let err = r.as_ref().expect_err("the attack must fail").to_string();
    assert!(
        err.starts_with(&format!("scripts/behaviors/attack.lua:{file_line}: "))
            && err.contains(why),
        "{err}"
    );
}

// ---- isolation between modules --------------------------------------------------------------

#[test]
fn test_library_and_api_writes_stay_in_their_module() {
    let poison = "math.sqrt = nil\nstring.format = function() return 'pwned' end\ntable.insert = nil\nshoal.wander = nil\ncoroutine.wrap = nil\nos.clock = nil\nutf8.char = nil\n_G.pairs = nil\nrawset(_G, 'ipairs', nil)\ntostring = nil\nreturn { tick = function(fish)\n  fish.memory.sqrt = type(math.sqrt)\n  string.rep = nil\nend }\n";
    let victim = "return { tick = function(fish)\n  local m = fish.memory\n  m.sqrt = math.sqrt(16)\n  m.format = string.format('%d-%s', 3, 'x')\n  m.method = ('ab'):rep(2)\n  m.rep = string.rep('c', 2)\n  m.wander = type(shoal.wander)\n  m.wrap = type(coroutine.wrap)\n  m.clock = type(os.clock)\n  m.char = utf8.char(72)\n  m.pairs = type(pairs)\n  m.ipairs = type(ipairs)\n  m.tostring = tostring(1)\n  local t = {}\n  table.insert(t, 5)\n  m.insert = t[1]\nend }\n";
    let (_d, root) = scripts(&[
        ("behaviors/poison.lua", poison),
        ("behaviors/victim.lua", victim),
    ]);
    let mut h = host(&root, Limits::default());
    let p = h.module("poison", 0.0).unwrap();
    let v = h.module("victim", 0.0).unwrap();
    run(&mut h, p, 0).unwrap();
    run(&mut h, v, 1).unwrap();
    assert_eq!(h.memory_json(fish(0)), serde_json::json!({"sqrt": "nil"}));
    assert_eq!(
        h.memory_json(fish(1)),
        serde_json::json!({
            "sqrt": 4.0, "format": "3-x", "method": "abab", "rep": "cc", "wander": "function",
            "wrap": "function", "clock": "function", "char": "H", "pairs": "function",
            "ipairs": "function", "tostring": "1", "insert": 5
        })
    );
    assert!(h.error_messages().is_empty(), "{:?}", h.error_messages());
}

#[test]
fn test_required_libraries_are_per_module() {
    // A library table one module changes is not the table another module gets.
    let (_d, root) = scripts(&[
        (
            "behaviors/lib/util.lua",
            "return { double = function(x) return 2 * x end }\n",
        ),
        (
            "behaviors/poison.lua",
            "local util = require('behaviors.lib.util')\nutil.double = nil\nreturn { tick = function(fish) end }\n",
        ),
        (
            "behaviors/victim.lua",
            "local util = require('behaviors.lib.util')\nreturn { tick = function(fish) fish.memory.d = util.double(21) end }\n",
        ),
    ]);
    let mut h = host(&root, Limits::default());
    let p = h.module("poison", 0.0).unwrap();
    let v = h.module("victim", 0.0).unwrap();
    run(&mut h, p, 0).unwrap();
    run(&mut h, v, 1).unwrap();
    assert_eq!(h.memory_json(fish(1)), serde_json::json!({"d": 42}));
}

#[test]
fn test_string_metatable_is_protected() {
    let (_d, root) = scripts(&[
        (
            "behaviors/poison.lua",
            "return { tick = function(fish)\n  fish.memory.mt = tostring(getmetatable(''))\n  getmetatable('').__index = { upper = function() return 'pwned' end }\nend }\n",
        ),
        (
            "behaviors/poison2.lua",
            "return { tick = function(fish)\n  setmetatable(getmetatable(''), nil)\nend }\n",
        ),
        (
            "behaviors/victim.lua",
            "return { tick = function(fish) fish.memory.up = ('abc'):upper(); fish.memory.len = ('abc'):len() end }\n",
        ),
    ]);
    let mut h = host(&root, Limits::default());
    let p = h.module("poison", 0.0).unwrap();
    let p2 = h.module("poison2", 0.0).unwrap();
    let v = h.module("victim", 0.0).unwrap();
    assert_eq!(
        run(&mut h, p, 0).unwrap_err().to_string(),
        "scripts/behaviors/poison.lua:3: attempt to index a boolean value"
    );
    assert_eq!(h.memory_json(fish(0)), serde_json::json!({"mt": "false"}));
    assert_eq!(
        run(&mut h, p2, 2).unwrap_err().to_string(),
        "scripts/behaviors/poison2.lua:2: bad argument #1 to 'setmetatable' (table expected, got boolean)"
    );
    run(&mut h, v, 1).unwrap();
    assert_eq!(
        h.memory_json(fish(1)),
        serde_json::json!({"up": "ABC", "len": 3})
    );
}

#[test]
fn test_environments_lead_nowhere_shared() {
    // _G is the module's own environment, which has no metatable leading to shared globals.
    let (_d, root) = scripts(&[(
        "behaviors/probe.lua",
        "return { tick = function(fish)\n  local m = fish.memory\n  m.g = (_G == _ENV)\n  m.meta = tostring(getmetatable(_ENV))\n  m.load_env = load('return _G == _ENV')()\nend }\n",
    )]);
    let mut h = host(&root, Limits::default());
    let m = h.module("probe", 0.0).unwrap();
    run(&mut h, m, 0).unwrap();
    assert_eq!(
        h.memory_json(fish(0)),
        serde_json::json!({"g": true, "meta": "nil", "load_env": true})
    );
}

/// A simulation of the repository's scripts plus `files` (behaviours), with one black porgy per
/// behaviour in `behaviours`.
fn sim_with(
    files: &[(&str, &str)],
    behaviours: &[&str],
) -> (tempfile::TempDir, Simulation, Vec<FishId>) {
    let (d, root) = common::scratch_repo();
    for (name, src) in files {
        std::fs::write(root.join("scripts").join(name), src).unwrap();
    }
    let mut sim = common::sim_in(&root, 7);
    let ids = behaviours
        .iter()
        .enumerate()
        .map(|(i, b)| {
            sim.spawn(
                "black_porgy",
                Vec3::new(100.0 * i as f32, 200.0, 0.0),
                0.0,
                0.0,
                Some(50.0),
                Some(b),
            )
            .unwrap()
        })
        .collect();
    (d, sim, ids)
}

#[test]
fn test_shared_api_tables_cannot_be_poisoned() {
    // The tables the API reuses for every fish of a lane (body, nearest, tank, see, species)
    // take no metatable, and the species table is read-only: another module's fish of the same
    // species keeps deciding with the real values.
    let poison = "return { tick = function(fish)\n  local m = fish.memory\n  m.body = pcall(setmetatable, shoal.body(), { __index = function() error('gotcha') end })\n  m.tank = pcall(setmetatable, shoal.tank(), {})\n  m.species = select(2, pcall(function() shoal.species().cruise_speed = 1e9 end))\n  m.see = pcall(setmetatable, shoal.see(), {})\nend }\n";
    let victim = "return { tick = function(fish)\n  fish.memory.cruise = shoal.species().cruise_speed\n  fish.memory.x = shoal.body().x ~= nil\n  fish.memory.ticks = (fish.memory.ticks or 0) + 1\nend }\n";
    let (_d, mut sim, ids) = sim_with(
        &[
            ("behaviors/poison.lua", poison),
            ("behaviors/victim.lua", victim),
        ],
        &["poison", "victim", "victim"],
    );
    sim.run(0.5);
    let p = sim.memory_json(ids[0]);
    assert_eq!(p["body"], false, "{p}");
    assert_eq!(p["tank"], false, "{p}");
    assert_eq!(p["see"], false, "{p}");
    assert!(
        p["species"]
            .as_str()
            .is_some_and(|s| s.ends_with("poison.lua:5: shoal.species() is read-only")),
        "{p}"
    );
    for id in &ids[1..] {
        let v = sim.memory_json(*id);
        assert_eq!(v["cruise"], 50.0, "{v}");
        assert_eq!(v["x"], true, "{v}");
        assert!(v["ticks"].as_u64().unwrap() > 2, "{v}");
    }
    assert!(
        sim.error_messages().is_empty(),
        "{:?}",
        sim.error_messages()
    );
}

#[test]
fn test_errors_name_the_deciding_module() {
    // One module fails every decision; the other module's fish in the same lane keep deciding
    // and have no error; the errors name the failing file.
    let bad = "return { tick = function(fish)\n  shoal.wander = nil\n  error('always')\nend }\n";
    let good = "return { tick = function(fish)\n  shoal.steer(shoal.wander())\n  fish.memory.ticks = (fish.memory.ticks or 0) + 1\nend }\n";
    let (_d, mut sim, ids) = sim_with(
        &[("behaviors/bad.lua", bad), ("behaviors/good.lua", good)],
        &["bad", "good", "good"],
    );
    sim.run(0.5);
    assert_eq!(
        sim.error_messages(),
        ["scripts/behaviors/bad.lua:3: always"]
    );
    for id in &ids[1..] {
        assert!(sim.memory_json(*id)["ticks"].as_u64().unwrap() > 2);
    }
}

// ---- finalizers ---------------------------------------------------------------------------

#[test]
fn test_finalizers_are_refused() {
    let (r, _, _) = attack(
        "return { tick = function(fish)\n  setmetatable({}, { __gc = function() while true do end end })\nend }\n",
        Limits::default(),
    );
    assert_stopped_at(
        &r,
        "2",
        "setmetatable: __gc finalizers are not available to scripts",
    );
    // A placeholder field set first (Lua marks the object then) is refused too.
    let (r, _, _) = attack(
        "return { tick = function(fish)\n  local mt = { __gc = true }\n  setmetatable({}, mt)\n  mt.__gc = function() while true do end end\nend }\n",
        Limits::default(),
    );
    assert_stopped_at(&r, "3", "__gc finalizers are not available");
}

#[test]
fn test_to_be_closed_variables_run_inside_the_budget() {
    // __close runs in the script's own call (also while an error unwinds it), under its budget.
    let (r, _, _) = attack(
        "return { tick = function(fish)\n  local x <close> = setmetatable({}, { __close = function() while true do end end })\nend }\n",
        Limits::default(),
    );
    assert_stopped_at(&r, "2", "exceeded");
}

// ---- work inside C: the time limit and the bounded string functions ------------------------

#[test]
fn test_catastrophic_pattern_returns() {
    // The pattern: Lua's backtracking matcher never returns; the sandbox's is linear.
    let (r, _, _) = attack(
        "return { tick = function(fish)\n  fish.memory.r = tostring(string.rep('a', 2e5):find(string.rep('a-', 30) .. 'b'))\n  fish.memory.m = ('x'):rep(2e5):match(('x*'):rep(40) .. 'y')\nend }\n",
        Limits::default(),
    );
    r.unwrap();
}

#[test]
fn test_patterns_lua_must_run_are_refused_when_costly() {
    // %b, %f and back-references run on Lua's matcher, only where its work is small.
    let (r, _, _) = attack(
        "return { tick = function(fish)\n  local ok = ('(x)'):find('%b()')\n  assert(ok == 1)\n  string.rep('a', 2e5):find(string.rep('a-', 30) .. '%b()')\nend }\n",
        Limits::default(),
    );
    assert_stopped_at(
        &r,
        "4",
        "string.find: pattern too complex for a subject of 200000 bytes",
    );
}

#[test]
fn test_doubling_gsub_is_stopped() {
    let (r, took, _) = attack(
        "return { tick = function(fish)\n  local s = 'x'\n  while true do s = s:gsub('.', '%0%0') end\nend }\n",
        Limits::default(),
    );
    let err = r.unwrap_err().to_string();
    assert!(
        err.starts_with("scripts/behaviors/attack.lua:3: ")
            && (err.contains("time limit exceeded") || err.contains("memory")),
        "{err}"
    );
    assert!(took < Duration::from_secs(10), "{took:?}");
}

#[test]
fn test_memory_bomb_in_a_loop_is_stopped() {
    let (r, took, _) = attack(
        "return { tick = function(fish)\n  local t = {}\n  while true do t[#t + 1] = string.rep('x', 1e5) .. #t end\nend }\n",
        Limits::default(),
    );
    let err = r.unwrap_err().to_string();
    assert!(
        err.starts_with("scripts/behaviors/attack.lua:3: ")
            && (err.contains("time limit exceeded") || err.contains("memory limit exceeded")),
        "{err}"
    );
    assert!(took < Duration::from_secs(10), "{took:?}");
}

#[test]
fn test_expensive_instructions_are_stopped_by_time() {
    // Each iteration is a few instructions that each copy megabytes: the instruction budget
    // would take minutes to run out; the time limit stops the call.
    let (r, took, _) = attack(
        "return { tick = function(fish)\n  local big = string.rep('x', 1 << 22)\n  while true do local y = big:upper() .. big end\nend }\n",
        Limits::default(),
    );
    assert_stopped_at(&r, "3", "time limit exceeded (50 ms of CPU time per call)");
    assert!(took < Duration::from_secs(10), "{took:?}");
}

#[test]
fn test_pcall_cannot_swallow_the_time_limit() {
    let (r, _, _) = attack(
        "return { tick = function(fish)\n  local big = string.rep('x', 1 << 22)\n  while true do\n    pcall(function() while true do local y = big:upper() end end)\n  end\nend }\n",
        Limits::default(),
    );
    assert_stopped_at(&r, "4", "time limit exceeded");
}

#[test]
fn test_repeating_nothing_returns_at_once() {
    let (r, _, _) = attack(
        "return { tick = function(fish)\n  assert(string.rep('', math.maxinteger) == '')\n  assert(('').rep('', math.maxinteger, '') == '')\n  string.rep('', 2^62, 'x')\nend }\n",
        Limits::default(),
    );
    let err = r.unwrap_err().to_string();
    assert!(
        err.starts_with("scripts/behaviors/attack.lua") && err.contains("not enough memory")
            || err.contains("too large"),
        "{err}"
    );
}

#[test]
fn test_huge_moves_and_chunks_are_refused() {
    let (r, _, _) = attack(
        "return { tick = function(fish)\n  table.move({}, 1, math.maxinteger, 1)\nend }\n",
        Limits::default(),
    );
    assert_stopped_at(&r, "2", "table.move: too many elements to move");
    let (r, _, _) = attack(
        "return { tick = function(fish)\n  local n = 0\n  load(function() n = n + 1; if n < 1e4 then return string.rep('x = 1 ', 1000) end end)\nend }\n",
        Limits::default(),
    );
    assert_stopped_at(&r, "3", "load: chunk too large");
    let (r, _, _) = attack(
        "return { tick = function(fish)\n  string.pack('c268435456', '')\nend }\n",
        Limits::default(),
    );
    assert_stopped_at(
        &r,
        "2",
        "string.pack: fixed-size strings ('c<n>') of more than",
    );
    let (r, took, _) = attack(
        "return { tick = function(fish)\n  fish.memory.n = #string.rep('x', 2e8)\nend }\n",
        Limits::default(),
    );
    // One call of Lua's rep would copy a byte at a time (some 0.4 s); a doubling copy is quick,
    // and whatever time it takes counts against the call's limit.
    assert!(
        match &r {
            Ok(()) => true,
            Err(e) => e.to_string().contains("time limit exceeded"),
        },
        "{r:?}"
    );
    assert!(took < Duration::from_secs(10), "{took:?}");
    let (r, _, _) = attack(
        "return { tick = function(fish)\n  string.format('%99999999d', 1)\nend }\n",
        Limits::default(),
    );
    assert_stopped_at(&r, "2", "invalid conversion");
}

#[test]
fn test_time_limit_holds_when_metered_from_the_start() {
    // States without the watchdog (or calls metered from their first instruction) read the
    // clock in the hook instead.
    let limits = Limits {
        metered_after: Duration::ZERO,
        ..Limits::default()
    };
    let (r, took, _) = attack(
        "return { tick = function(fish)\n  local big = string.rep('x', 1 << 22)\n  while true do local y = big:upper() end\nend }\n",
        limits,
    );
    assert_stopped_at(&r, "3", "time limit exceeded");
    assert!(took < Duration::from_secs(10), "{took:?}");
}

#[test]
fn test_error_values_with_looping_tostring_are_stopped() {
    // The host turns an error value into text with its __tostring, still inside the call.
    let (r, _, _) = attack(
        "return { tick = function(fish)\n  error(setmetatable({}, { __tostring = function() while true do end end }))\nend }\n",
        Limits::default(),
    );
    assert_stopped_at(&r, "2", "instruction budget exceeded");
}
