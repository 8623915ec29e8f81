//! The benchmark school: the population `shoal bench sim` and `shoal bench peer` run.

use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;
use shoal_core::world::bench::{bench_positions, bench_tank};

use super::Simulation;
use crate::ScriptError;

/// The constant-density bench tank populated through the Lua simulation with the shipped
/// behaviours, as `shoal bench sim` and `bench peer` measure it: per 100 fish, 89 black porgies
/// schooling, 10 foraging and one barracuda hunting, `lanes` Lua states (default: one per CPU
/// thread). The scripts come from `scripts_dir`, the models from `root`'s `assets/` (else the
/// source tree's).
pub fn bench_school(
    root: &Path,
    scripts_dir: &Path,
    fish: usize,
    seed: u64,
    lanes: Option<usize>,
) -> Result<Simulation, ScriptError> {
    let mut sim = Simulation::empty_with_scripts(root, scripts_dir, seed)?;
    if let Some(n) = lanes {
        sim.set_lanes(n)?;
    }
    let porgy = sim.species_id("black_porgy")?;
    let l = sim.world().species(porgy).body_length();
    let tank = bench_tank(l, fish);
    sim.set_tank(tank.min, tank.max)?;
    let mut rng = Pcg32::seed_from_u64(seed ^ 1);
    for (i, pos) in bench_positions(&tank, l, fish, seed)
        .into_iter()
        .enumerate()
    {
        let (species, behavior) = match i % 100 {
            0 => ("barracuda", "predator"),
            1..=10 => ("black_porgy", "forage"),
            _ => ("black_porgy", "school"),
        };
        let heading = rng.random_range(-std::f32::consts::PI..std::f32::consts::PI);
        sim.spawn(species, pos, heading, 0.0, None, Some(behavior))?;
    }
    sim.world_mut().rebuild_grid();
    Ok(sim)
}
