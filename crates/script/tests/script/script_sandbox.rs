//! The sandbox: one hostile script per rule, each checked for the exact error it gets, and the
//! instruction budget and memory limit stopping a script without stopping the host.

use std::path::{Path, PathBuf};
use std::time::Duration;

use shoal_core::world::FishId;
use shoal_script::host::{ModuleIndex, ScriptHost};
use shoal_script::{DecisionError, Limits, LogLevel};

/// A temporary `scripts/` with the given behaviour files.
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

fn host(root: &Path) -> ScriptHost {
    ScriptHost::new(root, Limits::default()).unwrap()
}

/// The budget's message under the default limits (calls metered once they have run 1 ms).
const DEFAULT_BUDGET: &str =
    "instruction budget exceeded (200000 instructions per call, counted once a call has run 1 ms)";

/// Limits that meter every call from its first instruction: the budget is exact.
fn metered_from_start() -> Limits {
    Limits {
        metered_after: Duration::ZERO,
        ..Limits::default()
    }
}

/// Runs behaviour `name` once for fish 0 and returns its error.
fn run_err(host: &mut ScriptHost, name: &str) -> String {
    let m = host.module(name, 0.0).expect("module loads");
    run(host, m, 0)
        .expect_err("the script must fail")
        .to_string()
}

fn run(host: &mut ScriptHost, m: ModuleIndex, i: u32) -> Result<(), DecisionError> {
    let t = host.fish_table(fish(i), "porgy", "test").unwrap();
    host.run(m, fish(i), &t, 0.0)
}

#[test]
fn test_os_execute_is_absent() {
    let (_d, root) = scripts(&[(
        "behaviors/os_exec.lua",
        "return { tick = function(fish)\n  os.execute('touch /tmp/pwned')\nend }\n",
    )]);
    let mut h = host(&root);
    assert_eq!(
        run_err(&mut h, "os_exec"),
        "scripts/behaviors/os_exec.lua:2: attempt to call a nil value (field 'execute')"
    );
}

#[test]
fn test_os_clock_is_present() {
    let (_d, root) = scripts(&[]);
    let h = host(&root);
    assert_eq!(
        h.eval(
            "t.lua",
            "return {type(os.clock()), os.getenv == nil, os.exit == nil, os.remove == nil}"
        )
        .unwrap(),
        serde_json::json!(["number", true, true, true])
    );
}

#[test]
fn test_io_is_absent() {
    let (_d, root) = scripts(&[(
        "behaviors/io_open.lua",
        "return { tick = function(fish)\n  local f = io.open('/etc/passwd')\nend }\n",
    )]);
    let mut h = host(&root);
    assert_eq!(
        run_err(&mut h, "io_open"),
        "scripts/behaviors/io_open.lua:2: attempt to index a nil value (global 'io')"
    );
}

#[test]
fn test_debug_is_absent() {
    let (_d, root) = scripts(&[(
        "behaviors/dbg.lua",
        "return { tick = function(fish)\n  debug.sethook()\nend }\n",
    )]);
    let mut h = host(&root);
    assert_eq!(
        run_err(&mut h, "dbg"),
        "scripts/behaviors/dbg.lua:2: attempt to index a nil value (global 'debug')"
    );
}

#[test]
fn test_package_dofile_loadfile_are_absent() {
    let (_d, root) = scripts(&[]);
    let h = host(&root);
    assert_eq!(
        h.eval(
            "t.lua",
            "return {package == nil, dofile == nil, loadfile == nil, string.dump == nil}"
        )
        .unwrap(),
        serde_json::json!([true, true, true, true])
    );
}

