//! A simulation at one tick, kept and put back: the world's state and every lane's fish tables.

use super::Simulation;
use crate::error::ScriptError;
use crate::fish_state::LaneState;
use shoal_core::world::WorldState;

/// Everything that decides a simulation's future at one tick (see [`Simulation::snapshot`]):
/// the world's state and each script lane's fish tables. Scripts themselves (modules and their
/// module-level variables) are not in it: restoring runs the scripts loaded now.
#[derive(Debug)]
pub struct SimSnapshot {
    world: WorldState,
    lanes: Vec<LaneState>,
}

impl SimSnapshot {
    /// The world's state in the snapshot.
    pub fn world(&self) -> &WorldState {
        &self.world
    }

    /// Simulated time of the snapshot, seconds.
    pub fn time(&self) -> f64 {
        self.world.time
    }

    /// Bytes this snapshot holds (the world's arrays and every fish table's entries, not
    /// counting allocator overhead): what keeping one costs, for the window's history ring.
    pub fn approx_bytes(&self) -> usize {
        use crate::fish_state::Datum;
        let entry = std::mem::size_of::<(Datum, Datum)>();
        let datum = |d: &Datum| match d {
            Datum::Str(s) => s.capacity(),
            _ => 0,
        };
        let lanes: usize = self
            .lanes
            .iter()
            .flat_map(|lane| &lane.fish)
            .flat_map(|(_, data)| &data.tables)
            .map(|table| {
                table.capacity() * entry
                    + table
                        .iter()
                        .map(|(k, v)| datum(k) + datum(v))
                        .sum::<usize>()
            })
            .sum();
        std::mem::size_of::<Self>() + self.world.approx_bytes() + lanes
    }
}

impl Simulation {
    /// The simulation as it is now: the world's state and each lane's fish tables (`memory`,
    /// `intention`, `percepts`…). Fails, naming the fish and field, when a fish table holds a
    /// function, coroutine or userdata (fish state must be plain data).
    pub fn snapshot(&self) -> Result<SimSnapshot, ScriptError> {
        let lanes = self
            .sim
            .behavior
            .lanes
            .iter()
            .map(|lane| lane.host.save_fish_state())
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| ScriptError::Lua(e.to_string()))?;
        Ok(SimSnapshot {
            world: self.sim.world().snapshot(),
            lanes,
        })
    }

    /// Puts the simulation back to `snapshot` (taken from this simulation, with as many lanes):
    /// with unchanged scripts it then runs exactly as it did from there; with edited scripts it
    /// runs the new ones from there.
    pub fn restore(&mut self, snapshot: &SimSnapshot) -> Result<(), ScriptError> {
        let lanes = &mut self.sim.behavior.lanes;
        if snapshot.lanes.len() != lanes.len() {
            return Err(ScriptError::Lua(format!(
                "the snapshot has {} script lanes, the simulation {}",
                snapshot.lanes.len(),
                lanes.len()
            )));
        }
        self.sim
            .world_mut()
            .restore(snapshot.world.clone())
            .map_err(|source| ScriptError::World {
                context: "restoring a snapshot".into(),
                source,
            })?;
        for (lane, state) in self.sim.behavior.lanes.iter_mut().zip(&snapshot.lanes) {
            lane.host
                .restore_fish_state(state)
                .map_err(|e| ScriptError::Lua(e.to_string()))?;
        }
        self.sync_props();
        Ok(())
    }
}
