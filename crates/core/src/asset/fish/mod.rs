//! The procedural fish generator behind `shoal asset porgy` and `shoal asset eel`.
//!
//! Asset space follows glTF: +Y up, +Z forward (the snout), so +X is the fish's left. The total
//! length (snout to caudal tips) is 1 unit: the snout at z = +0.5, the tail tips at z = −0.5.
//! Positions along the body are fractions `f` of that length from the snout (0) to the tail (1).
//!
//! Every fish has the joints named in [`JOINT_NAMES`] (which `species.rs` owns), with its own
//! number of driven joints: the vertebral chain `root`, `spine_1` … `spine_n`, `tail_end` — n + 1
//! segments bent at the n driven joints (the porgy's 6, the paper's seven segments; the eel's
//! [`crate::species::EEL_DRIVEN_JOINTS`]) — plus `head`, `snout`, `jaw`, eyes, gill covers and
//! fin joints. Joints are unrotated at rest.
//!
//! Everything is plain f32 arithmetic in a fixed order, so the output is byte-identical run to
//! run on the same platform.
//!
//! Files: this one holds the plan ([`FishPlan`], its two species and [`Profile`]s) and the
//! weight helpers; `joints` names and places the joints; `mesh` builds the body, fins and eyes.

use std::f32::consts::PI;

use super::rigged::{MaterialSet, RiggedMesh};
use crate::math::smoothstep_between;
#[cfg(doc)]
use crate::species::JOINT_NAMES;

mod joints;
mod mesh;

/// The root joint's index: the first joint of every generated fish.
const ROOT: u16 = 0;

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
    /// Fractions of length of root, head, and spine_1 … spine_n.
    pub root_f: f32,
    /// Head joint position.
    pub head_f: f32,
    /// Driven joints spine_1 … spine_n, head to tail (at least one).
    pub spine_f: &'static [f32],
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
            spine_f: &[0.30, 0.41, 0.51, 0.60, 0.68, 0.76],
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
    /// start near the front (the paper: the eel's motion centre is towards the front): twelve
    /// ([`crate::species::EEL_DRIVEN_JOINTS`]), so that its envelope is smooth
    /// (docs/motion.md). The first two stay where the six-joint eel had them, on either side of
    /// its pivot (0.2 L): a joint just behind the pivot would sample equation (4)'s near-zero
    /// amplitude there and show a still point. The other ten follow every 1/16 of the length
    /// from 6/16 to 15/16.
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
            spine_f: &[
                0.18, 0.31, 0.375, 0.4375, 0.5, 0.5625, 0.625, 0.6875, 0.75, 0.8125, 0.875, 0.9375,
            ],
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

    /// Builds the mesh and skin.
    pub fn build(&self) -> RiggedMesh {
        let (joint_positions, joint_parents) = self.joints();
        let mut m = RiggedMesh {
            name: self.name.to_string(),
            joint_names: self.joint_names(),
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
