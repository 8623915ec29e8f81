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
//!   food_sink_speed = 10, food_lifetime = 90,                   -- units/s, seconds
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

use shoal_core::species::SpeciesDesc;

/// An axis-aligned box, world units.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxDesc {
    /// Lower corner.
    pub min: [f32; 3],
    /// Upper corner.
    pub max: [f32; 3],
}

/// A group of fish of one species.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
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
    /// Any table of plain data (waypoints, a territory centre …) handed to each fish of the group
    /// as `fish.params`.
    #[serde(default, deserialize_with = "finite_params")]
    pub params: Option<serde_json::Value>,
}

/// `params` read as JSON, refusing NaN and infinities with their field path
/// (`fish[2].params.hide_at[3]`): JSON has no such numbers, so they would otherwise arrive in
/// Lua as `null`, a userdata.
fn finite_params<'de, D: serde::Deserializer<'de>>(
    de: D,
) -> Result<Option<serde_json::Value>, D::Error> {
    Ok(Some(FiniteJson::deserialize(de)?.0))
}

/// A JSON value whose numbers are all finite.
struct FiniteJson(serde_json::Value);

impl<'de> Deserialize<'de> for FiniteJson {
    fn deserialize<D: serde::Deserializer<'de>>(de: D) -> Result<Self, D::Error> {
        de.deserialize_any(FiniteJsonVisitor).map(FiniteJson)
    }
}

struct FiniteJsonVisitor;

impl<'de> serde::de::Visitor<'de> for FiniteJsonVisitor {
    type Value = serde_json::Value;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("plain data (numbers, strings, booleans, tables)")
    }
    fn visit_bool<E>(self, v: bool) -> Result<Self::Value, E> {
        Ok(v.into())
    }
    fn visit_i64<E>(self, v: i64) -> Result<Self::Value, E> {
        Ok(v.into())
    }
    fn visit_u64<E>(self, v: u64) -> Result<Self::Value, E> {
        Ok(v.into())
    }
    fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Self::Value, E> {
        serde_json::Number::from_f64(v)
            .map(serde_json::Value::Number)
            .ok_or_else(|| E::custom(format!("{v} is not a finite number")))
    }
    fn visit_str<E>(self, v: &str) -> Result<Self::Value, E> {
        Ok(v.into())
    }
    fn visit_unit<E>(self) -> Result<Self::Value, E> {
        Ok(serde_json::Value::Null)
    }
    fn visit_none<E>(self) -> Result<Self::Value, E> {
        Ok(serde_json::Value::Null)
    }
    fn visit_some<D: serde::Deserializer<'de>>(self, de: D) -> Result<Self::Value, D::Error> {
        FiniteJson::deserialize(de).map(|v| v.0)
    }
    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut items = Vec::new();
        while let Some(FiniteJson(v)) = seq.next_element()? {
            items.push(v);
        }
        Ok(serde_json::Value::Array(items))
    }
    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let mut out = serde_json::Map::new();
        while let Some((k, FiniteJson(v))) = map.next_entry::<String, FiniteJson>()? {
            out.insert(k, v);
        }
        Ok(serde_json::Value::Object(out))
    }
}

fn one() -> u32 {
    1
}

/// Food dropped in at regular intervals.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
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
#[serde(deny_unknown_fields)]
pub struct ObstacleDesc {
    /// Centre.
    pub pos: [f32; 3],
    /// Radius.
    pub radius: f32,
}

/// A current zone.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
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
#[serde(deny_unknown_fields)]
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
    /// How fast pellets sink, world units per second (default 0: they stay where dropped).
    #[serde(default)]
    pub food_sink_speed: Option<f32>,
    /// Seconds an uneaten pellet lasts before it dissolves (default: for ever).
    #[serde(default)]
    pub food_lifetime: Option<f32>,
    /// Obstacles.
    #[serde(default)]
    pub obstacles: Vec<ObstacleDesc>,
    /// Current zones.
    #[serde(default)]
    pub currents: Vec<CurrentDesc>,
    /// The names of the scene's own measures, sorted: the file's
    /// `measures = { NAME = function(fish) return number end }`. The functions stay in Lua (see
    /// [`take_measures`]); each is sampled once per simulated second for every fish, and a
    /// run's value is the mean over fish and samples.
    #[serde(default)]
    pub measures: Vec<String>,
    /// Behaviour level of detail (`shoal_core::world::lod`): its default and where it focuses
    /// when no window does.
    #[serde(default)]
    pub lod: Option<LodDesc>,
}

