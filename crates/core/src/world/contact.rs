//! Currents and hard contact: what the motion stage applies after each fish's motion step.

use glam::Vec3;

use super::sense::forward;
use super::{CONTACT_MARGIN_LENGTHS, Current, Obstacle, Tank};
use crate::motion::RootState;

/// Sum of the drift velocities of the current zones at `p`, world units per second. Each zone
/// drifts at full strength inside 80 % of its radius, fading linearly to 0 at the radius.
pub fn drift(currents: &[Current], p: Vec3) -> Vec3 {
    currents
        .iter()
        .map(|c| {
            let d = c.pos.distance(p);
            let w = ((c.radius - d) / (0.2 * c.radius)).clamp(0.0, 1.0);
            c.velocity * w
        })
        .sum()
}

/// Whether a fish of body length `l` with its root at `pos` is so far inside `tank` and from
/// every obstacle that, whatever its heading and pitch, [`resolve_contact`] would find no contact
/// (most fish, most ticks): then placing its body samples (two `sin_cos`) is skipped. Each
/// sample lies within `l` of the root (|forward| = 1 up to rounding); the test keeps 1 % of `l`
/// plus 1e-5 of the coordinates' size on top, far more than the samples' rounding. `false`
/// whenever unsure (NaN included).
fn clear_of_contact(pos: Vec3, l: f32, margin: f32, tank: &Tank, obstacles: &[Obstacle]) -> bool {
    if !(l >= 0.0 && margin >= 0.0) {
        return false;
    }
    let size = pos.abs().max_element() + tank.min.abs().max(tank.max.abs()).max_element();
    let body = 1.01 * l + 1e-5 * size;
    let inside = (pos - (tank.min + Vec3::splat(margin + body))).min_element() > 0.0
        && ((tank.max - Vec3::splat(margin + body)) - pos).min_element() > 0.0;
    inside
        && obstacles.iter().all(|o| {
            let clearance = o.radius + margin + body + 1e-5 * o.pos.abs().max_element();
            // A NaN compares false: not clear.
            pos.distance_squared(o.pos) > clearance * clearance
        })
}

/// Pushes a fish of body length `l` (root at the head, body straight behind it along its
/// heading and pitch) out of `obstacles` and back inside `tank`, keeping
/// [`CONTACT_MARGIN_LENGTHS`]·`l` of clearance. Returns whether it had to. The tank wins over
/// obstacles; a fish longer than the tank keeps at least its head inside.
pub fn resolve_contact(root: &mut RootState, l: f32, tank: &Tank, obstacles: &[Obstacle]) -> bool {
    let margin = CONTACT_MARGIN_LENGTHS * l;
    if clear_of_contact(root.pos, l, margin, tank, obstacles) {
        return false;
    }
    let back = -forward(root.heading, root.pitch) * l;
    let samples = [0.0f32, 0.5, 1.0];
    let mut touched = false;

    for o in obstacles {
        let reach = o.radius + margin;
        // Push the whole body out by the deepest penetration among its samples (twice, so a
        // push out of one sample's way that lands another inside is also resolved).
        for _ in 0..2 {
            let mut push = Vec3::ZERO;
            let mut deepest = 0.0f32;
            for &t in &samples {
                let p = root.pos + back * t;
                let off = p - o.pos;
                let dist = off.length();
                let depth = reach - dist;
                if depth > deepest {
                    deepest = depth;
                    push = off.try_normalize().unwrap_or(Vec3::Y) * depth;
                }
            }
            if deepest <= 0.0 {
                break;
            }
            root.pos += push;
            touched = true;
        }
    }

    let lo = tank.min + Vec3::splat(margin);
    let hi = tank.max - Vec3::splat(margin);
    let (mut low, mut high) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for &t in &samples {
        let p = root.pos + back * t;
        low = low.min(p);
        high = high.max(p);
    }
    let mut shift = Vec3::ZERO;
    for axis in 0..3 {
        if low[axis] < lo[axis] {
            shift[axis] = lo[axis] - low[axis];
        } else if high[axis] > hi[axis] {
            shift[axis] = hi[axis] - high[axis];
        }
    }
    if shift != Vec3::ZERO {
        root.pos += shift;
        touched = true;
    }
    // Whatever the geometry, the root ends inside the tank.
    let clamped = root.pos.clamp(tank.min, tank.max);
    if clamped != root.pos {
        root.pos = clamped;
        touched = true;
    }
    touched
}
