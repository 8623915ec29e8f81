//! Behaviour level of detail: which scripted fish decide on a tick (issue 34).
//!
//! Each fish's decision rate follows how much it matters. Its **band** comes from its distance
//! to the nearest focus point (the window's camera focus and selected fish, or a focus the scene
//! declares; with no focus every fish is in the last band): band `k` holds the fish within
//! `bands[k].radius` and beyond the bands before it. A fish whose species decides every `P`
//! ticks decides, in band `k`, every `P × bands[k].every` ticks, on the ticks where
//! `(tick + slot index / block) % period == 0` — the phase spreads one band's decisions evenly
//! over its period instead of firing them on one frame. `block` ([`phase_block`]) is 1 in a tank
//! of up to 2,047 slots and grows with the slot count, so that in a big tank runs of neighbouring
//! slots decide on the same tick: their Lua tables, motion players and roots lie next to each
//! other in memory, and a lane's decisions read them in order instead of one cold fish after
//! another (docs/performance.md). A behaviour module may ask for a minimum rate
//! (`min_decision_hz`): the period is then never longer than that rate's.
//!
//! An **event wakes** a slow fish at once: when a fish not due has not decided for a whole base
//! period `P` and any of these holds, it decides this tick —
//! it touched the tank or a rock on the last motion step, a wall, the floor or the surface lies
//! within a body length, or it is headed for one or for a rock within the lookahead the shipped
//! behaviours use (2.5 s at cruising speed, `lod.wall_lookahead`) plus the time until it is next
//! due (while these last, it decides every base period); another fish within half a body
//! length, on the ticks it would decide at full rate; a predator of another
//! species or a pellet came within its view range since its last decision (a fish that decided
//! with it in view has reacted, and keeps swimming on that), or the nearest predator in view has
//! closed to [`THREAT_CLOSING`] of its distance then, on the ticks it would decide at full rate
//! (a fleeing fish at full rate turns from the hunter again each base period; without this one
//! in the far band fled on a stale bearing and let it come nearer). Each is a handful of
//! comparisons (the predators and pellets mark the fish around them from one grid query each),
//! so the check costs far less than a decision.
//!
//! The schedule reads only the tick, the fish's slot indices, their state (positions, headings,
//! contact, the tick each last decided and what was in view then) and the focus points, which
//! are inputs (a recording keeps them). So a run with level of detail on is as deterministic as
//! one without: the same whatever the number of lanes or threads, and a replay is bit-exact.

use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};

use glam::Vec3;

use super::sense::forward;
use super::tick::TICK_DT;
use super::{FishId, Obstacle, SpeciesId, World};

/// A wall, the floor or the surface this many body lengths away, in any direction, wakes a
/// slow fish (see [`World::obstacle_near`]).
pub const WALL_MARGIN_LENGTHS: f32 = 1.0;

/// The default [`Lod::wall_lookahead`], seconds: the shipped behaviours look for a side wall
/// where they will be 2.5 s ahead at cruising speed (`C.WALL_LOOKAHEAD` in
/// scripts/behaviors/lib/common.lua), so a slow fish is woken for the walls a full-rate one
/// would already be turning from.
pub const DEFAULT_WALL_LOOKAHEAD_S: f32 = 2.5;

/// Another fish's centre this many body lengths away wakes a slow fish on the ticks it would
/// decide at its species' full rate (see [`World::crowded`]): bodies that close are about to
/// touch, which a full-rate fish's separation rule would already be answering.
pub const COLLISION_LENGTHS: f32 = 0.5;

/// A predator in view that has come this much nearer (as a fraction of its distance when the
/// fish last decided) wakes a slow fish on the ticks it would decide at full rate: a fleeing
/// fish at full rate turns from the hunter again every base period.
pub const THREAT_CLOSING: f32 = 0.8;

/// Most bands a schedule may have.
pub const MAX_BANDS: usize = 6;

/// A tank holds at least this many phase blocks ([`phase_block`]), so that a period of up to 32
/// ticks still gets 32 or more blocks on each of its ticks: the decisions due on a tick stay
/// within about 1/32 of the even share however the blocks fall.
pub const MIN_PHASE_BLOCKS: usize = 1024;

/// How many consecutive slot indices share a decision phase with level of detail on, in a
/// store of `slots` slots: the largest power of two that leaves at least [`MIN_PHASE_BLOCKS`]
/// blocks, 1 below 2,048 slots, at most 256. Despawns never lower the slot count, so the block
/// changes only when spawns double the store past a power of two (the fish's phases then move
/// once).
pub fn phase_block(slots: usize) -> u64 {
    let per = (slots / MIN_PHASE_BLOCKS).max(1);
    let pow2 = 1usize << per.ilog2();
    pow2.min(256) as u64
}

