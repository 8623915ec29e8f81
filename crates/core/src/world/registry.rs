//! The species registry: each species' data, rig and model, and what the stages precompute
//! from them (pose plans, wave tables).

use std::path::Path;
use std::sync::Arc;

use super::types::finite;
use super::{
    FishModel, MAX_DRIVEN_JOINTS, SpeciesDesc, SpeciesId, SpeciesRig, World, WorldError, pose,
};
use crate::motion::WaveTable;

/// The world's species (its configuration, not its state) and what is prepared per species for
/// the stages, all indexed by [`SpeciesId`].
#[derive(Default)]
pub(super) struct Catalog {
    pub(super) species: Vec<Species>,
    /// Each species' skeleton prepared for the pose stage.
    pub(super) plans: Vec<pose::PosePlan>,
    /// Each species' body wave constants for the motion stage.
    pub(super) wave_tables: Vec<WaveTable>,
}

/// A species in the world: its data, its rig and its model (shared by every fish of it).
#[derive(Debug, Clone)]
pub struct Species {
    /// The species description (motion parameters, senses, drives).
    pub desc: SpeciesDesc,
    /// Binding of the motion layer's body to the model's skeleton.
    pub rig: SpeciesRig,
    /// The skinned model.
    pub model: Arc<FishModel>,
}

impl Species {
    /// Loads the species' asset (`desc.asset`, relative to `assets_dir`) and binds its rig.
    pub fn load(desc: SpeciesDesc, assets_dir: &Path) -> Result<Self, WorldError> {
        let path = assets_dir.join(&desc.asset);
        let fail = |reason: String| WorldError::SpeciesLoad {
            species: desc.name.clone(),
            path: path.display().to_string(),
            reason,
        };
        let mut model = FishModel::load(&path).map_err(|e| fail(e.to_string()))?;
        if let Some(cutoff) = desc.alpha_cutoff {
            for m in &mut model.mesh.materials {
                m.alpha_mode = crate::skin::AlphaMode::Mask { cutoff };
            }
        }
        // A texture that cannot be used is not fatal (the fish keeps its base colour), but a
        // designer should hear of it.
        for w in model.warnings.iter().filter(|w| w.contains(" texture")) {
            log::warn!("species {}: {w}", desc.name);
        }
        let rig = SpeciesRig::bind(&desc, &model).map_err(|e| fail(e.to_string()))?;
        let species = Self {
            desc,
            rig,
            model: Arc::new(model),
        };
        species.validate()?;
        Ok(species)
    }

    /// Checks what the world relies on: at most [`MAX_DRIVEN_JOINTS`] driven joints, one more
    /// midline sample than driven joints, one inverse bind pose per skeleton joint, and sane
    /// sensor ranges.
    pub fn validate(&self) -> Result<(), WorldError> {
        let name = || self.desc.name.clone();
        let driven = self.rig.body.power.len();
        if driven > MAX_DRIVEN_JOINTS {
            return Err(WorldError::TooManyDrivenJoints {
                species: name(),
                joints: driven,
            });
        }
        if self.rig.body.joints_x.len() != driven + 1 {
            return Err(WorldError::BadSpecies {
                species: name(),
                why: format!(
                    "body has {} joint positions for {driven} driven joints (expected {})",
                    self.rig.body.joints_x.len(),
                    driven + 1
                ),
            });
        }
        let joints = self.model.skeleton.num_joints();
        if self.model.inverse_bind_poses.len() != joints {
            return Err(WorldError::BadSpecies {
                species: name(),
                why: format!(
                    "{} inverse bind poses for {joints} joints",
                    self.model.inverse_bind_poses.len()
                ),
            });
        }
        for (what, v) in [
            ("view_range", self.desc.view_range),
            ("view_angle_deg", self.desc.view_angle_deg),
            ("max_speed", self.desc.max_speed),
            ("motion.l", self.desc.motion.l),
        ] {
            finite(what, v)?;
            if v < 0.0 {
                return Err(WorldError::OutOfRange {
                    what,
                    value: v,
                    why: "must not be negative",
                });
            }
        }
        Ok(())
    }

    /// Body length `l`, world units.
    pub fn body_length(&self) -> f32 {
        self.desc.motion.l
    }
}

impl World {
    // ---- species ----------------------------------------------------------------------------

