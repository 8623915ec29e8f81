//! Small numeric helpers shared by every layer: the one smoothstep, the one angle wrap and the one
//! principal-axis fit. This module sits below [`crate::motion`] and imports nothing of the crate,
//! so any layer may use it.

use std::f32::consts::{PI, TAU};

use glam::Vec3;

/// Smoothstep 3u² − 2u³ of `u` clamped to [0, 1]: the ramp every speed change and blend uses.
/// NaN stays NaN.
pub fn smoothstep(u: f32) -> f32 {
    let u = u.clamp(0.0, 1.0);
    u * u * (3.0 - 2.0 * u)
}

/// Hermite smoothstep from 0 at `e0` to 1 at `e1` (either order): [`smoothstep`] of
/// (x − e0)/(e1 − e0), as GLSL's `smoothstep(e0, e1, x)`.
pub fn smoothstep_between(e0: f32, e1: f32, x: f32) -> f32 {
    smoothstep((x - e0) / (e1 - e0))
}

/// Wraps an angle (radians) into (−π, π]; NaN and ±∞ give 0.
///
/// An angle already in range is returned as it is, not as (a + 2π) − 2π, which would round a
/// negative angle (and call `fmodf`) every time. Outside it, `a` mod 2π is exact and so is the
/// one subtraction of 2π after it, so an angle within 2π of the range comes back exact.
pub fn wrap_angle(a: f32) -> f32 {
    if !a.is_finite() {
        return 0.0;
    }
    if a > -PI && a <= PI {
        return a;
    }
    let mut w = a.rem_euclid(TAU); // [0, 2π)
    if w > PI {
        w -= TAU;
    }
    w
}

/// Largest-variance direction of `points` around `centroid`, a unit vector whose largest
/// component is positive (so the same cloud always gives the same sign).
///
/// Power iteration (100 rounds) on the covariance, accumulated in f64, starting from the
/// coordinate axis of largest variance (that axis 1, the others 0.577), so that it converges fast
/// and deterministically. Points without any spread give that start vector, normalised.
pub fn principal_axis(points: &[Vec3], centroid: Vec3) -> Vec3 {
    let mut c = [[0.0f64; 3]; 3];
    for p in points {
        let d = (*p - centroid).to_array();
        for (i, row) in c.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v += f64::from(d[i]) * f64::from(d[j]);
            }
        }
    }
    let mut v = [0.577f64, 0.577, 0.577];
    let k = (0..3).fold(0, |b, i| if c[i][i] > c[b][b] { i } else { b });
    v[k] = 1.0;
    for _ in 0..100 {
        let next = [0, 1, 2].map(|i| c[i][0] * v[0] + c[i][1] * v[1] + c[i][2] * v[2]);
        let len = (next[0] * next[0] + next[1] * next[1] + next[2] * next[2]).sqrt();
        if len.is_nan() || len <= 0.0 {
            break;
        }
        v = next.map(|x| x / len);
    }
    let a = Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32).normalize_or(Vec3::X);
    let m = a.abs().max_element();
    let largest = if a.x.abs() == m {
        a.x
    } else if a.y.abs() == m {
        a.y
    } else {
        a.z
    };
    if largest < 0.0 { -a } else { a }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() <= 1e-6
    }

    #[test]
    fn smoothstep_hand_values() {
        assert_eq!(smoothstep(-1.0), 0.0);
        assert_eq!(smoothstep(0.5), 0.5);
        assert_eq!(smoothstep(2.0), 1.0);
        assert!(close(smoothstep(0.25), 0.15625));
        assert!(smoothstep(f32::NAN).is_nan());
    }

    #[test]
    fn smoothstep_between_runs_either_way() {
        assert_eq!(smoothstep_between(1.0, 3.0, 2.0), 0.5);
        assert_eq!(smoothstep_between(1.0, 3.0, 0.0), 0.0);
        assert_eq!(smoothstep_between(3.0, 1.0, 0.0), 1.0);
        for x in [-0.3f32, 0.1, 0.37, 0.9, 1.4] {
            assert_eq!(smoothstep_between(0.0, 1.0, x), smoothstep(x));
        }
    }

    #[test]
    fn wrap_angle_lands_in_half_open_range() {
        assert!(close(wrap_angle(3.0 * PI), PI));
        assert_eq!(wrap_angle(-PI), PI);
        assert!(close(wrap_angle(-PI / 2.0 - TAU), -PI / 2.0));
        assert_eq!(wrap_angle(1.25), 1.25);
        assert_eq!(wrap_angle(f32::NAN), 0.0);
        assert_eq!(wrap_angle(f32::INFINITY), 0.0);
        // Just past ±π: exact.
        let a = PI + 0.25;
        assert_eq!(wrap_angle(a), a - TAU);
        assert_eq!(wrap_angle(-a), TAU - a);
    }

    #[test]
    fn principal_axis_finds_the_long_direction_with_a_fixed_sign() {
        let dir = Vec3::new(1.0, -3.0, 0.5).normalize();
        let points: Vec<Vec3> = (0..21)
            .map(|i| {
                let t = i as f32 - 10.0;
                dir * t + Vec3::new(0.01 * (i % 3) as f32, 0.0, -0.01 * (i % 2) as f32)
            })
            .collect();
        let centroid = points.iter().copied().sum::<Vec3>() / points.len() as f32;
        let axis = principal_axis(&points, centroid);
        assert!(axis.dot(-dir) > 0.9999, "{axis}");
        assert!(axis.y > 0.0, "largest component positive: {axis}");
        let flipped: Vec<Vec3> = points.iter().map(|p| -*p).collect();
        assert_eq!(principal_axis(&flipped, -centroid), axis);
        let none = principal_axis(&[Vec3::ONE; 4], Vec3::ONE);
        assert!(none.is_normalized() && none.x > none.y, "{none}");
    }
}