#[test]
fn test_require_outside_scripts_is_refused() {
    let outside = tempfile::tempdir().unwrap();
    std::fs::write(outside.path().join("secret.lua"), "return 'secret'").unwrap();
    let (_d, root) = scripts(&[
        (
            "behaviors/up.lua",
            "return { tick = function(fish)\n  require('../secret')\nend }\n",
        ),
        (
            "behaviors/abs.lua",
            "return { tick = function(fish)\n\n  require('/etc/passwd')\nend }\n",
        ),
        (
            "behaviors/link.lua",
            "return { tick = function(fish)\n  require('behaviors.lib.evil')\nend }\n",
        ),
    ]);
    std::fs::create_dir_all(root.join("behaviors/lib")).unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink(
        outside.path().join("secret.lua"),
        root.join("behaviors/lib/evil.lua"),
    )
    .unwrap();
    let mut h = host(&root);
    assert_eq!(
        run_err(&mut h, "up"),
        "scripts/behaviors/up.lua:2: require: module name '../secret' may only name files inside scripts/ (letters, digits, '_', '-', separated by '.' or '/')"
    );
    assert_eq!(
        run_err(&mut h, "abs"),
        "scripts/behaviors/abs.lua:3: require: module name '/etc/passwd' must be relative to scripts/"
    );
    #[cfg(unix)]
    assert_eq!(
        run_err(&mut h, "link"),
        "scripts/behaviors/link.lua:2: require: module 'behaviors.lib.evil' resolves outside scripts/"
    );
}

#[test]
fn test_require_inside_scripts_loads_once() {
    let (_d, root) = scripts(&[
        (
            "behaviors/lib/counter.lua",
            "loads = (loads or 0) + 1\nreturn { n = 41 }\n",
        ),
        (
            "behaviors/user.lua",
            "local c = require('behaviors.lib.counter')\nlocal c2 = require('behaviors/lib/counter')\nreturn { tick = function(fish) fish.memory.n = c.n + 1; fish.memory.same = (c == c2) end }\n",
        ),
    ]);
    let mut h = host(&root);
    let m = h.module("user", 0.0).unwrap();
    run(&mut h, m, 0).unwrap();
    assert_eq!(
        h.memory_json(fish(0)),
        serde_json::json!({"n": 42, "same": true})
    );
}

#[test]
fn test_binary_chunks_are_refused() {
    let (_d, root) = scripts(&[
        (
            "behaviors/bin.lua",
            "return { tick = function(fish)\n  local f, err = load('\\27LuaT\\0\\25\\147\\r\\n\\26\\n')\n  error(err)\nend }\n",
        ),
        (
            "behaviors/dump.lua",
            "return { tick = function(fish)\n  local s = string.dump(function() end)\nend }\n",
        ),
    ]);
    let mut h = host(&root);
    assert_eq!(
        run_err(&mut h, "bin"),
        "scripts/behaviors/bin.lua:3: attempt to load a binary chunk (mode is 't')"
    );
    assert_eq!(
        run_err(&mut h, "dump"),
        "scripts/behaviors/dump.lua:2: attempt to call a nil value (field 'dump')"
    );
}

#[test]
fn test_text_load_runs_in_the_sandbox() {
    let (_d, root) = scripts(&[]);
    let h = host(&root);
    assert_eq!(
        h.eval("t.lua", "return load('return io == nil and 7')()")
            .unwrap(),
        serde_json::json!(7)
    );
}

#[test]
fn test_collectgarbage_only_counts() {
    let (_d, root) = scripts(&[(
        "behaviors/gc.lua",
        "return { tick = function(fish)\n  collectgarbage('stop')\nend }\n",
    )]);
    let mut h = host(&root);
    assert_eq!(
        run_err(&mut h, "gc"),
        "scripts/behaviors/gc.lua:2: collectgarbage: scripts may only ask for \"count\""
    );
}

#[test]
fn test_infinite_loop_is_stopped_and_other_fish_run() {
    let (_d, root) = scripts(&[
        (
            "behaviors/spin.lua",
            "return { tick = function(fish)\n  local i = 0\n  while true do i = i + 1 end\nend }\n",
        ),
        (
            "behaviors/fine.lua",
            "return { tick = function(fish) fish.memory.ticks = (fish.memory.ticks or 0) + 1 end }\n",
        ),
    ]);
    let mut h = host(&root);
    let spin = h.module("spin", 0.0).unwrap();
    let fine = h.module("fine", 0.0).unwrap();
    for _ in 0..3 {
        // Unmetered for its first millisecond, then the watchdog turns the hook on.
        assert_eq!(
            run(&mut h, spin, 0).unwrap_err().to_string(),
            format!("scripts/behaviors/spin.lua:3: {DEFAULT_BUDGET}")
        );
        run(&mut h, fine, 1).unwrap();
    }
    assert_eq!(h.memory_json(fish(1)), serde_json::json!({"ticks": 3}));

    let mut h = ScriptHost::new(&root, metered_from_start()).unwrap();
    let spin = h.module("spin", 0.0).unwrap();
    assert_eq!(
        run(&mut h, spin, 0).unwrap_err().to_string(),
        "scripts/behaviors/spin.lua:3: instruction budget exceeded (200000 instructions per call)"
    );
}

