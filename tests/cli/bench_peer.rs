//! `shoal bench peer` runs shoal's bench scene beside a pure-Lua peer and prints the ratios (issue
//! 18). The real peer lives outside the repository, so these tests hand the command a small
//! stand-in with the same interface (arguments, the `WARM_S, MEAS_S` line, the report lines) and
//! run it under shoal's own Lua (`--engines mlua`), which needs nothing installed. No timing is
//! asserted: the figures the stand-in prints are fixed, so the ratios can be checked exactly.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A peer with the real one's interface: fish from `arg[1]`, run length from the
/// `WARM_S, MEAS_S` line, and fixed figures (0.5 ms per tick, 2 µs per decision).
const STAND_IN: &str = r#"-- stand-in for ../shared/bench/peer_school.lua
local N = tonumber(arg and arg[1]) or 1000
local FOOD = tonumber(arg and arg[2]) or 30
local MODE = (arg and arg[3]) or "shoal"
local WARM_S, MEAS_S = 1, 5
local x = 0
for i = 1, N * 10 do x = x + math.sin(i) end
local engine = (jit and jit.version) or _VERSION
print(string.format("engine=%s  jit=%s  fish=%d (predators %d)  food=%d  mode=%s", engine, "-", N,
  math.floor(N / 100), FOOD, MODE))
print(string.format("ticks measured %d after %d warm-up; decisions/tick %.1f",
  math.floor(MEAS_S * 60 + 0.5), WARM_S * 60, N / 6))
print("median ms/tick 0.500  (p99 0.900)   [grid 0.100  decide 0.300  motion 0.100 ms medians]")
print("us/decision (mean CPU) 2.000")
print("us/fish/tick motion+grid (median) 0.2000   [grid 0.1000  motion 0.1000]")
"#;

