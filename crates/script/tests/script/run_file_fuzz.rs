//! A recording is an input too (issue 36, finding 9): every header field is checked against
//! what shoal can run, each refusal one line naming the field, and a mutation fuzz harness
//! (the checksum recomputed, so that mutations reach the parser, as the glTF importer's
//! harness does for its files) checks that no `.shoalrun` makes the reader panic or lets an
//! impossible header through.
//!
//! `SHOAL_FUZZ_CASES` sets the number of cases (default 300) and `SHOAL_FUZZ_SEED` the seed.

use crate::common;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde_json::{Value, json};
use shoal_script::timeline::run_file::{MAX_LANES, Run, RunFileError};
use shoal_script::timeline::{self, RecordSpec};

const PATH: &str = "runs/x.shoalrun";

/// Half a second of the default scene, recorded.
fn recording() -> Run {
    timeline::record(&RecordSpec {
        root: common::repo(),
        scripts: &common::repo().join("scripts"),
        scene: "scenes/default.lua",
        seed: 5,
        lanes: 1,
        seconds: 0.5,
        lod: None,
    })
    .unwrap()
}

/// A recording's header (as JSON) and frame bytes.
fn split(bytes: &[u8]) -> (Value, Vec<u8>) {
    let word = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
    let header_len = word(12);
    let header = serde_json::from_slice(&bytes[20..20 + header_len]).unwrap();
    let frames_at = 20 + header_len;
    let frames_len = word(frames_at);
    (
        header,
        bytes[frames_at + 8..frames_at + 8 + frames_len].to_vec(),
    )
}

/// A recording from its parts, its checksum computed, as shoal writes one.
fn join(header: &[u8], frames: &[u8]) -> Vec<u8> {
    let mut out = b"SHOALRUN".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend((header.len() as u64).to_le_bytes());
    out.extend(header);
    out.extend((frames.len() as u64).to_le_bytes());
    out.extend(frames);
    let crc = crc32fast::hash(&out);
    out.extend(crc.to_le_bytes());
    out
}

fn with_header(bytes: &[u8], edit: impl FnOnce(&mut Value)) -> Vec<u8> {
    let (mut header, frames) = split(bytes);
    edit(&mut header);
    join(&serde_json::to_vec(&header).unwrap(), &frames)
}

/// A change to a recording's header (as JSON).
type HeaderEdit = Box<dyn Fn(&mut Value)>;

