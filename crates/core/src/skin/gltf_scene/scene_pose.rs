//! Posing the scene: node matrices from local transforms, and the skinned, scene-space triangles
//! of every mesh instance.

use glam::{Mat4, Vec3};

use super::{GltfScene, PoseRotations, PosedPrimitive};
use crate::skeleton::JointTransform;
use crate::skin::{LinearBlendSkinningJob, SkinError};

impl GltfScene {
    /// Scene-space (global) matrix of every node from the given local matrices; nodes outside
    /// the hierarchy reachable from a root still get their chain product.
    pub fn globals_from(&self, locals: &[Mat4]) -> Vec<Mat4> {
        let mut globals = vec![Mat4::IDENTITY; self.nodes.len()];
        let mut done = vec![false; self.nodes.len()];
        let mut chain = Vec::new();
        for start in 0..self.nodes.len() {
            chain.clear();
            let mut at = Some(start);
            while let Some(n) = at {
                if done[n] {
                    break;
                }
                chain.push(n);
                at = self.nodes[n].parent;
            }
            let mut m = at.map_or(Mat4::IDENTITY, |n| globals[n]);
            for &n in chain.iter().rev() {
                m *= locals[n];
                globals[n] = m;
                done[n] = true;
            }
        }
        globals
    }

    /// The rest (file) local matrices of all nodes.
    pub fn rest_locals(&self) -> Vec<Mat4> {
        self.nodes.iter().map(|n| n.local_matrix).collect()
    }

    /// Local matrices with the pose's rotations replacing those nodes' rest rotations. Fails if
    /// a pose entry names no node, or its quaternion is not finite or zero.
    pub fn posed_locals(&self, pose: &PoseRotations) -> Result<Vec<Mat4>, SkinError> {
        let mut locals = self.rest_locals();
        for (name, rotation) in pose {
            let len = rotation.length();
            if !len.is_finite() || len < 1e-6 {
                return Err(SkinError::Pose {
                    path: self.path.clone(),
                    problem: format!(
                        "rotation of {name:?} is {rotation:?}, not a usable quaternion"
                    ),
                });
            }
            let mut found = false;
            for (i, node) in self.nodes.iter().enumerate() {
                if node.name.as_deref() == Some(name.as_str()) {
                    let t = JointTransform {
                        rotation: *rotation / len,
                        ..node.local
                    };
                    locals[i] = t.to_mat4();
                    found = true;
                }
            }
            if !found {
                let mut names: Vec<String> = self
                    .skins
                    .iter()
                    .flat_map(|s| s.joints.iter())
                    .filter_map(|&j| self.nodes[j].name.clone())
                    .collect();
                names.sort();
                names.dedup();
                return Err(SkinError::Pose {
                    path: self.path.clone(),
                    problem: format!(
                        "no node is named {name:?}; joint names are: {}",
                        names.join(", ")
                    ),
                });
            }
        }
        Ok(locals)
    }

    /// Mesh nodes of the default scene, depth-first in file order.
    pub fn scene_mesh_nodes(&self) -> Vec<usize> {
        let mut out = Vec::new();
        let mut stack: Vec<usize> = self.scene_roots.iter().rev().copied().collect();
        let mut seen = vec![false; self.nodes.len()];
        while let Some(n) = stack.pop() {
            if std::mem::replace(&mut seen[n], true) {
                continue;
            }
            if self.nodes[n].mesh.is_some() {
                out.push(n);
            }
            stack.extend(self.nodes[n].children.iter().rev());
        }
        out
    }

    /// Skins every primitive of every mesh node of the default scene with the given local node
    /// matrices (see [`Self::posed_locals`]): skinned nodes by equation (1) with palette =
    /// global(joint) · IBM (the node's own transform ignored), others by their global transform.
    pub fn pose_scene(&self, locals: &[Mat4]) -> Result<Vec<PosedPrimitive>, SkinError> {
        let globals = self.globals_from(locals);
        let mut out = Vec::new();
        for node_index in self.scene_mesh_nodes() {
            let node = &self.nodes[node_index];
            let Some(mesh_index) = node.mesh else {
                continue;
            };
            let mesh = self.meshes.get(mesh_index).ok_or_else(|| {
                self.invalid(format!("node {node_index} names missing mesh {mesh_index}"))
            })?;
            let palette: Option<Vec<Mat4>> = match node.skin {
                None => None,
                Some(s) => {
                    let skin = self.skins.get(s).ok_or_else(|| {
                        self.invalid(format!("node {node_index} names missing skin {s}"))
                    })?;
                    Some(
                        skin.joints
                            .iter()
                            .zip(&skin.inverse_bind_matrices)
                            .map(|(&j, ibm)| globals[j] * *ibm)
                            .collect(),
                    )
                }
            };
            for prim in &mesh.primitives {
                let positions: Vec<Vec3> = match (&palette, &prim.joints, &prim.weights) {
                    (Some(palette), Some(joints), Some(weights)) => {
                        let mut pos = vec![Vec3::ZERO; prim.positions.len()];
                        LinearBlendSkinningJob {
                            palette,
                            positions_in: &prim.positions,
                            normals_in: &[],
                            joints,
                            weights,
                            positions_out: &mut pos,
                            normals_out: &mut [],
                        }
                        .run()
                        .map_err(|e| {
                            self.invalid(format!(
                                "node {node_index}, mesh {mesh_index} primitive {}: {e}",
                                prim.index
                            ))
                        })?;
                        pos
                    }
                    (Some(_), _, _) => {
                        return Err(self.invalid(format!(
                            "node {node_index} is skinned but mesh {mesh_index} primitive {} has no JOINTS_0/WEIGHTS_0",
                            prim.index
                        )));
                    }
                    (None, _, _) => prim
                        .positions
                        .iter()
                        .map(|&p| globals[node_index].transform_point3(p))
                        .collect(),
                };
                out.push(PosedPrimitive {
                    node: node_index,
                    node_name: node.name.clone(),
                    mesh: mesh_index,
                    primitive: prim.index,
                    positions: positions.iter().map(|p| p.to_array()).collect(),
                });
            }
        }
        Ok(out)
    }
}
