//! Perception layer geometry (paper section 3.1: the vision sensor and the body sensor), as pure
//! functions over plain values. The world's [`World::vision`](super::World::vision) and
//! [`World::body_sense`](super::World::body_sense) are built on these.
//!
//! Conventions (see `crates/core/src/motion/mod.rs`): +y up; heading is radians counter-clockwise seen from
//! above with 0 facing +x, so the horizontal forward vector is (cos h, 0, −sin h) and the fish's
//! left is the direction its heading turns towards.

use glam::Vec3;

use super::Tank;

/// Unit forward vector of a fish with `heading` and `pitch` (radians).
pub fn forward(heading: f32, pitch: f32) -> Vec3 {
    let (sh, ch) = heading.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    Vec3::new(ch * cp, sp, -sh * cp)
}

/// Wraps an angle (radians) into (−π, π]; NaN gives 0 (written once, in [`crate::math`]).
pub use crate::math::wrap_angle;

/// Heading (radians, counter-clockwise from +x seen from above) of the horizontal part of `dir`;
/// 0 when `dir` is vertical or zero.
pub fn heading_of(dir: Vec3) -> f32 {
    if dir.x == 0.0 && dir.z == 0.0 {
        0.0
    } else {
        (-dir.z).atan2(dir.x)
    }
}

/// Bearing of `target` seen from `pos` by a fish with `heading`: radians in (−π, π], positive to
/// the fish's left.
pub fn bearing(pos: Vec3, heading: f32, target: Vec3) -> f32 {
    let d = target - pos;
    if d.x == 0.0 && d.z == 0.0 {
        return 0.0;
    }
    wrap_angle(heading_of(d) - heading)
}

/// Elevation of `target` seen from `pos`: radians above the horizontal plane (negative below),
/// in [−π/2, π/2].
pub fn elevation(pos: Vec3, target: Vec3) -> f32 {
    let d = target - pos;
    d.y.atan2((d.x * d.x + d.z * d.z).sqrt())
}

/// Whether `target` lies inside a view cone of full opening `view_angle_deg` degrees around
/// `forward` (a unit vector) seen from `pos`. 360° or more sees all around; a target at `pos`
/// itself counts as seen.
pub fn in_view_cone(pos: Vec3, forward: Vec3, view_angle_deg: f32, target: Vec3) -> bool {
    if view_angle_deg >= 360.0 {
        return true;
    }
    let d = target - pos;
    let len = d.length();
    if len <= f32::EPSILON {
        return true;
    }
    let half = (view_angle_deg.max(0.0) * 0.5).to_radians();
    forward.dot(d) >= len * half.cos()
}

/// A view cone prepared for many tests: [`in_view_cone`] with the half-angle's cosine computed
/// once and no square root per test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewCone {
    pos: Vec3,
    forward: Vec3,
    cos_half: f32,
    all_round: bool,
}

impl ViewCone {
    /// The cone of full opening `view_angle_deg` degrees around the unit vector `forward`, apex
    /// at `pos`.
    pub fn new(pos: Vec3, forward: Vec3, view_angle_deg: f32) -> Self {
        Self {
            pos,
            forward,
            cos_half: (view_angle_deg.max(0.0) * 0.5).to_radians().cos(),
            all_round: view_angle_deg >= 360.0,
        }
    }

    /// Same answer as [`in_view_cone`]: forward·d ≥ |d|·cos(half), compared squared.
    pub fn contains(&self, target: Vec3) -> bool {
        if self.all_round {
            return true;
        }
        let d = target - self.pos;
        let len2 = d.length_squared();
        if len2 <= f32::EPSILON * f32::EPSILON {
            return true;
        }
        let dot = self.forward.dot(d);
        let bound2 = len2 * self.cos_half * self.cos_half;
        if self.cos_half >= 0.0 {
            dot >= 0.0 && dot * dot >= bound2
        } else {
            dot >= 0.0 || dot * dot <= bound2
        }
    }
}

