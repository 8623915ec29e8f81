//! The procedural fish generator behind `shoal asset porgy` and `shoal asset eel`.
//!
//! Asset space follows glTF: +Y up, +Z forward (the snout), so +X is the fish's left. The total
//! length (snout to caudal tips) is 1 unit: the snout at z = +0.5, the tail tips at z = −0.5.
//! Positions along the body are fractions `f` of that length from the snout (0) to the tail (1).
//!
//! Every fish has the same 30 joints (names in [`JOINT_NAMES`], which the species side owns): the vertebral chain
//! `root`, `spine_1` … `spine_6`, `tail_end` — seven segments (root→spine_1, …,
//! spine_6→tail_end) bent at the six driven joints `spine_1` … `spine_6` — plus `head`, `snout`,
//! `jaw`, eyes, gill covers and fin joints. Joints are unrotated at rest.
//!
//! Everything is plain f32 arithmetic in a fixed order, so the output is byte-identical run to
//! run on the same platform.

use std::f32::consts::{PI, TAU};

use glam::Vec3;

use super::rigged::{Influences, MaterialSet, RiggedMesh};
use crate::math::smoothstep_between;
use crate::species::{DRIVEN_JOINTS, JOINT_NAMES};

fn joint(name: &str) -> u16 {
    JOINT_NAMES.iter().position(|n| *n == name).unwrap_or(0) as u16
}