/// One band of the schedule: the fish within `radius` of a focus (and beyond the bands before)
/// decide `every` times less often than their species' rate. With a `cap`, at most that many
/// scripted fish hold the band: the nearest to a focus keep it (ties by slot index) and the
/// rest drop to the next band, as MassLOD caps how many agents a level holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodBand {
    /// Outer radius, world units (the last band's is infinite, whatever it says).
    pub radius: f32,
    /// Period multiplier, ≥ 1.
    pub every: u32,
    /// Most scripted fish the band may hold (`None`: no cap). Not on the last band, which
    /// takes every fish the others do not.
    pub cap: Option<u32>,
}

/// The behaviour level-of-detail settings of a world (configuration, not state: the focus
/// points are inputs, set from outside each tick they change).
#[derive(Clone, Debug, PartialEq)]
pub struct Lod {
    /// Whether the schedule applies (off: every fish decides at its species' rate).
    pub on: bool,
    /// The bands, nearest first (1 to [`MAX_BANDS`]; radii increasing).
    pub bands: Vec<LodBand>,
    /// Focus points; none: every fish is in the last band.
    pub focus: Vec<Vec3>,
    /// Whether events wake slow fish (see the module docs).
    pub wake: bool,
    /// Seconds ahead, at cruising speed or faster, a slow fish looks for walls and rocks:
    /// it is woken when the point it would reach then lies within [`WALL_MARGIN_LENGTHS`]
    /// of a wall, the floor or the surface, or a rock lies on the way. Set it to the horizon
    /// the behaviours avoid walls at ([`DEFAULT_WALL_LOOKAHEAD_S`] for the shipped ones).
    pub wall_lookahead: f32,
}

impl Default for Lod {
    fn default() -> Self {
        Self {
            on: false,
            bands: default_bands(),
            focus: Vec::new(),
            wake: true,
            wall_lookahead: DEFAULT_WALL_LOOKAHEAD_S,
        }
    }
}

/// The default bands: full rate within 600 units of a focus (about twelve porgy lengths), half
/// rate to 1,500, a third beyond. A third, not a quarter: at a quarter `shoal compare` finds the
/// big school touching the glass about 3 % more often than at full rate over 16 seeds and its
/// barracuda catching more over 32; at a third neither over 16 seeds, nor the catches over 32
/// (the wall contacts still read +2 % there; docs/performance.md, "The same at 32 seeds").
pub fn default_bands() -> Vec<LodBand> {
    vec![
        LodBand {
            radius: 600.0,
            every: 1,
            cap: None,
        },
        LodBand {
            radius: 1500.0,
            every: 2,
            cap: None,
        },
        LodBand {
            radius: f32::INFINITY,
            every: 3,
            cap: None,
        },
    ]
}

/// Why a schedule was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LodError {
    /// No band, or more than [`MAX_BANDS`].
    #[error("bands: expected 1 to {MAX_BANDS} bands, got {0}")]
    BandCount(usize),
    /// A band's radius is not positive, or not larger than the band's before.
    #[error("bands[{band}].radius: {radius} must be positive and larger than the band before's")]
    Radius {
        /// The band (1-based, as Lua counts).
        band: usize,
        /// Its radius.
        radius: f32,
    },
    /// A band's period multiplier is 0 or above 600.
    #[error("bands[{band}].every: {every} must be a whole number from 1 to 600")]
    Every {
        /// The band (1-based).
        band: usize,
        /// Its multiplier.
        every: u32,
    },
    /// The last band has a cap: it takes every fish the bands before do not, so it has no
    /// band to drop the rest to.
    #[error(
        "bands[{band}].cap: the last band takes every fish the bands before it do not, so it \
         cannot have a cap (cap the bands before it)"
    )]
    LastCap {
        /// The band (1-based).
        band: usize,
    },
    /// A focus point is not finite.
    #[error("focus: {0} is not a finite point")]
    Focus(Vec3),
    /// The wall lookahead is not a number of seconds from 0 to 60.
    #[error("wall_lookahead: {0} must be a number of seconds from 0 to 60")]
    WallLookahead(f32),
}

impl Lod {
    /// Checks the bands and focus points.
    pub fn validate(&self) -> Result<(), LodError> {
        if self.bands.is_empty() || self.bands.len() > MAX_BANDS {
            return Err(LodError::BandCount(self.bands.len()));
        }
        let mut last = 0.0f32;
        for (k, b) in self.bands.iter().enumerate() {
            let is_last = k + 1 == self.bands.len();
            if !(b.radius > last || (is_last && b.radius.is_infinite())) || b.radius.is_nan() {
                return Err(LodError::Radius {
                    band: k + 1,
                    radius: b.radius,
                });
            }
            if b.every == 0 || b.every > 600 {
                return Err(LodError::Every {
                    band: k + 1,
                    every: b.every,
                });
            }
            if is_last && b.cap.is_some() {
                return Err(LodError::LastCap { band: k + 1 });
            }
            last = b.radius;
        }
        if let Some(p) = self.focus.iter().find(|p| !p.is_finite()) {
            return Err(LodError::Focus(*p));
        }
        if !(0.0..=60.0).contains(&self.wall_lookahead) {
            return Err(LodError::WallLookahead(self.wall_lookahead));
        }
        Ok(())
    }

