//! Frame pacing (issue 35): the panel answers within a frame or two whatever the simulation and
//! the 3D view cost, because no frame does more than its budget of either.
//!
//! The window draws the panel every frame, but a frame is only shown once the GPU has done
//! everything submitted before it, the view included: on a software renderer (lavapipe) one
//! view of 100,000 fish takes tens of seconds, and a frame that drew it whole kept a click on
//! the panel waiting that long. So, measured frame by frame ([`Pacer`]):
//!
//! - **The simulation** runs at most as many ticks a frame as fit in [`SIM_BUDGET_MS`] at the
//!   measured cost of a tick (at least one, so the world moves); the world then falls behind
//!   real time, and the panel says so.
//! - **The view** is drawn whole when its measured cost fits in [`VIEW_BUDGET_MS`] — always on a
//!   GPU that keeps up, so nothing changes there (1,000 fish, or 100,000 on a real GPU). When it
//!   does not, it is drawn *progressively*: the fish as they were at one moment ([`ViewSnapshot`])
//!   are drawn a slice per frame into a texture of its own, each slice over the colour and depth
//!   the earlier ones left ([`shoal_render::Renderer::encode_part`]), and the picture is shown
//!   when complete; the last complete picture is shown meanwhile. The slice is sized from the
//!   measured cost per fish so that a frame's non-simulation time comes to the budget.
//!
//! Why slices and not a lower resolution: on lavapipe the view's cost follows the fish, not the
//! pixels (`shoal bench render --fish 10000`: 2.5 s a frame at 64×64 against 7.6 s at 830×760,
//! and 0.22 s for 1,000 fish — docs/performance.md), so drawing fewer pixels cannot bring a
//! frame of 100,000 fish near a budget, and drawing fewer fish at a time can.
//!
//! The pacer measures with the frame's wall time: on a pipelined GPU that is the GPU's frame
//! time (the window waits for a free surface image), on lavapipe the rendering itself.

use std::ops::Range;

use glam::Mat4;
use shoal_core::skin::pose_program::{GpuFishPose, GpuPosePrograms};
use shoal_render::{
    Camera, FishInstance, FrameInput, FramePart, GpuPoseFrame, Look, OverlayLine, Prop, TankBounds,
};

/// Most real time a frame spends simulating, milliseconds (beyond its first tick).
pub(super) const SIM_BUDGET_MS: f32 = 50.0;
/// Most real time a frame spends on everything but the simulation (the view, the panel,
/// presenting), milliseconds, when the view can be drawn in slices.
pub(super) const VIEW_BUDGET_MS: f32 = 50.0;
/// Fewest fish a slice draws: a view of this many fish or fewer is always drawn whole (the
/// panel and the water's fixed cost dominate there).
pub(super) const MIN_SLICE: usize = 500;
/// The first frame's view before anything is measured: whole up to this many fish, else a
/// slice of this many.
const FIRST_SLICE: usize = 2_000;
/// Weight of the newest measurement in the running estimates.
const SMOOTHING: f32 = 0.5;

/// What the view draws this frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum ViewPlan {
    /// The whole view, as it is now, into the shown picture.
    Whole,
    /// The slice `fish` (indices into the snapshot) of a view drawn progressively; `part` says
    /// whether it starts the picture (take a [`ViewSnapshot`] first) and whether it completes it
    /// (then show it).
    Slice {
        /// The fish of this slice.
        fish: Range<usize>,
        /// First and last of the view's slices.
        part: FramePart,
    },
}

/// A view being drawn a slice at a time.
#[derive(Debug, Clone, Copy)]
struct Progress {
    /// Fish in the snapshot.
    total: usize,
    /// The next slice's first fish.
    next: usize,
    /// Frames spent on this view so far.
    frames: u32,
}

/// Chooses each frame's simulation ticks and view (see the module docs) from the costs it
/// measured in the frames before.
#[derive(Debug, Clone)]
pub(super) struct Pacer {
    sim_budget_ms: f32,
    view_budget_ms: f32,
    /// Running estimate of a tick's cost, milliseconds.
    ms_per_tick: Option<f32>,
    /// Running estimate of a frame's non-simulation time per fish drawn, milliseconds.
    ms_per_fish: Option<f32>,
    progress: Option<Progress>,
    /// Views completed progressively, and how many frames the last one took.
    completed: u64,
    last_view_frames: u32,
    /// The last view planned was a slice.
    sliced: bool,
}

