//! The window's time travel (issue 14), driven through the panel like a designer would
//! (`egui_kittest`, widgets by label) over the real default aquarium (`scenes/default.lua`,
//! Lua behaviours): scrub back with the slider, step back a tick, play on from a rewound moment
//! with unchanged or edited scripts (ghosts and divergences), jump to the last script error.
//! Each test compares the simulation with what it was at that moment, recorded while it ran.

use crate::common;

use std::path::{Path, PathBuf};

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use glam::Vec3;
use shoal_app::{AppOptions, Aquarium, GHOST_COLOR, NEW_PATH_COLOR, Showable};
use shoal_core::world::FishId;
use shoal_script::Simulation;

const DT: f32 = 1.0 / 60.0;

/// What the aquarium was at one tick: time and every fish's position.
#[derive(Debug, Clone, PartialEq)]
struct Moment {
    tick: u64,
    time: f64,
    fish: Vec<(FishId, [u32; 3])>,
}

fn moment(aq: &Aquarium) -> Moment {
    let w = aq.scene.world();
    Moment {
        tick: w.tick_count(),
        time: w.time(),
        fish: w
            .fish_id_slice()
            .iter()
            .map(|&id| (id, bits(w.root(id).unwrap().pos)))
            .collect(),
    }
}

fn bits(p: Vec3) -> [u32; 3] {
    p.to_array().map(f32::to_bits)
}

/// The default aquarium of the scripts under `root`.
fn default_aquarium(root: &Path) -> Aquarium {
    let sim = Simulation::from_scene(root, Path::new("scenes/default.lua"), 7)
        .expect("the default scene loads");
    Aquarium::new(Box::new(sim), AppOptions::default())
}

fn harness(aq: Aquarium) -> Harness<'static, Aquarium> {
    Harness::builder()
        .with_size(egui::vec2(520.0, 1800.0))
        .build_ui_state(|ui, aq: &mut Aquarium| aq.panel(ui), aq)
}

/// Plays `ticks` frames of one tick each, recording every moment.
fn play(h: &mut Harness<'static, Aquarium>, ticks: usize) -> Vec<Moment> {
    (0..ticks)
        .map(|_| {
            h.state_mut().advance(DT);
            moment(h.state())
        })
        .collect()
}

/// Sets the timeline slider to `time_s` and lets the aquarium take it.
fn scrub(h: &mut Harness<'static, Aquarium>, time_s: f64) {
    h.get_by_role_and_label(egui::accesskit::Role::Slider, "time (s)")
        .set_value_accesskit(time_s);
    h.run();
    h.state_mut().advance(DT);
    h.run();
}

fn click(h: &mut Harness<'static, Aquarium>, label: &str) {
    h.get_by_label(label).click();
    h.run();
    h.state_mut().advance(DT);
    h.run();
}

#[test]
fn the_slider_and_step_back_go_back_to_the_exact_moment() {
    let (_dir, root) = common::scratch_repo();
    let mut h = harness(default_aquarium(&root));
    h.run();
    let ran = play(&mut h, 240);
    assert!(h.state().timeline().num_states() >= 4, "a state a second");
    let span = h.state().timeline().span_s().expect("a history");
    assert_eq!(span.0, 0.0);
    assert!((span.1 - 4.0).abs() < 1e-9 && ran.last().unwrap().tick == 240);
    h.run();
    assert!(
        h.query_by_label_contains("history: 0:00–0:04").is_some(),
        "the panel shows the span"
    );

    // Between two kept states (1 s and 2 s): 1.5 s is tick 90.
    let want = ran.iter().find(|m| m.tick == 90).unwrap().clone();
    scrub(&mut h, 1.5);
    assert!(h.state().paused(), "scrubbing pauses");
    assert_eq!(
        moment(h.state()),
        want,
        "time and every fish as they were at 1.5 s"
    );

    click(&mut h, "step back");
    let want = ran.iter().find(|m| m.tick == 89).unwrap();
    assert_eq!(&moment(h.state()), want, "one tick earlier");

    // Scrubbing forward again, within the history, also lands on what was.
    scrub(&mut h, 3.25);
    let want = ran.iter().find(|m| m.tick == 195).unwrap();
    assert_eq!(&moment(h.state()), want);
    assert!(h.state().divergences().is_empty());
}