/// A scene file's value read into a [`SceneDesc`]: its `measures` checked (see
/// [`take_measures`]), then every other field as [`from_lua_value`] reads it.
pub fn scene_from_lua(value: Value, file: &str) -> Result<SceneDesc, FieldError> {
    if let Value::Table(t) = &value {
        take_measures(t, file)?;
    }
    from_lua_value(value, file)
}

/// Checks a scene table's `measures` (a table of functions by name, each field path named in
/// the error) and replaces it, in `scene`, by the list of their names, sorted, which serde reads
/// (functions are not data). Returns the names.
pub fn take_measures(scene: &Table, file: &str) -> Result<Vec<String>, FieldError> {
    let field = |path: String, why: String| FieldError {
        file: file.to_owned(),
        path,
        why,
    };
    let lua_err = |e: mlua::Error| field("measures".into(), e.to_string());
    let measures = match scene.raw_get::<Value>("measures").map_err(lua_err)? {
        Value::Nil => return Ok(Vec::new()),
        Value::Table(t) => t,
        other => {
            return Err(field(
                "measures".into(),
                format!(
                    "expected a table of functions by name, such as \
                     measures = {{ hiding = function(fish) return 1 end }} (got {})",
                    other.type_name()
                ),
            ));
        }
    };
    let mut names = Vec::new();
    for pair in measures.pairs::<Value, Value>() {
        let (k, v) = pair.map_err(lua_err)?;
        let name = match &k {
            Value::String(s) => s.to_string_lossy(),
            other => {
                return Err(field(
                    "measures".into(),
                    format!(
                        "a measure is named by a string key (NAME = function(fish) … end), \
                         got the {} key {}",
                        other.type_name(),
                        other.to_string().unwrap_or_default()
                    ),
                ));
            }
        };
        if name.is_empty() {
            return Err(field(
                "measures".into(),
                "a measure's name cannot be empty".into(),
            ));
        }
        if !v.is_function() {
            return Err(field(
                format!("measures.{name}"),
                format!(
                    "expected a function(fish) returning a number (or a boolean, or nil to leave \
                     the fish out), got {}",
                    v.type_name()
                ),
            ));
        }
        names.push(name);
    }
    names.sort();
    // The table is the scene file's own fresh value: the names replace the functions for serde.
    let seq = scene
        .weak_lua()
        .try_upgrade()
        .ok_or_else(|| mlua::Error::runtime("the scene's Lua state is gone"))
        .and_then(|lua| lua.create_sequence_from(names.iter().map(String::as_str)))
        .map_err(lua_err)?;
    scene.raw_set("measures", seq).map_err(lua_err)?;
    Ok(names)
}

/// A scene's `lod` table: `lod = { on = true, focus = { {0, 150, 0} },
/// bands = { {radius = 600, every = 1, cap = 500}, {radius = 1500, every = 2}, {every = 3} },
/// wake = true, wall_lookahead = 2.5 }`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LodDesc {
    /// Whether level of detail is on by default for this scene (`--lod` overrides it).
    #[serde(default)]
    pub on: Option<bool>,
    /// Focus points for headless runs (a window focuses on its camera and selection instead).
    #[serde(default)]
    pub focus: Vec<[f32; 3]>,
    /// The bands, nearest first (default: 600 units at full rate, 1,500 at half, a third
    /// beyond); the last band's radius may be left out (it reaches everywhere).
    #[serde(default)]
    pub bands: Option<Vec<LodBandDesc>>,
    /// Whether events wake slow fish (default true).
    #[serde(default)]
    pub wake: Option<bool>,
    /// Seconds ahead a slow fish looks for walls and rocks to be woken for (default 2.5, the
    /// shipped behaviours' wall horizon).
    #[serde(default)]
    pub wall_lookahead: Option<f32>,
}