impl Default for Pacer {
    fn default() -> Self {
        Self::new(SIM_BUDGET_MS, VIEW_BUDGET_MS)
    }
}

impl Pacer {
    /// A pacer with these budgets, milliseconds.
    pub(super) fn new(sim_budget_ms: f32, view_budget_ms: f32) -> Self {
        Self {
            sim_budget_ms,
            view_budget_ms,
            ms_per_tick: None,
            ms_per_fish: None,
            progress: None,
            completed: 0,
            last_view_frames: 0,
            sliced: false,
        }
    }

    /// Most ticks this frame may simulate: as many as fit in the budget at the measured cost
    /// of a tick, at least one (one before anything is measured).
    pub(super) fn max_ticks(&self) -> u64 {
        match self.ms_per_tick {
            Some(ms) if ms > 0.0 => ((self.sim_budget_ms / ms).floor() as u64).max(1),
            Some(_) => u64::MAX,
            None => 1,
        }
    }

    /// The simulation ran `ticks` ticks in `ms` milliseconds this frame.
    pub(super) fn simulated(&mut self, ticks: u64, ms: f32) {
        if ticks > 0 && ms.is_finite() && ms >= 0.0 {
            let per_tick = ms / ticks as f32;
            self.ms_per_tick = Some(smooth(self.ms_per_tick, per_tick));
        }
    }

    /// The frame that drew `fish_drawn` fish took `frame_ms`, `sim_ms` of it simulating.
    pub(super) fn frame_done(&mut self, fish_drawn: usize, frame_ms: f32, sim_ms: f32) {
        if fish_drawn == 0 || !frame_ms.is_finite() || !sim_ms.is_finite() {
            return;
        }
        let per_fish = (frame_ms - sim_ms).max(0.0) / fish_drawn as f32;
        self.ms_per_fish = Some(smooth(self.ms_per_fish, per_fish));
    }

    /// Fish a frame can draw within the view budget at the measured cost.
    fn affordable(&self) -> usize {
        match self.ms_per_fish {
            Some(ms) if ms > 0.0 => {
                let n = self.view_budget_ms / ms;
                if n >= usize::MAX as f32 {
                    usize::MAX
                } else {
                    n as usize
                }
            }
            Some(_) => usize::MAX,
            None => FIRST_SLICE,
        }
    }

    /// This frame's view of `num_fish` fish (the live count; a view in progress keeps its
    /// snapshot's).
    pub(super) fn plan_view(&mut self, num_fish: usize) -> ViewPlan {
        let affordable = self.affordable();
        if num_fish <= MIN_SLICE.max(affordable) {
            // The whole view fits: a view in progress is dropped (the picture drawn now is
            // newer).
            self.progress = None;
            self.sliced = false;
            return ViewPlan::Whole;
        }
        let progress = self.progress.get_or_insert(Progress {
            total: num_fish,
            next: 0,
            frames: 0,
        });
        let n = affordable.max(MIN_SLICE);
        let fish = progress.next..progress.next.saturating_add(n).min(progress.total);
        let part = FramePart {
            first: progress.next == 0,
            last: fish.end == progress.total,
        };
        progress.next = fish.end;
        progress.frames += 1;
        self.sliced = true;
        if part.last {
            self.last_view_frames = progress.frames;
            self.completed += 1;
            self.progress = None;
        }
        ViewPlan::Slice { fish, part }
    }

    /// Forgets a view in progress (its target was resized, or it cannot be drawn): the next
    /// slice starts a new one.
    pub(super) fn restart_view(&mut self) {
        self.progress = None;
    }

    /// One line for the panel while the view is drawn a slice at a time (also in the frame
    /// that completes a view, so the panel's layout does not jump), else `None`.
    pub(super) fn status(&self) -> Option<String> {
        if !self.sliced {
            return None;
        }
        let done = self
            .progress
            .map_or(100.0, |p| 100.0 * p.next as f32 / p.total.max(1) as f32);
        let last = match self.completed {
            0 => "none complete yet".to_owned(),
            _ => format!("the last took {} frames", self.last_view_frames),
        };
        Some(format!(
            "view slower than a frame: drawn in slices, the next {done:.0} % done ({last})"
        ))
    }
}

