//! The window's time travel (issue 14): a bounded history of the running aquarium — a kept
//! [`SimState`] every second of simulated time and every fish's position at every tick — to
//! scrub back to any moment of it, and, after playing on from a rewound moment (with whatever
//! scripts are loaded now), the previous run's paths as ghosts and which fish left them.
//!
//! A scrub to tick `t` puts back the latest kept state at or before `t` and runs the ticks
//! between (at most a second's). Playing on from a rewound moment moves the history after it
//! into the ghost and records the new run in its place; each new tick's positions are compared,
//! bit for bit, with the ghost's at the same tick.

use std::collections::VecDeque;

use glam::Vec3;

use super::showable::{Showable, SimState};
use shoal_core::world::{FishId, TICK_HZ};
use shoal_render::OverlayLine;

/// What the panel calls a ghost made by rewinding.
const GHOST_OF_REWIND: &str = "the run before the rewind";

/// Default history span: the last five minutes of simulated time.
pub const DEFAULT_SPAN_S: f64 = 300.0;

/// Ticks between kept states at the least (one second).
const KEEP_EVERY_TICKS: u64 = TICK_HZ as u64;

/// Fish from which a state is kept every [`KEEP_LARGE_TICKS`] instead of every second. Taking
/// a state (the world and every fish's script table) costs about as much as 13 ticks, whatever
/// the number of fish (`shoal bench history`); every 3 s that is about 7 % of the ticks' time.
/// A small aquarium keeps one every second, so a scrub re-runs at most a second of ticks.
const LARGE_AQUARIUM_FISH: usize = 500;

/// Ticks between kept states in a large aquarium (three seconds).
const KEEP_LARGE_TICKS: u64 = 3 * KEEP_EVERY_TICKS;

/// Every fish's position at one tick.
#[derive(Debug, Clone)]
struct TickTrack {
    tick: u64,
    ids: Vec<FishId>,
    pos: Vec<Vec3>,
}

impl TickTrack {
    fn of<S: Showable + ?Sized>(sim: &S) -> Self {
        let w = sim.world();
        let ids = w.fish_id_slice().to_vec();
        let pos = ids
            .iter()
            .map(|&id| w.root(id).map_or(Vec3::NAN, |r| r.pos))
            .collect();
        Self {
            tick: w.tick_count(),
            ids,
            pos,
        }
    }

    /// Position of `id` (the dense order rarely changes: try the same index first).
    fn pos_of(&self, id: FishId, hint: usize) -> Option<Vec3> {
        if self.ids.get(hint) == Some(&id) {
            return Some(self.pos[hint]);
        }
        self.ids.iter().position(|&i| i == id).map(|i| self.pos[i])
    }

    fn bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.ids.capacity() * std::mem::size_of::<FishId>()
            + self.pos.capacity() * std::mem::size_of::<Vec3>()
    }
}

/// A fish that left its ghost (the previous run's path after the rewound moment).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Divergence {
    /// The fish.
    pub fish: FishId,
    /// Simulated time of the first tick its position differed from the ghost's, seconds.
    pub first_s: f64,
    /// Largest distance from its ghost so far, length units.
    pub max_distance: f32,
}

/// The history ring, the ghost and the divergence list (see the module docs).
#[derive(Debug)]
pub struct Timeline {
    span_ticks: u64,
    /// Kept states, oldest first, one per `keep_every` ticks.
    states: VecDeque<SimState>,
    states_bytes: usize,
    /// Positions at every tick from the first kept state's tick on, contiguous.
    track: VecDeque<TickTrack>,
    track_bytes: usize,
    /// The previous run's positions after the rewound moment.
    ghost: VecDeque<TickTrack>,
    divergences: Vec<Divergence>,
    /// Simulated times of script errors, oldest first.
    error_times: Vec<f64>,
    /// The last "cannot keep the state" message, shown once.
    last_keep_error: Option<String>,
    /// Where the ghost comes from, as the panel says it.
    ghost_source: &'static str,
    /// Ticks between kept states now (see [`LARGE_AQUARIUM_FISH`]).
    keep_every: u64,
}

impl Default for Timeline {
    fn default() -> Self {
        Self::new(DEFAULT_SPAN_S)
    }
}

impl Timeline {
    /// An empty history keeping the last `span_s` seconds.
    pub fn new(span_s: f64) -> Self {
        Self {
            span_ticks: (span_s.max(1.0) * TICK_HZ).round() as u64,
            states: VecDeque::new(),
            states_bytes: 0,
            track: VecDeque::new(),
            track_bytes: 0,
            ghost: VecDeque::new(),
            divergences: Vec::new(),
            error_times: Vec::new(),
            last_keep_error: None,
            ghost_source: GHOST_OF_REWIND,
            keep_every: KEEP_EVERY_TICKS,
        }
    }

