//! A mutation fuzz harness for the glTF importer (the path `shoal skin`, `shoal run` and species
//! assets share): structural mutations of the shared samples and the generated assets — values
//! in the JSON replaced by out-of-range indices, wrong types, huge numbers; keys removed;
//! arrays emptied or grown; the binary chunk cut or bit-flipped; the container's lengths
//! corrupted — each loaded in full (`GltfScene` then `FishModel`). Nothing may panic; every
//! failure must be an error naming the file.
//!
//! The run is seeded, so it is the same every time. `SHOAL_FUZZ_CASES` sets the number of cases
//! per input file (default 150) and `SHOAL_FUZZ_SEED` the seed, for a longer campaign:
//!
//! ```sh
//! SHOAL_FUZZ_CASES=20000 SHOAL_FUZZ_SEED=7 cargo test --release --test skin_fuzz -- --nocapture
//! ```
//!
//! A panicking case is written to the system's temporary directory and its path printed.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde_json::{Value, json};
use shoal_core::skin::{FishModel, GltfScene};

/// The inputs: the shared samples (outside the repository) and the generated assets.
fn inputs() -> Vec<PathBuf> {
    let root = shoal_core::source_root();
    let mut files = Vec::new();
    let samples = root.join("../shared/gltf-samples");
    for dir in [
        samples.join("RedFinnedFish"),
        samples.clone(),
        root.join("assets"),
    ] {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            if matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("glb") | Some("gltf")
            ) {
                files.push(p);
            }
        }
    }
    files.sort();
    files
}

/// A glTF file taken apart: its JSON and, for a `.glb`, its binary chunk.
struct Parts {
    json: Value,
    bin: Option<Vec<u8>>,
}

fn split(bytes: &[u8]) -> Option<Parts> {
    if !bytes.starts_with(b"glTF") {
        return Some(Parts {
            json: serde_json::from_slice(bytes).ok()?,
            bin: None,
        });
    }
    let u32_at = |i: usize| -> Option<usize> {
        Some(u32::from_le_bytes(bytes.get(i..i + 4)?.try_into().ok()?) as usize)
    };
    let json_len = u32_at(12)?;
    let json = serde_json::from_slice(bytes.get(20..20 + json_len)?).ok()?;
    let bin_at = 20 + json_len;
    let bin =
        u32_at(bin_at).and_then(|n| bytes.get(bin_at + 8..bin_at + 8 + n).map(<[u8]>::to_vec));
    Some(Parts { json, bin })
}