/// One band of a scene's `lod.bands`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LodBandDesc {
    /// Outer radius, world units (left out: everywhere; only the last band).
    #[serde(default)]
    pub radius: Option<f32>,
    /// Decide this many times less often than the species' rate (1 to 600).
    pub every: u32,
    /// Most scripted fish the band holds: the nearest to a focus keep it, the rest drop to the
    /// next band (not on the last band).
    #[serde(default)]
    pub cap: Option<u32>,
}

impl LodDesc {
    /// The level-of-detail settings this table asks for (`on` as given, default off).
    pub fn to_lod(&self) -> shoal_core::world::Lod {
        let mut lod = shoal_core::world::Lod {
            on: self.on.unwrap_or(false),
            focus: self
                .focus
                .iter()
                .map(|p| glam::Vec3::from_array(*p))
                .collect(),
            ..Default::default()
        };
        if let Some(bands) = &self.bands {
            lod.bands = bands
                .iter()
                .map(|b| shoal_core::world::LodBand {
                    radius: b.radius.unwrap_or(f32::INFINITY),
                    every: b.every,
                    cap: b.cap,
                })
                .collect();
        }
        if let Some(w) = self.wake {
            lod.wake = w;
        }
        if let Some(s) = self.wall_lookahead {
            lod.wall_lookahead = s;
        }
        lod
    }
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

/// Why a species table (the value a species file returned) is not a species. Each names the
/// file.
#[derive(Debug, thiserror::Error)]
pub enum SpeciesFileError {
    /// Lua failed reading the table (a metamethod raised an error).
    #[error("{file}: {}", super::lua_error::describe(cause))]
    Lua {
        /// The file, as shown.
        file: String,
        /// Lua's error.
        cause: mlua::Error,
    },
    /// `decision_hz` is not a number in (0, 60].
    #[error("{file}: decision_hz must be a number in (0, 60], got {got}")]
    DecisionHz {
        /// The file, as shown.
        file: String,
        /// The value given, as Lua writes it.
        got: String,
    },
    /// `base` names no built-in species.
    #[error("{file}: unknown base species '{base}' (expected \"black_porgy\" or \"eel\")")]
    UnknownBase {
        /// The file, as shown.
        file: String,
        /// The name given.
        base: String,
    },
    /// The built-in description did not become a Lua table (a bug of the host's).
    #[error("{file}: base species did not serialize to a table")]
    BaseNotATable {
        /// The file, as shown.
        file: String,
    },
    /// A key no species has (`vertebral_joint`, `motion.lamda`).
    #[error("{file}: {key}: {why}")]
    UnknownKey {
        /// The file, as shown.
        file: String,
        /// The key's path (`motion.lamda`).
        key: String,
        /// The "unknown key …; did you mean …" line.
        why: String,
    },
    /// A value of the wrong type.
    #[error(transparent)]
    Field(#[from] FieldError),
    /// The motion parameters are out of range.
    #[error("{file}: motion: {source}")]
    Motion {
        /// The file, as shown.
        file: String,
        /// Which parameter, and why.
        source: shoal_core::motion::MotionError,
    },
}

/// Reads a species table (the value a species file returned) into a [`SpeciesFile`]. `file` names
/// the file in messages.
pub fn species_from_table(
    lua: &Lua,
    file: &str,
    t: Table,
) -> Result<SpeciesFile, SpeciesFileError> {
    let err = |cause: mlua::Error| SpeciesFileError::Lua {
        file: file.to_owned(),
        cause,
    };
    let decision_hz = match t.raw_get::<Value>("decision_hz").map_err(err)? {
        Value::Nil => 10.0,
        v => {
            let hz = v
                .as_number()
                .or(v.as_integer().map(|i| i as f64))
                .unwrap_or(f64::NAN);
            if !(hz.is_finite() && hz > 0.0 && hz <= 60.0) {
                return Err(SpeciesFileError::DecisionHz {
                    file: file.to_owned(),
                    got: v.to_string().unwrap_or_default(),
                });
            }
            hz
        }
    };
    t.raw_set("decision_hz", Value::Nil).map_err(err)?;
    let table = match t.raw_get::<Option<String>>("base").map_err(err)? {
        Some(base) => {
            let desc = base_desc(&base).ok_or_else(|| SpeciesFileError::UnknownBase {
                file: file.to_owned(),
                base: base.clone(),
            })?;
            let Value::Table(b) = lua.to_value(&desc).map_err(err)? else {
                return Err(SpeciesFileError::BaseNotATable {
                    file: file.to_owned(),
                });
            };
            t.raw_set("base", Value::Nil).map_err(err)?;
            merge(&b, &t).map_err(err)?;
            b
        }
        None => t,
    };
    // Keys no species has (`vertebral_joint`, `motion.lamda`): the JSON form of a full
    // description lists every field, optional ones included.
    if let Ok(known) = serde_json::to_value(SpeciesDesc::black_porgy())
        && let Some((key, why)) = unknown_species_key(&table, &known, "")
    {
        return Err(SpeciesFileError::UnknownKey {
            file: file.to_owned(),
            key,
            why,
        });
    }
    let desc: SpeciesDesc = from_lua_value(Value::Table(table), file)?;
    // Motion values out of range (a pivot with λ' ≤ 0, a turning axis off the body, NaN) are
    // refused here, naming the file and the field, rather than swum.
    desc.motion
        .validate()
        .map_err(|source| SpeciesFileError::Motion {
            file: file.to_owned(),
            source,
        })?;
    Ok(SpeciesFile { desc, decision_hz })
}

/// A data file's value that does not fit what it is read as (see [`from_lua_value`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{file}: {}{why}", if path.is_empty() { String::new() } else { format!("{path}: ") })]
pub struct FieldError {
    /// The file, as shown (`scripts/scenes/default.lua`).
    pub file: String,
    /// The field as written in Lua (`fish[2].count`, arrays counted from 1); empty for the value
    /// as a whole.
    pub path: String,
    /// What is wrong and what was expected, in the designer's words.
    pub why: String,
}

/// Reads a data file's value (a scene, a species) into `T`. Every error names `file`, the field
/// path as written in Lua (`fish[2].count`, arrays counted from 1) and what was expected, in the
/// designer's words: an unknown key comes with the closest known one ("did you mean").
pub fn from_lua_value<T: serde::de::DeserializeOwned>(
    value: Value,
    file: &str,
) -> Result<T, FieldError> {
    serde_path_to_error::deserialize(mlua::serde::Deserializer::new(value)).map_err(|e| {
        FieldError {
            file: file.to_owned(),
            path: lua_path(e.path()),
            why: humanize_serde(&e.inner().to_string()),
        }
    })
}

/// A serde path as Lua would index it: `fish[2].region.min` (sequence indices from 1).
fn lua_path(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut out = String::new();
    for seg in path.iter() {
        match seg {
            Segment::Seq { index } => out.push_str(&format!("[{}]", index + 1)),
            Segment::Map { key } | Segment::Enum { variant: key } => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(key);
            }
            Segment::Unknown => out.push_str(".?"),
        }
    }
    out
}

/// The names between backticks in a serde message, in order.
fn backticked(msg: &str) -> Vec<&str> {
    msg.split('`').skip(1).step_by(2).collect()
}

/// Rewrites serde's messages ("invalid value: integer `-5`, expected u32") as a designer would
/// read them ("got -5, expected a whole number ≥ 0").
pub fn humanize_serde(msg: &str) -> String {
    let msg = msg.trim();
    let msg = msg.strip_prefix("deserialize error: ").unwrap_or(msg);
    if let Some(rest) = msg.strip_prefix("unknown field ") {
        let names = backticked(rest);
        if let Some((unknown, known)) = names.split_first() {
            return unknown_name("key", unknown, known);
        }
    }
    if let Some(rest) = msg.strip_prefix("missing field ") {
        return format!("missing key \"{}\"", rest.trim_matches('`'));
    }
    let expected = |what: &str| -> String {
        match what.trim() {
            "u8" | "u16" | "u32" | "u64" | "usize" => "a whole number ≥ 0".into(),
            "i8" | "i16" | "i32" | "i64" | "isize" => "a whole number".into(),
            "f32" | "f64" => "a number".into(),
            "a string" | "string" => "a string".into(),
            "a boolean" | "bool" => "true or false".into(),
            w if w.starts_with("an array of length") => {
                let n = w.trim_start_matches("an array of length ");
                format!("a list of {n} numbers, like {{0, 0, 0}}")
            }
            w if w.starts_with("struct ") || w == "a map" => "a table with named keys".into(),
            w if w.starts_with("a sequence") => "a list (a table like {a, b, c})".into(),
            w => w.to_owned(),
        }
    };
    for prefix in ["invalid value: ", "invalid type: "] {
        if let Some(rest) = msg.strip_prefix(prefix)
            && let Some((got, want)) = rest.rsplit_once(", expected ")
        {
            let got = got
                .replace("integer ", "")
                .replace("floating point ", "")
                .replace('`', "");
            return format!("got {got}, expected {}", expected(want));
        }
    }
    if let Some(rest) = msg.strip_prefix("invalid length ")
        && let Some((got, want)) = rest.split_once(", expected ")
    {
        return format!("{got} values, expected {}", expected(want));
    }
    msg.to_owned()
}

/// "unknown key "behaviour"; did you mean "behavior"? (known: …)" for a name not in `known`.
pub fn unknown_name(what: &str, name: &str, known: &[impl AsRef<str>]) -> String {
    let mut msg = format!("unknown {what} \"{name}\"");
    if let Some(best) = did_you_mean(name, known) {
        msg.push_str(&format!("; did you mean \"{best}\"?"));
    }
    if !known.is_empty() {
        let list: Vec<&str> = known.iter().map(AsRef::as_ref).collect();
        msg.push_str(&format!(" (known: {})", list.join(", ")));
    }
    msg
}

/// The entry of `known` closest to `name`, if it is close enough to be a likely typo.
pub fn did_you_mean<'a>(name: &str, known: &'a [impl AsRef<str>]) -> Option<&'a str> {
    // Close: a few edits for its length (`eal` → `eel`, `lamda` → `lambda`) or a similar
    // spelling (`behaviour` → `behavior`); the fewest edits wins.
    known
        .iter()
        .map(|k| {
            let k = k.as_ref();
            (
                k,
                strsim::levenshtein(name, k),
                strsim::jaro_winkler(name, k),
            )
        })
        .filter(|&(_, edits, similar)| {
            edits <= (name.chars().count() / 3).max(1) || similar >= 0.85
        })
        .min_by(|a, b| a.1.cmp(&b.1).then(b.2.total_cmp(&a.2)))
        .map(|(k, _, _)| k)
}