    /// Forgets everything (the scene restarted).
    pub fn clear(&mut self) {
        *self = Self::new(self.span_ticks as f64 / TICK_HZ);
    }

    /// Records the simulation's tick: its fish positions, and its whole state on a whole
    /// second. A tick at or before the newest recorded one means the simulation was rewound
    /// and plays on: the history after it becomes the ghost. Returns a console line when the
    /// state could not be kept (once per distinct message; the aquarium goes on, and so does
    /// recording of positions).
    pub fn record<S: Showable + ?Sized>(&mut self, sim: &S) -> Option<String> {
        let now = TickTrack::of(sim);
        let tick = now.tick;
        if self.track.back().is_some_and(|b| tick <= b.tick) {
            self.branch(tick);
        }
        let mut message = None;
        self.keep_every = if now.ids.len() >= LARGE_AQUARIUM_FISH {
            KEEP_LARGE_TICKS
        } else {
            KEEP_EVERY_TICKS
        };
        if self.states.is_empty() || tick.is_multiple_of(self.keep_every) {
            let taken = sim.snapshot();
            match taken {
                Ok(state) => {
                    self.states_bytes += state.approx_bytes();
                    self.states.push_back(state);
                    self.last_keep_error = None;
                }
                Err(e) => {
                    let line = format!(
                        "history: cannot keep the state at {:.2} s: {e}",
                        now_s(tick)
                    );
                    let text = e.to_string();
                    if self.last_keep_error.as_deref() != Some(text.as_str()) {
                        message = Some(line);
                    }
                    self.last_keep_error = Some(text);
                }
            }
        }
        if !self.states.is_empty() {
            self.compare_with_ghost(&now);
            self.track_bytes += now.bytes();
            self.track.push_back(now);
        }
        self.evict();
        message
    }

    /// Seconds between kept states now: 1, or 3 from [`LARGE_AQUARIUM_FISH`] fish.
    pub fn keep_every_s(&self) -> f64 {
        self.keep_every as f64 / TICK_HZ
    }

    /// Remembers a script error's simulated time (for "jump to last error").
    pub fn note_error(&mut self, time_s: f64) {
        self.error_times.push(time_s);
        if self.error_times.len() > 1000 {
            self.error_times.remove(0);
        }
    }

    /// The last script error's time within the history, seconds.
    pub fn last_error_s(&self) -> Option<f64> {
        let (from, to) = self.span_s()?;
        self.error_times
            .iter()
            .rev()
            .copied()
            .find(|t| (from..=to + 1e-9).contains(t))
    }

    /// Simulated times the history covers, seconds (first kept state to newest tick).
    pub fn span_s(&self) -> Option<(f64, f64)> {
        let first = self.states.front()?.tick();
        let last = self.track.back().map_or(first, |t| t.tick);
        Some((now_s(first), now_s(last)))
    }

    /// Number of kept states.
    pub fn num_states(&self) -> usize {
        self.states.len()
    }

    /// Bytes held by the kept states.
    pub fn states_bytes(&self) -> usize {
        self.states_bytes
    }

    /// Bytes held by the per-tick positions (history and ghost).
    pub fn track_bytes(&self) -> usize {
        self.track_bytes + self.ghost.iter().map(TickTrack::bytes).sum::<usize>()
    }

    /// The fish that left their ghost, by the time they did.
    pub fn divergences(&self) -> &[Divergence] {
        &self.divergences
    }

