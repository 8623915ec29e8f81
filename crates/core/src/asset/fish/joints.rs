//! Where a generated fish's joints sit, and which joint each hangs from.

use glam::Vec3;

use super::FishPlan;
use crate::species::{generated_joint_names, spine_name, spine_number};

impl FishPlan {
    /// The joint names in file order: [`crate::species::JOINT_NAMES`] with this plan's chain
    /// `spine_1` … `spine_n` (n = `spine_f.len()`; [`generated_joint_names`]).
    pub fn joint_names(&self) -> Vec<String> {
        generated_joint_names(self.spine_f.len())
            .map(|n| n.into_owned())
            .collect()
    }

    /// Index of joint `name` in [`FishPlan::joint_names`] (0, the root, for an unknown name).
    pub(super) fn joint(&self, name: &str) -> u16 {
        generated_joint_names(self.spine_f.len())
            .position(|n| n == name)
            .unwrap_or(0) as u16
    }

    /// Index of the chain joint `spine_k`.
    fn spine(&self, k: usize) -> u16 {
        self.joint(&spine_name(k))
    }

    /// The last driven joint, `spine_n`: the caudal fin and the tail tip hang from it.
    pub(super) fn last_spine(&self) -> u16 {
        self.spine(self.spine_f.len())
    }

    /// Joint positions in asset space, in [`FishPlan::joint_names`] order, and their parents.
    pub fn joints(&self) -> (Vec<Vec3>, Vec<Option<usize>>) {
        let names = self.joint_names();
        let positions: Vec<Vec3> = names.iter().map(|n| self.joint_position(n)).collect();
        let parents = names
            .iter()
            .zip(&positions)
            .map(|(n, p)| self.joint_parent(n, *p))
            .collect();
        (positions, parents)
    }

    /// A joint's position in asset space: on the body's axis for the chain, on the surface for
    /// the eyes, gills and fins.
    fn joint_position(&self, name: &str) -> Vec3 {
        let on_axis = |f: f32| Vec3::new(0.0, self.mid(f), Self::z(f));
        let d = &self.dorsal;
        let a = &self.anal;
        let d_f = |t: f32| d.start + t * (d.end - d.start);
        let a_f = |t: f32| a.start + t * (a.end - a.start);
        let (pf, plen, _, _) = self.pectoral;
        let (ef, eh, _, _) = self.eye;
        let eye_y = self.bottom.at(ef) + eh * (self.top.at(ef) - self.bottom.at(ef));
        let eye_x = self.half_width.at(ef) * 0.8;
        let pec_y = self.bottom.at(pf) + 0.35 * (self.top.at(pf) - self.bottom.at(pf));
        let pec_x = self.half_width.at(pf);
        let (vf, vlen) = self.pelvic.map_or((pf + 0.04, plen * 0.6), |p| (p.0, p.1));
        let pel_y = self.bottom.at(vf);
        let cf = self.body_end;
        let clen = 1.0 - cf;
        if let Some(k) = spine_number(name) {
            return on_axis(self.spine_f[k - 1]);
        }
        match name {
            "root" => on_axis(self.root_f),
            "head" => on_axis(self.head_f),
            "snout" => on_axis(0.0),
            "jaw" => Vec3::new(0.0, self.bottom.at(0.04) * 0.6, Self::z(0.04)),
            "eye_L" => Vec3::new(eye_x, eye_y, Self::z(ef)),
            "eye_R" => Vec3::new(-eye_x, eye_y, Self::z(ef)),
            "gill_L" => Vec3::new(self.half_width.at(0.2), self.mid(0.2), Self::z(0.2)),
            "gill_R" => Vec3::new(-self.half_width.at(0.2), self.mid(0.2), Self::z(0.2)),
            "pectoral_L_1" => Vec3::new(pec_x, pec_y, Self::z(pf)),
            "pectoral_L_2" => Vec3::new(
                pec_x + plen * 0.25,
                pec_y - plen * 0.2,
                Self::z(pf + plen * 0.5),
            ),
            "pectoral_R_1" => Vec3::new(-pec_x, pec_y, Self::z(pf)),
            "pectoral_R_2" => Vec3::new(
                -pec_x - plen * 0.25,
                pec_y - plen * 0.2,
                Self::z(pf + plen * 0.5),
            ),
            "pelvic_L" => Vec3::new(0.02, pel_y, Self::z(vf + vlen * 0.1)),
            "pelvic_R" => Vec3::new(-0.02, pel_y, Self::z(vf + vlen * 0.1)),
            "dorsal_1" => Vec3::new(0.0, self.top.at(d_f(0.15)), Self::z(d_f(0.15))),
            "dorsal_2" => Vec3::new(0.0, self.top.at(d_f(0.5)), Self::z(d_f(0.5))),
            "dorsal_3" => Vec3::new(0.0, self.top.at(d_f(0.85)), Self::z(d_f(0.85))),
            "anal_1" => Vec3::new(0.0, self.bottom.at(a_f(0.2)), Self::z(a_f(0.2))),
            "anal_2" => Vec3::new(0.0, self.bottom.at(a_f(0.75)), Self::z(a_f(0.75))),
            "caudal_upper_1" => Vec3::new(
                0.0,
                self.mid(cf) + 0.3 * self.caudal_half_span,
                Self::z(cf + 0.35 * clen),
            ),
            "caudal_upper_2" => Vec3::new(
                0.0,
                self.mid(cf) + 0.7 * self.caudal_half_span,
                Self::z(cf + 0.75 * clen),
            ),
            "caudal_lower_1" => Vec3::new(
                0.0,
                self.mid(cf) - 0.3 * self.caudal_half_span,
                Self::z(cf + 0.35 * clen),
            ),
            "caudal_lower_2" => Vec3::new(
                0.0,
                self.mid(cf) - 0.7 * self.caudal_half_span,
                Self::z(cf + 0.75 * clen),
            ),
            "tail_end" => on_axis(1.0),
            _ => unreachable!("{name} is not a joint of a generated fish"),
        }
    }