#[test]
fn every_header_field_is_checked_with_one_line_naming_it() {
    let bytes = recording().to_bytes();
    let path = Path::new(PATH);
    // The unchanged parts read back: the test's own writer matches shoal's.
    let (header, frames) = split(&bytes);
    Run::from_bytes(&join(&serde_json::to_vec(&header).unwrap(), &frames), path).unwrap();
    let forage_crc = header["scripts"]["behaviors/forage.lua"]["crc32"].clone();
    let cases: Vec<(HeaderEdit, &str)> = vec![
        (
            Box::new(|h| h["lanes"] = json!(1_000_000_000u64)),
            "lanes: 1000000000 is out of range",
        ),
        (
            Box::new(|h| h["lanes"] = json!(0)),
            "lanes: 0 is out of range",
        ),
        (
            Box::new(|h| h["tick_hz"] = json!(1e-300)),
            "tick_hz: 1e-300 is not shoal's tick rate",
        ),
        (Box::new(|h| h["tick_hz"] = json!(30.0)), "tick_hz: 30.0"),
        (
            Box::new(|h| h["tank"] = json!([[0, 0, 0], [0, 10, 10]])),
            "tank: min [0.0, 0.0, 0.0] must be below max",
        ),
        (
            Box::new(|h| h["tank"][1][2] = json!(1e300)),
            "tank[1][2]: number out of range",
        ),
        (
            Box::new(|h| {
                let s = h["scripts"]["behaviors/forage.lua"].clone();
                h["scripts"]["../../evil.lua"] = s;
            }),
            "scripts: `../../evil.lua` is not a .lua file inside the scripts directory",
        ),
        (
            Box::new(|h| {
                let s = h["scripts"]["behaviors/forage.lua"].clone();
                h["scripts"]["/etc/evil.lua"] = s;
            }),
            "scripts: `/etc/evil.lua`",
        ),
        (
            Box::new(|h| h["scripts"]["behaviors/forage.lua"]["text"] = json!("return {}")),
            "scripts.behaviors/forage.lua: its crc32 does not match its text",
        ),
        (Box::new(|h| h["scripts"] = json!({})), "scripts: none"),
        (
            Box::new(|h| h["scene"] = json!("../scenes/default.lua")),
            "scene: `../scenes/default.lua` is not a path inside",
        ),
        (
            Box::new(|h| h["scene"] = json!("scenes/nope.lua")),
            "scene: `scenes/nope.lua` is not among",
        ),
        (
            Box::new(|h| {
                h["inputs"] = json!([{ "tick": 100000, "input": { "kind": "food", "pos": [0.0, 100.0, 0.0] } }])
            }),
            "inputs: one at tick 100000, after the recording's last frame (tick 30)",
        ),
        (
            Box::new(
                |h| h["inputs"] = json!([{ "tick": 1, "input": { "kind": "obstacle", "pos": [0.0, 1e300, 0.0], "radius": 5.0 } }]),
            ),
            "inputs[1].pos: inf is not a finite number",
        ),
        (
            Box::new(|h| {
                h["replay_of"] = json!({ "run": "a.shoalrun", "from_s": 1e9, "changed": [] })
            }),
            "replay_of.from_s: 1000000000.0 is not a time inside the recording",
        ),
        (
            Box::new(|h| {
                h["replay_of"] =
                    json!({ "run": "a.shoalrun", "from_s": 0.1, "changed": ["../x.lua"] })
            }),
            "replay_of.changed: `../x.lua`",
        ),
    ];
    assert!(!forage_crc.is_null());
    for (edit, expected) in cases {
        let e = Run::from_bytes(&with_header(&bytes, edit), path).unwrap_err();
        let text = e.to_string();
        assert!(
            matches!(e, RunFileError::Header { .. }),
            "{expected}: {text}"
        );
        assert!(
            text.starts_with(&format!("{PATH}: bad header: ")) && text.contains(expected),
            "expected `{expected}` in: {text}"
        );
        assert!(!text.contains('\n'), "one line: {text}");
    }
}

/// Every JSON pointer under `v`.
fn pointers(v: &Value, at: String, out: &mut Vec<String>) {
    out.push(at.clone());
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                // Script texts are long and not the header's structure: mutate them whole.
                let k = k.replace('~', "~0").replace('/', "~1");
                pointers(x, format!("{at}/{k}"), out);
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                pointers(x, format!("{at}/{i}"), out);
            }
        }
        _ => {}
    }
}

/// A value a hostile or careless editor might put in place of `old`.
fn hostile(rng: &mut Pcg64, old: &Value) -> Value {
    match rng.random_range(0..12) {
        0 => json!(u64::MAX),
        1 => json!(1_000_000_000u64),
        2 => json!(-1),
        3 => json!(1e-300),
        4 => json!(1e300),
        5 => json!(0),
        6 => json!("../../etc/passwd"),
        7 => json!(""),
        8 => Value::Null,
        9 => json!([]),
        10 => json!({}),
        _ => match old {
            Value::Number(n) => json!(n.as_f64().unwrap_or(0.0) * rng.random_range(-3.0..3.0)),
            Value::String(s) => json!(format!("{s}/../x")),
            _ => json!(rng.random_range(0..8)),
        },
    }
}

