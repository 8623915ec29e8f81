//! `shoal render` end to end: PNG, GIF and directory outputs, determinism, argument errors.

use std::process::Command;

fn shoal(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(args)
        .output()
        .expect("shoal runs")
}

fn ok(out: &std::process::Output) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "exit {:?}\nstdout:\n{stdout}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

#[test]
fn png_output_is_deterministic_and_names_the_adapter() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.png");
    let b = dir.path().join("b.png");
    for p in [&a, &b] {
        let stdout = ok(&shoal(&[
            "render",
            "--seconds",
            "0.5",
            "--fps",
            "10",
            "--size",
            "96x64",
            "--seed",
            "3",
            "--fish",
            "8",
            "--out",
            p.to_str().unwrap(),
        ]));
        assert!(stdout.contains("adapter: "), "{stdout}");
    }
    let ia = image::open(&a).unwrap().to_rgba8();
    assert_eq!(ia.dimensions(), (96, 64));
    assert_eq!(
        ia,
        image::open(&b).unwrap().to_rgba8(),
        "same seed, same image"
    );
    // A different seed places the fish elsewhere.
    let c = dir.path().join("c.png");
    ok(&shoal(&[
        "render",
        "--seconds",
        "0.5",
        "--fps",
        "10",
        "--size",
        "96x64",
        "--seed",
        "4",
        "--fish",
        "8",
        "--out",
        c.to_str().unwrap(),
    ]));
    assert_ne!(ia, image::open(&c).unwrap().to_rgba8());
}

#[test]
fn directory_and_gif_outputs_hold_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    ok(&shoal(&[
        "render",
        "--seconds",
        "0.3",
        "--fps",
        "10",
        "--size",
        "48x32",
        "--fish",
        "3",
        "--out",
        frames.to_str().unwrap(),
    ]));
    let mut names: Vec<String> = std::fs::read_dir(&frames)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        ["frame_00000.png", "frame_00001.png", "frame_00002.png"]
    );

    let gif = dir.path().join("a.gif");
    ok(&shoal(&[
        "render",
        "--seconds",
        "0.4",
        "--fps",
        "10",
        "--size",
        "48x32",
        "--fish",
        "3",
        "--out",
        gif.to_str().unwrap(),
    ]));
    use image::AnimationDecoder;
    let decoder = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(
        std::fs::File::open(&gif).unwrap(),
    ))
    .unwrap();
    let frames = decoder.into_frames().collect_frames().unwrap();
    assert_eq!(frames.len(), 4);
}

#[test]
fn bad_arguments_are_errors_that_say_why() {
    let out = shoal(&["render", "--size", "12by4", "--out", "x.png"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("WIDTHxHEIGHT"));
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.lua");
    std::fs::write(
        &scene,
        "return { tank = { min = {0, 0, 0}, max = {-1, 5, 5} }, fish = {} }\n",
    )
    .unwrap();
    let out = shoal(&[
        "render",
        "--scene",
        scene.to_str().unwrap(),
        "--out",
        "x.png",
    ]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("scene.lua") && stderr.contains("tank"),
        "{stderr}"
    );
}

/// `--scene demo` (retired) and other unknown names are refused with the scenes there are.
#[test]
fn an_unknown_scene_names_the_scenes_there_are() {
    for name in ["demo", "no_such_scene"] {
        let out = shoal(&["render", "--scene", name, "--out", "x.png"]);
        assert!(!out.status.success());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.contains(&format!("no scene `{name}`"))
                && stderr.contains("porgies")
                && stderr.contains("default"),
            "{stderr}"
        );
    }
}

