//! Species data binds motion to a skeleton: which asset a species uses, which joints form its
//! vertebral chain, its motion parameters (Table 1) and its senses and drives.
//!
//! [`SpeciesDesc`] is plain data (serde; the Lua host reads it from `scripts/species/*.lua`).
//! [`SpeciesRig::bind`] resolves it against a loaded [`FishModel`]: the driven joints' positions
//! along the body ([`Body::joints_x`]), their power weights after Fig. 5, the axis each one bends
//! about, and the matrix from asset space to the *body frame* (+x forward, +y up, +z the fish's
//! right, head at the origin, scaled so the body is `motion.l` long). [`SpeciesRig::pose`] turns
//! the motion layer's joint yaws into local joint transforms.
//!
//! Sign convention (from `crates/core/src/motion/mod.rs`): a positive yaw bends the body towards the fish's
//! left — the part of the body behind the joint swings to the left. With +y up and +x forward,
//! the fish's left is −z (heading is counter-clockwise seen from above).

use std::borrow::Cow;

use glam::{Mat3, Mat4, Quat, Vec3};
use serde::{Deserialize, Serialize};

use crate::motion::{Body, FrontWave, MotionParams, PowerProfile};
use crate::skeleton::JointTransform;
use crate::skin::FishModel;

/// The 30 joint names of the generated black porgy (`shoal asset porgy`), in file order: the
/// vertebral chain `root`, `spine_1` … `spine_6`, `tail_end` with the head, eye, gill and fin
/// joints between. The generator (`asset::FishPlan`) writes them; species such as
/// [`SpeciesDesc::black_porgy`] drive them. A generated fish with another number of driven
/// joints (the eel has [`EEL_DRIVEN_JOINTS`]) has the same names with its own chain:
/// [`generated_joint_names`].
pub const JOINT_NAMES: [&str; 30] = [
    "root",
    "head",
    "snout",
    "jaw",
    "eye_L",
    "eye_R",
    "gill_L",
    "gill_R",
    "pectoral_L_1",
    "pectoral_L_2",
    "pectoral_R_1",
    "pectoral_R_2",
    "pelvic_L",
    "pelvic_R",
    "spine_1",
    "dorsal_1",
    "spine_2",
    "dorsal_2",
    "spine_3",
    "dorsal_3",
    "anal_1",
    "spine_4",
    "anal_2",
    "spine_5",
    "spine_6",
    "caudal_upper_1",
    "caudal_upper_2",
    "caudal_lower_1",
    "caudal_lower_2",
    "tail_end",
];

/// The six driven vertebral joints of the generated black porgy, head to tail (each one of
/// [`JOINT_NAMES`]).
pub const DRIVEN_JOINTS: [&str; 6] = [
    "spine_1", "spine_2", "spine_3", "spine_4", "spine_5", "spine_6",
];

/// The driven vertebral joints of the generated eel (`shoal asset eel`): `spine_1` …
/// `spine_12`. Eels have about a hundred vertebrae; six rigid segments 0.13 L long showed as dips
/// of up to a quarter of the amplitude between joints, since a straight segment between two
/// joints that swing out of phase moves less in its middle than at its ends (docs/motion.md).
pub const EEL_DRIVEN_JOINTS: usize = 12;

/// The driven joints `spine_1` … `spine_n`, head to tail.
pub fn spine_names(n: usize) -> Vec<String> {
    (1..=n).map(spine_name).collect()
}

/// The chain joint `spine_k`.
pub fn spine_name(k: usize) -> String {
    format!("spine_{k}")
}

/// `k` for the chain joint `spine_k`.
pub fn spine_number(name: &str) -> Option<usize> {
    name.strip_prefix("spine_")?.parse().ok()
}

/// The joint names of a generated fish with `num_spines` driven joints, in file order:
/// [`JOINT_NAMES`] with `spine_1` … `spine_n` as its chain (`spine_7` … follow `spine_6`).
/// Six gives [`JOINT_NAMES`] exactly.
pub fn generated_joint_names(num_spines: usize) -> impl Iterator<Item = Cow<'static, str>> {
    JOINT_NAMES.iter().flat_map(move |&name| {
        let keep = spine_number(name).is_none_or(|k| k <= num_spines);
        // After spine_6, the spines beyond it.
        let more = if name == "spine_6" {
            num_spines.saturating_sub(6)
        } else {
            0
        };
        keep.then_some(Cow::Borrowed(name))
            .into_iter()
            .chain((7..7 + more).map(|k| Cow::Owned(spine_name(k))))
    })
}

