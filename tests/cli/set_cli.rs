//! `shoal set` as a designer runs it: good edits change only their literals, bad ones are one
//! line naming the file and key, and `shoal check` stays clean on the saved files.

use std::path::Path;
use std::process::{Command, Output};

use crate::common::scratch_repo;

fn shoal(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shoal"))
        .current_dir(cwd)
        .env_remove("RUST_LOG")
        .env_remove("SHOAL_SCRIPTS")
        .args(args)
        .output()
        .unwrap()
}

fn err(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn test_set_writes_only_the_named_literals() {
    let (_dir, root) = scratch_repo();
    let porgy = root.join("scripts/species/black_porgy.lua");
    let before = std::fs::read_to_string(&porgy).unwrap();
    let out = shoal(
        &root,
        &[
            "set",
            "scripts/species/black_porgy.lua",
            "motion.s=70",
            "view_range=260",
        ],
    );
    assert!(out.status.success(), "{}", err(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("set motion.s = 70, view_range = 260"),
        "{stdout}"
    );
    let after = std::fs::read_to_string(&porgy).unwrap();
    let tail = "(staggered over the 60 Hz tick)\n";
    assert_eq!(
        after,
        before.replacen(
            tail,
            &format!("{tail}  motion = {{ s = 70 }},\n  view_range = 260,\n"),
            1
        )
    );

    let scene = root.join("scripts/scenes/default.lua");
    let before = std::fs::read_to_string(&scene).unwrap();
    let out = shoal(
        &root,
        &[
            "set",
            "scripts/scenes/default.lua",
            "obstacles[2].pos={-300, 40, 150}",
        ],
    );
    assert!(out.status.success(), "{}", err(&out));
    assert_eq!(
        std::fs::read_to_string(&scene).unwrap(),
        before.replacen("pos = { -280, 40, 150 }", "pos = { -300, 40, 150 }", 1)
    );
}

#[test]
fn test_set_refuses_bad_input_in_one_line_and_writes_nothing() {
    let (_dir, root) = scratch_repo();
    let file = "scripts/species/barracuda.lua";
    let before = std::fs::read_to_string(root.join(file)).unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["motion.lamda=90"], "did you mean \"lambda\"?"),
        (
            &["motion.s=fast"],
            "barracuda.lua:12: motion.s is a number in the file",
        ),
        (
            &["motion.max_amp=14"],
            "barracuda.lua:13: motion.max_amp is written as an expression (`80 * 0.16`)",
        ),
        (&["motion.s"], "expected KEY.PATH=VALUE"),
        (&["motion.s=-5"], "motion"),
    ];
    for (args, want) in cases {
        let mut all = vec!["set", file];
        all.extend_from_slice(args);
        let out = shoal(&root, &all);
        let e = err(&out);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(
            e.starts_with("error: ") && e.contains(want),
            "{args:?}: {e}"
        );
        assert_eq!(e.trim_end().lines().count(), 1, "{args:?}: one line: {e}");
    }
    assert_eq!(std::fs::read_to_string(root.join(file)).unwrap(), before);
    // Asked for, the expression is replaced and kept in a comment.
    let out = shoal(
        &root,
        &["set", file, "motion.max_amp=14", "--replace-expressions"],
    );
    assert!(out.status.success(), "{}", err(&out));
    assert_eq!(
        std::fs::read_to_string(root.join(file)).unwrap(),
        before.replacen(
            "max_amp = 80 * 0.16,",
            "max_amp = 14 --[[was: 80 * 0.16]],",
            1
        )
    );
}

#[test]
fn test_check_stays_clean_on_saved_files() {
    let (_dir, root) = scratch_repo();
    let out = shoal(
        &root,
        &[
            "set",
            "scripts/species/black_porgy.lua",
            "motion.s=70",
            "motion.omega=12.5",
        ],
    );
    assert!(out.status.success(), "{}", err(&out));
    let out = shoal(
        &root,
        &[
            "set",
            "scripts/species/barracuda.lua",
            "motion.max_amp=14",
            "--replace-expressions",
        ],
    );
    assert!(out.status.success(), "{}", err(&out));
    let out = shoal(
        &root,
        &[
            "set",
            "scripts/scenes/default.lua",
            "obstacles[1].radius=70",
            "food_lifetime=60",
        ],
    );
    assert!(out.status.success(), "{}", err(&out));
    // (Without a config of its own, the copy is checked with shoal's.)
    let out = shoal(
        &root,
        &[
            "check",
            "scripts/species/black_porgy.lua",
            "scripts/species/barracuda.lua",
            "scripts/scenes/default.lua",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "check: {stdout}{}", err(&out));
    assert!(stdout.contains("check: no diagnostics"), "{stdout}");
}