    /// The band of a fish at `pos` by its distance alone (before any band's cap).
    pub fn band_of(&self, pos: Vec3) -> usize {
        let last = self.bands.len().saturating_sub(1);
        let Some(d2) = self.focus_distance2(pos) else {
            return last;
        };
        self.bands[..last]
            .iter()
            .position(|b| d2 <= b.radius * b.radius)
            .unwrap_or(last)
    }

    /// The squared distance from `pos` to the nearest focus point (`None`: no focus).
    fn focus_distance2(&self, pos: Vec3) -> Option<f32> {
        self.focus
            .iter()
            .map(|f| f.distance_squared(pos))
            .min_by(f32::total_cmp)
    }

    /// Whether a band before the last has a cap (and there is a focus to rank fish by).
    fn capped(&self) -> bool {
        !self.focus.is_empty() && self.bands.iter().any(|b| b.cap.is_some())
    }
}

/// How a tick's decisions fell (see [`World::lod_counts`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LodCounts {
    /// Scripted fish per band (band 0 only when level of detail is off).
    pub fish: [u32; MAX_BANDS],
    /// Decisions per band, wakes included.
    pub decisions: [u32; MAX_BANDS],
    /// Decisions an event caused (fish that were not due by their band).
    pub woken: u32,
    /// Of those, what woke them (the first of the checks, in this order, that held).
    pub woken_by: WokenBy<u32>,
    /// Bands in use.
    pub bands: u8,
}

/// What woke slow fish (see the module docs), per cause.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct WokenBy<T> {
    /// A predator of another species or a pellet came into view, or a predator in view closed
    /// in.
    pub seen: T,
    /// Contact, or a wall, the floor, the surface or a rock near or ahead.
    pub obstacle: T,
    /// Another fish within half a body length.
    pub neighbour: T,
}

impl<T: std::ops::AddAssign + From<u32>> WokenBy<T> {
    /// Adds one tick's counts.
    pub fn add(&mut self, tick: WokenBy<u32>) {
        self.seen += T::from(tick.seen);
        self.obstacle += T::from(tick.obstacle);
        self.neighbour += T::from(tick.neighbour);
    }
}

impl<T> WokenBy<T> {
    /// Each count through `f`.
    pub fn map<U>(self, mut f: impl FnMut(T) -> U) -> WokenBy<U> {
        WokenBy {
            seen: f(self.seen),
            obstacle: f(self.obstacle),
            neighbour: f(self.neighbour),
        }
    }
}

impl LodCounts {
    /// Decisions in all bands.
    pub fn total(&self) -> u32 {
        self.decisions.iter().sum()
    }
}

/// A fish's sighting this tick, one `u32` ([`World::mark_alerts`]): [`Sight::NONE`], nothing in
/// view; [`Sight::PELLET`], a pellet and no predator; anything smaller, a predator of another
/// species, the bits of the nearest one's squared distance (not negative and finite, so below
/// the bits of infinity, and ordered as the distances are: each query keeps the smallest with
/// `fetch_min`, so the marks do not depend on the order of the queries).
struct Sight;

impl Sight {
    const NONE: u32 = u32::MAX;
    const PELLET: u32 = 0x7f80_0000; // f32::INFINITY's bits
    /// The nearest predator's squared distance in a sighting (infinite: none).
    fn threat(bits: u32) -> f32 {
        if bits < Self::PELLET {
            f32::from_bits(bits)
        } else {
            f32::INFINITY
        }
    }
}

/// What woke a fish, in its entry of a tick's schedule (with [`WOKEN`]).
const BY_SEEN: u8 = 0x08;
const BY_OBSTACLE: u8 = 0x10;
const BY_NEIGHBOUR: u8 = 0x20;
/// The `1 + band` part of an entry (bands ≤ [`MAX_BANDS`] fit in three bits).
const BAND_BITS: u8 = 0x07;
/// One fish's entry of a tick's schedule: 0 not due, else `1 + band` (+ [`WOKEN`] if an event
/// woke it).
const WOKEN: u8 = 0x80;
/// Set in a fish's mark when a predator or pellet is in its view range this tick (what it
/// remembers as `alerted` when it decides).
const ALERT: u8 = 0x40;

impl World {
    /// The level-of-detail settings.
    pub fn lod(&self) -> &Lod {
        &self.lod
    }

    /// Replaces the level-of-detail settings (checked first).
    pub fn set_lod(&mut self, lod: Lod) -> Result<(), LodError> {
        lod.validate()?;
        self.lod = lod;
        Ok(())
    }

    /// Moves the focus points (the camera's focus, the selected fish): an input, so a
    /// recording must keep it. Non-finite points are dropped.
    pub fn set_lod_focus(&mut self, focus: Vec<Vec3>) {
        self.lod.focus = focus.into_iter().filter(|p| p.is_finite()).collect();
    }

    /// How the last schedule ([`World::schedule_decisions`]) fell.
    pub fn lod_counts(&self) -> &LodCounts {
        &self.lod_counts
    }

