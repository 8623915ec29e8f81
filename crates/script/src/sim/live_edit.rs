//! Edits of the running scene from the window: a group's `params`, the obstacles, the current
//! zones and the groups' start regions, applied at once without a restart
//! ([`Simulation::apply_scene_edit`]). The panel then saves the same values into the scene file
//! (`crate::edit`), and the hot reload of that file finds nothing to change.

use glam::Vec3;
use shoal_core::world::Current;

use super::Simulation;
use crate::error::ScriptError;
use crate::scene::SceneDesc;

impl Simulation {
    /// Makes `desc` the running scene: its groups' `params` reach their live fish at once (the
    /// scripts read them as `fish.params`), its obstacles and current zones replace the world's,
    /// and its start regions and positions are kept for a restart and for saving (fish already
    /// swimming stay where the simulation has them). Anything else (the tank, species, counts,
    /// behaviours, food) needs a restart and is refused, naming the field; nothing changes then.
    pub fn apply_scene_edit(&mut self, desc: SceneDesc) -> Result<(), ScriptError> {
        let Some(old) = self.scene.clone() else {
            return Err(ScriptError::Data {
                file: "scene".into(),
                why: "this simulation was not built from a scene file".into(),
            });
        };
        let file = self
            .scene_path
            .as_deref()
            .map_or_else(|| "scene".to_owned(), |p| self.host().root().display_of(p));
        let refuse = |field: &str| ScriptError::Data {
            file: file.clone(),
            why: format!("{field} cannot change while the scene runs: edit the file and restart"),
        };
        let bad = |field: String, why: &str| ScriptError::Data {
            file: file.clone(),
            why: format!("{field}: {why}"),
        };
        let finite = |v: &[f32; 3]| v.iter().all(|x| x.is_finite());
        for (i, o) in desc.obstacles.iter().enumerate() {
            if !(finite(&o.pos) && o.radius.is_finite() && o.radius >= 0.0) {
                return Err(bad(
                    format!("obstacles[{}]", i + 1),
                    "needs a finite position and a radius of 0 or more",
                ));
            }
        }
        for (i, c) in desc.currents.iter().enumerate() {
            if !(finite(&c.pos) && finite(&c.velocity) && c.radius.is_finite() && c.radius > 0.0) {
                return Err(bad(
                    format!("currents[{}]", i + 1),
                    "needs a finite position and velocity and a radius above 0",
                ));
            }
        }
        // What may change live, taken back to the old values: the rest must be equal.
        let mut same = desc.clone();
        same.obstacles.clone_from(&old.obstacles);
        same.currents.clone_from(&old.currents);
        if same.fish.len() != old.fish.len() {
            return Err(refuse("the number of fish groups"));
        }
        for (g, (n, o)) in same.fish.iter_mut().zip(&old.fish).enumerate() {
            n.params.clone_from(&o.params);
            n.region = o.region;
            n.pos = o.pos;
            if n != o {
                return Err(refuse(&format!("fish[{}]", g + 1)));
            }
        }
        if same != old {
            return Err(refuse("the tank, species and food"));
        }
        for (g, (n, o)) in desc.fish.iter().zip(&old.fish).enumerate() {
            if n.params == o.params {
                continue;
            }
            let params = n.params.clone().unwrap_or(serde_json::Value::Null);
            let alive: Vec<_> = self
                .group_fish
                .get(g)
                .into_iter()
                .flatten()
                .copied()
                .filter(|&id| self.sim.world().species_of(id).is_some())
                .collect();
            for id in alive {
                self.set_params(id, params.clone())?;
            }
        }
        let props_changed = desc.obstacles != old.obstacles || desc.currents != old.currents;
        self.scene = Some(desc);
        if props_changed {
            self.props_edited = true;
            self.sync_props();
        }
        Ok(())
    }

    /// Puts the scene's rocks and current zones into the world. After a live edit of them, a
    /// state restored from the history (kept before the edit) gets them too: they are scene
    /// data, like the scripts, and a rewound simulation runs on with the scene as edited now.
    pub(super) fn sync_props(&mut self) {
        if !self.props_edited {
            return;
        }
        let Some(desc) = &self.scene else { return };
        let rocks: Vec<_> = desc
            .obstacles
            .iter()
            .map(|o| (Vec3::from_array(o.pos), o.radius))
            .collect();
        let zones: Vec<_> = desc
            .currents
            .iter()
            .map(|c| Current {
                pos: Vec3::from_array(c.pos),
                radius: c.radius,
                velocity: Vec3::from_array(c.velocity),
            })
            .collect();
        let w = self.sim.world_mut();
        w.set_obstacles(rocks);
        w.set_currents(zones);
    }
}
