//! The world's value types: the tank, what a fish spawns with, food, rocks, currents, what a
//! fish perceives, the stage timings, and the errors.

use glam::Vec3;

use super::{FishId, FoodId, MAX_DRIVEN_JOINTS, ObstacleId, SpeciesId};
use crate::motion::MotionError;

/// The tank: an axis-aligned box. The floor is `min.y`, the water surface `max.y`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tank {
    /// Lower corner, world units.
    pub min: Vec3,
    /// Upper corner, world units.
    pub max: Vec3,
}

impl Tank {
    /// Depth below the surface of height `y`, world units.
    pub fn depth_of(&self, y: f32) -> f32 {
        self.max.y - y
    }

    /// Whether `p` lies inside the tank (boundaries included).
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Size along each axis, world units.
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }
}

/// Errors of the world: each names the value and why it was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum WorldError {
    /// A number is NaN or infinite.
    #[error("{what} is {value}: must be a finite number")]
    NonFinite {
        /// Which value.
        what: &'static str,
        /// The value given.
        value: f32,
    },
    /// A number is finite but out of range.
    #[error("{what} is {value}: {why}")]
    OutOfRange {
        /// Which value.
        what: &'static str,
        /// The value given.
        value: f32,
        /// What was expected.
        why: &'static str,
    },
    /// A position lies outside the tank.
    #[error("{what} {pos} lies outside the tank ({min} .. {max})")]
    OutsideTank {
        /// Which position.
        what: &'static str,
        /// The position given.
        pos: Vec3,
        /// The tank's lower corner.
        min: Vec3,
        /// The tank's upper corner.
        max: Vec3,
    },
    /// No species has this id.
    #[error("no species with id {0:?}")]
    UnknownSpecies(SpeciesId),
    /// The fish was despawned (or never existed).
    #[error("fish {0:?} does not exist (despawned or never spawned)")]
    StaleFish(FishId),
    /// The species drives more joints than a fish's fixed-size arrays hold.
    #[error(
        "species {species:?} drives {joints} joints; at most {MAX_DRIVEN_JOINTS} are supported"
    )]
    TooManyDrivenJoints {
        /// The species' name.
        species: String,
        /// Its number of driven joints.
        joints: usize,
    },
    /// A species' rig and model disagree (joint count, inverse bind poses).
    #[error("species {species:?} is inconsistent: {why}")]
    BadSpecies {
        /// The species' name.
        species: String,
        /// What is wrong.
        why: String,
    },
    /// Loading a species' asset or binding its rig failed.
    #[error("cannot load species {species:?} from {path}: {reason}")]
    SpeciesLoad {
        /// The species' name.
        species: String,
        /// The asset path tried.
        path: String,
        /// The underlying error.
        reason: String,
    },
    /// The motion layer refused a request.
    #[error(transparent)]
    Motion(#[from] MotionError),
}

/// Where and how a new fish starts.
#[derive(Debug, Clone, PartialEq)]
pub struct SpawnParams {
    /// Its species.
    pub species: SpeciesId,
    /// Root (head) position, world units; must lie inside the tank.
    pub pos: Vec3,
    /// Heading, radians.
    pub heading: f32,
    /// Pitch, radians, positive nose-up.
    pub pitch: f32,
    /// Starting speed, world units per second (≥ 0); a positive speed starts a swim.
    pub speed: f32,
    /// Name of the behaviour script it runs, if any.
    pub behavior: Option<String>,
    /// Seed of the fish's own random generator.
    pub seed: u64,
}

/// A food pellet. A pellet in the water has `eaten == false`; an eaten one leaves the world, and
/// the world remembers the last few it saw eaten (see [`super::World::food`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Food {
    /// Position, world units.
    pub pos: Vec3,
    /// Whether a fish has eaten it.
    pub eaten: bool,
    /// Which fish ate it.
    pub eaten_by: Option<FishId>,
    /// World time it was eaten at, seconds.
    pub eaten_at: Option<f64>,
    /// World time it was dropped at, seconds (its age counts against the scene's
    /// `food_lifetime`).
    pub dropped_at: f64,
    /// Whether it has come to rest on the floor or a rock (it no longer sinks or drifts).
    pub settled: bool,
}

/// A spherical obstacle (a rock).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Obstacle {
    /// Centre, world units.
    pub pos: Vec3,
    /// Radius, world units.
    pub radius: f32,
}

/// A spherical zone of moving water: fish inside drift with `velocity`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Current {
    /// Centre, world units.
    pub pos: Vec3,
    /// Radius, world units; the drift fades out over the outer fifth.
    pub radius: f32,
    /// Drift velocity, world units per second.
    pub velocity: Vec3,
}

/// What a vision percept is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum PerceptKind {
    /// A fish of a non-predator species (or of the viewer's own species).
    Fish,
    /// A food pellet not yet eaten.
    Food,
    /// An obstacle sphere.
    Obstacle,
    /// A fish of another species whose description marks it a predator.
    Predator,
}

impl PerceptKind {
    /// Every kind, in the order scripts number them (1-based on the Lua side of the API): the
    /// one place those numbers are written.
    pub const ALL: [PerceptKind; 4] = [
        PerceptKind::Fish,
        PerceptKind::Food,
        PerceptKind::Obstacle,
        PerceptKind::Predator,
    ];