#[test]
fn test_loops_in_coroutines_are_stopped() {
    // Coroutines created while the call is still unmetered carry the budget hook themselves.
    let (_d, root) = scripts(&[
        (
            "behaviors/co.lua",
            "return { tick = function(fish)\n  local co = coroutine.create(function()\n    while true do end\n  end)\n  coroutine.resume(co)\nend }\n",
        ),
        (
            "behaviors/wrapped.lua",
            "return { tick = function(fish)\n  local f = coroutine.wrap(function(a)\n    local b = coroutine.yield(a + 1)\n    while b do end\n  end)\n  fish.memory.first = f(1)\n  f(true)\nend }\n",
        ),
    ]);
    let mut h = host(&root);
    assert_eq!(
        run_err(&mut h, "co"),
        format!("scripts/behaviors/co.lua:3: {DEFAULT_BUDGET}")
    );
    assert_eq!(
        run_err(&mut h, "wrapped"),
        format!("scripts/behaviors/wrapped.lua:4: {DEFAULT_BUDGET}")
    );
    // The wrapped coroutine passed values in and out before it was stopped.
    assert_eq!(h.memory_json(fish(0)), serde_json::json!({"first": 2}));
}

#[test]
#[cfg(target_os = "linux")]
fn test_short_calls_run_without_the_hook() {
    // A budget of 10 instructions stops the call at once when it is metered from the start, but
    // not when metering begins only after a second: short calls run without the hook.
    let (_d, root) = scripts(&[(
        "behaviors/short.lua",
        "return { tick = function(fish)\n  local s = 0\n  for i = 1, 2000 do s = s + i end\n  fish.memory.s = s\nend }\n",
    )]);
    let tiny = Limits {
        instructions_per_call: 10,
        metered_after: Duration::from_secs(1),
        ..Limits::default()
    };
    let mut h = ScriptHost::new(&root, tiny).unwrap();
    let m = h.module("short", 0.0).unwrap();
    for _ in 0..100 {
        run(&mut h, m, 0).unwrap();
    }
    assert_eq!(h.memory_json(fish(0)), serde_json::json!({"s": 2001000}));

    let mut h = ScriptHost::new(
        &root,
        Limits {
            metered_after: Duration::ZERO,
            ..tiny
        },
    )
    .unwrap();
    let m = h.module("short", 0.0).unwrap();
    assert_eq!(
        run(&mut h, m, 0).unwrap_err().to_string(),
        "scripts/behaviors/short.lua:3: instruction budget exceeded (10 instructions per call)"
    );
}

#[test]
fn test_pcall_cannot_swallow_the_budget() {
    let (_d, root) = scripts(&[(
        "behaviors/sneaky.lua",
        "return { tick = function(fish)\n  while true do\n    pcall(function() while true do end end)\n    coroutine.resume(coroutine.create(function() while true do end end))\n  end\nend }\n",
    )]);
    let mut h = host(&root);
    let err = run_err(&mut h, "sneaky");
    assert!(
        err.starts_with("scripts/behaviors/sneaky.lua:") && err.ends_with(DEFAULT_BUDGET),
        "{err}"
    );
}