/// A number of a scene out of its range (see [`validate_scene`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {problem}")]
pub struct SceneValueError {
    /// The field as written in Lua (`fish[2].speed`, `food_drops.region.min`).
    pub field: String,
    /// What is wrong with it.
    pub problem: ValueProblem,
}

/// What is wrong with a scene's number (see [`SceneValueError`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ValueProblem {
    /// A position or size with a NaN or an infinity.
    #[error("{0:?} must be three finite numbers (world units)")]
    NotFinite([f32; 3]),
    /// A box whose min is above its max on some axis.
    #[error("min {min:?} must not be above max {max:?} on any axis")]
    MinAboveMax {
        /// The box's min corner.
        min: [f32; 3],
        /// The box's max corner.
        max: [f32; 3],
    },
    /// The tank has no room on some axis.
    #[error("min must be below max on every axis")]
    NoRoom,
    /// Not a number > 0.
    #[error("{value} is out of range: expected a number > 0 ({unit})")]
    NotPositive {
        /// The value given.
        value: f32,
        /// Its unit (`seconds`, `world units`).
        unit: &'static str,
    },
    /// Not a number ≥ 0.
    #[error("{value} is out of range: expected a number ≥ 0 ({unit})")]
    Negative {
        /// The value given.
        value: f32,
        /// Its unit.
        unit: &'static str,
    },
    /// More fish than one group may ask for.
    #[error("{0} is out of range: expected 0 to {MAX_FISH_PER_GROUP} fish")]
    TooManyFish(u32),
    /// An angle that is NaN or infinite.
    #[error("{0} must be a finite angle (radians)")]
    NotAnAngle(f32),
    /// `params` that is not a table.
    #[error("expected a table, got {0}")]
    NotATable(serde_json::Value),
    /// A level-of-detail band or focus out of range.
    #[error("{0}")]
    Lod(String),
}

