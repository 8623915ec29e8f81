//! The watchdog's limit on watched Lua states. The test takes every watch slot of the process,
//! which would change the budget messages of the tests running beside it in this binary: it
//! runs alone, in a process of its own (this binary run again with only it selected).

use std::path::PathBuf;

use shoal_core::world::FishId;
use shoal_script::Limits;
use shoal_script::host::ScriptHost;
use shoal_script::watchdog::SLOTS;

fn scripts(files: &[(&str, &str)]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("scripts");
    for (name, src) in files {
        let p = root.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, src).unwrap();
    }
    (dir, root)
}

/// Set in the process that runs the test alone.
const ALONE: &str = "SHOAL_TEST_WATCHDOG_ALONE";

#[test]
fn test_states_beyond_the_watch_slots_are_metered_from_the_start() {
    if std::env::var_os(ALONE).is_none() {
        let name = "script_watchdog::test_states_beyond_the_watch_slots_are_metered_from_the_start";
        let out = std::process::Command::new(std::env::current_exe().unwrap())
            .args(["--exact", name, "--test-threads=1"])
            .env(ALONE, "1")
            .output()
            .expect("the test binary runs again");
        let said = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success() && said.contains("1 passed"),
            "{name} in its own process:\n{said}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        return;
    }
    // Only SLOTS states can be watched at once; the others meter every call from its first
    // instruction (and say so). Either way a runaway stops.
    let (_d, root) = scripts(&[(
        "behaviors/spin.lua",
        "return { tick = function(fish)\n  while true do end\nend }\n",
    )]);
    let mut hosts: Vec<ScriptHost> = (0..=SLOTS)
        .map(|_| ScriptHost::new(&root, Limits::default()).unwrap())
        .collect();
    let exact =
        "scripts/behaviors/spin.lua:2: instruction budget exceeded (200000 instructions per call)";
    let watched = "scripts/behaviors/spin.lua:2: instruction budget exceeded (200000 instructions per call, counted once a call has run 1 ms)";
    let mut metered_from_start = 0;
    for (i, h) in hosts.iter_mut().enumerate() {
        let fish = FishId {
            index: i as u32,
            generation: 0,
        };
        let m = h.module("spin", 0.0).unwrap();
        let t = h.fish_table(fish, "porgy", "test").unwrap();
        let err = h.run(m, fish, &t, 0.0).unwrap_err().to_string();
        if err == exact {
            metered_from_start += 1;
        } else if cfg!(target_os = "linux") {
            assert_eq!(err, watched);
        }
    }
    if cfg!(target_os = "linux") {
        assert_eq!(metered_from_start, 1, "one state more than slots");
    } else {
        assert_eq!(metered_from_start, SLOTS + 1, "no watchdog here");
    }
}