/// The running estimate `old` moved toward `new`.
fn smooth(old: Option<f32>, new: f32) -> f32 {
    match old {
        Some(old) => old + SMOOTHING * (new - old),
        None => new,
    }
}

/// What a view drawn progressively draws, copied at its first slice, so that every slice shows
/// the same moment from the same camera (the world moves on meanwhile).
pub(super) struct ViewSnapshot {
    palettes: Vec<Mat4>,
    instances: Vec<FishInstance>,
    /// The scene's name for `instances` ([`FrameInput::instances_revision`]).
    instances_revision: Option<u64>,
    camera: Camera,
    tank: TankBounds,
    time_s: f32,
    props: Vec<Prop>,
    overlay: Vec<OverlayLine>,
    look: Look,
    pose: Option<PoseSnapshot>,
    /// The slice's instances and pose records, their palette offsets from the slice's first.
    scratch_instances: Vec<FishInstance>,
    scratch_fish: Vec<GpuFishPose>,
}

/// The GPU pose pass's part of a [`ViewSnapshot`].
struct PoseSnapshot {
    programs: GpuPosePrograms,
    fish: Vec<GpuFishPose>,
    anchors: Vec<Mat4>,
}

impl ViewSnapshot {
    /// A copy of `input`. The instances are taken from `spare` (an earlier view's snapshot)
    /// without copying them when the scene names them by the same revision: they are the same
    /// while no fish comes, goes or changes (the fish's poses are copied every view).
    pub(super) fn take(input: &FrameInput<'_>, spare: Option<ViewSnapshot>) -> Self {
        let instances = match spare {
            Some(s)
                if input.instances_revision.is_some()
                    && s.instances_revision == input.instances_revision
                    && s.instances.len() == input.instances.len() =>
            {
                s.instances
            }
            Some(mut s) => {
                s.instances.clear();
                s.instances.extend_from_slice(input.instances);
                s.instances
            }
            None => input.instances.to_vec(),
        };
        Self {
            palettes: input.palettes.to_vec(),
            instances,
            instances_revision: input.instances_revision,
            camera: input.camera,
            tank: input.tank,
            time_s: input.time_s,
            props: input.props.to_vec(),
            overlay: input.overlay.to_vec(),
            look: input.look,
            pose: input.gpu_pose.map(|p| PoseSnapshot {
                programs: p.programs.clone(),
                fish: p.fish.to_vec(),
                anchors: p.anchors.to_vec(),
            }),
            scratch_instances: Vec::new(),
            scratch_fish: Vec::new(),
        }
    }

    /// Fish in the snapshot.
    pub(super) fn num_fish(&self) -> usize {
        self.instances.len()
    }