/// Checks the numbers of a scene against their ranges; the error names the field (as
/// [`from_lua_value`] does) and the range in world units and seconds.
pub fn validate_scene(desc: &SceneDesc) -> Result<(), SceneValueError> {
    fn bad(field: impl Into<String>, problem: ValueProblem) -> SceneValueError {
        SceneValueError {
            field: field.into(),
            problem,
        }
    }
    fn finite3(v: &[f32; 3], field: &str) -> Result<(), SceneValueError> {
        if v.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(bad(field, ValueProblem::NotFinite(*v)))
        }
    }
    fn boxed(b: &BoxDesc, field: &str) -> Result<(), SceneValueError> {
        finite3(&b.min, &format!("{field}.min"))?;
        finite3(&b.max, &format!("{field}.max"))?;
        if (0..3).any(|i| b.min[i] > b.max[i]) {
            return Err(bad(
                field,
                ValueProblem::MinAboveMax {
                    min: b.min,
                    max: b.max,
                },
            ));
        }
        Ok(())
    }
    fn positive(v: f32, field: &str, unit: &'static str) -> Result<(), SceneValueError> {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(bad(field, ValueProblem::NotPositive { value: v, unit }))
        }
    }
    fn not_negative(v: f32, field: &str, unit: &'static str) -> Result<(), SceneValueError> {
        if v.is_finite() && v >= 0.0 {
            Ok(())
        } else {
            Err(bad(field, ValueProblem::Negative { value: v, unit }))
        }
    }
    boxed(&desc.tank, "tank")?;
    if (0..3).any(|i| desc.tank.min[i] >= desc.tank.max[i]) {
        return Err(bad("tank", ValueProblem::NoRoom));
    }
    for (g, group) in desc.fish.iter().enumerate() {
        let f = format!("fish[{}]", g + 1);
        if group.count > MAX_FISH_PER_GROUP {
            return Err(bad(
                format!("{f}.count"),
                ValueProblem::TooManyFish(group.count),
            ));
        }
        if let Some(p) = &group.pos {
            finite3(p, &format!("{f}.pos"))?;
        }
        if let Some(r) = &group.region {
            boxed(r, &format!("{f}.region"))?;
        }
        if let Some(h) = group.heading
            && !h.is_finite()
        {
            return Err(bad(format!("{f}.heading"), ValueProblem::NotAnAngle(h)));
        }
        if let Some(v) = group.speed {
            not_negative(v, &format!("{f}.speed"), "world units per second")?;
        }
        if let Some(p) = &group.params
            && !p.is_object()
            && !p.is_array()
        {
            return Err(bad(
                format!("{f}.params"),
                ValueProblem::NotATable(p.clone()),
            ));
        }
    }
    for (i, p) in desc.food.iter().enumerate() {
        finite3(p, &format!("food[{}]", i + 1))?;
    }
    if let Some(v) = desc.food_sink_speed {
        not_negative(v, "food_sink_speed", "world units per second")?;
    }
    if let Some(l) = desc.food_lifetime {
        positive(l, "food_lifetime", "seconds")?;
    }
    if let Some(d) = &desc.food_drops {
        positive(d.every, "food_drops.every", "seconds")?;
        if let Some(start) = d.start {
            not_negative(start, "food_drops.start", "seconds")?;
        }
        if let Some(r) = &d.region {
            boxed(r, "food_drops.region")?;
        }
    }
    for (i, o) in desc.obstacles.iter().enumerate() {
        finite3(&o.pos, &format!("obstacles[{}].pos", i + 1))?;
        positive(
            o.radius,
            &format!("obstacles[{}].radius", i + 1),
            "world units",
        )?;
    }
    if let Some(lod) = &desc.lod {
        for (i, p) in lod.focus.iter().enumerate() {
            finite3(p, &format!("lod.focus[{}]", i + 1))?;
        }
        if let Some(bands) = &lod.bands {
            for (i, b) in bands.iter().enumerate() {
                if b.radius.is_none() && i + 1 != bands.len() {
                    return Err(bad(
                        format!("lod.bands[{}].radius", i + 1),
                        ValueProblem::Lod(
                            "missing: only the last band may leave its radius out".into(),
                        ),
                    ));
                }
            }
        }
        if let Err(e) = lod.to_lod().validate() {
            // The core's message starts with the field under `lod`.
            let text = e.to_string();
            let (field, why) = text.split_once(": ").unwrap_or(("", &text));
            return Err(bad(
                format!("lod.{field}"),
                ValueProblem::Lod(why.to_owned()),
            ));
        }
    }
    for (i, c) in desc.currents.iter().enumerate() {
        finite3(&c.pos, &format!("currents[{}].pos", i + 1))?;
        positive(
            c.radius,
            &format!("currents[{}].radius", i + 1),
            "world units",
        )?;
        finite3(&c.velocity, &format!("currents[{}].velocity", i + 1))?;
    }
    Ok(())
}

