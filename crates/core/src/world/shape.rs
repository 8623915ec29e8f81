//! A fish's body shape from its motion player: the midline's lateral displacement at each
//! `joints_x` sample and the driven joints' yaws, as the motion stage stores them and as the
//! pose stage brings them up to date when the GPU pass left them stale. Shared by the motion
//! stage (`stages.rs`) and the pose buffers (`pose/buffers.rs`), which otherwise do not import
//! each other.

use super::MAX_DRIVEN_JOINTS;

/// How many entries of a fish's stored `lateral` and `yaw` arrays `body` uses: its `joints_x`
/// samples and its driven joints.
pub(super) fn shape_lens(body: &crate::motion::Body) -> (usize, usize) {
    (
        body.joints_x.len().min(MAX_DRIVEN_JOINTS + 1),
        body.power.len().min(MAX_DRIVEN_JOINTS),
    )
}

/// `player`'s body shape for a root moving at `speed`, into `lateral` and `yaw` as the motion
/// stage stores them (all 0 if a value is not finite); returns the head's lateral offset and
/// yaw, for [`crate::motion::MotionPlayer::set_head_shape`], and whether the shape was finite.
pub(super) fn derive_shape(
    player: &crate::motion::MotionPlayer,
    speed: f32,
    sp: &super::Species,
    table: &crate::motion::WaveTable,
    lateral: &mut [f32; MAX_DRIVEN_JOINTS + 1],
    yaw: &mut [f32; MAX_DRIVEN_JOINTS],
) -> ((f32, f32), bool) {
    let body = &sp.rig.body;
    let (samples, driven) = shape_lens(body);
    let head = player.shape_tabled(
        speed,
        &sp.desc.motion,
        body,
        table,
        &mut lateral[..samples],
        &mut yaw[..driven],
    );
    let finite = finite_shape(&lateral[..samples], &yaw[..driven]);
    if !finite {
        lateral.fill(0.0);
        yaw.fill(0.0);
    }
    (head, finite)
}

/// Whether a body shape's values are all finite.
fn finite_shape(lateral: &[f32], yaw: &[f32]) -> bool {
    lateral.iter().chain(yaw).all(|v| v.is_finite())
}
