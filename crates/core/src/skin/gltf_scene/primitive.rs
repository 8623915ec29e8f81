//! A mesh's primitives: triangles, vertex attributes and skin influences, every accessor
//! checked against the primitive's vertex count.

use std::path::Path;

use gltf::accessor::DataType;
use gltf::mesh::Mode;

use super::{GltfScene, RawAccessor, SceneMesh, ScenePrimitive};
use crate::skin::SkinError;

impl GltfScene {
    pub(super) fn read_meshes(
        &mut self,
        doc: &gltf::Document,
        buffers: &[&[u8]],
    ) -> Result<(), SkinError> {
        for mesh in doc.meshes() {
            let mut out = SceneMesh {
                name: mesh.name().map(str::to_string),
                primitives: Vec::new(),
            };
            for prim in mesh.primitives() {
                if let Some(p) = self.read_primitive(&mesh, &prim, buffers)? {
                    out.primitives.push(p);
                }
            }
            self.meshes.push(out);
        }
        Ok(())
    }

    /// One primitive of `mesh`: its vertex attributes, skin influences and triangle list
    /// (`None`, with a warning, when it is not made of triangles).
    fn read_primitive(
        &mut self,
        mesh: &gltf::Mesh,
        prim: &gltf::Primitive,
        buffers: &[&[u8]],
    ) -> Result<Option<ScenePrimitive>, SkinError> {
        let label = format!("mesh {} primitive {}", mesh.index(), prim.index());
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.warnings.push(format!(
                "{}: {label} is {mode:?}, not triangles; skipped",
                self.path.display()
            ));
            return Ok(None);
        }
        let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
            return Err(self.invalid(format!("{label} has no POSITION")));
        };
        let raw = RawAccessor::new(&pos_acc, buffers, &self.path, &format!("{label} POSITION"))?;
        let positions = raw.vec3s()?;
        let n = positions.len();
        let path = self.path.clone();
        let attrs = Attributes {
            prim,
            buffers,
            path: &path,
            label: &label,
            n,
        };
        let normals = match attrs.get(gltf::Semantic::Normals, "NORMAL")? {
            None => None,
            Some(raw) => Some(raw.vec3s()?),
        };
        let (colors, vertex_colors) = attrs.colors()?;
        let tex_coords = attrs.tex_coords()?;
        let uvs = tex_coords.first().cloned();
        let tangents = attrs.tangents()?;
        let sets = attrs.influence_sets()?;
        let (joints, weights) = if sets.is_empty() {
            (None, None)
        } else {
            let (j, w) = self.merge_influences(&label, &sets, n)?;
            (Some(j), Some(w))
        };
        let indices = attrs.indices()?;
        let indices = self.triangle_list(&label, mode, indices);
        let has_morph_targets = prim.morph_targets().len() > 0;
        Ok(Some(ScenePrimitive {
            index: prim.index(),
            positions,
            normals,
            colors,
            vertex_colors,
            uvs,
            tex_coords,
            tangents,
            joints,
            weights,
            indices,
            has_morph_targets,
            material: prim.material().index(),
        }))
    }

    /// `indices` of a primitive drawn as `mode` as a plain triangle list: strips and fans
    /// unrolled; a list whose length is not a multiple of 3 loses its last indices, with a
    /// warning.
    fn triangle_list(&mut self, label: &str, mode: Mode, mut indices: Vec<u32>) -> Vec<u32> {
        match mode {
            Mode::TriangleStrip => strip_to_list(&indices),
            Mode::TriangleFan => fan_to_list(&indices),
            _ => {
                if !indices.len().is_multiple_of(3) {
                    self.warnings.push(format!(
                        "{}: {label} has {} indices, not a multiple of 3; the last are dropped",
                        self.path.display(),
                        indices.len()
                    ));
                    indices.truncate(indices.len() / 3 * 3);
                }
                indices
            }
        }
    }

    /// Merges JOINTS_n/WEIGHTS_n sets: per vertex, the four strongest influences, renormalized.
    fn merge_influences(
        &mut self,
        label: &str,
        sets: &[(RawAccessor, RawAccessor)],
        n: usize,
    ) -> Result<Influences, SkinError> {
        let mut joints = Vec::with_capacity(n);
        let mut weights = Vec::with_capacity(n);
        let mut num_off = 0usize;
        let mut num_dropped = 0usize;
        let mut num_zero = 0usize;
        let mut worst_sum = 1.0f32;
        for v in 0..n {
            let mut best = [(0u16, 0.0f32); 4];
            let mut sum = 0.0f32;
            for (rj, rw) in sets {
                for k in 0..4 {
                    let w = rw.float(v, k);
                    if !w.is_finite() || w < 0.0 {
                        return Err(rw.error(&format!("vertex {v} has weight {w}")));
                    }
                    sum += w;
                    if w == 0.0 {
                        continue;
                    }
                    let j = rj.uint(v, k);
                    let j = u16::try_from(j)
                        .map_err(|_| rj.error(&format!("vertex {v} joint {j} is too large")))?;
                    // Insert into the four strongest (ties keep the earlier influence).
                    if w > best[3].1 {
                        if best[3].1 > 0.0 {
                            num_dropped += 1;
                        }
                        let mut at = 3;
                        while at > 0 && w > best[at - 1].1 {
                            best[at] = best[at - 1];
                            at -= 1;
                        }
                        best[at] = (j, w);
                    } else {
                        num_dropped += 1;
                    }
                }
            }
            let tolerance = if sets[0].1.data_type == DataType::F32 {
                2e-3
            } else {
                8e-3
            };
            if (sum - 1.0).abs() > tolerance {
                num_off += 1;
                if (sum - 1.0).abs() > (worst_sum - 1.0).abs() {
                    worst_sum = sum;
                }
            }
            let kept: f32 = best.iter().map(|b| b.1).sum();
            if kept <= 0.0 {
                num_zero += 1;
                joints.push([0; 4]);
                weights.push([1.0, 0.0, 0.0, 0.0]);
                continue;
            }
            joints.push([best[0].0, best[1].0, best[2].0, best[3].0]);
            weights.push([
                best[0].1 / kept,
                best[1].1 / kept,
                best[2].1 / kept,
                best[3].1 / kept,
            ]);
        }
        let file = self.path.display().to_string();
        if num_off > 0 {
            self.warnings.push(format!(
                "{file}: {label}: the weights of {num_off} of {n} vertices do not sum to 1 (worst sum {worst_sum}); renormalized"
            ));
        }
        if num_dropped > 0 {
            self.warnings.push(format!(
                "{file}: {label}: {num_dropped} influences beyond the 4 strongest per vertex were dropped; renormalized"
            ));
        }
        if num_zero > 0 {
            self.warnings.push(format!(
                "{file}: {label}: {num_zero} vertices have no weight; bound to the skin's first joint"
            ));
        }
        Ok((joints, weights))
    }
}