    /// The scripted fish due to decide this tick, in dense order, into `out` (cleared), and
    /// marks them as having decided now. `period(species, behaviour)` gives a fish's base
    /// period in ticks and the longest period its behaviour allows (`u64::MAX`: no minimum
    /// rate). With level of detail off a fish is due when `(tick + slot) % base == 0`, as
    /// always; with it on, see the module docs. The per-fish work (bands, alerts, marks) runs
    /// over rayon's threads in chunks; the result does not depend on their number.
    pub fn schedule_decisions(
        &mut self,
        period: impl Fn(SpeciesId, &str) -> (u64, u64) + Sync,
        out: &mut Vec<(FishId, SpeciesId)>,
    ) {
        use rayon::prelude::*;
        out.clear();
        let tick = self.state.tick;
        let mut marks = std::mem::take(&mut self.lod_marks);
        let mut alert = std::mem::take(&mut self.lod_alert);
        let mut bands = std::mem::take(&mut self.lod_bands);
        if self.lod.on {
            let mut near = std::mem::take(&mut self.lod_near);
            self.assign_bands(&mut bands, &mut near);
            self.lod_near = near;
            if self.lod.wake {
                self.mark_alerts(&mut alert);
            }
        }
        {
            let sight = &alert[..];
            let bands = &bands;
            let world: &World = self;
            let f = &world.state.fish;
            let lod = &world.lod;
            let on = lod.on;
            let block = phase_block(f.slots());
            marks.clear();
            // `period` per species and behaviour, remembered per thread: a tick asks it once
            // for each of the few pairs instead of once per fish (behaviour names are shared,
            // so the name's address tells them apart; another copy of a name only misses).
            type Periods = Vec<(SpeciesId, usize, (u64, u64))>;
            let period_of = |memo: &mut Periods, sid: SpeciesId, behavior: &Arc<str>| {
                let name = Arc::as_ptr(behavior).cast::<u8>() as usize;
                if let Some(&(_, _, p)) = memo.iter().find(|e| e.0 == sid && e.1 == name) {
                    return p;
                }
                let p = period(sid, behavior);
                memo.push((sid, name, p));
                p
            };
            marks.par_extend((0..f.len()).into_par_iter().with_min_len(2048).map_init(
                Periods::new,
                |memo, d| {
                    let Some(behavior) = &f.behaviors[d] else {
                        return 0;
                    };
                    let (base, cap) = period_of(memo, f.species[d], behavior);
                    let base = base.max(1);
                    let slot = u64::from(f.ids[d].index);
                    if !on {
                        return u8::from((tick + slot).is_multiple_of(base));
                    }
                    let phase = tick + slot / block;
                    let band = usize::from(bands[d]);
                    let p = (base * u64::from(lod.bands[band].every))
                        .min(cap.max(1))
                        .max(1);
                    let due = phase.is_multiple_of(p);
                    let idle = tick.saturating_sub(f.last_decided[d]);
                    // Only fish that could be woken, or that decide now (they remember it), ask.
                    let could_wake = lod.wake && p > base && idle >= base;
                    if !(due || could_wake) {
                        return 0;
                    }
                    let alert = lod.wake && world.alerted_now(d, sight);
                    let alert_bit = if alert { ALERT } else { 0 };
                    if due {
                        return (1 + band as u8) | alert_bit;
                    }
                    // A predator or pellet wakes the fish when it came into view since its last
                    // decision (a fish that decided with it in view has reacted and goes on with
                    // that); contact and a wall or rock ahead wake it every base period while
                    // they last; a predator in view that has closed in since, on the ticks it
                    // would decide at full rate (`threat_seen`: its squared distance then).
                    // The ticks until it is next due: how far it swims on its last request before
                    // it decides again.
                    let until_due = p - phase % p;
                    let by = if alert && !f.alerted[d] {
                        BY_SEEN
                    } else if world.obstacle_near(d, until_due) {
                        BY_OBSTACLE
                    } else if phase.is_multiple_of(base) && world.crowded(d) {
                        BY_NEIGHBOUR
                    } else if alert
                        && phase.is_multiple_of(base)
                        && world.threat_now(d, sight)
                            < THREAT_CLOSING * THREAT_CLOSING * f.threat_seen[d]
                    {
                        BY_SEEN
                    } else {
                        return 0;
                    };
                    (1 + band as u8) | WOKEN | by | alert_bit
                },
            ));
        }
        let on = self.lod.on;
        let mut counts = LodCounts {
            bands: if on { self.lod.bands.len() as u8 } else { 1 },
            ..LodCounts::default()
        };
        // Without the marks (the grid was not exact), the nearest predator of each deciding fish
        // that has one in view, scanned before the pass below takes the fish to write to.
        let scanned: Vec<f32> = if alert.is_empty() && self.lod.on && self.lod.wake {
            marks
                .iter()
                .enumerate()
                .map(|(d, &m)| {
                    if m & ALERT != 0 {
                        self.threat_now(d, &alert)
                    } else {
                        f32::INFINITY
                    }
                })
                .collect()
        } else {
            Vec::new()
        };
        // One pass over a byte or two per fish: the per-fish work is done above.
        let f = &mut self.state.fish;
        for (d, &m) in marks.iter().enumerate() {
            if f.behaviors[d].is_none() {
                continue;
            }
            counts.fish[if on { usize::from(bands[d]) } else { 0 }] += 1;
            if m == 0 {
                continue;
            }
            let band = usize::from((m & BAND_BITS) - 1);
            counts.decisions[band] += 1;
            counts.woken += u32::from(m & WOKEN != 0);
            let by = &mut counts.woken_by;
            by.seen += u32::from(m & BY_SEEN != 0);
            by.obstacle += u32::from(m & BY_OBSTACLE != 0);
            by.neighbour += u32::from(m & BY_NEIGHBOUR != 0);
            f.last_decided[d] = tick;
            f.alerted[d] = m & ALERT != 0;
            f.threat_seen[d] = if m & ALERT == 0 {
                f32::INFINITY
            } else if let Some(s) = alert.get(d) {
                Sight::threat(s.load(Ordering::Relaxed))
            } else {
                scanned[d]
            };
            out.push((f.ids[d], f.species[d]));
        }
        self.lod_marks = marks;
        self.lod_alert = alert;
        self.lod_bands = bands;
        self.lod_counts = counts;
    }