/// Drives that the behaviour scripts read and update (all rates per second).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Drives {
    /// How fast hunger rises, in [0, 1] units per second.
    pub hunger_per_s: f32,
    /// How much hunger one food item removes, in [0, 1] units.
    pub satiation_per_food: f32,
    /// How fast fear decays, in [0, 1] units per second.
    pub fear_decay_per_s: f32,
    /// Preference for staying near its own species, in [0, 1].
    pub sociability: f32,
}

impl Default for Drives {
    fn default() -> Self {
        Self {
            hunger_per_s: 0.01,
            satiation_per_food: 0.4,
            fear_decay_per_s: 0.2,
            sociability: 0.5,
        }
    }
}

fn default_view_range() -> f32 {
    200.0
}
fn default_view_angle_deg() -> f32 {
    300.0
}
fn default_max_speed() -> f32 {
    100.0
}

/// A species: asset, vertebral chain, motion parameters, senses and drives.
///
/// Lengths are world units, in which the body is `motion.l` long.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpeciesDesc {
    /// Species name (unique in a scene).
    pub name: String,
    /// The skinned model, a path relative to the repository's `assets/` directory.
    pub asset: String,
    /// The driven vertebral joints, head to tail (joint node names in the asset).
    pub vertebral_joints: Vec<String>,
    /// Motion parameters (pivot p, speed s, body length l, …). `l` also sets the fish's size
    /// in the world: the model is scaled so its body (snout to tail tip) is `l` long.
    pub motion: MotionParams,
    /// How strongly each driven joint bends along the body: `"fig5"` (the paper's black porgy,
    /// the default) or `"uniform"` (anguilliform swimmers; docs/motion.md).
    #[serde(default)]
    pub power_profile: PowerProfile,
    /// How far the fish sees, world units.
    #[serde(default = "default_view_range")]
    pub view_range: f32,
    /// Total angle of its field of view, degrees (centred on the heading).
    #[serde(default = "default_view_angle_deg")]
    pub view_angle_deg: f32,
    /// Top speed, world units per second.
    #[serde(default = "default_max_speed")]
    pub max_speed: f32,
    /// Whether other species see this one as a predator (their vision reports its fish as
    /// `PerceptKind::Predator`).
    #[serde(default)]
    pub predator: bool,
    /// Optional linear RGB multiplier on the asset's colours.
    #[serde(default)]
    pub color_tint: Option<[f32; 3]>,
    /// Draw the model's alpha as a mask cut at this value in (0, 1], instead of the file's
    /// `alphaMode`/`alphaCutoff` (for a model whose fins a cutoff of 1.0 cuts to ribbons).
    #[serde(default)]
    pub alpha_cutoff: Option<f32>,
    /// Hunger and other drives.
    #[serde(default)]
    pub drives: Drives,
}

/// Why a species description is invalid or does not fit its model.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SpeciesError {
    /// A named vertebral joint is not in the model.
    #[error("species {species:?}: joint {joint:?} is not in the model; its joints are: {}", available.join(", "))]
    MissingJoint {
        /// Species name.
        species: String,
        /// The joint asked for.
        joint: String,
        /// Every joint name the model has.
        available: Vec<String>,
    },
    /// A joint is listed twice.
    #[error("species {species:?}: joint {joint:?} is listed twice in vertebral_joints")]
    DuplicateJoint {
        /// Species name.
        species: String,
        /// The joint.
        joint: String,
    },
    /// The vertebral joints are not strictly head to tail inside the body.
    #[error(
        "species {species:?}: vertebral joint {joint:?} sits at {x} of the body length (head 0, tail 1), {why}"
    )]
    JointOrder {
        /// Species name.
        species: String,
        /// The joint.
        joint: String,
        /// Its position as a fraction of body length.
        x: f32,
        /// What is wrong.
        why: String,
    },
    /// A field has a value that cannot work.
    #[error("species {species:?}: {field} = {value}: {why}")]
    InvalidField {
        /// Species name.
        species: String,
        /// The field.
        field: &'static str,
        /// Its value.
        value: f32,
        /// Why it is rejected.
        why: &'static str,
    },
    /// Structural problems (no joints, empty mesh, …).
    #[error("species {species:?}: {why}")]
    Invalid {
        /// Species name.
        species: String,
        /// What is wrong.
        why: String,
    },
}