/// A profile: smooth interpolation through (f, value) control points, f increasing.
#[derive(Debug, Clone, Copy)]
pub struct Profile(pub &'static [(f32, f32)]);

impl Profile {
    /// Value at `f` (clamped to the ends); cubic Hermite with finite-difference tangents.
    pub fn at(&self, f: f32) -> f32 {
        let p = self.0;
        if f <= p[0].0 {
            return p[0].1;
        }
        let last = p.len() - 1;
        if f >= p[last].0 {
            return p[last].1;
        }
        let mut i = 0;
        while p[i + 1].0 < f {
            i += 1;
        }
        let (x0, y0) = p[i];
        let (x1, y1) = p[i + 1];
        let slope = |k: usize| {
            let a = p[k.saturating_sub(1)];
            let b = p[(k + 1).min(last)];
            (b.1 - a.1) / (b.0 - a.0)
        };
        let h = x1 - x0;
        let t = (f - x0) / h;
        let (m0, m1) = (slope(i) * h, slope(i + 1) * h);
        let t2 = t * t;
        let t3 = t2 * t;
        (2.0 * t3 - 3.0 * t2 + 1.0) * y0
            + (t3 - 2.0 * t2 + t) * m0
            + (-2.0 * t3 + 3.0 * t2) * y1
            + (t3 - t2) * m1
    }
}

/// A median fin along the back or belly: base from `start` to `end` (fractions of length),
/// height profile over the fin's own 0..1, and how many stiff spines lead it.
#[derive(Debug, Clone, Copy)]
pub struct MedianFin {
    /// Base start (front), fraction of length.
    pub start: f32,
    /// Base end (back), fraction of length.
    pub end: f32,
    /// Height (units) over the fin's own 0..1 from front to back.
    pub height: Profile,
    /// Number of spines in the front part (0: a soft fin); the membrane dips between them.
    pub spines: usize,
    /// Fraction of the fin's base that is spiny.
    pub spiny_part: f32,
    /// How far the edge sweeps back (units) at full height.
    pub sweep: f32,
    /// Quads along the base and outwards.
    pub grid: (usize, usize),
}

/// Everything that distinguishes one generated species from another.
#[derive(Debug, Clone)]
pub struct FishPlan {
    /// Mesh and scene name.
    pub name: &'static str,
    /// Fraction of the length where the body ends and the caudal fin begins.
    pub body_end: f32,
    /// Dorsal outline height above y = 0, over f in [0, body_end].
    pub top: Profile,
    /// Ventral outline (negative), over f.
    pub bottom: Profile,
    /// Half width, over f.
    pub half_width: Profile,
    /// Cross-section side fullness: x = w·sign(s)|s|^k; k < 1 gives flat, slab-like sides.
    pub side_exponent: f32,
    /// Body rings and ring segments.
    pub rings: usize,
    /// Segments around each ring.
    pub segments: usize,
    /// Fractions of length of root, head, and spine_1 … spine_6.
    pub root_f: f32,
    /// Head joint position.
    pub head_f: f32,
    /// Driven joints spine_1 … spine_6.
    pub spine_f: [f32; 6],
    /// Dorsal fin.
    pub dorsal: MedianFin,
    /// Anal fin.
    pub anal: MedianFin,
    /// Caudal fin: half span of the lobe tips (units) and depth of the fork (0: rounded tail).
    pub caudal_half_span: f32,
    /// Fork depth as a fraction of the caudal length (negative: rounded, convex edge).
    pub caudal_fork: f32,
    /// Caudal grid (quads along the span, outwards).
    pub caudal_grid: (usize, usize),
    /// Pectoral fins: base position f, length (units), width at the base, grid.
    pub pectoral: (f32, f32, f32, (usize, usize)),
    /// Pelvic fins: position f, length, grid; none for the eel.
    pub pelvic: Option<(f32, f32, (usize, usize))>,
    /// Eye position f, height fraction between bottom and top, radius; stacks and slices.
    pub eye: (f32, f32, f32, (usize, usize)),
    /// Back colour (linear RGB).
    pub back: [f32; 3],
    /// Belly colour.
    pub belly: [f32; 3],
    /// Fin colour.
    pub fin: [f32; 3],
    /// Number and strength of faint vertical bars.
    pub bars: (usize, f32),
    /// The material's base colour, metallic and roughness.
    pub material: ([f32; 4], f32, f32),
}

impl FishPlan {
    /// The black porgy (*Acanthopagrus schlegelii*): deep, laterally compressed sparid body,
    /// steep head profile, long spiny dorsal fin, forked caudal fin, dark silver-grey with faint
    /// bars. About 5,700 triangles (the paper's model has 5,695 polygons).
    pub fn black_porgy() -> Self {
        Self {
            name: "black_porgy",
            body_end: 0.80,
            top: Profile(&[
                (0.0, 0.0),
                (0.03, 0.035),
                (0.10, 0.105),
                (0.20, 0.165),
                (0.32, 0.195),
                (0.45, 0.19),
                (0.58, 0.155),
                (0.70, 0.095),
                (0.76, 0.06),
                (0.80, 0.05),
            ]),
            bottom: Profile(&[
                (0.0, -0.005),
                (0.03, -0.03),
                (0.10, -0.08),
                (0.20, -0.13),
                (0.32, -0.16),
                (0.45, -0.16),
                (0.58, -0.13),
                (0.70, -0.08),
                (0.76, -0.055),
                (0.80, -0.045),
            ]),
            half_width: Profile(&[
                (0.0, 0.004),
                (0.03, 0.025),
                (0.10, 0.05),
                (0.20, 0.068),
                (0.32, 0.072),
                (0.45, 0.064),
                (0.58, 0.048),
                (0.70, 0.028),
                (0.80, 0.016),
            ]),
            side_exponent: 0.7,
            rings: 44,
            segments: 36,
            root_f: 0.16,
            head_f: 0.06,
            spine_f: [0.30, 0.41, 0.51, 0.60, 0.68, 0.76],
            dorsal: MedianFin {
                start: 0.28,
                end: 0.70,
                height: Profile(&[
                    (0.0, 0.02),
                    (0.12, 0.10),
                    (0.3, 0.09),
                    (0.55, 0.065),
                    (0.62, 0.07),
                    (0.85, 0.06),
                    (1.0, 0.015),
                ]),
                spines: 11,
                spiny_part: 0.58,
                sweep: 0.02,
                grid: (24, 6),
            },
            anal: MedianFin {
                start: 0.56,
                end: 0.72,
                height: Profile(&[(0.0, 0.02), (0.2, 0.075), (0.6, 0.06), (1.0, 0.015)]),
                spines: 3,
                spiny_part: 0.3,
                sweep: 0.03,
                grid: (12, 5),
            },
            caudal_half_span: 0.17,
            caudal_fork: 0.45,
            caudal_grid: (24, 8),
            pectoral: (0.29, 0.17, 0.05, (8, 6)),
            pelvic: Some((0.33, 0.11, (6, 4))),
            eye: (0.085, 0.68, 0.03, (7, 12)),
            back: [0.07, 0.075, 0.085],
            belly: [0.62, 0.64, 0.66],
            fin: [0.045, 0.045, 0.05],
            bars: (6, 0.25),
            material: ([0.85, 0.87, 0.9, 1.0], 0.35, 0.4),
        }
    }

    /// An eel-like fish: long slender round body, dorsal and anal fins running most of its
    /// length into a small rounded tail, small pectorals, no pelvic fins. Its driven joints
    /// start near the front (the paper: the eel's motion centre is towards the front).
    pub fn eel() -> Self {
        Self {
            name: "eel",
            body_end: 0.96,
            top: Profile(&[
                (0.0, 0.0),
                (0.02, 0.012),
                (0.06, 0.024),
                (0.15, 0.032),
                (0.5, 0.032),
                (0.8, 0.024),
                (0.96, 0.008),
            ]),
            bottom: Profile(&[
                (0.0, -0.003),
                (0.02, -0.012),
                (0.06, -0.022),
                (0.15, -0.03),
                (0.5, -0.03),
                (0.8, -0.022),
                (0.96, -0.008),
            ]),
            half_width: Profile(&[
                (0.0, 0.003),
                (0.02, 0.012),
                (0.06, 0.022),
                (0.15, 0.028),
                (0.5, 0.026),
                (0.8, 0.016),
                (0.96, 0.004),
            ]),
            side_exponent: 0.95,
            rings: 64,
            segments: 24,
            root_f: 0.07,
            head_f: 0.025,
            spine_f: [0.18, 0.31, 0.44, 0.57, 0.70, 0.83],
            dorsal: MedianFin {
                start: 0.35,
                end: 0.97,
                height: Profile(&[(0.0, 0.004), (0.1, 0.018), (0.8, 0.02), (1.0, 0.012)]),
                spines: 0,
                spiny_part: 0.0,
                sweep: 0.0,
                grid: (48, 3),
            },
            anal: MedianFin {
                start: 0.5,
                end: 0.97,
                height: Profile(&[(0.0, 0.004), (0.1, 0.016), (0.8, 0.018), (1.0, 0.012)]),
                spines: 0,
                spiny_part: 0.0,
                sweep: 0.0,
                grid: (40, 3),
            },
            caudal_half_span: 0.02,
            caudal_fork: -0.6,
            caudal_grid: (8, 4),
            pectoral: (0.12, 0.035, 0.018, (5, 4)),
            pelvic: None,
            eye: (0.03, 0.7, 0.007, (6, 10)),
            back: [0.05, 0.06, 0.035],
            belly: [0.45, 0.42, 0.25],
            fin: [0.04, 0.045, 0.03],
            bars: (0, 0.0),
            material: ([0.9, 0.9, 0.9, 1.0], 0.1, 0.35),
        }
    }

    fn z(f: f32) -> f32 {
        0.5 - f
    }

    fn mid(&self, f: f32) -> f32 {
        let f = f.min(self.body_end);
        0.5 * (self.top.at(f) + self.bottom.at(f))
    }

    /// Joint positions in asset space, in [`JOINT_NAMES`] order, and their parents.
    pub fn joints(&self) -> (Vec<Vec3>, Vec<Option<usize>>) {
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
        let positions: Vec<(&str, Vec3)> = vec![
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
        ];
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
        let parents: Vec<Option<usize>> = JOINT_NAMES
            .iter()
            .zip(&positions)
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
            .collect();
        (positions.into_iter().map(|(_, p)| p).collect(), parents)
    }

    /// The vertebral chain used for body weights: (joint, f) head to tail.
    fn chain(&self) -> [(u16, f32); 8] {
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

    /// Builds the mesh and skin.
    pub fn build(&self) -> RiggedMesh {
        let (joint_positions, joint_parents) = self.joints();
        let mut m = RiggedMesh {
            name: self.name.to_string(),
            joint_names: JOINT_NAMES.iter().map(|s| s.to_string()).collect(),
            joint_parents,
            joint_positions,
            ..RiggedMesh::default()
        };
        self.body(&mut m);
        let d = self.dorsal;
        self.median_fin(&mut m, &d, true);
        let a = self.anal;
        self.median_fin(&mut m, &a, false);
        self.caudal(&mut m);
        self.pectorals(&mut m);
        self.pelvics(&mut m);
        self.eyes(&mut m);
        m
    }

    /// Smooth weights along a chain of (joint, f) sorted by f: one joint inside a segment,
    /// smoothstep blends across each joint over ±35% of the shorter neighbouring segment.
    fn chain_weights(chain: &[(u16, f32)], f: f32, out: &mut Vec<(u16, f32)>, scale: f32) {
        chain_blend(chain, f, 0.35, |j, w| out.push((j, w * scale)));
    }

    fn body_color(&self, f: f32, c: f32) -> [f32; 4] {
        let up = smoothstep_between(-0.35, 0.45, c);
        let mut rgb = [0.0; 3];
        for (k, v) in rgb.iter_mut().enumerate() {
            *v = self.belly[k] + (self.back[k] - self.belly[k]) * up;
        }
        let (n, strength) = self.bars;
        if n > 0 && f > 0.18 && f < self.body_end {
            let t = (f - 0.18) / (self.body_end - 0.18);
            let bar = (t * n as f32 * PI).sin().abs().powi(6) * strength * (0.3 + 0.7 * up);
            for v in &mut rgb {
                *v *= 1.0 - bar;
            }
        }
        [rgb[0], rgb[1], rgb[2], 1.0]
    }

    fn body(&self, m: &mut RiggedMesh) {
        let chain = self.chain();
        let base = m.positions.len() as u32;
        let first_index = m.indices.len();
        let segs = self.segments;
        let mut pairs = Vec::new();
        // Snout pole.
        let pole = Vec3::new(0.0, self.mid(0.0), Self::z(0.0));
        m.positions.push(pole);
        m.colors.push(self.body_color(0.0, 0.0));
        m.influences.push(Influences::from_pairs(
            &[(joint("snout"), 0.3), (joint("head"), 0.7)],
            0,
        ));
        for i in 0..self.rings {
            let t = (i + 1) as f32 / self.rings as f32;
            let f = self.body_end * t.powf(1.15);
            let top = self.top.at(f);
            let bottom = self.bottom.at(f);
            let (mid, hh) = (0.5 * (top + bottom), 0.5 * (top - bottom));
            let w = self.half_width.at(f);
            for j in 0..segs {
                let th = TAU * j as f32 / segs as f32;
                let (s, c) = th.sin_cos();
                let x = w * s.signum() * s.abs().powf(self.side_exponent);
                let y = mid + hh * c;
                m.positions.push(Vec3::new(x, y, Self::z(f)));
                m.colors.push(self.body_color(f, c));
                pairs.clear();
                Self::chain_weights(&chain, f, &mut pairs, 1.0);
                // Lower jaw.
                let jaw = (1.0 - f / 0.07).max(0.0) * smoothstep_between(-0.1, -0.6, c);
                // Gill covers.
                let gill = 0.5 * bump(f, 0.15, 0.26) * smoothstep_between(0.4, 0.9, s.abs());
                let keep = 1.0 - jaw - gill;
                for p in &mut pairs {
                    p.1 *= keep;
                }
                pairs.push((joint("jaw"), jaw));
                pairs.push((joint(if s > 0.0 { "gill_L" } else { "gill_R" }), gill));
                m.influences
                    .push(Influences::from_pairs(&pairs, joint("root")));
            }
        }
        // Tail cap centre.
        let fe = self.body_end;
        m.positions.push(Vec3::new(0.0, self.mid(fe), Self::z(fe)));
        m.colors.push(self.body_color(fe, 0.0));
        m.influences
            .push(Influences::from_pairs(&[(joint("spine_6"), 1.0)], 0));
        let ring = |i: usize, j: usize| base + 1 + (i * segs + j % segs) as u32;
        let cap = base + 1 + (self.rings * segs) as u32;
        // Faces wound counter-clockwise seen from outside.
        for j in 0..segs {
            m.indices.extend([base, ring(0, j + 1), ring(0, j)]);
        }
        for i in 0..self.rings - 1 {
            for j in 0..segs {
                let (a, b, c, d) = (
                    ring(i, j),
                    ring(i, j + 1),
                    ring(i + 1, j + 1),
                    ring(i + 1, j),
                );
                m.indices.extend([a, b, c, a, c, d]);
            }
        }
        for j in 0..segs {
            m.indices
                .extend([cap, ring(self.rings - 1, j), ring(self.rings - 1, j + 1)]);
        }
        let local: Vec<u32> = m.indices[first_index..].iter().map(|i| i - base).collect();
        let normals = crate::skin::vertex_normals(&m.positions[base as usize..], &local);
        m.normals.extend(normals);
    }

    /// Adds a two-sided sheet: grid points `point(a, b)` (a along the base, b from base to edge),
    /// offset ±`thickness`·(1 − b) along `side`, normals ±`side`; each triangle is wound so its
    /// front faces its side's normal.
    #[allow(clippy::too_many_arguments)]
    fn sheet(
        m: &mut RiggedMesh,
        grid: (usize, usize),
        side: Vec3,
        thickness: f32,
        point: &dyn Fn(f32, f32) -> Vec3,
        weights: &WeightFn,
        color: &dyn Fn(f32, f32) -> [f32; 4],
    ) {
        let (na, nb) = grid;
        let mut pairs = Vec::new();
        for sign in [1.0f32, -1.0] {
            let base = m.positions.len() as u32;
            for i in 0..=na {
                for j in 0..=nb {
                    let (a, b) = (i as f32 / na as f32, j as f32 / nb as f32);
                    m.positions
                        .push(point(a, b) + side * (sign * thickness * (1.0 - b)));
                    m.normals.push(side * sign);
                    m.colors.push(color(a, b));
                    pairs.clear();
                    weights(a, b, &mut pairs);
                    m.influences
                        .push(Influences::from_pairs(&pairs, joint("root")));
                }
            }
            let v = |i: usize, j: usize| base + (i * (nb + 1) + j) as u32;
            for i in 0..na {
                for j in 0..nb {
                    let (p, q, r, s) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
                    // Wind each triangle so its front faces this side's normal.
                    for [x, y, z] in [[p, q, r], [p, r, s]] {
                        let pos = |k: u32| m.positions[k as usize];
                        let face = (pos(y) - pos(x)).cross(pos(z) - pos(x));
                        if face.dot(side * sign) >= 0.0 {
                            m.indices.extend([x, y, z]);
                        } else {
                            m.indices.extend([x, z, y]);
                        }
                    }
                }
            }
        }
    }

    fn fin_color(&self, b: f32) -> [f32; 4] {
        let k = 1.0 + 0.6 * (1.0 - b);
        [self.fin[0] * k, self.fin[1] * k, self.fin[2] * k, 1.0]
    }

    fn median_fin(&self, m: &mut RiggedMesh, fin: &MedianFin, dorsal: bool) {
        let chain = self.chain();
        let fin_joints: Vec<(u16, f32)> = if dorsal {
            ["dorsal_1", "dorsal_2", "dorsal_3"]
                .iter()
                .map(|n| {
                    (
                        joint(n),
                        fin.start + [0.15, 0.5, 0.85][joint_slot(n)] * (fin.end - fin.start),
                    )
                })
                .collect()
        } else {
            vec![
                (joint("anal_1"), fin.start + 0.2 * (fin.end - fin.start)),
                (joint("anal_2"), fin.start + 0.75 * (fin.end - fin.start)),
            ]
        };
        let sign = if dorsal { 1.0 } else { -1.0 };
        let spines = fin.spines;
        let point = |a: f32, b: f32| {
            let f = fin.start + a * (fin.end - fin.start);
            let root_y = if dorsal {
                self.top.at(f)
            } else {
                self.bottom.at(f)
            };
            // Sink the base slightly into the body so no gap opens when it bends.
            let root_y = root_y - sign * 0.006;
            let mut h = fin.height.at(a);
            if spines > 0 && a < fin.spiny_part {
                // Spine tips at a = k·spiny/spines; the membrane dips between them.
                let k = a / fin.spiny_part * spines as f32;
                let dip = (k * PI).sin().abs();
                h *= 1.0 - 0.3 * dip * b.powf(1.5);
            }
            let sweep = fin.sweep * b;
            Vec3::new(0.0, root_y + sign * h * b, Self::z(f) - sweep)
        };
        let weights = |a: f32, b: f32, out: &mut Vec<(u16, f32)>| {
            let f = fin.start + a * (fin.end - fin.start);
            let t = smoothstep_between(0.0, 1.0, b);
            Self::chain_weights(&chain, f, out, 1.0 - t);
            chain_blend(&fin_joints, f, 0.5, |j, w| out.push((j, w * t)));
        };
        let color = |_a: f32, b: f32| self.fin_color(b);
        Self::sheet(m, fin.grid, Vec3::X, 0.0025, &point, &weights, &color);
    }

    fn caudal(&self, m: &mut RiggedMesh) {
        let cf = self.body_end;
        let clen = 1.0 - cf;
        let mid = self.mid(cf);
        let root_h = 0.5 * (self.top.at(cf) - self.bottom.at(cf));
        let span = self.caudal_half_span;
        let fork = self.caudal_fork;
        let point = |a: f32, b: f32| {
            let s = 2.0 * a - 1.0; // −1 lower tip … +1 upper tip
            let base = Vec3::new(0.0, mid + s * root_h * 0.9, Self::z(cf - 0.01));
            // Trailing edge: tips at z = −0.5, the fork's notch `fork`·clen further forward
            // (negative fork: a rounded, convex edge).
            let edge_f = 1.0 - fork * clen * (1.0 - s.abs().powf(1.5));
            let edge_f = edge_f.min(1.0);
            let edge = Vec3::new(0.0, mid + s * span, Self::z(edge_f));
            base + (edge - base) * b
        };
        let weights = |a: f32, b: f32, out: &mut Vec<(u16, f32)>| {
            let s = 2.0 * a - 1.0;
            let upper = smoothstep_between(-0.4, 0.4, s);
            let outer = smoothstep_between(0.25, 0.8, b);
            let body = (1.0 - smoothstep_between(0.0, 0.5, b)).max(0.0);
            let fin = 1.0 - body;
            out.push((joint("spine_6"), body));
            out.push((joint("caudal_upper_1"), fin * upper * (1.0 - outer)));
            out.push((joint("caudal_upper_2"), fin * upper * outer));
            out.push((joint("caudal_lower_1"), fin * (1.0 - upper) * (1.0 - outer)));
            out.push((joint("caudal_lower_2"), fin * (1.0 - upper) * outer));
        };
        let color = |_a: f32, b: f32| self.fin_color(b);
        Self::sheet(
            m,
            self.caudal_grid,
            Vec3::X,
            0.003,
            &point,
            &weights,
            &color,
        );
    }

    fn pectorals(&self, m: &mut RiggedMesh) {
        let (pf, len, width, grid) = self.pectoral;
        let chain = self.chain();
        for (side, j1, j2) in [
            (1.0f32, "pectoral_L_1", "pectoral_L_2"),
            (-1.0, "pectoral_R_1", "pectoral_R_2"),
        ] {
            let y0 = self.bottom.at(pf) + 0.35 * (self.top.at(pf) - self.bottom.at(pf));
            let x0 = self.half_width.at(pf) * 0.95;
            // The fin sweeps back, out and slightly down: a rounded paddle.
            let dir = Vec3::new(side * 0.35, -0.25, -1.0).normalize();
            let up = Vec3::new(side * 0.15, 1.0, 0.0).normalize();
            let point = |a: f32, b: f32| {
                let s = 2.0 * a - 1.0;
                let half =
                    0.5 * width * (1.0 + 0.4 * b) * (1.0 - b.powi(3)).max(0.0).sqrt().max(0.25);
                let reach = len * b * (1.0 - 0.25 * s * s);
                Vec3::new(side * x0, y0, Self::z(pf)) + up * (s * half) + dir * reach
            };
            let normal = dir.cross(up).normalize() * side;
            let weights = |_a: f32, b: f32, out: &mut Vec<(u16, f32)>| {
                let base = 1.0 - smoothstep_between(0.0, 0.3, b);
                let outer = smoothstep_between(0.3, 0.9, b);
                Self::chain_weights(&chain, pf, out, base);
                out.push((joint(j1), (1.0 - base) * (1.0 - outer)));
                out.push((joint(j2), (1.0 - base) * outer));
            };
            let color = |_a: f32, b: f32| self.fin_color(b);
            Self::sheet(m, grid, normal, 0.0015, &point, &weights, &color);
        }
    }

    fn pelvics(&self, m: &mut RiggedMesh) {
        let Some((vf, len, grid)) = self.pelvic else {
            return;
        };
        let chain = self.chain();
        for (side, j) in [(1.0f32, "pelvic_L"), (-1.0, "pelvic_R")] {
            let y0 = self.bottom.at(vf) + 0.004;
            // A paddle hanging down, back and slightly out from a short base along the belly.
            let dir = Vec3::new(side * 0.3, -0.8, -1.0).normalize();
            let point = |a: f32, b: f32| {
                let s = a - 0.5;
                let base = Vec3::new(side * 0.012, y0, Self::z(vf) - s * 0.035 * (1.0 - 0.6 * b));
                base + dir * (len * b * (1.0 - 0.5 * s.abs()))
            };
            let normal = dir.cross(Vec3::Z).normalize();
            let weights = |_a: f32, b: f32, out: &mut Vec<(u16, f32)>| {
                let base = 1.0 - smoothstep_between(0.0, 0.4, b);
                Self::chain_weights(&chain, vf, out, base);
                out.push((joint(j), 1.0 - base));
            };
            let color = |_a: f32, b: f32| self.fin_color(b);
            Self::sheet(m, grid, normal, 0.0015, &point, &weights, &color);
        }
    }

    fn eyes(&self, m: &mut RiggedMesh) {
        let (ef, eh, r, (stacks, slices)) = self.eye;
        let y = self.bottom.at(ef) + eh * (self.top.at(ef) - self.bottom.at(ef));
        // Sit the eye so it bulges a little out of the flank.
        let x = self.half_width.at(ef) * 0.8;
        for (side, name) in [(1.0f32, "eye_L"), (-1.0, "eye_R")] {
            let centre = Vec3::new(side * x, y, Self::z(ef));
            let axis = Vec3::X * side;
            let base = m.positions.len() as u32;
            // Poles on the eye's own axis (outwards and inwards), rings between.
            for i in 0..=stacks {
                let phi = PI * i as f32 / stacks as f32; // 0 at the outer pole
                for j in 0..slices {
                    let th = TAU * j as f32 / slices as f32;
                    let dir =
                        axis * phi.cos() + (Vec3::Y * th.cos() + Vec3::Z * th.sin()) * phi.sin();
                    let n = dir.normalize();
                    m.positions.push(centre + n * r);
                    m.normals.push(n);
                    let look = n.dot(axis);
                    let rgb = if look > 0.85 {
                        [0.01, 0.01, 0.012]
                    } else if look > 0.6 {
                        [0.35, 0.27, 0.1]
                    } else {
                        [0.5, 0.5, 0.5]
                    };
                    m.colors.push([rgb[0], rgb[1], rgb[2], 1.0]);
                    m.influences
                        .push(Influences::from_pairs(&[(joint(name), 1.0)], 0));
                    if i == 0 || i == stacks {
                        break; // one vertex per pole
                    }
                }
            }
            let ring = |i: usize, j: usize| base + 1 + ((i - 1) * slices + j % slices) as u32;
            let inner = base + 1 + ((stacks - 1) * slices) as u32;
            let flip = side < 0.0;
            let mut tri = |a: u32, b: u32, c: u32| {
                if flip {
                    m.indices.extend([a, c, b]);
                } else {
                    m.indices.extend([a, b, c]);
                }
            };
            for j in 0..slices {
                tri(base, ring(1, j), ring(1, j + 1));
            }
            for i in 1..stacks - 1 {
                for j in 0..slices {
                    let (a, b, c, d) = (
                        ring(i, j),
                        ring(i + 1, j),
                        ring(i + 1, j + 1),
                        ring(i, j + 1),
                    );
                    tri(a, b, c);
                    tri(a, c, d);
                }
            }
            for j in 0..slices {
                tri(inner, ring(stacks - 1, j + 1), ring(stacks - 1, j));
            }
        }
    }

    /// The material of this plan.
    pub fn material(&self) -> MaterialSet {
        let (c, metal, rough) = self.material;
        MaterialSet::pbr(self.name, c, metal, rough)
    }

    /// The finished GLB file.
    pub fn to_glb(&self) -> Vec<u8> {
        self.build()
            .to_glb(&self.material(), "shoal asset (procedural fish generator)")
    }
}

fn joint_slot(name: &str) -> usize {
    match name {
        "dorsal_1" => 0,
        "dorsal_2" => 1,
        _ => 2,
    }
}

/// Writes (joint, weight) pairs for the sheet point (a, b).
type WeightFn<'a> = dyn Fn(f32, f32, &mut Vec<(u16, f32)>) + 'a;

/// A smooth bump: 0 outside [a, b], 1 in the middle.
fn bump(x: f32, a: f32, b: f32) -> f32 {
    if x <= a || x >= b {
        return 0.0;
    }
    let t = (x - a) / (b - a);
    (PI * t).sin().powi(2)
}

/// Smooth weights along a chain of (joint, position) sorted by position: a point between two
/// joints belongs to the earlier one, except within ±`blend`·(shorter neighbouring gap) of a
/// joint, where a smoothstep hands it over. Calls `emit(joint, weight)` with weights summing to 1.
pub fn chain_blend(chain: &[(u16, f32)], x: f32, blend: f32, mut emit: impl FnMut(u16, f32)) {
    if chain.is_empty() {
        return;
    }
    let gap = |k: usize| -> f32 {
        let before = if k > 0 {
            chain[k].1 - chain[k - 1].1
        } else {
            f32::INFINITY
        };
        let after = if k + 1 < chain.len() {
            chain[k + 1].1 - chain[k].1
        } else {
            f32::INFINITY
        };
        let g = before.min(after);
        if g.is_finite() { g * blend } else { 0.0 }
    };
    let mut k = 0;
    while k + 1 < chain.len() && chain[k + 1].1 <= x {
        k += 1;
    }
    // Hand-over zone around joint k (from k−1) or around joint k+1 (to k+1).
    if k > 0 && x < chain[k].1 + gap(k) {
        let h = gap(k);
        let t = smoothstep_between(chain[k].1 - h, chain[k].1 + h, x);
        emit(chain[k - 1].0, 1.0 - t);
        emit(chain[k].0, t);
    } else if k + 1 < chain.len() && x > chain[k + 1].1 - gap(k + 1) {
        let h = gap(k + 1);
        let t = smoothstep_between(chain[k + 1].1 - h, chain[k + 1].1 + h, x);
        emit(chain[k].0, 1.0 - t);
        emit(chain[k + 1].0, t);
    } else if k == 0 && x < chain[0].1 {
        emit(chain[0].0, 1.0);
    } else {
        emit(chain[k].0, 1.0);
    }
}