/// `shoal bench render` prints, per fish count, the draw calls, the fish drawn and culled, the
/// fish per level of detail and the triangles submitted, which add up: every fish of the bench
/// world is in view, each drawn at one level, and the triangles are those of the levels in use plus
/// one coarsest-level shadow per fish. With a tolerance of 0 every fish is at full detail; culled on the CPU or on the GPU
/// (`--culling`), the counts are the same, and the draws that drew something are told apart
/// from those recorded.
#[test]
fn bench_render_reports_triangles_per_frame() {
    for (tolerance, full_detail, culling) in
        [("1", false, "gpu"), ("1", false, "cpu"), ("0", true, "gpu")]
    {
        let stdout = ok(&shoal(&[
            "bench",
            "render",
            "--fish",
            "1,12",
            "--size",
            "64x48",
            "--frames",
            "1",
            "--lod-tolerance-px",
            tolerance,
            "--culling",
            culling,
        ]));
        // "mesh: black_porgy (30 joints), triangles per level of detail: 5616 (error 0.000), …"
        let levels: Vec<u64> = stdout
            .lines()
            .find_map(|l| l.split_once("triangles per level of detail: "))
            .map(|(_, rest)| {
                rest.split(", ")
                    .map(|lvl| lvl.split(' ').next().unwrap().parse().unwrap())
                    .collect()
            })
            .unwrap_or_else(|| panic!("no level line in\n{stdout}"));
        assert_eq!(levels.len(), 5, "{stdout}");
        assert!(levels[0] > 4 * levels[2], "{stdout}");
        // "…; shadow: 8 (error 0.053)": the outline level the far fish's shadows use.
        let outline: u64 = stdout
            .lines()
            .find_map(|l| l.split_once("; shadow: "))
            .and_then(|(_, rest)| rest.split(' ').next()?.parse().ok())
            .unwrap_or_else(|| panic!("no shadow level in\n{stdout}"));
        assert!(outline * 4 <= levels[4], "{stdout}");
        let rows: Vec<Vec<&str>> = stdout
            .lines()
            .map(|l| l.split_whitespace().collect::<Vec<_>>())
            .filter(|c| c.len() == 16 && c[0].parse::<u64>().is_ok())
            .collect();
        assert_eq!(rows.len(), 2, "{stdout}");
        for (row, fish) in rows.iter().zip([1u64, 12]) {
            assert_eq!(row[0].parse::<u64>().unwrap(), fish);
            // The tick's pose stage on the CPU: the GPU pass's records, by default.
            assert!(row[3].parse::<f64>().unwrap() >= 0.0, "{stdout}");
            // The scene's instances, the renderer's checks, the upload and of it the pose
            // records: CPU milliseconds, the pose records within the upload.
            let ms: Vec<f64> = row[4..10].iter().map(|c| c.parse().unwrap()).collect();
            assert!(ms.iter().all(|&m| m >= 0.0), "{stdout}");
            assert!(ms[3] <= ms[2], "pose up ms within upload ms: {stdout}");
            // No record changes after the warm-up frame: none written (0 on the CPU path).
            assert_eq!(row[10], "0", "{stdout}");
            // Draws recorded/that drew something: the CPU path records only those that draw,
            // the GPU path every level's (5 of the porgy's 10 draw here).
            let draws: Vec<u32> = row[11].split('/').map(|n| n.parse().unwrap()).collect();
            assert_eq!(draws.len(), 2, "{stdout}");
            if culling == "cpu" {
                assert_eq!(draws[0], draws[1], "{stdout}");
            } else {
                assert!(draws[1] < draws[0], "{stdout}");
            }
            let (drawn, culled): (u64, u64) = (row[12].parse().unwrap(), row[13].parse().unwrap());
            assert_eq!((drawn, culled), (fish, 0), "{stdout}");
            let per_lod: Vec<u64> = row[14].split('/').map(|n| n.parse().unwrap()).collect();
            assert_eq!(per_lod.iter().sum::<u64>(), fish, "{stdout}");
            if full_detail {
                assert_eq!(per_lod[0], fish, "{stdout}");
            } else {
                // 64×48 pixels: every porgy is a few pixels long, so the coarsest level.
                assert_eq!(per_lod[4], fish, "{stdout}");
            }
            // Fish at levels 0–2 cast level 2's shadow, coarser ones the outline.
            let near: u64 = per_lod[..3].iter().sum();
            let expected: u64 = per_lod.iter().zip(&levels).map(|(n, t)| n * t).sum::<u64>()
                + near * levels[2]
                + (fish - near) * outline;
            assert_eq!(row[15].parse::<u64>().unwrap(), expected, "{stdout}");
        }
    }
}

/// The simulated time a `shoal render` clip ends at: every frame's ticks run, even below 8 fps.
#[test]
fn a_low_frame_rate_still_simulates_every_second_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    let stdout = ok(&shoal(&[
        "render",
        "--seconds",
        "2",
        "--fps",
        "2",
        "--size",
        "64x48",
        "--scene",
        "porgies",
        "--fish",
        "3",
        "--out",
        frames.to_str().unwrap(),
    ]));
    // 4 frames at t = 0, 0.5, 1, 1.5 s (each step is 30 ticks; at most 8 used to run).
    assert!(
        stdout.contains("4 frames, the last at t = 1.50 s"),
        "{stdout}"
    );
}