    /// The frame input of the slice `fish` (clamped to the snapshot): those fish, with the props
    /// in the first part and the overlay in the last. Posed on the GPU, the slice's palette is
    /// its fish's entries alone (the offsets moved down to start at 0), as a frame of those
    /// fish would have it; posed on the CPU it is the whole palette.
    pub(super) fn slice(&mut self, fish: Range<usize>, part: FramePart) -> FrameInput<'_> {
        let end = fish.end.min(self.instances.len());
        let fish = fish.start.min(end)..end;
        let mut instances = &self.instances[fish.clone()];
        let gpu_pose = match &self.pose {
            Some(p) => {
                let records = &p.fish[fish.clone()];
                let slots = |r: &GpuFishPose| {
                    p.programs
                        .programs
                        .get(r.program as usize)
                        .map_or(0, |g| g.num_slots)
                };
                let base = records.iter().map(|r| r.palette_offset).min().unwrap_or(0);
                let len = records
                    .iter()
                    .map(|r| r.palette_offset + slots(r) - base)
                    .max()
                    .unwrap_or(0);
                self.scratch_fish.clear();
                self.scratch_fish
                    .extend(records.iter().map(|r| GpuFishPose {
                        palette_offset: r.palette_offset - base,
                        ..*r
                    }));
                self.scratch_instances.clear();
                self.scratch_instances
                    .extend(instances.iter().map(|i| FishInstance {
                        palette_offset: i.palette_offset.saturating_sub(base),
                        ..*i
                    }));
                instances = &self.scratch_instances;
                Some(GpuPoseFrame {
                    programs: &p.programs,
                    fish: &self.scratch_fish,
                    anchors: &p.anchors[fish.clone()],
                    palette_len: len,
                })
            }
            None => None,
        };
        FrameInput {
            palettes: &self.palettes,
            instances,
            // Each slice is other fish: nothing to keep from the last frame.
            instances_revision: None,
            camera: self.camera,
            tank: self.tank,
            time_s: self.time_s,
            props: if part.first { &self.props } else { &[] },
            overlay: if part.last { &self.overlay } else { &[] },
            look: self.look,
            gpu_pose,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A window whose frames cost what the model says: `tick_ms` a tick, `fixed_ms` for the
    /// panel, water and presenting, `fish_ms` per fish drawn. Runs `frames` frames of
    /// `num_fish`, returning each frame's cost (model milliseconds, not measured) and plan.
    fn run(
        pacer: &mut Pacer,
        num_fish: usize,
        tick_ms: f32,
        fixed_ms: f32,
        fish_ms: f32,
        frames: usize,
    ) -> Vec<(f32, ViewPlan)> {
        (0..frames)
            .map(|_| {
                let ticks = pacer.max_ticks().min(6);
                let sim_ms = ticks as f32 * tick_ms;
                pacer.simulated(ticks, sim_ms);
                let plan = pacer.plan_view(num_fish);
                let drawn = match &plan {
                    ViewPlan::Whole => num_fish,
                    ViewPlan::Slice { fish, .. } => fish.len(),
                };
                let frame_ms = sim_ms + fixed_ms + fish_ms * drawn as f32;
                pacer.frame_done(drawn, frame_ms, sim_ms);
                (frame_ms, plan)
            })
            .collect()
    }

    #[test]
    fn a_slow_view_is_drawn_in_slices_and_no_frame_waits_for_all_of_it() {
        // lavapipe on this VM: 0.25 ms a fish, 40 ms of panel and water, 90 ms a tick.
        let mut pacer = Pacer::default();
        let frames = run(&mut pacer, 100_000, 90.0, 40.0, 0.25, 2_000);
        // Drawn whole, each frame would take 25 s: the panel drawn in it would answer that late.
        // After a few frames to measure, every frame stays near one tick plus the view budget
        // (or the smallest slice where the fixed cost alone eats the budget).
        let bound = 90.0 + 40.0 + (VIEW_BUDGET_MS.max(MIN_SLICE as f32 * 0.25)) * 1.2;
        for (k, (ms, _)) in frames.iter().enumerate().skip(5) {
            assert!(*ms <= bound, "frame {k} costs {ms} ms > {bound}");
        }
        // The slices of each view cover every fish once, in order, and views complete.
        let mut next = 0;
        let mut complete = 0;
        for (_, plan) in &frames {
            let ViewPlan::Slice { fish, part } = plan else {
                panic!("a 25 s view drawn whole: {plan:?}");
            };
            assert_eq!(part.first, fish.start == 0, "{fish:?}");
            assert_eq!(fish.start, next, "slices are contiguous");
            assert!(!fish.is_empty());
            next = fish.end;
            if part.last {
                assert_eq!(fish.end, 100_000);
                complete += 1;
                next = 0;
            }
        }
        assert!(complete >= 5, "{complete} complete views in 2,000 frames");
        assert!(
            pacer.status().is_some(),
            "the panel says the view is drawn in slices"
        );
    }

    #[test]
    fn a_fast_gpu_draws_every_view_whole() {
        // 1,000 fish on a GPU: the frame is the display's 16.7 ms; nothing changes.
        let mut pacer = Pacer::default();
        for (ms, plan) in run(&mut pacer, 1_000, 1.0, 16.7, 0.0005, 100) {
            assert_eq!(plan, ViewPlan::Whole, "{ms}");
        }
        assert_eq!(pacer.status(), None);
        // 100,000 fish on a real GPU (the view ~30 ms): whole after the first measurements.
        let mut pacer = Pacer::default();
        let frames = run(&mut pacer, 100_000, 90.0, 5.0, 0.0003, 100);
        assert!(
            frames[10..].iter().all(|(_, p)| *p == ViewPlan::Whole),
            "{:?}",
            &frames[..12]
        );
    }

    #[test]
    fn small_views_are_drawn_whole_even_on_a_slow_renderer() {
        // 40 fish on lavapipe: 92 ms a frame, nearly all of it the fixed cost.
        let mut pacer = Pacer::default();
        for (_, plan) in run(&mut pacer, 40, 1.0, 90.0, 0.05, 50) {
            assert_eq!(plan, ViewPlan::Whole);
        }
    }

    #[test]
    fn the_simulation_runs_as_many_ticks_as_fit_in_its_budget_and_at_least_one() {
        let mut pacer = Pacer::default();
        assert_eq!(pacer.max_ticks(), 1, "one tick before any is measured");
        pacer.simulated(1, 90.0);
        assert_eq!(pacer.max_ticks(), 1, "a tick over the budget still runs");
        let mut pacer = Pacer::default();
        pacer.simulated(2, 10.0);
        assert_eq!(pacer.max_ticks(), (SIM_BUDGET_MS / 5.0) as u64);
        // A frame that ran no tick (paused) teaches nothing.
        pacer.simulated(0, 0.0);
        assert_eq!(pacer.max_ticks(), (SIM_BUDGET_MS / 5.0) as u64);
    }

    #[test]
    fn a_restarted_view_starts_again_from_its_first_slice() {
        let mut pacer = Pacer::default();
        pacer.frame_done(1_000, 1_000.0, 0.0); // 1 ms a fish
        let ViewPlan::Slice { fish, part } = pacer.plan_view(10_000) else {
            panic!("10 s of view drawn whole");
        };
        assert!(part.first && !part.last && fish.start == 0);
        let ViewPlan::Slice { fish, .. } = pacer.plan_view(10_000) else {
            panic!();
        };
        assert!(fish.start > 0);
        pacer.restart_view();
        let ViewPlan::Slice { fish, part } = pacer.plan_view(10_000) else {
            panic!();
        };
        assert!(part.first && fish.start == 0);
    }

    /// A view's moment reuses the last one's instance list while the scene names it by the
    /// same revision (no copy per view of a steady scene), and copies the new one otherwise.
    #[test]
    fn a_snapshot_reuses_the_instances_of_the_same_revision_and_copies_new_ones() {
        let fish = |n: u32, tint: f32| -> Vec<FishInstance> {
            (0..n)
                .map(|i| FishInstance {
                    mesh: shoal_render::MeshId(0),
                    palette_offset: i * 7,
                    tint: [tint; 3],
                    selected: false,
                })
                .collect()
        };
        fn input(instances: &[FishInstance], revision: Option<u64>) -> FrameInput<'_> {
            FrameInput {
                palettes: &[],
                instances,
                instances_revision: revision,
                camera: Camera::default(),
                tank: TankBounds::default(),
                time_s: 0.0,
                props: &[],
                overlay: &[],
                look: Look::default(),
                gpu_pose: None,
            }
        }
        let a = fish(600, 1.0);
        let first = ViewSnapshot::take(&input(&a, Some(5)), None);
        assert_eq!(first.instances, a);
        let kept = first.instances.as_ptr();
        // The same revision: the list is taken over, not copied.
        let second = ViewSnapshot::take(&input(&a, Some(5)), Some(first));
        assert_eq!(second.instances.as_ptr(), kept);
        assert_eq!(second.instances, a);
        // A new revision (a fish tinted): copied.
        let mut b = a.clone();
        b[17].tint = [0.5; 3];
        let third = ViewSnapshot::take(&input(&b, Some(6)), Some(second));
        assert_eq!(third.instances, b);
        // No revision: always copied.
        let fourth = ViewSnapshot::take(&input(&a, None), Some(third));
        assert_eq!(fourth.instances, a);
        let fifth = ViewSnapshot::take(&input(&b, None), Some(fourth));
        assert_eq!(fifth.instances, b);
    }
}