#[test]
fn playing_on_from_a_rewound_moment_with_the_same_scripts_follows_the_ghost_exactly() {
    let (_dir, root) = common::scratch_repo();
    let mut h = harness(default_aquarium(&root));
    h.run();
    let ran = play(&mut h, 240);
    scrub(&mut h, 2.0);
    assert_eq!(h.state().scene.world().tick_count(), 120);
    click(&mut h, "play");
    assert!(!h.state().paused());
    let again = play(&mut h, 119);
    // The click's own frame ran tick 121; `again` holds 122..=240.
    assert_eq!(again.first().unwrap().tick, 122);
    assert_eq!(&again[..], &ran[121..240], "bit for bit the same run");
    let ghost = h
        .state()
        .timeline()
        .ghost_span_s()
        .expect("a ghost after the rewind");
    assert_eq!(ghost, (121.0 / 60.0, 4.0));
    assert!(
        h.state().divergences().is_empty(),
        "no fish leaves its ghost: {:?}",
        h.state().divergences()
    );
    h.run();
    assert!(h.query_by_label_contains("0 fish left it").is_some());
    assert!(
        h.state().overlay_lines().is_empty(),
        "a fish on its ghost draws nothing over itself"
    );
    // The selected fish shows its ghost ahead (the run before the rewind went on to 4 s).
    let fish0 = h.state().scene.world().fish_id_slice()[0];
    let at = h.state().scene.fish_info(fish0).unwrap().center;
    let px = project(h.state(), at);
    h.state_mut().click(px, VIEW, false);
    let picked = h.state().selected().expect("a fish is picked");
    h.state_mut().advance(0.0);
    assert!(
        h.state()
            .overlay_lines()
            .iter()
            .any(|l| l.color == GHOST_COLOR),
        "the selected fish {picked:?} shows its ghost"
    );
}

const VIEW: glam::Vec2 = glam::Vec2::new(960.0, 600.0);

fn project(aq: &Aquarium, p: Vec3) -> glam::Vec2 {
    let ndc = aq.camera().view_proj(VIEW.x / VIEW.y).project_point3(p);
    glam::Vec2::new((ndc.x + 1.0) * 0.5 * VIEW.x, (1.0 - ndc.y) * 0.5 * VIEW.y)
}

#[test]
fn an_edited_behaviour_replayed_from_a_rewound_moment_leaves_the_ghost() {
    let (_dir, root) = common::scratch_repo();
    let mut h = harness(default_aquarium(&root));
    h.run();
    let ran = play(&mut h, 240);
    scrub(&mut h, 1.0);

    // The designer strengthens cohesion in school.lua and saves.
    let school = root.join("scripts/behaviors/school.lua");
    let src = std::fs::read_to_string(&school).unwrap();
    let edited = src.replace(
        "M.COHESION, M.COHESION_RADIUS = 1.0, 6.0",
        "M.COHESION, M.COHESION_RADIUS = 6.0, 6.0",
    );
    assert_ne!(src, edited, "the edit applies");
    std::fs::write(&school, edited).unwrap();
    let events = h
        .state_mut()
        .scene
        .sim_mut()
        .reload_changed(&[PathBuf::from(&school)]);
    assert!(!events.is_empty(), "the edit is reloaded: {events:?}");

    click(&mut h, "play");
    let again = play(&mut h, 179);
    assert_eq!(again.last().unwrap().tick, ran.last().unwrap().tick);
    let d = h.state().divergences().to_vec();
    assert!(!d.is_empty(), "the schooling fish leave their ghosts");
    assert!(
        d.windows(2).all(|w| w[0].first_s <= w[1].first_s),
        "sorted by divergence time"
    );
    assert!(d.iter().all(|d| d.first_s > 1.0 && d.max_distance > 0.0));
    let lines = h.state().overlay_lines();
    for color in [GHOST_COLOR, NEW_PATH_COLOR] {
        assert!(
            lines.iter().any(|l| l.color == color),
            "ghosts and new paths are drawn"
        );
    }
    // The first to part is listed and selects its fish on a click.
    h.run();
    let first = d[0];
    let label = format!(
        "fish #{} at {:.2} s, up to {:.1} apart",
        first.fish.index, first.first_s, first.max_distance
    );
    h.get_by_label(&label).click();
    h.run();
    assert_eq!(h.state().selected(), Some(first.fish));
}

#[test]
fn jump_to_last_error_goes_to_the_moment_the_script_failed() {
    let (_dir, root) = common::scratch_repo();
    // The eels' behaviour fails once per eel when it first decides after 1.5 s.
    let wander = root.join("scripts/behaviors/wander.lua");
    let src = std::fs::read_to_string(&wander).unwrap();
    let edited = src.replace(
        "function M.behave(fish, intention)\n",
        "function M.behave(fish, intention)\n  if shoal.time() >= 1.5 and not fish.memory.boomed then\n    fish.memory.boomed = true\n    error('late boom')\n  end\n",
    );
    assert_ne!(src, edited);
    std::fs::write(&wander, edited).unwrap();
    let mut h = harness(default_aquarium(&root));
    h.run();
    play(&mut h, 240);
    // One line per eel; the last is the one to jump to.
    let line = h
        .state()
        .console()
        .filter(|l| l.contains("late boom"))
        .last()
        .expect("the error is in the console")
        .to_owned();
    // `[1.52 s] error fish #35 behaviors/wander.lua:…`
    let logged: f64 = line[1..line.find(" s]").unwrap()].parse().unwrap();
    assert!((1.5..2.0).contains(&logged), "{line}");
    click(&mut h, "jump to last error");
    let t = h.state().scene.world().time();
    assert!(
        (t - logged).abs() < 0.006,
        "at the error's moment: {t} vs {line}"
    );
    assert!(h.state().paused());
}