impl SpeciesDesc {
    /// The black porgy: the paper's fish (l = 50, swimming like a carangiform fish:
    /// [`MotionParams::BLACK_PORGY`]) on `assets/black_porgy.glb`, driven at `spine_1` …
    /// `spine_6`.
    pub fn black_porgy() -> Self {
        Self {
            name: "black_porgy".into(),
            asset: "black_porgy.glb".into(),
            vertebral_joints: DRIVEN_JOINTS.iter().map(|s| s.to_string()).collect(),
            // The motion layer's black porgy defaults, written once there.
            motion: MotionParams::BLACK_PORGY,
            power_profile: PowerProfile::Fig5,
            view_range: 250.0,
            view_angle_deg: 300.0,
            max_speed: 120.0,
            predator: false,
            color_tint: None,
            alpha_cutoff: None,
            drives: Drives::default(),
        }
    }

    /// An eel-like fish on `assets/eel.glb`, swimming like an anguilliform fish (docs/motion.md):
    /// long, slender, driven at its [`EEL_DRIVEN_JOINTS`] joints `spine_1` … `spine_12`, its
    /// motion centre towards the front (pivot p = 0.2, Table 1 Ex3's pivot, just behind the
    /// first driven joint of `eel.glb`, which is also where it turns about), the
    /// front wave travelling from the snout at 0.035 L in step with the body wave behind the pivot
    /// (the whole body undulates, no still point), a body wave shorter than the body (λ = 0.7·l,
    /// more than one wave on the body), every joint bending with the same weight, ω = 6 so the
    /// tail beats at s·p·ω/λ ≈ 1.7 Hz per body length per second (Strouhal number about 0.3),
    /// and a slower cruise.
    pub fn eel() -> Self {
        Self {
            name: "eel".into(),
            asset: "eel.glb".into(),
            vertebral_joints: spine_names(EEL_DRIVEN_JOINTS),
            motion: MotionParams {
                p: 0.2,
                s: 30.0,
                l: 70.0,
                max_amp: 70.0 * 0.107,
                lambda: 0.7 * 70.0,
                omega: 7.0,
                tt: 2.5,
                f: 1.0,
                turn_angle: std::f32::consts::FRAC_PI_2,
                turn_axis: None,
                front_amp: 0.01,
                front_wave: FrontWave::Anguilliform,
            },
            power_profile: PowerProfile::Uniform,
            view_range: 180.0,
            view_angle_deg: 280.0,
            max_speed: 70.0,
            predator: false,
            color_tint: None,
            alpha_cutoff: None,
            drives: Drives {
                sociability: 0.1,
                ..Drives::default()
            },
        }
    }