fn join(parts: &Parts) -> Vec<u8> {
    let mut json = serde_json::to_vec(&parts.json).unwrap();
    let Some(bin) = &parts.bin else {
        return json;
    };
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.clone();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// JSON pointers of every value in `v`.
fn pointers(v: &Value, at: String, out: &mut Vec<String>) {
    match v {
        Value::Object(m) => {
            for (k, c) in m {
                pointers(
                    c,
                    format!("{at}/{}", k.replace('~', "~0").replace('/', "~1")),
                    out,
                );
            }
        }
        Value::Array(a) => {
            for (i, c) in a.iter().enumerate() {
                pointers(c, format!("{at}/{i}"), out);
            }
        }
        _ => {}
    }
    out.push(at);
}

/// A value likely to break an importer: an index just out of range, a huge or negative
/// number, the wrong type.
fn hostile(rng: &mut Pcg64, like: &Value) -> Value {
    match rng.random_range(0..12) {
        0 => json!(-1),
        1 => json!(u32::MAX),
        2 => json!(rng.random_range(0..64)),
        3 => json!(1e300),
        4 => json!(i64::MAX),
        5 => Value::Null,
        6 => json!("x"),
        7 => json!([]),
        8 => json!({}),
        9 => json!(0.5),
        10 => match like {
            Value::Number(n) => json!(n.as_u64().unwrap_or(0) + rng.random_range(1..4)),
            _ => json!(rng.random_range(0..8)),
        },
        _ => json!([0, 1, 2, 3]),
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
        Value::Object(m) if !m.is_empty() && rng.random_bool(0.5) => {
            let k = m.keys().nth(rng.random_range(0..m.len())).cloned().unwrap();
            m.remove(&k);
        }
        Value::Array(a) if !a.is_empty() && rng.random_bool(0.5) => {
            if rng.random_bool(0.5) {
                a.truncate(rng.random_range(0..a.len()));
            } else {
                let dup = a[rng.random_range(0..a.len())].clone();
                a.push(dup);
            }
        }
        other => {
            let new = hostile(rng, other);
            *other = new;
        }
    }
}

fn mutate(rng: &mut Pcg64, original: &[u8]) -> Vec<u8> {
    let mut bytes = match split(original) {
        Some(mut parts) if rng.random_bool(0.8) => {
            for _ in 0..rng.random_range(1..4) {
                if let Some(bin) = parts.bin.as_mut().filter(|_| rng.random_bool(0.2)) {
                    if rng.random_bool(0.3) {
                        bin.truncate(rng.random_range(0..=bin.len()));
                    } else if !bin.is_empty() {
                        let at = rng.random_range(0..bin.len());
                        bin[at] ^= 1 << rng.random_range(0..8);
                    }
                } else {
                    mutate_json(rng, &mut parts.json);
                }
            }
            join(&parts)
        }
        _ => original.to_vec(),
    };
    match rng.random_range(0..10) {
        // The container: cut short, or a length field corrupted.
        0 => bytes.truncate(rng.random_range(0..=bytes.len())),
        1 if bytes.len() > 24 => {
            let at = [8, 12, 20][rng.random_range(0..3)];
            let v = rng.random::<u32>() >> rng.random_range(0..32);
            bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
        }
        2 if !bytes.is_empty() => {
            for _ in 0..rng.random_range(1..5) {
                let at = rng.random_range(0..bytes.len());
                bytes[at] ^= 1 << rng.random_range(0..8);
            }
        }
        _ => {}
    }
    bytes
}

fn env_number(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

#[test]
fn mutated_gltf_files_never_panic() {
    // Without SHOAL_FUZZ_CASES: 150 cases for a small file, fewer for a large one (a case of a
    // half-megabyte file takes some 0.5 s in a debug build), so the run stays near 10 s.
    let fixed = std::env::var("SHOAL_FUZZ_CASES").is_ok();
    let cases = env_number("SHOAL_FUZZ_CASES", 150);
    let seed = env_number("SHOAL_FUZZ_SEED", 1);
    let files = inputs();
    assert!(
        files.len() >= 3,
        "no inputs: expected the shared samples and assets/*.glb ({files:?})"
    );
    let (mut loaded, mut failed, mut total) = (0u64, 0u64, 0u64);
    for (n, path) in files.iter().enumerate() {
        let started = std::time::Instant::now();
        let original = std::fs::read(path).unwrap();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let mut rng = Pcg64::seed_from_u64(seed.wrapping_mul(1000).wrapping_add(n as u64));
        let cases = if fixed {
            cases
        } else {
            (cases * 50_000 / original.len().max(1) as u64).clamp(10, cases)
        };
        total += cases;
        for case in 0..cases {
            let bytes = mutate(&mut rng, &original);
            let outcome = catch_unwind(AssertUnwindSafe(|| {
                GltfScene::from_bytes(&bytes, path).and_then(|s| FishModel::from_scene(&s))
            }));
            match outcome {
                Ok(Ok(model)) => {
                    loaded += 1;
                    let m = &model.mesh;
                    assert_eq!(m.joints.len(), m.positions.len(), "{name} case {case}");
                    assert!(
                        m.indices.iter().all(|&i| (i as usize) < m.positions.len()),
                        "{name} case {case}"
                    );
                }
                Ok(Err(e)) => {
                    failed += 1;
                    let msg = e.to_string();
                    assert!(msg.contains(&name), "{name} case {case}: {msg}");
                }
                Err(_) => {
                    let keep =
                        std::env::temp_dir().join(format!("shoal-fuzz-{seed}-{case}-{name}"));
                    std::fs::write(&keep, &bytes).unwrap();
                    panic!(
                        "{name}: mutated case {case} (seed {seed}) panicked; the file is {}",
                        keep.display()
                    );
                }
            }
        }
        println!("{}: {:?}", path.display(), started.elapsed());
    }
    println!(
        "{} files, {total} cases (seed {seed}): {loaded} loaded, {failed} failed with an error, none panicked",
        files.len()
    );
    assert!(failed > 0, "the mutations must break some files");
}

#[test]
fn truncated_glb_says_truncated() {
    let path = shoal_core::source_root().join("assets/black_porgy.glb");
    let bytes = std::fs::read(&path).unwrap();
    for cut in [5, 30, bytes.len() / 2, bytes.len() - 1] {
        let err = GltfScene::from_bytes(&bytes[..cut], &path)
            .err()
            .unwrap_or_else(|| panic!("a cut at {cut} must fail"))
            .to_string();
        assert!(
            err.contains("black_porgy.glb") && err.contains("truncated"),
            "cut at {cut}: {err}"
        );
    }
}

#[test]
fn out_of_range_position_accessor_is_an_error() {
    // gltf-json's validation indexes the POSITION accessor unchecked: this used to panic.
    let path = shoal_core::source_root().join("assets/black_porgy.glb");
    let mut parts = split(&std::fs::read(&path).unwrap()).unwrap();
    parts.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(9999);
    let err = match GltfScene::from_bytes(&join(&parts), &path) {
        Ok(_) => panic!("an out-of-range POSITION accessor must fail"),
        Err(e) => e.to_string(),
    };
    assert!(
        err.contains("black_porgy.glb")
            && err.contains("meshes[0].primitives[0].attributes.POSITION refers to accessor 9999"),
        "{err}"
    );
}