    /// Where the ghost comes from: the run before a rewind, or a recording opened.
    pub fn ghost_source(&self) -> &'static str {
        self.ghost_source
    }

    /// Simulated times the ghost covers, seconds.
    pub fn ghost_span_s(&self) -> Option<(f64, f64)> {
        Some((
            now_s(self.ghost.front()?.tick),
            now_s(self.ghost.back()?.tick),
        ))
    }

    /// Where to scrub to reach tick `target`: the latest kept state at or before it (clamped
    /// to the history) and the ticks to run from there.
    pub fn seek(&self, target_s: f64) -> Option<(&SimState, u64)> {
        let (from, to) = self.span_s()?;
        let target = tick_of(target_s.clamp(from, to));
        let i = self.states.partition_point(|s| s.tick() <= target);
        let state = self.states.get(i.checked_sub(1)?)?;
        Some((state, target - state.tick()))
    }

    /// Makes the history after `tick - 1` the ghost: the simulation was rewound there and a
    /// new run starts.
    fn branch(&mut self, tick: u64) {
        self.ghost_source = GHOST_OF_REWIND;
        let keep = self.track.partition_point(|t| t.tick < tick);
        self.ghost = self.track.split_off(keep);
        self.track_bytes = self.track.iter().map(TickTrack::bytes).sum();
        while self.states.back().is_some_and(|s| s.tick() >= tick) {
            if let Some(s) = self.states.pop_back() {
                self.states_bytes -= s.approx_bytes();
            }
        }
        self.divergences.clear();
    }

    /// Makes `ticks` — `(tick, fish, positions)`, contiguous, from the current tick on — the
    /// ghost: a recording opened at this moment (`shoal run --open`). Playing on compares each
    /// new tick with the recording's, bit for bit, as after a rewind, and lists the fish that
    /// leave it.
    pub fn set_ghost(&mut self, ticks: impl IntoIterator<Item = (u64, Vec<FishId>, Vec<Vec3>)>) {
        self.ghost_source = "the recording opened";
        self.ghost = ticks
            .into_iter()
            .map(|(tick, ids, pos)| TickTrack { tick, ids, pos })
            .collect();
        self.divergences.clear();
    }

    fn compare_with_ghost(&mut self, now: &TickTrack) {
        let Some(first) = self.ghost.front() else {
            return;
        };
        let Some(ghost) = now
            .tick
            .checked_sub(first.tick)
            .and_then(|k| self.ghost.get(k as usize))
        else {
            return;
        };
        note_divergences(now, ghost, &mut self.divergences);
    }

    /// The recorded positions of `tick`, if the history holds it.
    fn track_at(&self, tick: u64) -> Option<&TickTrack> {
        let first = self.track.front()?.tick;
        let k = usize::try_from(tick.checked_sub(first)?).ok()?;
        match self.track.get(k) {
            Some(t) if t.tick == tick => Some(t),
            // Not contiguous (never expected): look it up.
            _ => {
                let i = self.track.partition_point(|t| t.tick < tick);
                self.track.get(i).filter(|t| t.tick == tick)
            }
        }
    }

    /// Compares this history with `other`'s (another version of the scripts run in lockstep,
    /// the split tank) over ticks `from..=to`, tick by tick and bit for bit, as a new run is
    /// compared with its ghost: adds each fish whose position first differs to `out`, with the
    /// time it did, and grows the largest distance of those already listed. Ticks either
    /// history lacks are skipped.
    pub fn compare_with(&self, other: &Timeline, from: u64, to: u64, out: &mut Vec<Divergence>) {
        if from > to {
            return;
        }
        let start = self.track.partition_point(|t| t.tick < from);
        for now in self.track.range(start..).take_while(|t| t.tick <= to) {
            if let Some(reference) = other.track_at(now.tick) {
                note_divergences(now, reference, out);
            }
        }
    }

    /// Tick of the first recorded positions (the start of the history), if any.
    pub fn first_tick(&self) -> Option<u64> {
        self.track.front().map(|t| t.tick)
    }

    /// Fish `ids`' paths in this history from tick `from` to tick `to` (every fourth tick), in
    /// `color`: the split tank draws the other version's path beside a fish that left it.
    pub fn path_lines(
        &self,
        ids: impl IntoIterator<Item = FishId>,
        from: u64,
        to: u64,
        color: [f32; 4],
        out: &mut Vec<OverlayLine>,
    ) {
        const EVERY: usize = 4;
        let start = self.track.partition_point(|t| t.tick < from);
        let end = self.track.partition_point(|t| t.tick <= to);
        let rows: Vec<usize> = (start..end)
            .step_by(EVERY)
            .chain(end.checked_sub(1).filter(|&last| last >= start))
            .collect();
        for id in ids {
            polyline(&self.track, &rows, id, color, out);
        }
    }

    fn evict(&mut self) {
        let Some(newest) = self.track.back().map(|t| t.tick) else {
            return;
        };
        let floor = newest.saturating_sub(self.span_ticks);
        while self.states.len() > 1 && self.states.front().is_some_and(|s| s.tick() < floor) {
            if let Some(s) = self.states.pop_front() {
                self.states_bytes -= s.approx_bytes();
            }
        }
        let first = self.states.front().map_or(newest, SimState::tick);
        while self.track.front().is_some_and(|t| t.tick < first) {
            if let Some(t) = self.track.pop_front() {
                self.track_bytes -= t.bytes();
            }
        }
    }

    /// For each fish that left its ghost, and for `also` (the selected fish): its ghost's path
    /// (faint), its new path since the rewind (orange), and a tether from where it is to where
    /// its ghost is now; from `before_s` seconds before simulated time `now_s` to `after_s`
    /// seconds after it (the ghost runs ahead of the new run). Fish that follow their ghost
    /// draw nothing: their ghost is their path.
    pub fn ghost_lines(
        &self,
        now_s: f64,
        before_s: f64,
        after_s: f64,
        also: Option<FishId>,
        out: &mut Vec<OverlayLine>,
    ) {
        const EVERY: usize = 4;
        let (Some(first), Some(last)) = (self.ghost.front(), self.ghost.back()) else {
            return;
        };
        let (ghost_start, ghost_end) = (first.tick, last.tick);
        let now = tick_of(now_s);
        let (from, to) = (
            tick_of((now_s - before_s).max(0.0)),
            tick_of(now_s + after_s),
        );
        let window = |track: &VecDeque<TickTrack>, to: u64| -> Vec<usize> {
            let start = track.partition_point(|t| t.tick < from);
            let end = track.partition_point(|t| t.tick <= to);
            (start..end)
                .step_by(EVERY)
                .chain(end.checked_sub(1).filter(|&last| last >= start))
                .collect()
        };
        let ghost_rows = window(&self.ghost, to);
        let new_rows: Vec<usize> = window(&self.track, now)
            .into_iter()
            .filter(|&k| self.track[k].tick + 1 >= ghost_start)
            .collect();
        let ghost_now = (ghost_start..=ghost_end)
            .contains(&now)
            .then(|| &self.ghost[(now - ghost_start) as usize]);
        let fish = self
            .divergences
            .iter()
            .map(|d| d.fish)
            .chain(also.filter(|id| self.divergences.iter().all(|d| d.fish != *id)));
        for id in fish {
            polyline(&self.ghost, &ghost_rows, id, GHOST_COLOR, out);
            polyline(&self.track, &new_rows, id, NEW_PATH_COLOR, out);
            let here = self.track.back().filter(|t| t.tick == now);
            if let (Some(a), Some(b)) = (
                here.and_then(|t| t.pos_of(id, 0)),
                ghost_now.and_then(|t| t.pos_of(id, 0)),
            ) && a != b
            {
                out.push(OverlayLine {
                    a,
                    b,
                    color: TETHER_COLOR,
                });
            }
        }
    }
}