/// Distances from `pos` to the tank's boundaries: (to floor, to surface, to the nearest side wall,
/// that wall's inward unit normal). Negative distances mean `pos` is beyond that boundary.
pub fn tank_distances(tank: &Tank, pos: Vec3) -> (f32, f32, f32, Vec3) {
    let to_floor = pos.y - tank.min.y;
    let to_surface = tank.max.y - pos.y;
    let walls = [
        (pos.x - tank.min.x, Vec3::X),
        (tank.max.x - pos.x, Vec3::NEG_X),
        (pos.z - tank.min.z, Vec3::Z),
        (tank.max.z - pos.z, Vec3::NEG_Z),
    ];
    let (to_wall, normal) = walls.into_iter().fold((f32::INFINITY, Vec3::X), |best, w| {
        if w.0 < best.0 { w } else { best }
    });
    (to_floor, to_surface, to_wall, normal)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::{PI, TAU};

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() < 1e-5
    }

    #[test]
    fn forward_matches_the_motion_convention() {
        assert!(forward(0.0, 0.0).abs_diff_eq(Vec3::X, 1e-6));
        // A quarter turn to the left from +x faces −z.
        assert!(forward(PI / 2.0, 0.0).abs_diff_eq(Vec3::NEG_Z, 1e-6));
        assert!(forward(0.0, PI / 2.0).abs_diff_eq(Vec3::Y, 1e-6));
    }

    #[test]
    fn bearing_is_positive_to_the_left() {
        // Facing +x, the left is −z.
        let b = bearing(Vec3::ZERO, 0.0, Vec3::new(1.0, 0.0, -1.0));
        assert!(close(b, PI / 4.0), "{b}");
        let b = bearing(Vec3::ZERO, 0.0, Vec3::new(1.0, 0.0, 1.0));
        assert!(close(b, -PI / 4.0), "{b}");
        // Facing −z (heading π/2), a target at +x is to the right.
        let b = bearing(Vec3::ZERO, PI / 2.0, Vec3::new(5.0, 0.0, 0.0));
        assert!(close(b, -PI / 2.0), "{b}");
        // Straight behind is π, not −π.
        let b = bearing(Vec3::ZERO, 0.0, Vec3::new(-3.0, 0.0, 0.0));
        assert!(close(b, PI), "{b}");
    }

    #[test]
    fn wrap_angle_lands_in_half_open_range() {
        assert!(close(wrap_angle(3.0 * PI), PI));
        assert!(close(wrap_angle(-PI), PI));
        assert!(close(wrap_angle(-PI / 2.0 - TAU), -PI / 2.0));
        assert_eq!(wrap_angle(f32::NAN), 0.0);
    }

    #[test]
    fn elevation_is_positive_above() {
        assert!(close(
            elevation(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0)),
            PI / 4.0
        ));
        assert!(close(
            elevation(Vec3::ZERO, Vec3::new(0.0, -2.0, 0.0)),
            -PI / 2.0
        ));
    }

    #[test]
    fn view_cone_uses_the_full_opening_angle() {
        let f = Vec3::X;
        // 90° opening = 45° either side.
        assert!(in_view_cone(Vec3::ZERO, f, 90.0, Vec3::new(1.0, 0.0, 0.9)));
        assert!(!in_view_cone(Vec3::ZERO, f, 90.0, Vec3::new(1.0, 0.0, 1.1)));
        assert!(!in_view_cone(
            Vec3::ZERO,
            f,
            300.0,
            Vec3::new(-1.0, 0.0, 0.1)
        ));
        assert!(in_view_cone(
            Vec3::ZERO,
            f,
            300.0,
            Vec3::new(-1.0, 0.0, 0.7)
        ));
        assert!(in_view_cone(Vec3::ZERO, f, 360.0, Vec3::NEG_X));
    }

    #[test]
    fn prepared_view_cone_agrees_with_the_plain_test() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg32::seed_from_u64(5);
        let mut disagreements = 0;
        for _ in 0..20_000 {
            let pos = Vec3::new(rng.random(), rng.random(), rng.random()) * 10.0;
            let fwd = forward(rng.random_range(-PI..PI), rng.random_range(-1.5..1.5));
            let target = Vec3::new(rng.random(), rng.random(), rng.random()) * 10.0;
            let angle = rng.random_range(0.0..400.0);
            let cone = ViewCone::new(pos, fwd, angle);
            if cone.contains(target) != in_view_cone(pos, fwd, angle, target) {
                // Only exactly on the cone's surface may rounding differ.
                let d = (target - pos).normalize();
                let off = fwd.dot(d).clamp(-1.0, 1.0).acos().to_degrees();
                assert!((off - angle * 0.5).abs() < 0.01, "off {off}, angle {angle}");
                disagreements += 1;
            }
        }
        assert!(disagreements < 5);
    }

    #[test]
    fn tank_distances_name_the_nearest_wall() {
        let tank = Tank {
            min: Vec3::new(0.0, 0.0, 0.0),
            max: Vec3::new(10.0, 4.0, 6.0),
        };
        let (floor, surface, wall, n) = tank_distances(&tank, Vec3::new(8.5, 1.0, 3.0));
        assert!(close(floor, 1.0) && close(surface, 3.0) && close(wall, 1.5));
        assert_eq!(n, Vec3::NEG_X);
        let (_, _, wall, n) = tank_distances(&tank, Vec3::new(5.0, 1.0, 0.25));
        assert!(close(wall, 0.25));
        assert_eq!(n, Vec3::Z);
    }
}
