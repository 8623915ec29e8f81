//! A script lane's per-fish state as a value that can be kept and put back: deep copies of the
//! fish tables (`fish.memory`, `fish.intention`, `fish.percepts` and anything else a behaviour
//! stored on `fish`), for rewinding a simulation (see `script::Simulation::snapshot`).
//!
//! Fish state must be plain data: numbers, strings, booleans and tables of them (nested, shared
//! and cyclic tables are copied as they are: a table reached twice is copied once). A function,
//! coroutine or userdata in a fish table is refused, naming the fish and the field. `fish.params`
//! (the scene's data, never written by scripts) is shared, not copied. Module-level variables
//! belong to the lane, not to a fish, and are not part of this state.

use std::collections::HashMap;

use mlua::{Lua, Table, Value};

/// Copies of a lane's fish tables, by slot index, held in the lane's Lua registry.
#[derive(Debug)]
pub struct LaneState {
    /// A table: slot index → copy of the fish table.
    tables: mlua::RegistryKey,
    /// Fish in the copy.
    fish: usize,
}

impl LaneState {
    /// Number of fish whose state the copy holds.
    pub fn num_fish(&self) -> usize {
        self.fish
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
        /// The Lua type found.
        what: &'static str,
    },
    /// Lua failed (out of memory).
    #[error("copying fish state: {0}")]
    Lua(#[from] mlua::Error),
}

/// Deep-copies every fish table of `fish_tables` (slot index → table) into a new table kept in
/// the registry of `lua`.
pub fn save(lua: &Lua, fish_tables: &Table) -> Result<LaneState, FishStateError> {
    let out = lua.create_table()?;
    let mut fish = 0;
    for pair in fish_tables.clone().pairs::<Value, Value>() {
        let (k, v) = pair?;
        let (Value::Integer(index), Value::Table(t)) = (&k, &v) else {
            continue;
        };
        let mut copier = Copier::new(lua, *index as u32);
        out.raw_set(k.clone(), copier.fish(t)?)?;
        fish += 1;
    }
    Ok(LaneState {
        tables: lua.create_registry_value(out)?,
        fish,
    })
}

/// Replaces every fish table of `fish_tables` with a fresh copy of the saved ones (so a saved
/// state can be put back any number of times); fish absent from the saved state lose theirs.
pub fn restore(lua: &Lua, fish_tables: &Table, state: &LaneState) -> Result<(), FishStateError> {
    let saved: Table = lua.registry_value(&state.tables)?;
    fish_tables.clear()?;
    for pair in saved.pairs::<Value, Value>() {
        let (k, v) = pair?;
        let (Value::Integer(index), Value::Table(t)) = (&k, &v) else {
            continue;
        };
        let mut copier = Copier::new(lua, *index as u32);
        fish_tables.raw_set(k.clone(), copier.fish(t)?)?;
    }
    Ok(())
}

/// One fish's deep copy: tables already copied (by identity), so sharing and cycles survive.
struct Copier<'a> {
    lua: &'a Lua,
    fish: u32,
    seen: HashMap<*const std::ffi::c_void, Table>,
}

impl<'a> Copier<'a> {
    fn new(lua: &'a Lua, fish: u32) -> Self {
        Self {
            lua,
            fish,
            seen: HashMap::new(),
        }
    }

    /// The fish table: every field copied but `params`, which is shared.
    fn fish(&mut self, t: &Table) -> Result<Table, FishStateError> {
        let out = self.lua.create_table()?;
        for pair in t.clone().pairs::<Value, Value>() {
            let (k, v) = pair?;
            let v = match (&k, v) {
                (Value::String(s), v) if s.as_bytes().as_ref() == b"params" => v,
                (_, v) => self.value(v, &key_name(&k))?,
            };
            out.raw_set(k, v)?;
        }
        Ok(out)
    }

    fn value(&mut self, v: Value, path: &str) -> Result<Value, FishStateError> {
        match v {
            Value::Table(t) => Ok(Value::Table(self.table(&t, path)?)),
            Value::Function(_) => Err(self.not_data(path, "function")),
            Value::Thread(_) => Err(self.not_data(path, "coroutine")),
            Value::UserData(_) | Value::LightUserData(_) => Err(self.not_data(path, "userdata")),
            Value::Error(_) => Err(self.not_data(path, "error value")),
            other => Ok(other),
        }
    }

    fn table(&mut self, t: &Table, path: &str) -> Result<Table, FishStateError> {
        if let Some(c) = self.seen.get(&t.to_pointer()) {
            return Ok(c.clone());
        }
        let out = self.lua.create_table()?;
        self.seen.insert(t.to_pointer(), out.clone());
        for pair in t.clone().pairs::<Value, Value>() {
            let (k, v) = pair?;
            let name = format!("{path}.{}", key_name(&k));
            let k = self.value(k, &name)?;
            let v = self.value(v, &name)?;
            out.raw_set(k, v)?;
        }
        // Metatables (read-only views the API hands out) are shared, not copied.
        out.set_metatable(t.metatable())?;
        Ok(out)
    }

    fn not_data(&self, path: &str, what: &'static str) -> FishStateError {
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