fn write_peer(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn shoal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shoal"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env_remove("SHOAL_PEER")
        .args(["bench", "peer", "--seconds", "0.2", "--fish", "100"])
        .args(args)
        .output()
        .expect("run shoal")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn prints_shoal_and_the_peer_with_the_ratios() {
    let dir = tempfile::tempdir().unwrap();
    let peer = write_peer(dir.path(), "peer.lua", STAND_IN);
    let out = shoal(&["--engines", "mlua", "--peer", peer.to_str().unwrap()]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    let shoal_row = text
        .lines()
        .find(|l| l.trim_start().starts_with("100  shoal ("))
        .unwrap_or_else(|| panic!("no shoal row in:\n{text}"));
    let peer_row = text
        .lines()
        .find(|l| l.trim_start().starts_with("100  mlua (Lua 5.4)"))
        .unwrap_or_else(|| panic!("no peer row in:\n{text}"));
    assert!(
        peer_row.contains("0.500") && peer_row.contains("2.00"),
        "{peer_row}"
    );
    assert_eq!(
        peer_row.matches('×').count(),
        2,
        "tick and decision ratios: {peer_row}"
    );
    assert!(!shoal_row.contains('×'), "{shoal_row}");
    assert!(text.contains("ratios are shoal ÷ peer"), "{text}");
}

#[test]
fn json_carries_the_figures_and_ratios_and_the_seconds_reach_the_peer() {
    let dir = tempfile::tempdir().unwrap();
    let peer = write_peer(dir.path(), "peer.lua", STAND_IN);
    let out = shoal(&[
        "--engines",
        "mlua",
        "--peer",
        peer.to_str().unwrap(),
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let r = &v["results"][0];
    assert_eq!(r["fish"].as_u64(), Some(100));
    let shoal_ms = r["shoal"]["median_ms"].as_f64().unwrap();
    let shoal_us = r["shoal"]["us_per_decision"].as_f64().unwrap();
    assert!(shoal_ms > 0.0 && shoal_us > 0.0);
    assert_eq!(r["shoal"]["ticks"].as_u64(), Some(12), "0.2 s at 60 Hz");
    let p = &r["peers"][0];
    assert_eq!(p["engine"], "mlua");
    assert_eq!(p["version"], "Lua 5.4");
    assert_eq!(p["fish"].as_u64(), Some(100), "arg[1] reached the peer");
    assert_eq!(p["ticks"].as_u64(), Some(12), "--seconds rewrote MEAS_S");
    assert_eq!(p["median_ms"].as_f64(), Some(0.5));
    assert_eq!(p["us_per_decision"].as_f64(), Some(2.0));
    let tick_ratio = p["tick_ratio"].as_f64().unwrap();
    assert!((tick_ratio - shoal_ms / 0.5).abs() < 1e-9, "{tick_ratio}");
    let decision_ratio = p["decision_ratio"].as_f64().unwrap();
    assert!(
        (decision_ratio - shoal_us / 2.0).abs() < 1e-9,
        "{decision_ratio}"
    );
}

#[test]
fn a_missing_interpreter_is_named_with_its_package_and_the_rest_runs() {
    let dir = tempfile::tempdir().unwrap();
    let peer = write_peer(dir.path(), "peer.lua", STAND_IN);
    let empty = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("PATH", empty.path())
        .args(["bench", "peer", "--seconds", "0.2", "--fish", "100"])
        .args(["--engines", "luajit,lua5.4,mlua", "--peer"])
        .arg(&peer)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(
        err.contains("`luajit` is not installed") && err.contains("apt-get install luajit"),
        "{err}"
    );
    assert!(err.contains("apt-get install lua5.4"), "{err}");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("mlua (Lua 5.4)"), "{text}");
    assert!(!text.contains("luajit ("), "{text}");
}

#[test]
fn a_missing_peer_is_an_error_naming_the_path() {
    let out = shoal(&[
        "--engines",
        "mlua",
        "--peer",
        "/nonexistent/peer_school.lua",
    ]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("/nonexistent/peer_school.lua") && err.contains("no such file"),
        "{err}"
    );
    // The default: beside the repository root given by --root. The root is a folder inside the
    // test's own temporary directory, so its `../shared` is in there too (and absent), whatever
    // happens to sit beside the system's temporary directory.
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("repo");
    std::fs::create_dir(&root).unwrap();
    let out = shoal(&["--engines", "mlua", "--root", root.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("../shared/bench/peer_school.lua") && err.contains("--peer PATH"),
        "{err}"
    );
}

#[test]
fn a_peer_that_reports_something_else_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let silent = write_peer(
        dir.path(),
        "silent.lua",
        "local WARM_S, MEAS_S = 1, 5\nprint('hello')\n",
    );
    let out = shoal(&["--engines", "mlua", "--peer", silent.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("silent.lua under mlua: expected a line like"),
        "{err}"
    );
    assert!(err.contains("hello"), "shows what it printed: {err}");

    let other = write_peer(dir.path(), "other.lua", "print('not a peer')\n");
    let out = shoal(&["--engines", "mlua", "--peer", other.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("other.lua: expected a line `local WARM_S, MEAS_S"),
        "{err}"
    );

    let broken = write_peer(
        dir.path(),
        "broken.lua",
        "local WARM_S, MEAS_S = 1, 5\nerror('boom')\n",
    );
    let out = shoal(&["--engines", "mlua", "--peer", broken.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains("broken.lua:2: boom"),
        "file:line of the peer's error: {err}"
    );
}

/// `--repeat 3` against the stand-in under `mlua`, with `extra` arguments.
fn three_rounds(extra: &[&str]) -> Output {
    let dir = tempfile::tempdir().unwrap();
    let peer = write_peer(dir.path(), "peer.lua", STAND_IN);
    let mut args = vec![
        "--engines",
        "mlua",
        "--peer",
        peer.to_str().unwrap(),
        "--repeat",
        "3",
    ];
    args.extend_from_slice(extra);
    shoal(&args)
}

#[test]
fn repeated_rounds_print_each_round_and_the_medians_of_their_ratios() {
    let out = three_rounds(&[]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    let shoal_rows = text
        .lines()
        .filter(|l| l.trim_start().starts_with("100  shoal ("))
        .count();
    assert_eq!(shoal_rows, 3, "one shoal row per round:\n{text}");
    assert!(text.contains("3 rounds per fish count"), "{text}");
    let (_, after) = text
        .split_once("medians over 3 rounds")
        .unwrap_or_else(|| panic!("no summary in:\n{text}"));
    let row = after
        .lines()
        .find(|l| l.trim_start().starts_with("100  mlua"))
        .unwrap_or_else(|| panic!("no summary row in:\n{after}"));
    // The peer's median is its fixed 0.5 ms; three ratios with their ranges.
    assert!(row.contains("0.500"), "{row}");
    assert_eq!(row.matches('×').count(), 3, "{row}");
}

#[test]
fn json_summary_is_the_median_and_range_of_the_rounds_ratios() {
    let out = three_rounds(&["--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let results = v["results"].as_array().unwrap();
    assert_eq!(results.len(), 3);
    let rounds: Vec<u64> = results
        .iter()
        .map(|r| r["round"].as_u64().unwrap())
        .collect();
    assert_eq!(rounds, [1, 2, 3]);
    let mut ticks: Vec<f64> = results
        .iter()
        .map(|r| r["peers"][0]["tick_ratio"].as_f64().unwrap())
        .collect();
    ticks.sort_by(f64::total_cmp);
    let summary = &v["summary"][0];
    assert_eq!(summary["fish"].as_u64(), Some(100));
    assert_eq!(summary["engine"], "mlua");
    assert_eq!(summary["rounds"].as_u64(), Some(3));
    assert_eq!(summary["tick_ratio"]["median"].as_f64(), Some(ticks[1]));
    assert_eq!(summary["tick_ratio"]["min"].as_f64(), Some(ticks[0]));
    assert_eq!(summary["tick_ratio"]["max"].as_f64(), Some(ticks[2]));
    assert_eq!(summary["peer_median_ms"].as_f64(), Some(0.5));
    // The stages ratio: shoal's grid + motion + skeleton + palette (wall × threads) per
    // fish-tick over the stand-in's 0.2 µs of grid + motion.
    for r in results {
        let s = &r["shoal"];
        let st = &s["stages_ms"];
        let ms: f64 = ["grid", "motion", "skeleton", "palette"]
            .iter()
            .map(|k| st[*k].as_f64().unwrap())
            .sum();
        let want = ms * 1000.0 * s["threads"].as_f64().unwrap() / 100.0 / 0.2;
        let got = r["peers"][0]["stages_ratio"].as_f64().unwrap();
        assert!(
            (got - want).abs() <= 1e-9 * want.max(1.0),
            "{got} vs {want}"
        );
    }
}

#[test]
fn zero_rounds_is_refused() {
    let out = shoal(&["--engines", "mlua", "--repeat", "0"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("--repeat 0"), "{}", stderr(&out));
}
