//! The generated fish's surfaces: the body, the median, caudal, paired fins and the eyes, each
//! with its skin weights and vertex colours.

use std::f32::consts::{PI, TAU};

use glam::Vec3;

use super::{FishPlan, MedianFin, ROOT, WeightFn, bump, chain_blend, joint_slot};
use crate::asset::rigged::{Influences, RiggedMesh};
use crate::math::smoothstep_between;

impl FishPlan {
    /// Smooth weights along a chain of (joint, f) sorted by f: one joint inside a segment,
    /// smoothstep blends across each joint over ±35% of the shorter neighbouring segment.
    pub(super) fn chain_weights(
        chain: &[(u16, f32)],
        f: f32,
        out: &mut Vec<(u16, f32)>,
        scale: f32,
    ) {
        chain_blend(chain, f, 0.35, |j, w| out.push((j, w * scale)));
    }

    pub(super) fn body_color(&self, f: f32, c: f32) -> [f32; 4] {
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

    pub(super) fn body(&self, m: &mut RiggedMesh) {
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
            &[(self.joint("snout"), 0.3), (self.joint("head"), 0.7)],
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
                pairs.push((self.joint("jaw"), jaw));
                pairs.push((self.joint(if s > 0.0 { "gill_L" } else { "gill_R" }), gill));
                m.influences.push(Influences::from_pairs(&pairs, ROOT));
            }
        }
        // Tail cap centre.
        let fe = self.body_end;
        m.positions.push(Vec3::new(0.0, self.mid(fe), Self::z(fe)));
        m.colors.push(self.body_color(fe, 0.0));
        m.influences
            .push(Influences::from_pairs(&[(self.last_spine(), 1.0)], 0));
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
    pub(super) fn sheet(
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
                    m.influences.push(Influences::from_pairs(&pairs, ROOT));
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

    pub(super) fn fin_color(&self, b: f32) -> [f32; 4] {
        let k = 1.0 + 0.6 * (1.0 - b);
        [self.fin[0] * k, self.fin[1] * k, self.fin[2] * k, 1.0]
    }

    pub(super) fn median_fin(&self, m: &mut RiggedMesh, fin: &MedianFin, dorsal: bool) {
        let chain = self.chain();
        let fin_joints: Vec<(u16, f32)> = if dorsal {
            ["dorsal_1", "dorsal_2", "dorsal_3"]
                .iter()
                .map(|n| {
                    (
                        self.joint(n),
                        fin.start + [0.15, 0.5, 0.85][joint_slot(n)] * (fin.end - fin.start),
                    )
                })
                .collect()
        } else {
            vec![
                (
                    self.joint("anal_1"),
                    fin.start + 0.2 * (fin.end - fin.start),
                ),
                (
                    self.joint("anal_2"),
                    fin.start + 0.75 * (fin.end - fin.start),
                ),
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

    pub(super) fn caudal(&self, m: &mut RiggedMesh) {
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
            out.push((self.last_spine(), body));
            out.push((self.joint("caudal_upper_1"), fin * upper * (1.0 - outer)));
            out.push((self.joint("caudal_upper_2"), fin * upper * outer));
            out.push((
                self.joint("caudal_lower_1"),
                fin * (1.0 - upper) * (1.0 - outer),
            ));
            out.push((self.joint("caudal_lower_2"), fin * (1.0 - upper) * outer));
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

    pub(super) fn pectorals(&self, m: &mut RiggedMesh) {
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
                out.push((self.joint(j1), (1.0 - base) * (1.0 - outer)));
                out.push((self.joint(j2), (1.0 - base) * outer));
            };
            let color = |_a: f32, b: f32| self.fin_color(b);
            Self::sheet(m, grid, normal, 0.0015, &point, &weights, &color);
        }
    }

    pub(super) fn pelvics(&self, m: &mut RiggedMesh) {
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
                out.push((self.joint(j), 1.0 - base));
            };
            let color = |_a: f32, b: f32| self.fin_color(b);
            Self::sheet(m, grid, normal, 0.0015, &point, &weights, &color);
        }
    }

    pub(super) fn eyes(&self, m: &mut RiggedMesh) {
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
                        .push(Influences::from_pairs(&[(self.joint(name), 1.0)], 0));
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
}