    /// Each dense fish's band into `bands`: by its distance to the nearest focus, then, band
    /// by band from the nearest, a capped band keeps its `cap` scripted fish nearest to a focus
    /// (ties by slot index, so the result is one whatever the order of the work) and the
    /// rest drop to the next band, where they rank with the fish already there. `near` is a
    /// buffer (the candidates of one band).
    fn assign_bands(&self, bands: &mut Vec<u8>, near: &mut Vec<(u64, u32)>) {
        use rayon::prelude::*;
        let f = &self.state.fish;
        let lod = &self.lod;
        bands.clear();
        bands.par_extend(
            f.roots
                .par_iter()
                .with_min_len(2048)
                .map(|r| lod.band_of(r.pos) as u8),
        );
        if !lod.capped() {
            return;
        }
        for (k, band) in lod.bands.iter().enumerate() {
            let Some(cap) = band.cap else {
                continue;
            };
            let k8 = k as u8;
            near.clear();
            near.par_extend(
                (0..f.len())
                    .into_par_iter()
                    .with_min_len(2048)
                    .filter_map(|d| {
                        if bands[d] != k8 || f.behaviors[d].is_none() {
                            return None;
                        }
                        // Squared distances are not negative, so their bits order as they do.
                        let d2 = lod.focus_distance2(f.roots[d].pos).unwrap_or(f32::INFINITY);
                        let key = (u64::from(d2.to_bits()) << 32) | u64::from(f.ids[d].index);
                        Some((key, d as u32))
                    }),
            );
            let cap = cap as usize;
            if near.len() <= cap {
                continue;
            }
            // Keys are unique (one slot per fish), so the nearest `cap` are one set.
            near.select_nth_unstable_by_key(cap, |e| e.0);
            for &(_, d) in &near[cap..] {
                bands[d as usize] = k8 + 1;
            }
        }
    }

    /// Marks, per dense fish, what of the predators of other species and the pellets is within
    /// its view range ([`Sight`]: none, a pellet, or the nearest predator's squared distance),
    /// from one grid query around each predator and pellet (there are far fewer of them than
    /// fish, so this costs a few thousand candidate visits where a query per fish would cost one
    /// per fish), the queries over rayon's threads (a mark only ever falls, to the smallest
    /// value, so the marks do not depend on the order). Leaves `alert` empty when the grid is
    /// not exact (fish spawned or despawned since its rebuild): [`World::alerted_now`] and
    /// [`World::threat_now`] then scan them themselves.
    fn mark_alerts(&self, alert: &mut Vec<AtomicU32>) {
        use rayon::prelude::*;
        alert.clear();
        let f = &self.state.fish;
        if !(self.index.grid_exact && self.index.grid_positions_current) {
            return;
        }
        alert.resize_with(f.len(), || AtomicU32::new(Sight::NONE));
        // Each species' view range, 0 for one that sees nothing (not finite, not positive).
        let sight: Vec<f32> = self
            .catalog
            .species
            .iter()
            .map(|s| s.desc.view_range)
            .map(|r| if r.is_finite() && r > 0.0 { r } else { 0.0 })
            .collect();
        let farthest = |except: Option<usize>| {
            sight
                .iter()
                .enumerate()
                .filter(|(k, _)| Some(*k) != except)
                .fold(0.0f32, |m, (_, r)| m.max(*r))
        };
        let reach = farthest(None);
        if reach <= 0.0 {
            return;
        }
        let view2 = |d: usize| {
            let r = sight[usize::from(f.species[d].0)];
            if r > 0.0 { r * r } else { -1.0 }
        };
        // A predator alerts only fish of other species: it looks as far as the farthest-seeing
        // of those (the barracuda sees twice as far as the porgies it hunts, so its own range
        // would visit eight times the fish).
        let reach_of_others: Vec<f32> = (0..sight.len()).map(|own| farthest(Some(own))).collect();
        let alert = &alert[..];
        let grid = &self.index.grid;
        self.index
            .predator_spots
            .par_iter()
            .with_min_len(16)
            .for_each(|spot| {
                let reach = reach_of_others
                    .get(usize::from(spot.species().0))
                    .copied()
                    .unwrap_or(reach);
                if reach <= 0.0 {
                    return;
                }
                grid.for_each_within(spot.pos(), reach, |key, _, d2| {
                    let d = key as usize;
                    if f.species[d] != spot.species() && d2 <= view2(d) {
                        alert[d].fetch_min(d2.to_bits(), Ordering::Relaxed);
                    }
                    true
                });
            });
        self.state
            .foods
            .par_iter()
            .with_min_len(16)
            .filter(|(_, p)| !p.eaten)
            .for_each(|(_, pellet)| {
                grid.for_each_within(pellet.pos, reach, |key, _, d2| {
                    let d = key as usize;
                    if d2 <= view2(d) {
                        alert[d].fetch_min(Sight::PELLET, Ordering::Relaxed);
                    }
                    true
                });
            });
    }

