//! Orbit camera: looks at `target` from `distance` along the direction given by `yaw`/`pitch`.

use glam::{Mat4, Vec2, Vec3};

/// An orbit camera (right-handed, +y up, depth 0..1).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Camera {
    /// The point looked at, world space.
    pub target: Vec3,
    /// Angle around +y of the eye seen from the target, radians (0: eye on +z).
    pub yaw_rad: f32,
    /// Elevation of the eye above the target's horizontal plane, radians (clamped to ±1.5).
    pub pitch_rad: f32,
    /// Eye–target distance, length units (> 0).
    pub distance: f32,
    /// Vertical field of view, radians.
    pub fov_y_rad: f32,
}

/// A ray in world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
}

impl Ray {
    /// Distance along the ray to the first hit of a sphere, if any (origin inside counts as 0).
    pub fn hit_sphere(&self, center: Vec3, radius: f32) -> Option<f32> {
        let oc = self.origin - center;
        let b = oc.dot(self.dir);
        let c = oc.length_squared() - radius * radius;
        let disc = b * b - c;
        if disc < 0.0 {
            return None;
        }
        let t = -b - disc.sqrt();
        if t >= 0.0 {
            Some(t)
        } else if c <= 0.0 {
            Some(0.0)
        } else {
            None
        }
    }

    /// Distance along the ray to where it leaves the box `min`–`max` (the far side of a tank
    /// seen through its water: its floor or a wall), if the ray meets the box ahead of its origin.
    pub fn exit_box(&self, min: Vec3, max: Vec3) -> Option<f32> {
        let (mut enter, mut exit) = (0.0f32, f32::INFINITY);
        for axis in 0..3 {
            let (o, d) = (self.origin[axis], self.dir[axis]);
            if d == 0.0 {
                if o < min[axis] || o > max[axis] {
                    return None;
                }
                continue;
            }
            let (a, b) = ((min[axis] - o) / d, (max[axis] - o) / d);
            enter = enter.max(a.min(b));
            exit = exit.min(a.max(b));
        }
        (enter <= exit && exit.is_finite()).then_some(exit)
    }
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            target: Vec3::new(0.0, 100.0, 0.0),
            yaw_rad: 0.35,
            pitch_rad: 0.22,
            distance: 640.0,
            fov_y_rad: 50f32.to_radians(),
        }
    }
}

impl Camera {
    /// Near plane distance, length units.
    pub const NEAR: f32 = 1.0;
    /// Far plane distance, length units, for a camera up to [`Camera::FAR`] / 2 from its target
    /// (see [`Camera::far`]).
    pub const FAR: f32 = 10_000.0;

    /// This camera's far plane: [`Camera::FAR`], or twice its distance from the target when that
    /// is more, so a camera pulled back to see a tank of 100,000 fish whole still sees its far
    /// side.
    pub fn far(&self) -> f32 {
        Self::FAR.max(2.0 * self.distance)
    }

    /// The eye position, world space.
    pub fn eye(&self) -> Vec3 {
        let pitch = self.pitch_rad.clamp(-1.5, 1.5);
        let dir = Vec3::new(
            pitch.cos() * self.yaw_rad.sin(),
            pitch.sin(),
            pitch.cos() * self.yaw_rad.cos(),
        );
        self.target + dir * self.distance.max(1e-3)
    }