#[test]
fn unwritable_outputs_cameras_and_selections_are_refused_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let jpg = dir.path().join("x.jpg");
    let out = shoal(&["render", "--out", jpg.to_str().unwrap()]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("cannot write .jpg") && stderr.contains(".png") && stderr.contains(".gif"),
        "{stderr}"
    );
    assert!(!jpg.exists(), "no directory named x.jpg is made");

    let out = shoal(&[
        "render", "--scene", "porgies", "--fish", "3", "--select", "999", "--out", "x.png",
    ]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("--select 999") && stderr.contains("0 to 2"),
        "{stderr}"
    );

    let out = shoal(&["render", "--camera", "sideways", "--out", "x.png"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("EX,EY,EZ:TX,TY,TZ"));

    let out = shoal(&["render", "--camera", "follow", "--out", "x.png"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--select"));
}

/// A close-up that follows one fish shows that fish large: far more of the frame is fish than in
/// the whole-tank view, and the overlays add their colours.
#[test]
fn follow_camera_and_overlays_show_one_fish_close_up() {
    let dir = tempfile::tempdir().unwrap();
    let wide = dir.path().join("wide.png");
    let close = dir.path().join("close.png");
    let base = [
        "render",
        "--scene",
        "porgies",
        "--fish",
        "6",
        "--seconds",
        "0.2",
        "--fps",
        "10",
        "--size",
        "160x120",
        "--seed",
        "5",
    ];
    let mut a = base.to_vec();
    a.extend(["--out", wide.to_str().unwrap()]);
    ok(&shoal(&a));
    let mut b = base.to_vec();
    b.extend([
        "--select",
        "2",
        "--camera",
        "follow",
        "--overlays",
        "--out",
        close.to_str().unwrap(),
    ]);
    ok(&shoal(&b));
    let differs = |img: &image::RgbaImage| {
        // Pixels far from the water's blue-green: fish, sand, rocks, overlays.
        img.pixels()
            .filter(|p| {
                let [r, g, b, _] = p.0;
                i32::from(r) > i32::from(b) + 20 || i32::from(r) + i32::from(g) > 400
            })
            .count()
    };
    let wide = image::open(&wide).unwrap().to_rgba8();
    let close = image::open(&close).unwrap().to_rgba8();
    assert_ne!(wide, close);
    assert!(
        differs(&close) > differs(&wide),
        "close-up {} vs wide {}",
        differs(&close),
        differs(&wide)
    );
}

/// A negative number is read as the value it is and refused for what it is, not as an unknown
/// option ("unexpected argument '-1' found"); a runaway fish count is refused before anything
/// is built (issue 36).
#[test]
fn negative_seconds_and_huge_fish_counts_get_lines_that_say_why() {
    for (args, expected) in [
        (
            &["render", "--seconds", "-1", "--out", "x.png"][..],
            "--seconds -1 must be",
        ),
        (
            &["record", "--seconds", "-1", "--out", "x.shoalrun"],
            "seconds is -1",
        ),
        (&["bench", "sim", "--seconds", "-1"], "--seconds -1 must be"),
        (
            &[
                "render", "--scene", "porgies", "--fish", "10000000", "--out", "x.png",
            ],
            "--fish 10000000: the porgies scene takes 1 to 100000 fish (10000000 would take about",
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_shoal"))
            .current_dir(dir.path())
            .env("SHOAL_SCRIPTS", shoal_core::source_root().join("scripts"))
            .args(args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        assert!(
            !stderr.contains("unexpected argument"),
            "{args:?}: {stderr}"
        );
    }
}

/// A Lua scene whose groups add up to more fish than the machine's memory holds is refused
/// before anything is spawned, saying how much it would take and how much there is; one of
/// 10,000 fish says on stderr that it is setting them up, and when it is done (issue 36).
#[test]
fn impossible_fish_counts_are_refused_and_large_set_ups_say_so() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = dir.path().join("scripts/scenes");
    std::fs::create_dir_all(&scenes).unwrap();
    let group = r#"{ species = "black_porgy", count = 200000 }"#;
    let groups = vec![group; 1000].join(",\n");
    std::fs::write(
        scenes.join("huge.lua"),
        format!(
            "return {{ tank = {{ min = {{-2000, 0, -2000}}, max = {{2000, 800, 2000}} }},\n\
             fish = {{ {groups} }} }}\n"
        ),
    )
    .unwrap();
    std::fs::write(
        scenes.join("large.lua"),
        "return { tank = { min = {-2000, 0, -2000}, max = {2000, 800, 2000} },\n\
         fish = { { species = \"black_porgy\", count = 10000 } } }\n",
    )
    .unwrap();
    let render = |scene: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_shoal"))
            .current_dir(dir.path())
            .env("SHOAL_SCRIPTS", shoal_core::source_root().join("scripts"))
            .env("XDG_RUNTIME_DIR", dir.path())
            .args(["render", "--scene"])
            .arg(scenes.join(scene))
            .args(["--seconds", "0.03", "--size", "64x36", "--out"])
            .arg(dir.path().join("out.png"))
            .output()
            .unwrap()
    };
    let out = render("huge.lua");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(
        stderr.contains("200000000 fish would take about 2.6 TiB of memory")
            && stderr.contains("available"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("setting up"),
        "refused before spawning: {stderr}"
    );
    let out = render("large.lua");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("setting up 10000 fish") && stderr.contains("set up 10000 fish in"),
        "{stderr}"
    );
}

/// Compares `actual` with `crates/render/tests/reference/<name>.png` by the rule of the render
/// crate's reference tests (a pixel differs when a channel differs by more than 16; at most 0.5 %
/// may), or writes it with `SHOAL_BLESS=1`. On failure the actual image is written beside it.
fn check_reference(name: &str, actual: &image::RgbImage) {
    let dir =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/render/tests/reference");
    let path = dir.join(format!("{name}.png"));
    let actual_path = dir.join(format!("{name}-actual.png"));
    if std::env::var_os("SHOAL_BLESS").is_some_and(|v| v == "1") {
        actual.save(&path).unwrap();
        return;
    }
    let reference = image::open(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (SHOAL_BLESS=1 writes it)", path.display()))
        .to_rgb8();
    assert_eq!(reference.dimensions(), actual.dimensions(), "{name}");
    let differing = actual
        .pixels()
        .zip(reference.pixels())
        .filter(|(a, r)| (0..3).any(|c| a[c].abs_diff(r[c]) > 16))
        .count();
    let fraction = differing as f64 / f64::from(actual.width() * actual.height());
    if fraction > 0.005 {
        actual.save(&actual_path).unwrap();
        panic!(
            "{name}: {:.2} % of pixels differ by more than 16; see {}",
            fraction * 100.0,
            actual_path.display()
        );
    }
    let _ = std::fs::remove_file(&actual_path);
}

/// Issue 35's picture check: `shoal render` of 1,000 porgies at 1920×1080 with the default
/// level-of-detail tolerance and with `--lod-tolerance-px 0` (every fish at full detail)
/// match their reference images, and differ from each other by a mean of at most 1 grey level
/// in 255.
#[test]
fn a_school_of_1000_at_1080p_looks_the_same_at_both_tolerances() {
    let dir = tempfile::tempdir().unwrap();
    let mut images = Vec::new();
    for (tolerance, name) in [("1", "school_1000_default"), ("0", "school_1000_full")] {
        let out = dir.path().join(format!("{name}.png"));
        ok(&shoal(&[
            "render",
            "--scene",
            "porgies",
            "--fish",
            "1000",
            "--size",
            "1920x1080",
            "--seconds",
            "0.5",
            "--fps",
            "2",
            "--lod-tolerance-px",
            tolerance,
            "--out",
            out.to_str().unwrap(),
        ]));
        let img = image::open(&out).unwrap().to_rgb8();
        check_reference(name, &img);
        images.push(img);
    }
    let total: u64 = images[0]
        .as_raw()
        .iter()
        .zip(images[1].as_raw())
        .map(|(&a, &b)| u64::from(a.abs_diff(b)))
        .sum();
    let mean = total as f64 / images[0].as_raw().len() as f64;
    assert!(mean <= 1.0, "mean difference {mean:.3} grey levels");
    // Not the same picture twice: the default tolerance draws coarser levels somewhere.
    assert!(mean > 0.0, "the two tolerances drew identical images");
}