    /// Whether dense fish `d` touched the tank or a rock on the last motion step, has a wall,
    /// the floor or the surface within [`WALL_MARGIN_LENGTHS`] body lengths in any direction,
    /// or is headed for one: the point it reaches in [`Lod::wall_lookahead`] seconds plus the
    /// ticks until it is next due (`until_due`), at its cruising speed or faster and never
    /// nearer than two body lengths, lies within that margin of the tank's bounds, or a rock
    /// lies on the way. This is the horizon at which the shipped behaviours turn from a wall
    /// (`C.sense_collision`), widened by how far the fish swims before it decides again: a
    /// narrower wake (two body lengths straight ahead, then also a side wall within one) left
    /// the 10,000-fish scene touching the walls 7–9 % more often with level of detail on
    /// (docs/performance.md).
    fn obstacle_near(&self, d: usize, until_due: u64) -> bool {
        if self.state.fish.contact[d] {
            return true;
        }
        let path = self.wake_path(d, until_due);
        // Any face in any direction: what a school presses a fish against.
        if path.outside(path.pos) {
            return true;
        }
        !path.clear(&self.state.obstacles) && path.hits(&self.state.obstacles)
    }

    /// The path [`World::obstacle_near`] looks along for dense fish `d`, due in `until_due`
    /// ticks.
    fn wake_path(&self, d: usize, until_due: u64) -> WakePath {
        let f = &self.state.fish;
        let root = &f.roots[d];
        let motion = &self.catalog.species[usize::from(f.species[d].0)]
            .desc
            .motion;
        let l = motion.l;
        let tank = &self.state.tank;
        let margin = Vec3::splat(WALL_MARGIN_LENGTHS * l);
        let speed = root.speed.max(motion.s);
        let speed = if speed.is_finite() {
            speed.max(0.0)
        } else {
            0.0
        };
        WakePath {
            pos: root.pos,
            heading: root.heading,
            pitch: root.pitch,
            reach: (2.0 * l).max(speed * self.lod.wall_lookahead)
                + speed * until_due as f32 * TICK_DT,
            inner_min: tank.min + margin,
            inner_max: tank.max - margin,
        }
    }

    /// Whether another fish's centre lies within [`COLLISION_LENGTHS`] of dense fish `d`'s
    /// body lengths: one grid query of a few cells, stopped at the first fish found. Asked only
    /// on the ticks the fish would decide at full rate, so a crowded slow fish answers its
    /// neighbours as often as a full-rate one and costs at most one query a base period. False
    /// when the grid is not exact and current (fish came or went since it was built, or it
    /// was not rebuilt this tick): those are inputs, so the schedule stays a function of them.
    fn crowded(&self, d: usize) -> bool {
        if !(self.index.grid_exact && self.index.grid_positions_current) {
            return false;
        }
        let f = &self.state.fish;
        let l = self.catalog.species[usize::from(f.species[d].0)]
            .desc
            .motion
            .l;
        let mut found = false;
        self.index
            .grid
            .for_each_within(f.roots[d].pos, COLLISION_LENGTHS * l, |key, _, _| {
                found = key as usize != d;
                !found
            });
        found
    }