/// Most fish one scene group may ask for.
pub const MAX_FISH_PER_GROUP: u32 = 200_000;

/// Keys of a species file that no species field has: every key of `t` (recursing into nested
/// tables that are objects in `known`) missing from `known`, the JSON form of a full description.
/// Returns the first as its path and "unknown key …".
fn unknown_species_key(
    t: &Table,
    known: &serde_json::Value,
    path: &str,
) -> Option<(String, String)> {
    let serde_json::Value::Object(fields) = known else {
        return None;
    };
    let mut keys: Vec<String> = t
        .pairs::<Value, Value>()
        .flatten()
        .filter_map(|(k, _)| k.as_string().map(|s| s.to_string_lossy()))
        .collect();
    keys.sort();
    for k in keys {
        let here = if path.is_empty() {
            k.clone()
        } else {
            format!("{path}.{k}")
        };
        match fields.get(&k) {
            None => {
                let names: Vec<&str> = fields.keys().map(String::as_str).collect();
                return Some((here, unknown_name("key", &k, &names)));
            }
            Some(sub @ serde_json::Value::Object(_)) => {
                if let Ok(Value::Table(inner)) = t.raw_get::<Value>(k.as_str())
                    && let Some(e) = unknown_species_key(&inner, sub, &here)
                {
                    return Some(e);
                }
            }
            Some(_) => {}
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggestions_catch_typos_and_not_strangers() {
        let species = ["barracuda", "black_porgy", "eel"];
        assert_eq!(did_you_mean("eal", &species), Some("eel"));
        assert_eq!(did_you_mean("black_porgie", &species), Some("black_porgy"));
        assert_eq!(did_you_mean("shark", &species), None);
        let keys = ["species", "count", "behavior", "pos", "region"];
        assert_eq!(did_you_mean("behaviour", &keys), Some("behavior"));
        assert_eq!(did_you_mean("cuont", &keys), Some("count"));
    }

    #[test]
    fn serde_messages_read_as_a_designer_would() {
        assert_eq!(
            humanize_serde("deserialize error: invalid value: integer `-5`, expected u32"),
            "got -5, expected a whole number ≥ 0"
        );
        assert_eq!(
            humanize_serde("invalid type: string \"fast\", expected f32"),
            "got string \"fast\", expected a number"
        );
        assert_eq!(
            humanize_serde("missing field `tank`"),
            "missing key \"tank\""
        );
        let unknown =
            humanize_serde("unknown field `behaviour`, expected one of `species`, `behavior`");
        assert!(unknown.starts_with("unknown key \"behaviour\"; did you mean \"behavior\"?"));
    }
}