#[test]
#[cfg(target_os = "linux")]
fn test_a_metered_call_leaves_the_next_one_unmetered() {
    // `slow` spends some 300 ms inside string.rep (few VM instructions; the sandbox's rep
    // copies 16 MiB in a few milliseconds), long enough for the
    // watchdog to turn the hook on; `loop` runs ~200,000 instructions in well under the delay.
    let (_d, root) = scripts(&[
        (
            "behaviors/slow.lua",
            "return { tick = function(fish)\n  for i = 1, 48 do local s = string.rep('x', 1 << 24) end\n  if fish.memory.then_loop then\n    local n = 0\n    for i = 1, 100000 do n = n + i end\n  end\nend }\n",
        ),
        (
            "behaviors/loop.lua",
            "return { tick = function(fish)\n  local n = 0\n  for i = 1, 100000 do n = n + i end\n  fish.memory.n = n\nend }\n",
        ),
    ]);
    let limits = Limits {
        instructions_per_call: 100_000,
        metered_after: Duration::from_millis(20),
        // The slow call runs ~300 ms on purpose: no time limit here.
        time_per_call: Duration::from_secs(600),
        ..Limits::default()
    };
    let mut h = ScriptHost::new(&root, limits).unwrap();
    let slow = h.module("slow", 0.0).unwrap();
    let fast = h.module("loop", 0.0).unwrap();
    // Unmetered, the loop fits however tight the budget.
    run(&mut h, fast, 1).unwrap();
    // Metered part-way through, the slow call then fails on the same loop...
    let t = h.fish_table(fish(0), "porgy", "test").unwrap();
    t.get::<mlua::Table>("memory")
        .unwrap()
        .set("then_loop", true)
        .unwrap();
    let err = run(&mut h, slow, 0).unwrap_err().to_string();
    assert!(
        err.starts_with("scripts/behaviors/slow.lua:5: instruction budget exceeded (100000"),
        "{err}"
    );
    // ... and the next calls run unmetered again, after an error and after a success.
    run(&mut h, fast, 1).unwrap();
    t.get::<mlua::Table>("memory")
        .unwrap()
        .set("then_loop", false)
        .unwrap();
    run(&mut h, slow, 0).unwrap();
    run(&mut h, fast, 1).unwrap();
    assert_eq!(
        h.memory_json(fish(1)),
        serde_json::json!({"n": 5000050000_i64})
    );
}

#[test]
fn test_budget_is_per_call() {
    // 150,000 instructions fit once, not twice: the budget is re-armed for every call.
    let (_d, root) = scripts(&[(
        "behaviors/busy.lua",
        "return { tick = function(fish)\n  local s = 0\n  for i = 1, 30000 do s = s + i end\n  fish.memory.s = s\nend }\n",
    )]);
    let mut h = ScriptHost::new(&root, metered_from_start()).unwrap();
    let m = h.module("busy", 0.0).unwrap();
    for _ in 0..10 {
        run(&mut h, m, 0).unwrap();
    }
    let tight = Limits {
        instructions_per_call: 50_000,
        ..metered_from_start()
    };
    let mut h = ScriptHost::new(&root, tight).unwrap();
    let m = h.module("busy", 0.0).unwrap();
    assert_eq!(
        run(&mut h, m, 0).unwrap_err().to_string(),
        "scripts/behaviors/busy.lua:3: instruction budget exceeded (50000 instructions per call)"
    );
}

#[test]
fn test_memory_bomb_is_an_error_not_a_crash() {
    let (_d, root) = scripts(&[
        (
            "behaviors/bomb.lua",
            "return { tick = function(fish)\n  local t = {}\n  while true do t[#t + 1] = string.rep('x', 4096) .. #t end\nend }\n",
        ),
        (
            "behaviors/fine.lua",
            "return { tick = function(fish) fish.memory.ok = true end }\n",
        ),
    ]);
    // Metered from the start: the soft limit is checked by the hook, and an unmetered call
    // could reach the hard limit (which names no line) before the watchdog turned it on.
    let limits = Limits {
        memory_bytes: 32 << 20,
        instructions_per_call: u64::MAX / 2,
        // The memory limit, not the time limit, must stop it (crates/script/tests/script/script_hostile.rs has the
        // bomb under the default limits).
        time_per_call: Duration::from_secs(600),
        ..metered_from_start()
    };
    let mut h = ScriptHost::new(&root, limits).unwrap();
    let bomb = h.module("bomb", 0.0).unwrap();
    let fine = h.module("fine", 0.0).unwrap();
    for _ in 0..2 {
        let err = run(&mut h, bomb, 0).unwrap_err().to_string();
        assert!(
            err.starts_with("scripts/behaviors/bomb.lua:3: memory limit exceeded ("),
            "{err}"
        );
        run(&mut h, fine, 1).unwrap();
    }
    assert_eq!(h.memory_json(fish(1)), serde_json::json!({"ok": true}));
}

