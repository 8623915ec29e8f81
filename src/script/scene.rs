//! Scene and species files: Lua tables read into typed structs through mlua's serde support.
//!
//! A scene (`scripts/scenes/*.lua`) returns
//!
//! ```lua
//! return {
//!   tank = { min = {-400, 0, -250}, max = {400, 300, 250} },   -- world units, y up
//!   fish = {
//!     { species = "black_porgy", count = 24, behavior = "school",
//!       region = { min = {-150, 100, -100}, max = {150, 200, 100} }, heading = 0, speed = 40 },
//!     { species = "barracuda", behavior = "predator", pos = {-350, 150, 0} },
//!   },
//!   food = { {0, 150, 0} },                                     -- pellets at start
//!   food_drops = { every = 6, count = 4, start = 2,              -- seconds
//!                  region = { min = {-200, 280, -150}, max = {200, 290, 150} } },
//!   obstacles = { { pos = {100, 40, 0}, radius = 40 } },
//!   currents = { { pos = {0, 150, 0}, radius = 120, velocity = {10, 0, 0} } },
//! }
//! ```
//!
//! A species file (`scripts/species/<name>.lua`) returns a table of `SpeciesDesc` fields; with
//! `base = "black_porgy"` (or `"eel"`) it starts from that built-in description and overrides only
//! what it names (nested tables such as `motion` merge field by field). `decision_hz` (behaviour
//! decisions per second, default 10) is read by the script host.

use mlua::{Lua, LuaSerdeExt, Table, Value};
use serde::Deserialize;

use crate::species::SpeciesDesc;

/// An axis-aligned box, world units.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub struct BoxDesc {
    /// Lower corner.
    pub min: [f32; 3],
    /// Upper corner.
    pub max: [f32; 3],
}

/// A group of fish of one species.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct FishGroup {
    /// Species name (a file `scripts/species/<name>.lua`).
    pub species: String,
    /// How many (default 1).
    #[serde(default = "one")]
    pub count: u32,
    /// Behaviour module they run (`scripts/behaviors/<name>.lua`); none = no script.
    #[serde(default)]
    pub behavior: Option<String>,
    /// Exact start position of the first fish (the others, if any, are placed in `region`).
    #[serde(default)]
    pub pos: Option<[f32; 3]>,
    /// Box the fish start in, uniformly at random (seeded). Default: the middle half of the tank.
    #[serde(default)]
    pub region: Option<BoxDesc>,
    /// Start heading, radians; default random.
    #[serde(default)]
    pub heading: Option<f32>,
    /// Start speed, world units per second; default the species' cruise speed.
    #[serde(default)]
    pub speed: Option<f32>,
}

fn one() -> u32 {
    1
}

/// Food dropped in at regular intervals.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub struct FoodDrops {
    /// Seconds between drops (> 0).
    pub every: f32,
    /// Pellets per drop (default 1).
    #[serde(default = "one")]
    pub count: u32,
    /// Time of the first drop, seconds (default `every`).
    #[serde(default)]
    pub start: Option<f32>,
    /// Where pellets appear (default: a thin layer under the surface).
    #[serde(default)]
    pub region: Option<BoxDesc>,
}

/// A sphere obstacle.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub struct ObstacleDesc {
    /// Centre.
    pub pos: [f32; 3],
    /// Radius.
    pub radius: f32,
}

/// A current zone.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub struct CurrentDesc {
    /// Centre.
    pub pos: [f32; 3],
    /// Radius.
    pub radius: f32,
    /// Drift velocity, world units per second.
    pub velocity: [f32; 3],
}

/// A scene file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct SceneDesc {
    /// The tank.
    pub tank: BoxDesc,
    /// Directory of the species' assets, relative to the repository root (default `assets`).
    #[serde(default)]
    pub assets: Option<String>,
    /// Species to load even if no fish of them starts in the scene.
    #[serde(default)]
    pub species: Vec<String>,
    /// Fish groups.
    #[serde(default)]
    pub fish: Vec<FishGroup>,
    /// Pellets present at the start.
    #[serde(default)]
    pub food: Vec<[f32; 3]>,
    /// Periodic food drops.
    #[serde(default)]
    pub food_drops: Option<FoodDrops>,
    /// Obstacles.
    #[serde(default)]
    pub obstacles: Vec<ObstacleDesc>,
    /// Current zones.
    #[serde(default)]
    pub currents: Vec<CurrentDesc>,
}

/// A species file, read.
#[derive(Debug, Clone)]
pub struct SpeciesFile {
    /// The description for the world.
    pub desc: SpeciesDesc,
    /// Behaviour decisions per second (default 10).
    pub decision_hz: f64,
}

/// Built-in descriptions a species file can start from.
fn base_desc(name: &str) -> Option<SpeciesDesc> {
    match name {
        "black_porgy" => Some(SpeciesDesc::black_porgy()),
        "eel" => Some(SpeciesDesc::eel()),
        _ => None,
    }
}

/// Copies `over` into `base`, merging nested tables key by key.
fn merge(base: &Table, over: &Table) -> mlua::Result<()> {
    for kv in over.pairs::<Value, Value>() {
        let (k, v) = kv?;
        match (&v, base.raw_get::<Value>(k.clone())?) {
            (Value::Table(o), Value::Table(b)) if o.raw_len() == 0 && !is_array_like(&b) => {
                merge(&b, o)?
            }
            _ => base.raw_set(k, v)?,
        }
    }
    Ok(())
}

fn is_array_like(t: &Table) -> bool {
    t.raw_len() > 0
}

/// Reads a species table (the value a species file returned) into a [`SpeciesFile`]. `file` names
/// the file in messages.
pub fn species_from_table(lua: &Lua, file: &str, t: Table) -> Result<SpeciesFile, String> {
    let err = |e: mlua::Error| format!("{file}: {}", super::error::describe(&e));
    let decision_hz = match t.raw_get::<Value>("decision_hz").map_err(err)? {
        Value::Nil => 10.0,
        v => {
            let hz = v
                .as_number()
                .or(v.as_integer().map(|i| i as f64))
                .unwrap_or(f64::NAN);
            if !(hz.is_finite() && hz > 0.0 && hz <= 60.0) {
                return Err(format!(
                    "{file}: decision_hz must be a number in (0, 60], got {}",
                    v.to_string().unwrap_or_default()
                ));
            }
            hz
        }
    };
    t.raw_set("decision_hz", Value::Nil).map_err(err)?;
    let table = match t.raw_get::<Option<String>>("base").map_err(err)? {
        Some(base) => {
            let desc = base_desc(&base).ok_or_else(|| {
                format!(
                    "{file}: unknown base species '{base}' (expected \"black_porgy\" or \"eel\")"
                )
            })?;
            let Value::Table(b) = lua.to_value(&desc).map_err(err)? else {
                return Err(format!("{file}: base species did not serialize to a table"));
            };
            t.raw_set("base", Value::Nil).map_err(err)?;
            merge(&b, &t).map_err(err)?;
            b
        }
        None => t,
    };
    let desc: SpeciesDesc = lua
        .from_value(Value::Table(table))
        .map_err(|e| format!("{file}: {}", super::error::describe(&e)))?;
    Ok(SpeciesFile { desc, decision_hz })
}
