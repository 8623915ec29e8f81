//! Where a generated fish's 30 joints sit, and which joint each hangs from.

use glam::Vec3;

use super::{FishPlan, joint};
use crate::species::{DRIVEN_JOINTS, JOINT_NAMES};

impl FishPlan {
    /// Joint positions in asset space, in [`JOINT_NAMES`] order, and their parents.
    pub fn joints(&self) -> (Vec<Vec3>, Vec<Option<usize>>) {
        let positions = self.joint_positions();
        let parents = self.joint_parents(&positions);
        (positions.into_iter().map(|(_, p)| p).collect(), parents)
    }

    /// Each joint's name and position in asset space, in [`JOINT_NAMES`] order: on the body's
    /// axis for the chain, on the surface for the eyes, gills and fins.
    pub(super) fn joint_positions(&self) -> Vec<(&'static str, Vec3)> {
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
        let s = self.spine_f;
        vec![
            ("root", on_axis(self.root_f)),
            ("head", on_axis(self.head_f)),
            ("snout", on_axis(0.0)),
            (
                "jaw",
                Vec3::new(0.0, self.bottom.at(0.04) * 0.6, Self::z(0.04)),
            ),
            ("eye_L", Vec3::new(eye_x, eye_y, Self::z(ef))),
            ("eye_R", Vec3::new(-eye_x, eye_y, Self::z(ef))),
            (
                "gill_L",
                Vec3::new(self.half_width.at(0.2), self.mid(0.2), Self::z(0.2)),
            ),
            (
                "gill_R",
                Vec3::new(-self.half_width.at(0.2), self.mid(0.2), Self::z(0.2)),
            ),
            ("pectoral_L_1", Vec3::new(pec_x, pec_y, Self::z(pf))),
            (
                "pectoral_L_2",
                Vec3::new(
                    pec_x + plen * 0.25,
                    pec_y - plen * 0.2,
                    Self::z(pf + plen * 0.5),
                ),
            ),
            ("pectoral_R_1", Vec3::new(-pec_x, pec_y, Self::z(pf))),
            (
                "pectoral_R_2",
                Vec3::new(
                    -pec_x - plen * 0.25,
                    pec_y - plen * 0.2,
                    Self::z(pf + plen * 0.5),
                ),
            ),
            ("pelvic_L", Vec3::new(0.02, pel_y, Self::z(vf + vlen * 0.1))),
            (
                "pelvic_R",
                Vec3::new(-0.02, pel_y, Self::z(vf + vlen * 0.1)),
            ),
            ("spine_1", on_axis(s[0])),
            (
                "dorsal_1",
                Vec3::new(0.0, self.top.at(d_f(0.15)), Self::z(d_f(0.15))),
            ),
            ("spine_2", on_axis(s[1])),
            (
                "dorsal_2",
                Vec3::new(0.0, self.top.at(d_f(0.5)), Self::z(d_f(0.5))),
            ),
            ("spine_3", on_axis(s[2])),
            (
                "dorsal_3",
                Vec3::new(0.0, self.top.at(d_f(0.85)), Self::z(d_f(0.85))),
            ),
            (
                "anal_1",
                Vec3::new(0.0, self.bottom.at(a_f(0.2)), Self::z(a_f(0.2))),
            ),
            ("spine_4", on_axis(s[3])),
            (
                "anal_2",
                Vec3::new(0.0, self.bottom.at(a_f(0.75)), Self::z(a_f(0.75))),
            ),
            ("spine_5", on_axis(s[4])),
            ("spine_6", on_axis(s[5])),
            (
                "caudal_upper_1",
                Vec3::new(
                    0.0,
                    self.mid(cf) + 0.3 * self.caudal_half_span,
                    Self::z(cf + 0.35 * clen),
                ),
            ),
            (
                "caudal_upper_2",
                Vec3::new(
                    0.0,
                    self.mid(cf) + 0.7 * self.caudal_half_span,
                    Self::z(cf + 0.75 * clen),
                ),
            ),
            (
                "caudal_lower_1",
                Vec3::new(
                    0.0,
                    self.mid(cf) - 0.3 * self.caudal_half_span,
                    Self::z(cf + 0.35 * clen),
                ),
            ),
            (
                "caudal_lower_2",
                Vec3::new(
                    0.0,
                    self.mid(cf) - 0.7 * self.caudal_half_span,
                    Self::z(cf + 0.75 * clen),
                ),
            ),
            ("tail_end", on_axis(1.0)),
        ]
    }

    /// Each joint's parent (by index into [`JOINT_NAMES`]), `positions` as
    /// [`FishPlan::joint_positions`] gives them.
    pub(super) fn joint_parents(&self, positions: &[(&'static str, Vec3)]) -> Vec<Option<usize>> {
        let s = self.spine_f;
        // Parents: the head group hangs from head/root; fins from the chain joint whose segment
        // holds them; the chain is root → spine_1 → … → spine_6 → tail_end.
        let chain_parent = |f: f32| -> usize {
            let mut p = joint("root");
            for (k, &sf) in s.iter().enumerate() {
                if f >= sf {
                    p = joint(DRIVEN_JOINTS[k]);
                }
            }
            usize::from(p)
        };
        JOINT_NAMES
            .iter()
            .zip(positions)
            .map(|(name, (_, pos))| {
                let f = 0.5 - pos.z;
                match *name {
                    "root" => None,
                    "head" | "gill_L" | "gill_R" => Some(usize::from(joint("root"))),
                    "snout" | "jaw" | "eye_L" | "eye_R" => Some(usize::from(joint("head"))),
                    "pectoral_L_2" => Some(usize::from(joint("pectoral_L_1"))),
                    "pectoral_R_2" => Some(usize::from(joint("pectoral_R_1"))),
                    "spine_1" => Some(usize::from(joint("root"))),
                    "spine_2" => Some(usize::from(joint("spine_1"))),
                    "spine_3" => Some(usize::from(joint("spine_2"))),
                    "spine_4" => Some(usize::from(joint("spine_3"))),
                    "spine_5" => Some(usize::from(joint("spine_4"))),
                    "spine_6" => Some(usize::from(joint("spine_5"))),
                    "caudal_upper_2" => Some(usize::from(joint("caudal_upper_1"))),
                    "caudal_lower_2" => Some(usize::from(joint("caudal_lower_1"))),
                    "caudal_upper_1" | "caudal_lower_1" | "tail_end" => {
                        Some(usize::from(joint("spine_6")))
                    }
                    _ => Some(chain_parent(f)),
                }
            })
            .collect()
    }

    /// The vertebral chain used for body weights: (joint, f) head to tail.
    pub(super) fn chain(&self) -> [(u16, f32); 8] {
        let s = self.spine_f;
        [
            (joint("head"), self.head_f),
            (joint("root"), self.root_f),
            (joint("spine_1"), s[0]),
            (joint("spine_2"), s[1]),
            (joint("spine_3"), s[2]),
            (joint("spine_4"), s[3]),
            (joint("spine_5"), s[4]),
            (joint("spine_6"), s[5]),
        ]
    }
}