    /// Checks the fields this module relies on: a name, at least one vertebral joint, a finite
    /// positive body length, non-negative view range and speed, a view angle in (0, 360].
    /// (Motion parameters are checked in full by the motion layer.)
    pub fn validate(&self) -> Result<(), SpeciesError> {
        let bad = |field, value, why| SpeciesError::InvalidField {
            species: self.name.clone(),
            field,
            value,
            why,
        };
        if self.name.trim().is_empty() {
            return Err(SpeciesError::Invalid {
                species: self.name.clone(),
                why: "the name is empty".into(),
            });
        }
        if self.vertebral_joints.is_empty() {
            return Err(SpeciesError::Invalid {
                species: self.name.clone(),
                why: "vertebral_joints is empty; name the driven joints head to tail".into(),
            });
        }
        let l = self.motion.l;
        if !(l.is_finite() && l > 0.0) {
            return Err(bad(
                "motion.l",
                l,
                "the body length must be a positive number",
            ));
        }
        if !(self.view_range.is_finite() && self.view_range >= 0.0) {
            return Err(bad(
                "view_range",
                self.view_range,
                "must be a non-negative number",
            ));
        }
        if !(self.view_angle_deg > 0.0 && self.view_angle_deg <= 360.0) {
            return Err(bad(
                "view_angle_deg",
                self.view_angle_deg,
                "must lie in (0, 360]",
            ));
        }
        if !(self.max_speed.is_finite() && self.max_speed >= 0.0) {
            return Err(bad(
                "max_speed",
                self.max_speed,
                "must be a non-negative number",
            ));
        }
        if let Some(c) = self.alpha_cutoff
            && !(c > 0.0 && c <= 1.0)
        {
            return Err(bad("alpha_cutoff", c, "must lie in (0, 1]"));
        }
        if let Some(t) = self.color_tint {
            for c in t {
                if !(c.is_finite() && c >= 0.0) {
                    return Err(bad(
                        "color_tint",
                        c,
                        "components must be non-negative numbers",
                    ));
                }
            }
        }
        Ok(())
    }
}

/// A species bound to its model: everything the per-frame pose needs, precomputed.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeciesRig {
    /// The vertebral body the motion layer drives.
    pub body: Body,
    /// Skeleton index of each driven joint, head to tail.
    pub driven_joints: Vec<usize>,
    /// Per driven joint, the unit axis in the joint's local space about which a positive yaw
    /// rotates it: the body's ventral direction (−dorsal), so a positive yaw swings the part
    /// behind the joint to the fish's left.
    pub bend_axes: Vec<Vec3>,
    /// Asset (model) space → body frame: +x forward, +y up, +z right, the head (snout tip) at the
    /// origin, scaled so the body is `motion.l` long.
    pub model_to_body: Mat4,
    /// Body length in asset units (snout to tail tip along the long axis).
    pub model_body_length: f32,
    /// Unit forward (tail → head), dorsal and left directions in asset space.
    pub model_forward: Vec3,
    /// Unit dorsal direction in asset space.
    pub model_up: Vec3,
    /// Rest local transforms of every joint (copied by [`Self::pose`]).
    pub rest_locals: Vec<JointTransform>,
}

/// Slices of the body along its long axis for its mass model ([`crate::motion::body::mass_shares`]).
const MASS_SLICES: usize = 48;

/// The body's extent across (along `forward × up`) and up (along `up`) in [`MASS_SLICES`] equal
/// slices from the snout (`head_t` along `forward`) to the tail tip, asset units; (0, 0) for a
/// slice no vertex falls in.
fn cross_sections(
    positions: &[Vec3],
    forward: Vec3,
    up: Vec3,
    head_t: f32,
    length: f32,
) -> Vec<(f32, f32)> {
    let right = forward.cross(up);
    let mut bounds = [[
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
    ]; MASS_SLICES];
    for p in positions {
        let x = (head_t - p.dot(forward)) / length;
        if !x.is_finite() {
            continue;
        }
        let slice = ((x * MASS_SLICES as f32) as usize).min(MASS_SLICES - 1);
        let b = &mut bounds[slice];
        let (across, height) = (p.dot(right), p.dot(up));
        b[0] = b[0].min(across);
        b[1] = b[1].max(across);
        b[2] = b[2].min(height);
        b[3] = b[3].max(height);
    }
    bounds
        .iter()
        .map(|b| {
            if b[1] >= b[0] {
                (b[1] - b[0], b[3] - b[2])
            } else {
                (0.0, 0.0)
            }
        })
        .collect()
}

