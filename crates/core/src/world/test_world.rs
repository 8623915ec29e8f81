//! Random worlds for the world's unit tests: the shipped porgy under three species names (a
//! school species, another non-predator and a predator), densely packed, with food and rocks.

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

use super::steer::Steer;
use super::{SpawnParams, Species, SpeciesDesc, SpeciesId, Tank, World};

/// A random world and what the tests need to know about it.
pub struct Scene {
    pub world: World,
    /// Body length of every species, world units.
    pub l: f32,
    /// School species, another non-predator species, a predator species.
    pub species: [SpeciesId; 3],
}

/// The bits of a steer, for bitwise comparisons.
pub fn bits(s: &Steer) -> [u32; 3] {
    [s.heading.to_bits(), s.depth.to_bits(), s.speed.to_bits()]
}

/// `fish` fish (85 % school species, 10 % other, 5 % predators) at random positions, headings,
/// pitches and speeds in a 10 × 5 × 5 body-length tank, a few on top of each other; 40 food
/// pellets (some eaten) and three rocks; the grid rebuilt.
pub fn random_scene(seed: u64, fish: usize) -> Scene {
    random_scene_sized(seed, fish, Vec3::new(10.0, 5.0, 5.0))
}

/// [`random_scene`] in a tank of `lengths` body lengths.
pub fn random_scene_sized(seed: u64, fish: usize, lengths: Vec3) -> Scene {
    let assets = crate::source_root().join("assets");
    let porgy = Species::load(SpeciesDesc::black_porgy(), &assets).expect("shipped porgy");
    let l = porgy.body_length();
    let mut other = porgy.clone();
    other.desc.name = "other".into();
    let mut shark = porgy.clone();
    shark.desc.name = "shark".into();
    shark.desc.predator = true;
    shark.desc.view_range = 3.0 * l;
    shark.desc.view_angle_deg = 200.0;
    let tank = Tank {
        min: Vec3::ZERO,
        max: lengths * l,
    };
    let mut world = World::new(tank, seed);
    let species = [
        world.add_species(porgy),
        world.add_species(other),
        world.add_species(shark),
    ];
    let mut rng = Pcg32::seed_from_u64(seed);
    let mut last = Vec3::ZERO;
    for i in 0..fish {
        let pos = if i % 50 == 49 {
            last // exactly on top of the previous fish
        } else {
            Vec3::new(
                rng.random_range(tank.min.x..tank.max.x),
                rng.random_range(tank.min.y..tank.max.y),
                rng.random_range(tank.min.z..tank.max.z),
            )
        };
        last = pos;
        let kind = match rng.random_range(0..100) {
            0..85 => 0,
            85..95 => 1,
            _ => 2,
        };
        world
            .spawn(SpawnParams {
                species: species[kind],
                pos,
                heading: rng.random_range(-std::f32::consts::PI..std::f32::consts::PI),
                pitch: rng.random_range(-0.4..0.4),
                speed: rng.random_range(0.0..80.0),
                behavior: None,
                seed: i as u64,
            })
            .expect("spawn");
    }
    for k in 0..40 {
        let f = world.add_food(Vec3::new(
            rng.random_range(tank.min.x..tank.max.x),
            rng.random_range(tank.min.y..tank.max.y),
            rng.random_range(tank.min.z..tank.max.z),
        ));
        if k % 5 == 0 {
            world.take_food(f, None);
        }
    }
    for _ in 0..3 {
        world.add_obstacle(
            Vec3::new(
                rng.random_range(tank.min.x..tank.max.x),
                rng.random_range(tank.min.y..tank.max.y),
                rng.random_range(tank.min.z..tank.max.z),
            ),
            rng.random_range(0.2 * l..l),
        );
    }
    world.rebuild_grid();
    Scene { world, l, species }
}