/// The vertex attributes of one primitive of `n` vertices (its POSITION count), read with every
/// accessor checked to hold `n` entries; errors name the primitive by `label`.
struct Attributes<'a, 'b> {
    prim: &'a gltf::Primitive<'a>,
    buffers: &'a [&'b [u8]],
    path: &'a Path,
    label: &'a str,
    n: usize,
}

impl<'b> Attributes<'_, 'b> {
    /// The accessor of `semantic` (called `name` in errors), if the primitive has one.
    fn get(
        &self,
        semantic: gltf::Semantic,
        name: &str,
    ) -> Result<Option<RawAccessor<'b>>, SkinError> {
        let Some(acc) = self.prim.get(&semantic) else {
            return Ok(None);
        };
        let raw = self.read(&acc, name)?;
        self.same_count(&raw, name)?;
        Ok(Some(raw))
    }

    fn read(&self, acc: &gltf::Accessor, name: &str) -> Result<RawAccessor<'b>, SkinError> {
        let label = self.label;
        RawAccessor::new(acc, self.buffers, self.path, &format!("{label} {name}"))
    }

    fn same_count(&self, raw: &RawAccessor, name: &str) -> Result<(), SkinError> {
        let n = self.n;
        if raw.count != n {
            return Err(raw.error(&format!(
                "{name} has {} entries for {n} vertices",
                raw.count
            )));
        }
        Ok(())
    }

    /// The material's base colour times COLOR_0 per vertex, and COLOR_0 itself (if present).
    #[allow(clippy::type_complexity)]
    fn colors(&self) -> Result<(Vec<[f32; 4]>, Option<Vec<[f32; 4]>>), SkinError> {
        let n = self.n;
        let base = self
            .prim
            .material()
            .pbr_metallic_roughness()
            .base_color_factor();
        let mut colors = vec![base; n];
        let mut vertex_colors = None;
        if let Some(raw) = self.get(gltf::Semantic::Colors(0), "COLOR_0")? {
            if raw.dims != 3 && raw.dims != 4 {
                return Err(raw.error("must be VEC3 or VEC4"));
            }
            let mut vc = vec![[1.0f32; 4]; n];
            for (i, (c, v)) in colors.iter_mut().zip(vc.iter_mut()).enumerate() {
                for k in 0..raw.dims {
                    v[k] = raw.float(i, k);
                    c[k] *= v[k];
                }
            }
            vertex_colors = Some(vc);
        }
        Ok((colors, vertex_colors))
    }

    /// Every TEXCOORD_n set present from 0 up (a material may use any of them).
    fn tex_coords(&self) -> Result<Vec<Vec<[f32; 2]>>, SkinError> {
        let mut tex_coords: Vec<Vec<[f32; 2]>> = Vec::new();
        loop {
            let name = format!("TEXCOORD_{}", tex_coords.len());
            let semantic = gltf::Semantic::TexCoords(tex_coords.len() as u32);
            let Some(raw) = self.get(semantic, &name)? else {
                break;
            };
            if raw.dims != 2 {
                return Err(raw.error("must be VEC2"));
            }
            tex_coords.push(
                (0..self.n)
                    .map(|i| [raw.float(i, 0), raw.float(i, 1)])
                    .collect(),
            );
        }
        Ok(tex_coords)
    }

    /// TANGENT, if present (VEC4: xyz and the bitangent sign).
    fn tangents(&self) -> Result<Option<Vec<[f32; 4]>>, SkinError> {
        let Some(raw) = self.get(gltf::Semantic::Tangents, "TANGENT")? else {
            return Ok(None);
        };
        if raw.dims != 4 {
            return Err(raw.error("must be VEC4"));
        }
        Ok(Some(
            (0..self.n)
                .map(|i| std::array::from_fn(|k| raw.float(i, k)))
                .collect(),
        ))
    }

    /// Skinning attributes: every JOINTS_n/WEIGHTS_n pair, checked (merged by
    /// `GltfScene::merge_influences`).
    fn influence_sets(&self) -> Result<Vec<(RawAccessor<'b>, RawAccessor<'b>)>, SkinError> {
        let label = self.label;
        let mut sets = Vec::new();
        for set in 0.. {
            let j = self.prim.get(&gltf::Semantic::Joints(set));
            let w = self.prim.get(&gltf::Semantic::Weights(set));
            match (j, w) {
                (None, None) => break,
                (Some(j), Some(w)) => {
                    let rj = self.read(&j, &format!("JOINTS_{set}"))?;
                    let rw = self.read(&w, &format!("WEIGHTS_{set}"))?;
                    self.same_count(&rj, "JOINTS")?;
                    self.same_count(&rw, "WEIGHTS")?;
                    if rj.dims != 4 || !matches!(rj.data_type, DataType::U8 | DataType::U16) {
                        return Err(rj.error("must be VEC4 of UNSIGNED_BYTE or UNSIGNED_SHORT"));
                    }
                    if rw.dims != 4 {
                        return Err(rw.error("must be VEC4"));
                    }
                    sets.push((rj, rw));
                }
                _ => {
                    return Err(SkinError::Invalid {
                        path: self.path.to_path_buf(),
                        problem: format!(
                            "{label} has JOINTS_{set} without WEIGHTS_{set} or the reverse"
                        ),
                    });
                }
            }
        }
        Ok(sets)
    }

    /// The index list as stored (0 … n−1 when there is none), every index checked to be < n.
    fn indices(&self) -> Result<Vec<u32>, SkinError> {
        let n = self.n;
        let Some(acc) = self.prim.indices() else {
            return Ok((0..n as u32).collect());
        };
        let raw = self.read(&acc, "indices")?;
        if raw.dims != 1 || !matches!(raw.data_type, DataType::U8 | DataType::U16 | DataType::U32) {
            return Err(raw.error("must be SCALAR unsigned integers"));
        }
        let mut out = Vec::with_capacity(raw.count);
        for i in 0..raw.count {
            let v = raw.uint(i, 0);
            if v as usize >= n {
                return Err(raw.error(&format!("index {i} is {v}, past the {n} vertices")));
            }
            out.push(v);
        }
        Ok(out)
    }
}

/// Per-vertex joint indices and weights.
type Influences = (Vec<[u16; 4]>, Vec<[f32; 4]>);

fn strip_to_list(strip: &[u32]) -> Vec<u32> {
    let mut out = Vec::new();
    for i in 2..strip.len() {
        if i % 2 == 0 {
            out.extend([strip[i - 2], strip[i - 1], strip[i]]);
        } else {
            out.extend([strip[i - 1], strip[i - 2], strip[i]]);
        }
    }
    out
}

fn fan_to_list(fan: &[u32]) -> Vec<u32> {
    let mut out = Vec::new();
    for i in 2..fan.len() {
        out.extend([fan[i - 1], fan[i], fan[0]]);
    }
    out
}