    /// The squared distance from dense fish `d` to the nearest predator of another species in
    /// its view range (infinite: none): from `alert` ([`World::mark_alerts`]'s marks) when it
    /// has them, else scanned.
    fn threat_now(&self, d: usize, alert: &[AtomicU32]) -> f32 {
        if let Some(a) = alert.get(d) {
            return Sight::threat(a.load(Ordering::Relaxed));
        }
        let Some(r2) = self.view_range2(d) else {
            return f32::INFINITY;
        };
        let f = &self.state.fish;
        let pos = f.roots[d].pos;
        let me = f.species[d];
        self.index
            .predators
            .iter()
            .filter_map(|&p| f.dense(p))
            .filter(|&o| f.species[o] != me)
            .map(|o| f.roots[o].pos.distance_squared(pos))
            .filter(|&d2| d2 <= r2)
            .fold(f32::INFINITY, f32::min)
    }

    /// The square of dense fish `d`'s view range (`None`: its species sees nothing).
    fn view_range2(&self, d: usize) -> Option<f32> {
        let f = &self.state.fish;
        let range = self.catalog.species[usize::from(f.species[d].0)]
            .desc
            .view_range;
        (range.is_finite() && range > 0.0).then_some(range * range)
    }

    /// Whether a predator of another species or a pellet is within dense fish `d`'s view range:
    /// from `alert` ([`World::mark_alerts`]'s marks) when it has them, else scanned.
    fn alerted_now(&self, d: usize, alert: &[AtomicU32]) -> bool {
        if let Some(a) = alert.get(d) {
            return a.load(Ordering::Relaxed) != Sight::NONE;
        }
        if self.threat_now(d, alert).is_finite() {
            return true;
        }
        let Some(r2) = self.view_range2(d) else {
            return false;
        };
        let pos = self.state.fish.roots[d].pos;
        self.state
            .foods
            .iter()
            .any(|(_, p)| !p.eaten && p.pos.distance_squared(pos) <= r2)
    }
}

/// Where a slow fish is headed for the wall and rock wakes ([`World::obstacle_near`]): from
/// `pos`, `reach` along its heading (level, for the side walls) and along its heading and
/// pitch (for the floor, the surface and rocks), inside the tank shrunk by the wall margin.
#[derive(Clone, Copy, Debug)]
struct WakePath {
    pos: Vec3,
    heading: f32,
    pitch: f32,
    reach: f32,
    inner_min: Vec3,
    inner_max: Vec3,
}

impl WakePath {
    /// Whether `p` lies outside the shrunk tank.
    fn outside(&self, p: Vec3) -> bool {
        p.cmplt(self.inner_min).any() || p.cmpgt(self.inner_max).any()
    }

    /// Whether the path cannot reach a wall or a rock, known without its direction: the box of
    /// `reach` around `pos` lies inside the shrunk tank and every rock is farther than `reach`
    /// beyond its radius. Each component of a unit direction is at most 1 and rounding is
    /// monotonic, so `pos + dir * reach` lies between `pos - reach` and `pos + reach` as
    /// computed here: when this is true, [`WakePath::hits`] is false. Most fish are far from
    /// every wall and rock, and this spares them the sines and cosines.
    fn clear(&self, obstacles: &[Obstacle]) -> bool {
        let reach = Vec3::splat(self.reach);
        !self.outside(self.pos - reach)
            && !self.outside(self.pos + reach)
            && obstacles
                .iter()
                .all(|o| far_apart(o.pos, self.pos, self.reach + o.radius))
    }

    /// Whether the path's end, level or pitched, lies outside the shrunk tank, or a rock lies
    /// on the pitched path (a far lookahead can step over one). The shipped behaviours look
    /// for side walls level, along the heading alone; the pitched direction finds the floor
    /// and surface. The tank is a box: a path stays inside when both of its ends do.
    fn hits(&self, obstacles: &[Obstacle]) -> bool {
        let dir = forward(self.heading, self.pitch);
        if self.outside(self.pos + forward(self.heading, 0.0) * self.reach)
            || self.outside(self.pos + dir * self.reach)
        {
            return true;
        }
        obstacles.iter().any(|o| {
            let along = (o.pos - self.pos).dot(dir).clamp(0.0, self.reach);
            o.pos.distance_squared(self.pos + dir * along) <= o.radius * o.radius
        })
    }
}

