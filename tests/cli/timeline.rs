//! Time travel headless (issue 14): record a run, replay it from a moment with the same or
//! edited scripts, compare runs; recordings are checked when read.

use crate::common;

use std::path::Path;
use std::process::Command;

use shoal_script::timeline::run_file::{FORMAT, Run, RunFileError};
use shoal_script::timeline::{self, RecordSpec, ReplaySpec};

fn record(root: &Path, lanes: usize, seconds: f64) -> Run {
    timeline::record(&RecordSpec {
        root,
        scripts: &root.join("scripts"),
        scene: "scenes/default.lua",
        seed: 5,
        lanes,
        seconds,
        lod: None,
    })
    .unwrap()
}

fn replay(run: &Run, root: &Path, from_s: f64) -> Run {
    timeline::replay(&ReplaySpec {
        run,
        run_name: "a.shoalrun",
        root,
        scripts: &root.join("scripts"),
        from_s,
        seconds: None,
    })
    .unwrap()
}

#[test]
fn a_recording_survives_the_disk_and_replays_exactly_with_its_own_scripts() {
    let dir = tempfile::tempdir().unwrap();
    for lanes in [1, 2] {
        let run = record(common::repo(), lanes, 6.0);
        assert_eq!(run.frames.len(), 361);
        assert_eq!(run.frames[0].len(), 37);
        assert!(run.header.scripts.contains_key("behaviors/forage.lua"));
        let path = dir.path().join(format!("a{lanes}.shoalrun"));
        run.write(&path).unwrap();
        let back = Run::read(&path).unwrap();
        assert_eq!(back, run);

        let again = replay(&back, common::repo(), 2.5);
        assert_eq!(again.frames, run.frames, "{lanes} lanes");
        let d = timeline::diff(&run, &again);
        assert!(!d.diverged && d.first_divergence_s.is_none());
        assert_eq!(d.ticks_compared, 360);
        let of = again.header.replay_of.as_ref().unwrap();
        assert!(of.changed.is_empty());
        assert_eq!(of.from_s, 2.5);
    }
}

#[test]
fn replaying_with_an_edited_behaviour_departs_only_after_the_moment_chosen() {
    let (_dir, root) = common::scratch_repo();
    let run = record(&root, 2, 8.0);
    let forage = root.join("scripts/behaviors/forage.lua");
    let src = std::fs::read_to_string(&forage).unwrap();
    assert!(src.contains("common.wander(fish, 1.2)"));
    std::fs::write(
        &forage,
        src.replace("common.wander(fish, 1.2)", "common.wander(fish, 2.5)"),
    )
    .unwrap();
    let from = 3.0;
    let edited = replay(&run, &root, from);
    assert_eq!(
        edited.header.replay_of.as_ref().unwrap().changed,
        vec!["behaviors/forage.lua".to_owned()]
    );
    assert_eq!(edited.frames.len(), run.frames.len());
    let k = (from * 60.0) as usize;
    assert_eq!(
        edited.frames[..=k],
        run.frames[..=k],
        "identical up to the moment"
    );
    let d = timeline::diff(&run, &edited);
    assert!(d.diverged);
    let first = d.first_divergence_s.unwrap();
    assert!(first > from && first < 8.0, "parts at {first}");
    let parted = d.fish.iter().filter(|f| f.first_divergence_s.is_some());
    assert!(parted.clone().count() >= 1);
    assert!(
        parted
            .clone()
            .all(|f| f.first_divergence_s.unwrap() >= first)
    );
    assert!(
        d.fish[0].first_divergence_s == Some(first),
        "sorted by parting time"
    );
    assert!(d.fish.iter().any(|f| f.max_separation > 1.0));
}

#[test]
fn a_damaged_recording_is_a_clear_error_naming_the_file() {
    let run = record(common::repo(), 1, 0.5);
    let bytes = run.to_bytes();
    let path = Path::new("runs/x.shoalrun");
    let err = |b: &[u8]| Run::from_bytes(b, path).unwrap_err();

    let e = err(b"hello");
    assert!(matches!(e, RunFileError::NotARun { .. }), "{e}");
    for cut in [10, 40, bytes.len() / 2, bytes.len() - 2] {
        let e = err(&bytes[..cut]);
        assert!(
            matches!(e, RunFileError::Truncated { .. }),
            "cut at {cut}: {e}"
        );
        assert!(
            e.to_string().starts_with("runs/x.shoalrun: truncated"),
            "{e}"
        );
    }
    let mut flipped = bytes.clone();
    let mid = bytes.len() - 100;
    flipped[mid] ^= 1;
    let e = err(&flipped);
    assert!(matches!(e, RunFileError::Corrupt { .. }), "{e}");
    let mut newer = bytes.clone();
    newer[8..12].copy_from_slice(&(FORMAT + 1).to_le_bytes());
    let e = err(&newer).to_string();
    assert!(e.contains(&format!("format {}", FORMAT + 1)), "{e}");
}

#[test]
fn the_commands_record_replay_and_diff_as_a_designer_uses_them() {
    let dir = tempfile::tempdir().unwrap();
    let shoal = env!("CARGO_BIN_EXE_shoal");
    let run = |args: &[&str]| {
        let out = Command::new(shoal)
            .args(args)
            .current_dir(dir.path())
            .env("SHOAL_SCRIPTS", common::repo().join("scripts"))
            .output()
            .unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (ok, out, err) = run(&[
        "record",
        "--seconds",
        "2",
        "--lanes",
        "2",
        "--out",
        "a.shoalrun",
    ]);
    assert!(ok, "{out}{err}");
    assert!(
        out.contains("recorded 2.00 s of scenes/default.lua"),
        "{out}"
    );
    let (ok, out, err) = run(&["replay", "a.shoalrun", "--from", "1", "--out", "b.shoalrun"]);
    assert!(ok, "{out}{err}");
    assert!(out.contains("replay should match it exactly"), "{out}");
    let (ok, out, err) = run(&[
        "diff",
        "a.shoalrun",
        "b.shoalrun",
        "--json",
        "--plot",
        "d.png",
    ]);
    assert!(ok, "{out}{err}");
    let json: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(json["diverged"], false);
    assert!(json["first_divergence_s"].is_null());
    assert!(dir.path().join("d.png").is_file());

    let (ok, _, err) = run(&["replay", "a.shoalrun", "--from", "9", "--out", "c.shoalrun"]);
    assert!(
        !ok && err.contains("after the end of the recording"),
        "{err}"
    );
    let (ok, _, err) = run(&["record", "--seconds", "1", "--out", "c.json"]);
    assert!(!ok && err.contains(".shoalrun"), "{err}");
    std::fs::write(dir.path().join("junk.shoalrun"), "not a run").unwrap();
    let (ok, _, err) = run(&["diff", "a.shoalrun", "junk.shoalrun"]);
    assert!(
        !ok && err.contains("junk.shoalrun: not a shoal recording"),
        "{err}"
    );
}