#[test]
fn a_function_in_fish_memory_is_reported_once_and_the_aquarium_goes_on() {
    let (_dir, root) = common::scratch_repo();
    let wander = root.join("scripts/behaviors/wander.lua");
    let src = std::fs::read_to_string(&wander).unwrap();
    let edited = src.replace(
        "function M.behave(fish, intention)\n",
        "function M.behave(fish, intention)\n  fish.memory.callback = function() end\n",
    );
    assert_ne!(src, edited, "the edit applies");
    std::fs::write(&wander, edited).unwrap();
    let mut h = harness(default_aquarium(&root));
    h.run();
    let ran = play(&mut h, 130);
    assert_eq!(ran.last().unwrap().tick, 130, "the aquarium kept running");
    let lines: Vec<_> = h
        .state()
        .console()
        .filter(|l| l.contains("cannot keep the state"))
        .map(str::to_owned)
        .collect();
    assert_eq!(lines.len(), 1, "said once: {lines:?}");
    assert!(
        lines[0].contains("memory.callback") && lines[0].contains("fish #"),
        "names the fish and the field: {}",
        lines[0]
    );
}

/// `shoal run --open RUN --at T` as the window does it: the recording's moment, live, paused,
/// with its future as the ghost.
fn open_recording(root: &Path, run: &shoal_script::timeline::run_file::Run, at_s: f64) -> Aquarium {
    let (sim, tick) =
        shoal_script::timeline::resume(run, root, &root.join("scripts"), at_s).unwrap();
    let ghost = run.frames[tick..]
        .iter()
        .enumerate()
        .map(|(k, f)| {
            (
                (tick + k) as u64,
                f.iter()
                    .map(|p| FishId {
                        index: p.index,
                        generation: p.generation,
                    })
                    .collect(),
                f.iter().map(|p| p.pos).collect(),
            )
        })
        .collect();
    let mut aq = Aquarium::new(Box::new(sim), AppOptions::default());
    aq.open_recording(ghost, "opened");
    aq
}

#[test]
fn a_recording_opens_at_its_moment_and_playing_on_follows_or_leaves_it() {
    let (_dir, root) = common::scratch_repo();
    let run = shoal_script::timeline::record(&shoal_script::timeline::RecordSpec {
        root: &root,
        scripts: &root.join("scripts"),
        scene: "scenes/default.lua",
        seed: 3,
        lanes: 2,
        seconds: 4.0,
        lod: None,
    })
    .unwrap();
    let mut h = harness(open_recording(&root, &run, 1.5));
    h.run();
    assert!(h.state().paused(), "a recording opens paused");
    assert!(
        h.query_by_label_contains("ghost: the recording opened, 1.50–4.00 s")
            .is_some(),
        "the panel says the ghost is the recording's future"
    );
    assert_eq!(h.state().scene.world().tick_count(), 90);
    let bits_of = |k: usize| -> Vec<(FishId, [u32; 3])> {
        run.frames[k]
            .iter()
            .map(|p| {
                (
                    FishId {
                        index: p.index,
                        generation: p.generation,
                    },
                    bits(p.pos),
                )
            })
            .collect()
    };
    assert_eq!(
        moment(h.state()).fish,
        bits_of(90),
        "the recording's moment"
    );
    click(&mut h, "play");
    let went = play(&mut h, 60);
    let last = went.last().unwrap();
    assert_eq!(
        last.fish,
        bits_of(last.tick as usize),
        "playing on follows the recording"
    );
    assert!(h.state().divergences().is_empty());

    // Edited scripts: the same moment, then the fish part from the recording's ghost.
    let school = root.join("scripts/behaviors/school.lua");
    let src = std::fs::read_to_string(&school).unwrap();
    std::fs::write(
        &school,
        src.replace(
            "M.COHESION, M.COHESION_RADIUS = 1.0, 6.0",
            "M.COHESION, M.COHESION_RADIUS = 6.0, 6.0",
        ),
    )
    .unwrap();
    let mut h = harness(open_recording(&root, &run, 1.5));
    h.run();
    assert_eq!(
        moment(h.state()).fish,
        bits_of(90),
        "the moment is the recording's"
    );
    click(&mut h, "play");
    play(&mut h, 120);
    let d = h.state().divergences();
    assert!(!d.is_empty(), "the edited school leaves the recording");
    assert!(d.iter().all(|d| d.first_s > 1.5), "{d:?}");
}
