//! `shoal asset species`: a species script suggested from a rigged model's shape, the last step
//! of bringing your own fish (rig → species → scene).
//!
//! The body's slenderness (length over its largest cross-section extent, depth or width) picks
//! where between the two built-in swimmers the motion parameters sit:
//! - slender (ratio ≥ [`ANGUILLIFORM_RATIO`], an eel's ≈ 12): anguilliform like the built-in eel
//!   — pivot near the head (p = 0.2), a wave running from the snout, a short body wave
//!   (λ = 0.7 l), a slower cruise;
//! - deep (ratio ≤ [`CARANGIFORM_RATIO`], a porgy's ≈ 2): carangiform like the black porgy
//!   (p = 0.3, turning about 0.4, λ = 1.2 l, maxAmp = 0.16 l, cruising at a body length per
//!   second);
//! - in between: linearly interpolated.
//!
//! The suggestion is a starting point for a designer, printed with the measured ratio.

use std::path::Path;

use crate::motion::MotionParams;
use crate::skin::FishModel;
use crate::species::{SpeciesDesc, SpeciesError, SpeciesRig};

/// Length / cross-section ratio at and above which the body is treated as eel-like.
pub const ANGUILLIFORM_RATIO: f32 = 8.0;
/// Length / cross-section ratio at and below which the body is treated as porgy-like.
pub const CARANGIFORM_RATIO: f32 = 4.0;

/// What `shoal asset species` suggests for a model.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeciesSuggestion {
    /// The species description (name, asset, joints, motion; senses from the nearer built-in).
    pub desc: SpeciesDesc,
    /// Which built-in species the file is based on (`"eel"` or `"black_porgy"`).
    pub base: &'static str,
    /// Body length over its largest cross-section extent, model units.
    pub slenderness: f32,
    /// 0 = carangiform (deep) … 1 = anguilliform (slender).
    pub eel_likeness: f32,
    /// "anguilliform-like", "carangiform" or "subcarangiform".
    pub swimming_mode: &'static str,
}

/// Why no species could be suggested for a model.
#[derive(Debug, thiserror::Error)]
pub enum SuggestError {
    /// The model has no `spine_*` joints: it was not rigged by `shoal asset rig`.
    #[error(
        "the model has no joints named spine_1, spine_2, …; rig it first with `shoal asset rig`"
    )]
    NotRigged,
    /// The suggested description does not bind to the model.
    #[error(transparent)]
    Bind(#[from] SpeciesError),
}

/// The model's `spine_<n>` joints (as `shoal asset rig` names them), in order of `n`: the
/// driven joints, head to tail.
pub fn spine_joints(model: &FishModel) -> Vec<String> {
    let mut spines: Vec<(u32, String)> = model
        .skeleton
        .names()
        .iter()
        .filter_map(|n| Some((n.strip_prefix("spine_")?.parse().ok()?, n.clone())))
        .collect();
    spines.sort();
    spines.into_iter().map(|(_, n)| n).collect()
}

/// Suggests a species for `model`. `asset` is the path the file will name (relative to the
/// assets folder). Fails when the model has no `spine_*` joints (it was not rigged by
/// `shoal asset rig`) or its rig cannot be bound.
pub fn suggest(
    name: &str,
    asset: &str,
    model: &FishModel,
) -> Result<SpeciesSuggestion, SuggestError> {
    let spines = spine_joints(model);
    if spines.is_empty() {
        return Err(SuggestError::NotRigged);
    }
    let mut desc = SpeciesDesc::black_porgy();
    desc.name = name.to_string();
    desc.asset = asset.to_string();
    desc.vertebral_joints = spines;
    let rig = SpeciesRig::bind(&desc, model)?;
    // Cross-section: the largest extent across the body (up, and sideways).
    let side = rig.model_forward.cross(rig.model_up).normalize_or_zero();
    let extent = |axis: glam::Vec3| {
        let (lo, hi) = model
            .mesh
            .positions
            .iter()
            .map(|p| p.dot(axis))
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), t| {
                (a.min(t), b.max(t))
            });
        (hi - lo).max(0.0)
    };
    let across = extent(rig.model_up).max(extent(side)).max(1e-6);
    let slenderness = rig.model_body_length / across;
    let t = ((slenderness - CARANGIFORM_RATIO) / (ANGUILLIFORM_RATIO - CARANGIFORM_RATIO))
        .clamp(0.0, 1.0);
    let lerp = |a: f32, b: f32| a + (b - a) * t;
    let porgy = MotionParams::BLACK_PORGY;
    let eel = SpeciesDesc::eel();
    // Body length in world units: a porgy is 50, an eel 70.
    let l = lerp(porgy.l, eel.motion.l).round();
    desc.motion = MotionParams {
        p: lerp(porgy.p, eel.motion.p),
        s: (lerp(porgy.s / porgy.l, eel.motion.s / eel.motion.l) * l).round(),
        l,
        max_amp: l * lerp(porgy.max_amp / porgy.l, eel.motion.max_amp / eel.motion.l),
        lambda: (lerp(porgy.lambda / porgy.l, eel.motion.lambda / eel.motion.l) * l).round(),
        omega: lerp(porgy.omega, eel.motion.omega),
        tt: lerp(porgy.tt, eel.motion.tt),
        f: 1.0,
        turn_angle: porgy.turn_angle,
        turn_axis: Some(lerp(
            porgy.turn_axis_fraction(),
            eel.motion.turn_axis_fraction(),
        )),
        front_amp: lerp(porgy.front_amp, eel.motion.front_amp),
        // The eel's wave runs from the snout; the porgy's front recoils about the pivot.
        front_wave: if t >= 0.5 {
            eel.motion.front_wave
        } else {
            porgy.front_wave
        },
    };
    let base_desc = if t >= 0.5 {
        eel.clone()
    } else {
        SpeciesDesc::black_porgy()
    };
    desc.view_range = base_desc.view_range;
    desc.view_angle_deg = base_desc.view_angle_deg;
    // Top speed per body length: the porgy's 120 / 50, the eel's 70 / 70.
    let porgy_top = SpeciesDesc::black_porgy().max_speed / porgy.l;
    desc.max_speed = (lerp(porgy_top, eel.max_speed / eel.motion.l) * l).round();
    desc.drives = base_desc.drives;
    // A mask cut at (nearly) 1.0 keeps only texels whose filtered alpha is exactly opaque: fins
    // drawn with filtering come out in ribbons and body edges speckle. Suggest glTF's default.
    if model
        .mesh
        .materials
        .iter()
        .any(|m| matches!(m.alpha_mode, crate::skin::AlphaMode::Mask { cutoff } if cutoff > 0.99))
    {
        desc.alpha_cutoff = Some(0.5);
    }
    let swimming_mode = if t >= 0.75 {
        "anguilliform-like"
    } else if t <= 0.25 {
        "carangiform"
    } else {
        "subcarangiform"
    };
    Ok(SpeciesSuggestion {
        desc,
        base: if t >= 0.5 { "eel" } else { "black_porgy" },
        slenderness,
        eel_likeness: t,
        swimming_mode,
    })
}