/// Adds each fish whose position in `now` differs, bit for bit, from its position in
/// `reference` (the same tick of another run: the ghost, or the other version of the split
/// tank) to `out` with that tick's time, and grows the largest distance of every fish already
/// listed. Fish missing from `reference` are skipped.
fn note_divergences(now: &TickTrack, reference: &TickTrack, out: &mut Vec<Divergence>) {
    for (i, (&id, &p)) in now.ids.iter().zip(&now.pos).enumerate() {
        let Some(g) = reference.pos_of(id, i) else {
            continue;
        };
        let same = p.to_array().map(f32::to_bits) == g.to_array().map(f32::to_bits);
        let found = out.iter_mut().find(|d| d.fish == id);
        match (found, same) {
            (Some(d), _) => d.max_distance = d.max_distance.max(p.distance(g)),
            (None, false) => out.push(Divergence {
                fish: id,
                first_s: now_s(now.tick),
                max_distance: p.distance(g),
            }),
            (None, true) => {}
        }
    }
}

/// Colour of a ghost's path (the run before the rewind).
pub const GHOST_COLOR: [f32; 4] = [0.8, 0.92, 1.0, 0.45];
/// Colour of a fish's new path since the rewind, where it left its ghost.
pub const NEW_PATH_COLOR: [f32; 4] = [1.0, 0.55, 0.1, 1.0];
/// Colour of the tether from a fish to where its ghost is now.
pub const TETHER_COLOR: [f32; 4] = [1.0, 0.9, 0.2, 0.9];

/// Segments joining fish `id`'s positions at rows `rows` of `track`.
fn polyline(
    track: &VecDeque<TickTrack>,
    rows: &[usize],
    id: FishId,
    color: [f32; 4],
    out: &mut Vec<OverlayLine>,
) {
    let mut prev: Option<Vec3> = None;
    for &k in rows {
        let p = track[k].pos_of(id, 0);
        if let (Some(a), Some(b)) = (prev, p) {
            out.push(OverlayLine { a, b, color });
        }
        prev = p;
    }
}

fn now_s(tick: u64) -> f64 {
    tick as f64 / TICK_HZ
}

fn tick_of(time_s: f64) -> u64 {
    (time_s * TICK_HZ).round().max(0.0) as u64
}

/// `m:ss` for a simulated time.
pub fn clock(time_s: f64) -> String {
    let s = time_s.max(0.0).floor() as u64;
    format!("{}:{:02}", s / 60, s % 60)
}