#[test]
fn test_one_huge_allocation_is_an_error() {
    let (_d, root) = scripts(&[(
        "behaviors/huge.lua",
        "return { tick = function(fish)\n  local s = string.rep('x', 1 << 30)\nend }\n",
    )]);
    let limits = Limits {
        memory_bytes: 32 << 20,
        ..Limits::default()
    };
    let mut h = ScriptHost::new(&root, limits).unwrap();
    assert_eq!(
        run_err(&mut h, "huge"),
        // string.rep is a host function now, so the error has its line too.
        "scripts/behaviors/huge.lua:2: not enough memory"
    );
}

#[test]
fn test_syntax_error_names_file_and_line() {
    let (_d, root) = scripts(&[(
        "behaviors/broken.lua",
        "local M = {}\nfunction M.tick(fish)\n  if fish then\nend\nreturn M\n",
    )]);
    let mut h = host(&root);
    assert_eq!(h.module("broken", 0.0), None);
    let errs = h.load_errors();
    assert_eq!(
        errs.get("scripts/behaviors/broken.lua").map(String::as_str),
        Some(
            "scripts/behaviors/broken.lua:6: 'end' expected (to close 'function' at line 2) near <eof>"
        )
    );
}

#[test]
fn test_module_must_return_a_behaviour_table() {
    let (_d, root) = scripts(&[("behaviors/empty.lua", "return 42\n")]);
    let mut h = host(&root);
    assert_eq!(h.module("empty", 0.0), None);
    assert_eq!(
        h.error_messages(),
        [
            "scripts/behaviors/empty.lua: a behaviour must return a table with tick(fish) or perceive/intend/behave functions (got integer)"
        ]
    );
}

#[test]
fn test_repeated_errors_are_logged_once() {
    let (_d, root) = scripts(&[(
        "behaviors/oops.lua",
        "return { tick = function(fish)\n  local x = nil\n  return x.y\nend }\n",
    )]);
    let mut h = host(&root);
    let m = h.module("oops", 0.0).unwrap();
    for i in 0..100 {
        run(&mut h, m, i % 10).unwrap_err();
    }
    let msg = "scripts/behaviors/oops.lua:3: attempt to index a nil value (local 'x')";
    let log = h.drain_log();
    assert_eq!(log.len(), 1, "{log:?}");
    assert_eq!(log[0].message, msg);
    assert_eq!(log[0].level, LogLevel::Error);
    assert_eq!(log[0].fish, Some(fish(0)));
    assert_eq!(h.log_count(msg), 100);
    assert!(h.drain_log().is_empty());
    assert_eq!(h.fish_error(fish(7)), Some(msg));
}

#[test]
fn test_print_goes_to_the_console_with_its_line() {
    let (_d, root) = scripts(&[(
        "behaviors/talk.lua",
        "return { tick = function(fish)\n  print('hello', 3)\nend }\n",
    )]);
    let mut h = host(&root);
    let m = h.module("talk", 0.0).unwrap();
    run(&mut h, m, 0).unwrap();
    let log = h.drain_log();
    assert_eq!(log.len(), 1);
    assert_eq!(log[0].message, "scripts/behaviors/talk.lua:2: hello\t3");
    assert_eq!(log[0].level, LogLevel::Info);
}

#[test]
fn test_modules_have_their_own_globals() {
    let (_d, root) = scripts(&[
        (
            "behaviors/a.lua",
            "shared = 'a'\nreturn { tick = function(fish) fish.memory.a = shared end }\n",
        ),
        (
            "behaviors/b.lua",
            "return { tick = function(fish) fish.memory.b = tostring(shared) end }\n",
        ),
    ]);
    let mut h = host(&root);
    let a = h.module("a", 0.0).unwrap();
    let b = h.module("b", 0.0).unwrap();
    run(&mut h, a, 0).unwrap();
    run(&mut h, b, 0).unwrap();
    assert_eq!(
        h.memory_json(fish(0)),
        serde_json::json!({"a": "a", "b": "nil"})
    );
}