impl SpeciesSuggestion {
    /// The species script (Lua), commented for a designer.
    pub fn to_lua(&self, model: &Path) -> String {
        let d = &self.desc;
        let m = &d.motion;
        let joints: Vec<String> = d
            .vertebral_joints
            .iter()
            .map(|j| format!("{j:?}"))
            .collect();
        format!(
            "-- {name}: made by `shoal asset species` from {model}.\n\
             -- Its body is {ratio:.1} times as long as it is deep or wide, so it swims {mode}\n\
             -- (between the deep black porgy, ratio ≈ 2, and the slender eel, ≈ 12). Every value\n\
             -- is a suggestion: edit and save, and live fish pick it up.\n\
             ---@type shoal.SpeciesFile\n\
             local species = {{\n  \
               base = {base:?},             -- senses and drives of the nearer built-in species\n  \
               name = {name:?},\n  \
               asset = {asset:?},   -- relative to assets/\n  \
               vertebral_joints = {{ {joints} }},  -- driven joints, head to tail\n  \
               motion = {{\n    \
                 l = {l},                 -- body length, world units (the model is scaled to it)\n    \
                 p = {p:.2},               -- swim wave's pivot (its quietest point), fraction of l from the head\n    \
                 turn_axis = {axis:.2},       -- where it turns about, fraction of l from the head\n    \
                 front_amp = {front_amp:.3},      -- snout amplitude of the front wave, fraction of l\n    \
                 front_wave = {front_wave:?}, -- \"recoil\" (carangiform head yaw), \"travelling\" or \"anguilliform\" (whole-body envelope, docs/motion.md)\n    \
                 s = {s},                 -- cruising speed, units/s\n    \
                 max_amp = {amp:.2},        -- amplitude scale of the body wave, units\n    \
                 lambda = {lambda},            -- body wave length, units\n    \
                 omega = {omega:.2},           -- base frequency of the body wave (docs/motion.md)\n    \
                 tt = {tt:.2},              -- turning time, s\n  \
               }},\n  \
               max_speed = {max_speed},\n\
             {cutoff}  \
               decision_hz = 10,\n\
             }}\n\
             return species\n",
            name = d.name,
            model = model.display(),
            ratio = self.slenderness,
            mode = self.swimming_mode,
            base = self.base,
            asset = d.asset,
            joints = joints.join(", "),
            l = m.l,
            p = m.p,
            axis = m.turn_axis_fraction(),
            front_amp = m.front_amp,
            front_wave = match m.front_wave {
                crate::motion::FrontWave::Recoil => "recoil",
                crate::motion::FrontWave::Travelling => "travelling",
                crate::motion::FrontWave::Anguilliform => "anguilliform",
            },
            s = m.s,
            amp = m.max_amp,
            lambda = m.lambda,
            omega = m.omega,
            tt = m.tt,
            max_speed = d.max_speed,
            cutoff = d.alpha_cutoff.map_or(String::new(), |c| format!(
                "  alpha_cutoff = {c},      -- the model's own alphaCutoff (1.0) leaves filtered fins in ribbons\n"
            )),
        )
    }

    /// A scene snippet that puts a few of these fish in the default tank.
    pub fn scene_snippet(&self) -> String {
        format!(
            "    {{ species = {:?}, count = 6, behavior = \"school\",\n      \
             region = {{ min = {{ -200, 120, -120 }}, max = {{ 200, 260, 120 }} }} }},",
            self.desc.name
        )
    }
}

/// `to` relative to the directory `from` (both made absolute), with `..` where needed; `/`
/// separated so the script reads the same on every system.
pub fn relative_path(from: &Path, to: &Path) -> String {
    let abs = |p: &Path| {
        std::fs::canonicalize(p).unwrap_or_else(|_| {
            std::env::current_dir()
                .map(|d| d.join(p))
                .unwrap_or_else(|_| p.to_path_buf())
        })
    };
    let (from, to) = (abs(from), abs(to));
    let a: Vec<_> = from.components().collect();
    let b: Vec<_> = to.components().collect();
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut parts: Vec<String> = vec!["..".to_string(); a.len() - common];
    parts.extend(
        b[common..]
            .iter()
            .map(|c| c.as_os_str().to_string_lossy().into_owned()),
    );
    parts.join("/")
}