/// Whether `a` and `b` are more than `distance` apart with room to spare (a thousandth of it
/// plus a hundredth of a unit, far wider than single-precision rounding): a rock of radius
/// `r` this far beyond `reach + r` from a fish cannot be touched by any point of its path,
/// however the path's points are rounded.
fn far_apart(a: Vec3, b: Vec3, distance: f32) -> bool {
    let margin = distance * 1.001 + 0.01;
    a.distance_squared(b) > margin * margin
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::super::test_world::random_scene_sized;
    use super::*;

    /// The cheap check never clears a path the full check finds blocked, over fish at random
    /// positions, headings, pitches and speeds in a tank with rocks, for several lookaheads and
    /// times until due; and both answers occur, so the check is exercised.
    #[test]
    fn a_path_cleared_without_its_direction_hits_nothing() {
        let (mut cleared, mut hit) = (0, 0);
        for seed in 0..4 {
            let mut scene = random_scene_sized(seed, 600, Vec3::new(40.0, 16.0, 16.0));
            let l = scene.l;
            for k in 0..12 {
                let c = Vec3::new(3.0 + 3.0 * k as f32, 8.0, 4.0 + (k % 3) as f32 * 4.0) * l;
                scene.world.add_obstacle(c, (0.3 + 0.1 * k as f32) * l);
            }
            let world = &mut scene.world;
            for lookahead in [0.0, 2.5, 6.0] {
                world.lod.wall_lookahead = lookahead;
                for d in 0..world.state.fish.len() {
                    for until_due in [0, 5, 23] {
                        let path = world.wake_path(d, until_due);
                        let obstacles = &world.state.obstacles;
                        let hits = path.hits(obstacles);
                        if path.clear(obstacles) {
                            cleared += 1;
                            assert!(!hits, "fish {d}: cleared, but {path:?} hits");
                        }
                        hit += usize::from(hits);
                    }
                }
            }
        }
        assert!(cleared > 1000 && hit > 1000, "cleared {cleared}, hit {hit}");
    }

    /// The phase block is 1 in small tanks, a power of two that leaves at least
    /// [`MIN_PHASE_BLOCKS`] blocks in big ones, and never more than 256.
    #[test]
    fn the_phase_block_grows_with_the_slots_in_powers_of_two() {
        for (slots, block) in [
            (0, 1),
            (1, 1),
            (2_047, 1),
            (2_048, 2),
            (10_000, 8),
            (100_000, 64),
            (1 << 30, 256),
        ] {
            assert_eq!(phase_block(slots), block, "{slots} slots");
        }
        for slots in [2_048, 5_000, 77_777, 262_143, 262_144] {
            let b = phase_block(slots) as usize;
            assert!(
                b.is_power_of_two() && slots / b >= MIN_PHASE_BLOCKS,
                "{slots}: {b}"
            );
            assert!(
                b == 256 || slots / (2 * b) < MIN_PHASE_BLOCKS,
                "{slots}: {b} too small"
            );
        }
    }

    /// The far band's period for a species deciding every 6 ticks, with the default bands.
    fn far_period() -> u64 {
        6 * u64::from(default_bands().last().unwrap().every)
    }

    /// The ticks each of `fish` fish in one species decides on over two far-band periods, with
    /// level of detail on, no focus and no wakes.
    fn due_ticks(fish: usize) -> Vec<Vec<u64>> {
        let mut scene = random_scene_sized(1, fish, Vec3::splat(400.0));
        let world = &mut scene.world;
        let name: std::sync::Arc<str> = "school".into();
        for b in &mut world.state.fish.behaviors {
            *b = Some(name.clone());
        }
        world.lod.on = true;
        world.lod.wake = false;
        let mut due = vec![Vec::new(); fish];
        let mut out = Vec::new();
        for tick in 0..2 * far_period() {
            world.state.tick = tick;
            world.schedule_decisions(|_, _| (6, u64::MAX), &mut out);
            for (id, _) in &out {
                due[id.index as usize].push(tick);
            }
        }
        due
    }

    /// Below 2,048 slots a fish decides where `(tick + slot) % period == 0`, as it always did.
    /// In a bigger tank each run of `phase_block` slots decides on one tick, every fish still
    /// exactly once a period, and no tick takes more than 1/32 over its even share.
    #[test]
    fn neighbouring_slots_share_a_phase_and_the_ticks_stay_even() {
        let p = far_period();
        let due = due_ticks(1_000);
        for (slot, ticks) in due.iter().enumerate() {
            let first = (p - slot as u64 % p) % p;
            assert_eq!(ticks, &vec![first, first + p], "slot {slot}");
        }
        let fish = 4_096;
        let block = phase_block(fish) as usize;
        assert_eq!(block, 4);
        let due = due_ticks(fish);
        let mut per_tick = vec![0usize; 2 * p as usize];
        for (slot, ticks) in due.iter().enumerate() {
            assert_eq!(ticks.len(), 2, "slot {slot}: {ticks:?}");
            assert_eq!(ticks[1], ticks[0] + p, "slot {slot}");
            assert_eq!(
                ticks,
                &due[slot / block * block],
                "slot {slot} left its block"
            );
            per_tick[ticks[0] as usize] += 1;
            per_tick[ticks[1] as usize] += 1;
        }
        let share = (2 * fish) as f64 / (2 * p) as f64;
        let most = *per_tick.iter().max().unwrap() as f64;
        assert!(
            most <= share * (1.0 + 1.0 / 32.0),
            "{most} a tick against {share}: {per_tick:?}"
        );
        assert!(due[0] != due[block], "the next block has its own phase");
    }

    /// A rock is far from a point exactly when it is beyond the distance, with a margin.
    #[test]
    fn far_apart_keeps_a_margin() {
        let a = Vec3::new(100.0, 0.0, 0.0);
        assert!(!far_apart(a, Vec3::ZERO, 100.0));
        assert!(!far_apart(a, Vec3::ZERO, 99.95));
        assert!(far_apart(a, Vec3::ZERO, 99.0));
    }
}