fn mutate_json(rng: &mut Pcg64, json: &mut Value) {
    let mut all = Vec::new();
    pointers(json, String::new(), &mut all);
    let at = all[rng.random_range(0..all.len())].clone();
    let Some(target) = json.pointer_mut(&at) else {
        return;
    };
    match target {
        Value::Object(m) if !m.is_empty() && rng.random_bool(0.4) => {
            let k = m.keys().nth(rng.random_range(0..m.len())).cloned().unwrap();
            if rng.random_bool(0.5) {
                m.remove(&k);
            } else {
                // The same entry under a hostile name (a script path out of the directory).
                let v = m[&k].clone();
                m.insert(format!("../{k}"), v);
            }
        }
        Value::Array(a) if !a.is_empty() && rng.random_bool(0.5) => {
            if rng.random_bool(0.5) {
                a.truncate(rng.random_range(0..a.len()));
            } else {
                let dup = a[rng.random_range(0..a.len())].clone();
                a.push(dup);
            }
        }
        other => *other = hostile(rng, other),
    }
}

fn mutate_frames(rng: &mut Pcg64, frames: &mut Vec<u8>) {
    match rng.random_range(0..4) {
        0 => frames.truncate(rng.random_range(0..=frames.len())),
        1 if frames.len() >= 4 => {
            // A frame's fish count (the first one's, or a word anywhere).
            let at = if rng.random_bool(0.5) {
                0
            } else {
                rng.random_range(0..frames.len() - 3)
            };
            let v = rng.random::<u32>() >> rng.random_range(0..32);
            frames[at..at + 4].copy_from_slice(&v.to_le_bytes());
        }
        2 if !frames.is_empty() => {
            let at = rng.random_range(0..frames.len());
            frames[at] ^= 1 << rng.random_range(0..8);
        }
        _ => {}
    }
}

fn env_number(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

#[test]
fn mutated_recordings_never_panic_and_no_impossible_header_gets_through() {
    let cases = env_number("SHOAL_FUZZ_CASES", 300);
    let seed = env_number("SHOAL_FUZZ_SEED", 1);
    let original = recording().to_bytes();
    let (header, frames) = split(&original);
    let path = Path::new(PATH);
    let mut rng = Pcg64::seed_from_u64(seed);
    let (mut read, mut refused) = (0u64, 0u64);
    for case in 0..cases {
        let (mut h, mut f) = (header.clone(), frames.clone());
        for _ in 0..rng.random_range(1..4) {
            if rng.random_bool(0.75) {
                mutate_json(&mut rng, &mut h);
            } else {
                mutate_frames(&mut rng, &mut f);
            }
        }
        let bytes = join(&serde_json::to_vec(&h).unwrap(), &f);
        match catch_unwind(AssertUnwindSafe(|| Run::from_bytes(&bytes, path))) {
            Ok(Ok(run)) => {
                read += 1;
                let h = &run.header;
                assert!((1..=MAX_LANES).contains(&h.lanes), "case {case}: {h:?}");
                assert_eq!(h.tick_hz, shoal_core::world::TICK_HZ, "case {case}");
                assert!(
                    h.tank[0].iter().zip(&h.tank[1]).all(|(a, b)| a < b),
                    "case {case}"
                );
                for rel in h.scripts.keys().chain([&h.scene]) {
                    assert!(
                        !rel.split('/').any(|c| c == ".." || c.is_empty()) && !rel.starts_with('/'),
                        "case {case}: `{rel}` outside the scripts"
                    );
                }
                assert!(!run.frames.is_empty());
            }
            Ok(Err(e)) => {
                refused += 1;
                let text = e.to_string();
                assert!(text.starts_with(PATH), "case {case}: {text}");
                assert!(!text.contains('\n'), "case {case}: one line: {text}");
            }
            Err(_) => {
                let keep =
                    std::env::temp_dir().join(format!("shoal-run-fuzz-{seed}-{case}.shoalrun"));
                std::fs::write(&keep, &bytes).unwrap();
                panic!(
                    "mutated case {case} (seed {seed}) panicked; the file is {}",
                    keep.display()
                );
            }
        }
    }
    println!("{cases} cases (seed {seed}): {read} read, {refused} refused, none panicked");
    assert!(
        refused > cases / 4,
        "the mutations must break many recordings: {refused}"
    );
    assert!(
        read > 0,
        "some mutations are harmless (a seed, a shoal version): {read}"
    );
}