    /// World → view matrix.
    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye(), self.target, Vec3::Y)
    }

    /// Perspective projection for a `width / height` aspect ratio.
    pub fn projection(&self, aspect: f32) -> Mat4 {
        glam::camera::rh::proj::directx::perspective(
            self.fov_y_rad,
            aspect.max(1e-3),
            Self::NEAR,
            self.far(),
        )
    }

    /// World → clip matrix.
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        self.projection(aspect) * self.view()
    }

    /// The ray through a pixel (`pixel` in physical pixels from the top-left corner).
    pub fn ray_through_pixel(&self, pixel: Vec2, size_px: Vec2) -> Ray {
        let ndc = Vec2::new(
            pixel.x / size_px.x.max(1.0) * 2.0 - 1.0,
            1.0 - pixel.y / size_px.y.max(1.0) * 2.0,
        );
        let inv = self.view_proj(size_px.x / size_px.y.max(1.0)).inverse();
        let near = inv.project_point3(ndc.extend(0.0));
        let far = inv.project_point3(ndc.extend(1.0));
        Ray {
            origin: near,
            dir: (far - near).normalize_or(Vec3::NEG_Z),
        }
    }

    /// Rotates around the target by screen-space drag (radians).
    pub fn orbit(&mut self, d_yaw_rad: f32, d_pitch_rad: f32) {
        self.yaw_rad -= d_yaw_rad;
        self.pitch_rad = (self.pitch_rad + d_pitch_rad).clamp(-1.45, 1.45);
    }

    /// Moves target and eye together in the view plane; `dx`, `dy` are fractions of the view
    /// height (so a drag across the whole view height moves one view height).
    pub fn pan(&mut self, dx: f32, dy: f32) {
        let view = self.view();
        let right = Vec3::new(view.x_axis.x, view.y_axis.x, view.z_axis.x);
        let up = Vec3::new(view.x_axis.y, view.y_axis.y, view.z_axis.y);
        let scale = 2.0 * self.distance * (self.fov_y_rad * 0.5).tan();
        self.target += (-right * dx + up * dy) * scale;
    }

    /// Zooms by a factor (< 1 moves closer).
    pub fn zoom(&mut self, factor: f32) {
        if factor.is_finite() && factor > 0.0 {
            self.distance = (self.distance * factor).clamp(5.0, 5_000.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_ray_points_at_target() {
        let cam = Camera::default();
        let ray = cam.ray_through_pixel(Vec2::new(320.0, 240.0), Vec2::new(640.0, 480.0));
        let to_target = (cam.target - cam.eye()).normalize();
        assert!(
            ray.dir.dot(to_target) > 0.9999,
            "{:?} vs {to_target:?}",
            ray.dir
        );
    }

    #[test]
    fn ray_hits_sphere_in_front_only() {
        let ray = Ray {
            origin: Vec3::ZERO,
            dir: Vec3::X,
        };
        let t = ray.hit_sphere(Vec3::new(10.0, 0.0, 0.0), 2.0).unwrap();
        assert!((t - 8.0).abs() < 1e-5);
        assert!(ray.hit_sphere(Vec3::new(-10.0, 0.0, 0.0), 2.0).is_none());
        assert!(ray.hit_sphere(Vec3::new(10.0, 3.0, 0.0), 2.0).is_none());
    }

    #[test]
    fn ray_leaves_a_box_at_its_far_side() {
        let (min, max) = (Vec3::new(-10.0, 0.0, -5.0), Vec3::new(10.0, 8.0, 5.0));
        // From outside, through the box: out of its far wall.
        let through = Ray {
            origin: Vec3::new(-20.0, 4.0, 0.0),
            dir: Vec3::X,
        };
        assert_eq!(through.exit_box(min, max), Some(30.0));
        // From inside, looking down at an angle: out through the floor.
        let down = Ray {
            origin: Vec3::new(0.0, 4.0, 0.0),
            dir: Vec3::new(1.0, -1.0, 0.0).normalize(),
        };
        let t = down.exit_box(min, max).unwrap();
        assert!((down.origin + down.dir * t - Vec3::new(4.0, 0.0, 0.0)).length() < 1e-4);
        // Away from the box, or beside it parallel to an axis: no exit.
        let away = Ray {
            origin: Vec3::new(-20.0, 4.0, 0.0),
            dir: Vec3::NEG_X,
        };
        assert_eq!(away.exit_box(min, max), None);
        let beside = Ray {
            origin: Vec3::new(-20.0, 9.0, 0.0),
            dir: Vec3::X,
        };
        assert_eq!(beside.exit_box(min, max), None);
    }
}