    /// A joint's parent (an index into [`FishPlan::joint_names`]); `pos` is its position.
    ///
    /// The head group hangs from head/root; fins from the chain joint whose segment holds them;
    /// the chain is root → spine_1 → … → spine_n → tail_end.
    fn joint_parent(&self, name: &str, pos: Vec3) -> Option<usize> {
        let at = |n: &str| Some(usize::from(self.joint(n)));
        if let Some(k) = spine_number(name) {
            return if k == 1 {
                at("root")
            } else {
                Some(usize::from(self.spine(k - 1)))
            };
        }
        match name {
            "root" => None,
            "head" | "gill_L" | "gill_R" => at("root"),
            "snout" | "jaw" | "eye_L" | "eye_R" => at("head"),
            "pectoral_L_2" => at("pectoral_L_1"),
            "pectoral_R_2" => at("pectoral_R_1"),
            "caudal_upper_2" => at("caudal_upper_1"),
            "caudal_lower_2" => at("caudal_lower_1"),
            "caudal_upper_1" | "caudal_lower_1" | "tail_end" => {
                Some(usize::from(self.last_spine()))
            }
            _ => {
                // The chain joint whose segment holds f.
                let f = 0.5 - pos.z;
                let mut p = self.joint("root");
                for (k, &sf) in self.spine_f.iter().enumerate() {
                    if f >= sf {
                        p = self.spine(k + 1);
                    }
                }
                Some(usize::from(p))
            }
        }
    }

    /// The vertebral chain used for body weights: (joint, f) head to tail.
    pub(super) fn chain(&self) -> Vec<(u16, f32)> {
        let mut chain = vec![
            (self.joint("head"), self.head_f),
            (self.joint("root"), self.root_f),
        ];
        for (k, &f) in self.spine_f.iter().enumerate() {
            chain.push((self.spine(k + 1), f));
        }
        chain
    }
}