impl SpeciesRig {
    /// Binds `desc` to `model`.
    ///
    /// - Resolves `vertebral_joints` (an unknown name is an error listing the model's joints).
    /// - Long axis: the principal axis of the bind-shape vertices, snapped to an asset axis when
    ///   within 15° of one, oriented tail → head so that the first driven joint is nearer the
    ///   head than the last (one driven joint: its parent is towards the head). Joints listed
    ///   tail to head (each an ancestor of the one before) are an error.
    /// - Dorsal axis: asset +Y (glTF's up) made perpendicular to the long axis; when the long
    ///   axis is within ~17° of vertical, the perpendicular direction of larger vertex spread.
    /// - `joints_x`: each driven joint's distance from the snout along the long axis over the
    ///   body length (snout to tail tip), strictly increasing inside (0, 1), then 1.0.
    /// - `mass`: each segment's share of the body's mass, from the bind-shape vertices'
    ///   cross-sections along the long axis (uniform density), for the body's sideways recoil.
    pub fn bind(desc: &SpeciesDesc, model: &FishModel) -> Result<SpeciesRig, SpeciesError> {
        desc.validate()?;
        let species = desc.name.clone();
        let invalid = |why: String| SpeciesError::Invalid {
            species: species.clone(),
            why,
        };
        let skeleton = &model.skeleton;
        let mut driven = Vec::with_capacity(desc.vertebral_joints.len());
        for name in &desc.vertebral_joints {
            let Some(j) = skeleton.find(name) else {
                return Err(SpeciesError::MissingJoint {
                    species: species.clone(),
                    joint: name.clone(),
                    available: skeleton.names().to_vec(),
                });
            };
            if driven.contains(&j) {
                return Err(SpeciesError::DuplicateJoint {
                    species: species.clone(),
                    joint: name.clone(),
                });
            }
            driven.push(j);
        }
        let positions = &model.mesh.positions;
        if positions.len() < 4 {
            return Err(invalid("the model has fewer than 4 vertices".into()));
        }
        let centroid = positions.iter().copied().sum::<Vec3>() / positions.len() as f32;
        let joint_pos = |j: usize| skeleton.rest_models()[j].w_axis.truncate();
        let mut forward = snap_to_asset_axis(crate::math::principal_axis(positions, centroid));
        // Orient tail → head. The chain's hierarchy says which end is the head: each listed
        // joint should descend from the one before it.
        let descends = |child: usize, ancestor: usize| {
            let mut at = child;
            while skeleton.parents()[at] != crate::skeleton::NO_PARENT {
                at = usize::from(skeleton.parents()[at]);
                if at == ancestor {
                    return true;
                }
            }
            false
        };
        let pairs = driven.windows(2);
        if driven.len() > 1 && pairs.clone().all(|w| descends(w[0], w[1])) {
            return Err(SpeciesError::JointOrder {
                species: species.clone(),
                joint: desc.vertebral_joints[0].clone(),
                x: f32::NAN,
                why: "is a descendant of the joints listed after it; list them head to tail".into(),
            });
        }
        let first = joint_pos(driven[0]);
        let last = if driven.len() > 1 {
            joint_pos(driven[driven.len() - 1])
        } else {
            // One driven joint: its parent is towards the head.
            let p = skeleton.parents()[driven[0]];
            let parent = if p == crate::skeleton::NO_PARENT {
                driven[0]
            } else {
                usize::from(p)
            };
            2.0 * first - joint_pos(parent)
        };
        if (first - last).dot(forward) < 0.0 {
            forward = -forward;
        }
        let up = {
            let y = Vec3::Y - forward * forward.y;
            if y.length() > 0.3 {
                y.normalize()
            } else {
                perpendicular_spread_axis(positions, centroid, forward)
            }
        };
        let right = forward.cross(up);
        let (mut head_t, mut tail_t) = (f32::NEG_INFINITY, f32::INFINITY);
        for p in positions {
            let t = p.dot(forward);
            head_t = head_t.max(t);
            tail_t = tail_t.min(t);
        }
        let length = head_t - tail_t;
        if !(length.is_finite() && length > 1e-9) {
            return Err(invalid("the model's body has no length".into()));
        }
        let mut joints_x = Vec::with_capacity(driven.len() + 1);
        for (k, &j) in driven.iter().enumerate() {
            let x = (head_t - joint_pos(j).dot(forward)) / length;
            let why = if !(x > 0.0 && x < 1.0) {
                Some("outside the body (0, 1)".to_string())
            } else if k > 0 && x <= joints_x[k - 1] {
                Some(format!(
                    "not behind the previous joint {:?} (at {}); list them head to tail",
                    desc.vertebral_joints[k - 1],
                    joints_x[k - 1]
                ))
            } else {
                None
            };
            if let Some(why) = why {
                return Err(SpeciesError::JointOrder {
                    species: species.clone(),
                    joint: desc.vertebral_joints[k].clone(),
                    x,
                    why,
                });
            }
            joints_x.push(x);
        }
        joints_x.push(1.0);
        let sections = cross_sections(positions, forward, up, head_t, length);
        let mass = crate::motion::body::mass_shares(&joints_x, &sections);
        let power = joints_x[..driven.len()]
            .iter()
            .map(|&x| desc.power_profile.weight(x))
            .collect();

        // Bend axes in each driven joint's local frame: ventral direction through the inverse of
        // the joint's rest model 3×3.
        let bend_axes = driven
            .iter()
            .map(|&j| {
                let m = Mat3::from_mat4(skeleton.rest_models()[j]);
                let local = m.inverse() * (-up);
                local.normalize_or(-Vec3::Y)
            })
            .collect();

        // Head point: the snout extreme along the long axis, on the first driven joint's line.
        let head_point = forward * head_t + up * first.dot(up) + right * first.dot(right);
        let scale = desc.motion.l / length;
        let rotation = Mat4::from_mat3(Mat3::from_cols(forward, up, right).transpose());
        let model_to_body =
            Mat4::from_scale(Vec3::splat(scale)) * rotation * Mat4::from_translation(-head_point);
        Ok(SpeciesRig {
            body: Body {
                joints_x,
                power,
                mass,
            },
            driven_joints: driven,
            bend_axes,
            model_to_body,
            model_body_length: length,
            model_forward: forward,
            model_up: up,
            rest_locals: skeleton.rest_locals().to_vec(),
        })
    }

