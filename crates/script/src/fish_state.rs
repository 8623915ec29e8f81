//! A script lane's per-fish state as plain Rust data that can be kept and put back, into the same
//! simulation or another of the same scene: copies of the fish tables (`fish.memory`, `fish.intention`, `fish.percepts` and anything else a behaviour
//! stored on `fish`), for rewinding a simulation (see `script::Simulation::snapshot`).
//!
//! Fish state must be plain data: numbers, strings, booleans and tables of them (nested, shared
//! and cyclic tables are copied as they are: a table reached twice is copied once). A function,
//! coroutine or userdata in a fish table is refused, naming the fish and the field. `fish.params`
//! (the scene's data) is not copied: a restored fish gets its scene's params again. Metatables
//! are not kept (fish state holds no behaviour). Module-level variables belong to the lane, not
//! to a fish, and are not part of this state.

use std::collections::HashMap;

use mlua::{Lua, Table, Value};

/// A plain value of fish state (strings as bytes: Lua strings need not be UTF-8).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Datum {
    /// `true` or `false`.
    Bool(bool),
    /// A Lua integer.
    Int(i64),
    /// A Lua float.
    Num(f64),
    /// A Lua string.
    Str(Vec<u8>),
    /// A table, by its index in [`FishData::tables`].
    Table(u32),
}

/// One fish's table as plain data: `tables[0]` is the fish table itself (without `params`),
/// the others the tables it reaches, each once (so shared and cyclic tables stay so).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FishData {
    /// Each table's entries.
    pub tables: Vec<Vec<(Datum, Datum)>>,
}

/// A lane's fish tables as plain data, by slot index: independent of the Lua state they came
/// from, so they can be put back into another simulation of the same scene.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LaneState {
    /// (slot index, the fish's table).
    pub fish: Vec<(u32, FishData)>,
}

impl LaneState {
    /// Number of fish whose state the copy holds.
    pub fn num_fish(&self) -> usize {
        self.fish.len()
    }
}

/// Why a fish's state could not be copied.
#[derive(Debug, thiserror::Error)]
pub enum FishStateError {
    /// A value that is not plain data.
    #[error(
        "fish #{fish}: {path} holds a {what}; fish state must be plain data (numbers, strings, \
         booleans, tables) so the aquarium can rewind it — keep functions in the module, not in \
         the fish"
    )]
    NotData {
        /// The fish's slot index.
        fish: u32,
        /// Where in its table, e.g. `memory.plan.next`.
        path: String,
        /// The Lua type found (a function says where it was defined).
        what: String,
    },
    /// Lua failed (out of memory).
    #[error("copying fish state: {0}")]
    Lua(#[from] mlua::Error),
}

/// Copies every fish table of `fish_tables` (slot index → table) out of Lua.
pub fn save(fish_tables: &Table) -> Result<LaneState, FishStateError> {
    let mut fish = Vec::new();
    for pair in fish_tables.clone().pairs::<Value, Value>() {
        let (k, v) = pair?;
        let (Value::Integer(index), Value::Table(t)) = (k, v) else {
            continue;
        };
        let mut saver = Saver {
            fish: index as u32,
            seen: HashMap::new(),
            data: FishData::default(),
        };
        saver.table(&t, "", true)?;
        fish.push((index as u32, saver.data));
    }
    fish.sort_by_key(|(i, _)| *i);
    Ok(LaneState { fish })
}

/// Replaces every fish table of `fish_tables` with one built from `state` (fish absent from it
/// lose theirs); `params(slot, generation)` gives each fish table its `params` field.
pub fn restore(
    lua: &Lua,
    fish_tables: &Table,
    state: &LaneState,
    params: impl Fn(u32, u32) -> mlua::Result<Value>,
) -> Result<(), FishStateError> {
    fish_tables.clear()?;
    for (index, data) in &state.fish {
        let tables = data
            .tables
            .iter()
            .map(|_| lua.create_table())
            .collect::<mlua::Result<Vec<_>>>()?;
        let value = |d: &Datum| -> mlua::Result<Value> {
            Ok(match d {
                Datum::Bool(b) => Value::Boolean(*b),
                Datum::Int(i) => Value::Integer(*i),
                Datum::Num(n) => Value::Number(*n),
                Datum::Str(s) => Value::String(lua.create_string(s)?),
                Datum::Table(t) => Value::Table(tables[*t as usize].clone()),
            })
        };
        for (t, entries) in tables.iter().zip(&data.tables) {
            for (k, v) in entries {
                t.raw_set(value(k)?, value(v)?)?;
            }
        }
        if let Some(fish) = tables.first() {
            let generation = fish.raw_get::<Option<u32>>("generation")?.unwrap_or(0);
            fish.raw_set("params", params(*index, generation)?)?;
            fish_tables.raw_set(*index, fish)?;
        }
    }
    Ok(())
}

/// One fish's copy out of Lua: tables already copied (by identity), so sharing and cycles
/// survive.
struct Saver {
    fish: u32,
    seen: HashMap<*const std::ffi::c_void, u32>,
    data: FishData,
}

impl Saver {
    /// Copies `t` (the fish table itself when `top`, whose `params` is left out) and returns its
    /// index.
    fn table(&mut self, t: &Table, path: &str, top: bool) -> Result<u32, FishStateError> {
        if let Some(&i) = self.seen.get(&t.to_pointer()) {
            return Ok(i);
        }
        let i = self.data.tables.len() as u32;
        self.seen.insert(t.to_pointer(), i);
        self.data.tables.push(Vec::new());
        let mut entries = Vec::new();
        for pair in t.clone().pairs::<Value, Value>() {
            let (k, v) = pair?;
            if top && matches!(&k, Value::String(s) if s.as_bytes().as_ref() == b"params") {
                continue;
            }
            let name = match path {
                "" => key_name(&k),
                _ => format!("{path}.{}", key_name(&k)),
            };
            let k = self.value(k, &name)?;
            let v = self.value(v, &name)?;
            entries.push((k, v));
        }
        self.data.tables[i as usize] = entries;
        Ok(i)
    }

    fn value(&mut self, v: Value, path: &str) -> Result<Datum, FishStateError> {
        Ok(match v {
            Value::Boolean(b) => Datum::Bool(b),
            Value::Integer(i) => Datum::Int(i),
            Value::Number(n) => Datum::Num(n),
            Value::String(s) => Datum::Str(s.as_bytes().to_vec()),
            Value::Table(t) => Datum::Table(self.table(&t, path, false)?),
            Value::Function(f) => {
                let info = f.info();
                let what = match (info.short_src, info.line_defined) {
                    (Some(src), Some(line)) => format!("function (defined at {src}:{line})"),
                    _ => "function".to_owned(),
                };
                return Err(self.not_data(path, what));
            }
            Value::Thread(_) => return Err(self.not_data(path, "coroutine".into())),
            _ => return Err(self.not_data(path, "userdata".into())),
        })
    }

    fn not_data(&self, path: &str, what: String) -> FishStateError {
        FishStateError::NotData {
            fish: self.fish,
            path: path.to_owned(),
            what,
        }
    }
}

/// A table key as a designer reads it in a path.
fn key_name(k: &Value) -> String {
    match k {
        Value::String(s) => s.to_string_lossy(),
        Value::Integer(i) => format!("[{i}]"),
        Value::Number(n) => format!("[{n}]"),
        Value::Boolean(b) => format!("[{b}]"),
        other => format!("[{}]", other.type_name()),
    }
}
