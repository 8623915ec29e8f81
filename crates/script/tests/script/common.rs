//! Helpers of the script tests (and, through them, of the app's and the command line's): the
//! core helpers plus simulations of the repository's scripts.
#![allow(dead_code, unused_imports)]

use std::path::Path;

use shoal_script::Simulation;

#[path = "../../../core/tests/core/common.rs"]
mod core_common;
pub use core_common::*;

/// An empty-tank simulation of the repository's scripts with the test species
/// `black_porgy` and `barracuda` added.
pub fn sim(seed: u64) -> Simulation {
    sim_in(repo(), seed)
}

/// Like [`sim`] for the scripts under `root`.
pub fn sim_in(root: &Path, seed: u64) -> Simulation {
    let mut s = Simulation::from_scene(root, Path::new("scenes/empty_tank.lua"), seed).unwrap();
    s.add_species(species("black_porgy", false), 10.0);
    s.add_species(species("barracuda", true), 10.0);
    s
}

/// Fails the test with every script error the simulation logged, if it logged any.
#[track_caller]
pub fn assert_no_script_errors(sim: &Simulation) {
    let errors = sim.error_messages();
    assert!(errors.is_empty(), "script errors: {errors:?}");
}

/// A behaviour (`behaviors/split.lua`) whose `tick` calls `heavy` (defined at line 1) and `light`
/// (line 6), heavy doing ten times light's work per decision (`n` and 10·`n` sines), in the
/// same loop: the profiler tests' known cost split.
pub fn split_behavior(n: u32) -> String {
    format!(
        "\
local function heavy(n)
  local x = 0
  for i = 1, n * 10 do x = x + math.sin(i) end
  return x
end
local function light(n)
  local x = 0
  for i = 1, n do x = x + math.sin(i) end
  return x
end
return {{ tick = function(fish)
  fish.memory.x = heavy({n}) + light({n})
end }}
"
    )
}