    /// Number of driven joints (the length of `yaw` in [`Self::pose`]).
    pub fn num_driven(&self) -> usize {
        self.driven_joints.len()
    }

    /// Writes every joint's rest local transform into `locals`, then rotates each driven joint
    /// by its yaw (radians, positive = bend towards the fish's left) about its bend axis.
    ///
    /// `locals` has one entry per skeleton joint and `yaw` one per driven joint; extra entries
    /// are left alone and missing ones count as 0 (rest). A non-finite yaw counts as 0.
    /// Never allocates.
    pub fn pose(&self, yaw: &[f32], locals: &mut [JointTransform]) {
        let n = locals.len().min(self.rest_locals.len());
        locals[..n].copy_from_slice(&self.rest_locals[..n]);
        for ((&j, axis), &angle) in self.driven_joints.iter().zip(&self.bend_axes).zip(yaw) {
            if j >= n || !angle.is_finite() {
                continue;
            }
            let rest = self.rest_locals[j].rotation;
            locals[j].rotation = (rest * Quat::from_axis_angle(*axis, angle)).normalize();
        }
    }
}

/// Asset files are usually modelled along a coordinate axis; a principal axis within 15° of
/// one (tilted by fins or an asymmetric profile) is taken to mean that axis exactly.
pub(crate) fn snap_to_asset_axis(axis: Vec3) -> Vec3 {
    let cos_15 = 15f32.to_radians().cos();
    for a in [Vec3::X, Vec3::Y, Vec3::Z] {
        let d = axis.dot(a);
        if d.abs() >= cos_15 {
            return a * d.signum();
        }
    }
    axis
}

/// The direction perpendicular to `axis` along which the points spread most.
fn perpendicular_spread_axis(points: &[Vec3], centroid: Vec3, axis: Vec3) -> Vec3 {
    let helper = if axis.x.abs() < 0.9 { Vec3::X } else { Vec3::Z };
    let u = (helper - axis * helper.dot(axis)).normalize();
    let w = axis.cross(u);
    let (mut su, mut sw, mut suw) = (0.0f64, 0.0f64, 0.0f64);
    for p in points {
        let d = *p - centroid;
        let (a, b) = (f64::from(d.dot(u)), f64::from(d.dot(w)));
        su += a * a;
        sw += b * b;
        suw += a * b;
    }
    // Principal direction of the 2×2 covariance.
    let angle = 0.5 * (2.0 * suw).atan2(su - sw);
    (u * angle.cos() as f32 + w * angle.sin() as f32).normalize_or(u)
}