    /// Adds a species. A species that fails [`Species::validate`] is still added, but spawning
    /// it fails with the validation error.
    pub fn add_species(&mut self, s: Species) -> SpeciesId {
        if let Err(e) = s.validate() {
            log::error!("species {:?}: {e}", s.desc.name);
        }
        self.catalog
            .plans
            .push(pose::PosePlan::new(&s.rig, &s.model));
        self.catalog
            .wave_tables
            .push(WaveTable::new(&s.desc.motion, &s.rig.body));
        self.catalog.species.push(s);
        self.refresh_gpu_programs();
        SpeciesId((self.catalog.species.len() - 1) as u16)
    }

    /// Replaces a species (hot reload): live fish of it pick up the new data on their next step.
    /// If the driven joint count changes, their joint arrays restart from rest.
    pub fn replace_species(&mut self, id: SpeciesId, s: Species) -> Result<(), WorldError> {
        s.validate()?;
        let slot = self
            .catalog
            .species
            .get_mut(usize::from(id.0))
            .ok_or(WorldError::UnknownSpecies(id))?;
        let joints_changed = slot.rig.body.power.len() != s.rig.body.power.len()
            || slot.model.skeleton.num_joints() != s.model.skeleton.num_joints();
        let predator_changed = slot.desc.predator != s.desc.predator;
        let plan = pose::PosePlan::new(&s.rig, &s.model);
        // Other driven joints, rest poses or bind poses can change which palette entries are
        // copies, and so the fish's number of slots (the palette ranges then move).
        let slots_changed = plan.num_slots() != self.catalog.plans[usize::from(id.0)].num_slots();
        self.catalog.plans[usize::from(id.0)] = plan;
        self.catalog.wave_tables[usize::from(id.0)] = WaveTable::new(&s.desc.motion, &s.rig.body);
        *slot = s;
        self.refresh_gpu_programs();
        if predator_changed {
            self.refresh_predators();
        }
        if joints_changed {
            for i in 0..self.state.fish.len() {
                if self.state.fish.species[i] == id {
                    self.state.fish.yaw[i] = [0.0; MAX_DRIVEN_JOINTS];
                    self.state.fish.lateral[i] = [0.0; MAX_DRIVEN_JOINTS + 1];
                }
            }
        }
        if slots_changed {
            self.relayout_palettes();
        }
        Ok(())
    }

    /// Rebuilds the GPU pose programs from the species' pose plans (after either changes).
    fn refresh_gpu_programs(&mut self) {
        let shapes: Vec<pose::gpu::SpeciesShape<'_>> = self
            .catalog
            .species
            .iter()
            .zip(&self.catalog.wave_tables)
            .map(|(s, table)| pose::gpu::SpeciesShape {
                name: &s.desc.name,
                params: &s.desc.motion,
                body: &s.rig.body,
                table,
            })
            .collect();
        self.pose.gpu_programs = pose::gpu::programs(&self.catalog.plans, &shapes);
    }

    /// The species' palette layout: joint j's palette entry is slot `slot_of_joint(s)[j]` of a
    /// fish's range in [`World::palettes`] (see [`pose::PosePlan::slot_of_joint`]; joint 0's is
    /// slot 0). A mesh drawn with the world's palettes has its joint indices remapped through
    /// it ([`pose::remap_joints`]). Panics on an id this world did not issue.
    pub fn slot_of_joint(&self, id: SpeciesId) -> &[u16] {
        self.catalog.plans[usize::from(id.0)].slot_of_joint()
    }

    /// Palette entries (slots) per fish of the species: its distinct per-joint entries. Panics
    /// on an id this world did not issue.
    pub fn num_palette_slots(&self, id: SpeciesId) -> usize {
        self.catalog.plans[usize::from(id.0)].num_slots()
    }

    /// A species. Panics on an id this world did not issue (a programming error).
    pub fn species(&self, id: SpeciesId) -> &Species {
        &self.catalog.species[usize::from(id.0)]
    }

    /// A species, or `None` for an unknown id.
    pub fn try_species(&self, id: SpeciesId) -> Option<&Species> {
        self.catalog.species.get(usize::from(id.0))
    }

    /// Number of species.
    pub fn num_species(&self) -> usize {
        self.catalog.species.len()
    }

    /// The species named `name`.
    pub fn species_by_name(&self, name: &str) -> Option<SpeciesId> {
        self.catalog
            .species
            .iter()
            .position(|s| s.desc.name == name)
            .map(|i| SpeciesId(i as u16))
    }
}