    /// Its name in scripts (`shoal.see`, `shoal.nearest`): `"fish"`, `"food"`, `"obstacle"`,
    /// `"predator"`.
    pub fn name(self) -> &'static str {
        match self {
            PerceptKind::Fish => "fish",
            PerceptKind::Food => "food",
            PerceptKind::Obstacle => "obstacle",
            PerceptKind::Predator => "predator",
        }
    }

    /// The kind named `name` (bytes of a Lua string), if any.
    pub fn from_name(name: &[u8]) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name().as_bytes() == name)
    }

    /// The kind scripts number `k` (1-based place in [`PerceptKind::ALL`]).
    pub fn numbered(k: u8) -> Option<Self> {
        Self::ALL.get(usize::from(k).checked_sub(1)?).copied()
    }
}

/// One thing a fish sees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Percept {
    /// What it is.
    pub kind: PerceptKind,
    /// The fish seen (fish and predators).
    pub fish: Option<FishId>,
    /// The food seen.
    pub food: Option<FoodId>,
    /// The obstacle seen.
    pub obstacle: Option<ObstacleId>,
    /// The seen fish's species.
    pub species: Option<SpeciesId>,
    /// Its position (an obstacle's centre), world units.
    pub pos: Vec3,
    /// Distance from the viewer's root, world units (to an obstacle's surface, 0 inside it).
    pub distance: f32,
    /// Radians relative to the viewer's heading, positive to its left, in (−π, π].
    pub bearing: f32,
    /// Radians above the horizontal plane through the viewer (negative below).
    pub elevation: f32,
    /// Heading of the seen fish, radians (0 for food and obstacles).
    pub heading: f32,
    /// Speed of the seen fish, world units per second (0 for food and obstacles).
    pub speed: f32,
}

/// Percepts of many fish, filled by [`World::vision_batch`].
#[derive(Debug, Default, Clone)]
pub struct VisionBatch {
    pub(super) chunks: Vec<Vec<Percept>>,
    /// Per requested fish: (chunk, start, end) in `chunks`.
    pub(super) spans: Vec<(u32, u32, u32)>,
}

impl VisionBatch {
    /// Fish per parallel task.
    pub(super) const CHUNK: usize = 32;

    /// Number of fish in the batch.
    pub fn len(&self) -> usize {
        self.spans.len()
    }

    /// Whether the batch holds no fish.
    pub fn is_empty(&self) -> bool {
        self.spans.is_empty()
    }

    /// Percepts of the batch's `i`-th fish, nearest first (empty for a stale id or out of
    /// range).
    pub fn get(&self, i: usize) -> &[Percept] {
        match self.spans.get(i) {
            Some(&(c, start, end)) => &self.chunks[c as usize][start as usize..end as usize],
            None => &[],
        }
    }
}

/// What a fish feels of its own body and the tank (the paper's body sensor).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodySense {
    /// Root position, world units.
    pub pos: Vec3,
    /// Depth below the surface, world units.
    pub depth: f32,
    /// Height above the floor, world units.
    pub to_floor: f32,
    /// Distance below the surface, world units (equals `depth`).
    pub to_surface: f32,
    /// Distance to the nearest side wall, world units.
    pub to_wall: f32,
    /// Inward unit normal of that wall.
    pub wall_normal: Vec3,
    /// Whether it touched a wall, the floor, the surface or an obstacle in the last motion step.
    pub contact: bool,
    /// Forward speed, world units per second.
    pub speed: f32,
    /// Heading, radians.
    pub heading: f32,
    /// Pitch, radians.
    pub pitch: f32,
}

/// Wall time of each stage of the last tick, nanoseconds (the tuning panel and `shoal bench`
/// show these). The world fills `motion_ns`, `skeleton_ns`, `palette_ns` and `grid_ns`; the Lua
/// host (or a Rust driver) fills `perception_ns`, `lua_ns`, `schedule_ns` and the per-decision
/// figures.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StageCounters {
    /// Sensor queries (vision, body sense, neighbour queries).
    pub perception_ns: u64,
    /// Behaviour scripts.
    pub lua_ns: u64,
    /// Choosing which fish decide this tick (the level-of-detail schedule: bands, wakes), and
    /// checking their controls out and in; part of the behaviour stage's wall time.
    pub schedule_ns: u64,
    /// Motion players, currents and contact.
    pub motion_ns: u64,
    /// Rig pose and forward kinematics.
    pub skeleton_ns: u64,
    /// Skinning palettes.
    pub palette_ns: u64,
    /// Spatial grid rebuild.
    pub grid_ns: u64,
    /// Behaviour decisions made in the tick.
    pub decisions: u64,
    /// CPU time of those decisions' behaviour code, summed over threads, sensor queries not
    /// included (the cost per decision is this over `decisions`).
    pub decide_cpu_ns: u64,
    /// CPU time of the sensor queries those decisions made, summed over threads (0 where the
    /// sensing is not timed per decision).
    pub sense_cpu_ns: u64,
}

impl StageCounters {
    /// Sum of all stages, nanoseconds.
    pub fn total_ns(&self) -> u64 {
        self.perception_ns
            + self.lua_ns
            + self.schedule_ns
            + self.motion_ns
            + self.skeleton_ns
            + self.palette_ns
            + self.grid_ns
    }
}

pub(super) fn finite(what: &'static str, value: f32) -> Result<(), WorldError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(WorldError::NonFinite { what, value })
    }
}

pub(super) fn finite3(what: [&'static str; 3], v: Vec3) -> Result<(), WorldError> {
    finite(what[0], v.x)?;
    finite(what[1], v.y)?;
    finite(what[2], v.z)
}
