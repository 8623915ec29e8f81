//! Frustum culling and levels of detail (issue 4): the CPU side of deciding, per fish and per
//! frame, whether it is drawn and with how many triangles.
//!
//! - [`MeshBounds`]: a mesh's bounding sphere in bind space, carried to the world by the fish's
//!   palette joint 0 (the same root-anchored convention as the window's picking spheres) and
//!   grown by [`BEND_MARGIN`] for the body's bending.
//! - [`Frustum`]: the six planes of a view-projection matrix; a sphere is culled only when it
//!   lies wholly outside one of them, so one that touches the frustum is drawn.
//! - [`ShadowProjection`]: where a fish's planar shadow lands on the sand, so the shadow is culled
//!   against its own flattened place rather than the fish's.
//! - [`MeshLods`]: coarser index lists over the *same* vertices, made once at mesh upload with
//!   meshoptimizer's simplifier (`meshopt::simplify`); skinning, palettes and instance data are
//!   the same for every level.
//! - [`LodSelector`]: picks per fish the coarsest level whose error (meshoptimizer's own measure
//!   of how far the simplified surface, its normals and colours stray from the original),
//!   projected to the screen, stays within a pixel tolerance; so a level change moves the picture
//!   by about that much at most, and a fish seen large stays at full detail. The projected size
//!   thresholds are thus derived per mesh from its simplification rather than set by hand.

use glam::{Mat4, Vec3, Vec4};

/// The most levels of detail a mesh has: full detail, then about 1/4, 1/16, 1/32 and 1/64 of
/// its triangles (the porgy: 5,616, 1,404, 350, 174 and 80). The two coarsest are for fish a few
/// pixels long, which a whole-tank view of 10,000 or 100,000 fish is made of; the last is made
/// by meshoptimizer's sloppy simplifier (see [`MeshLods::build`]).
pub const MAX_LODS: usize = 5;

/// Meshes with fewer triangles than this get only their full-detail level: below it the vertex
/// work per instance is already small, and splitting their draws by level would cost more draw
/// calls than the triangles it saves (the rocks and food pellets are such meshes).
pub const MIN_TRIANGLES_FOR_LODS: usize = 1024;

/// Level k + 1 aims at `LOD_TRIANGLE_RATIOS[k]` of level k's triangles: quarters down to the
/// porgy's 350 triangles (full detail, 1,404, 350), then halves (175, 88), whose errors grow
/// fastest, so that a fish a few pixels long finds a level within the tolerance.
pub const LOD_TRIANGLE_RATIOS: [f32; MAX_LODS - 1] = [0.25, 0.25, 0.5, 0.5];

/// How far the simplifier may stray from the original surface, relative to the mesh's largest
/// extent, when it aims at a level's triangle count: a safety cap, well above what the fish
/// meshes need, so a mesh that cannot be simplified gracefully stops short of the target rather
/// than collapsing. The selection uses the error actually reached.
pub const MAX_SIMPLIFY_ERROR: f32 = 0.3;

/// A coarser level that does not drop at least this fraction of the previous level's triangles
/// is not kept (it would cost a draw call and save almost nothing).
const MIN_LEVEL_SAVING: f32 = 0.25;

/// Factor on a mesh's bind-pose bounding radius covering its bending: a fish is posed by the
/// motion layer's joint yaws, so its skinned vertices leave the rigid bind-pose sphere carried by
/// joint 0 (the tail swings, a quick turn curls the body). Through swimming and forced quick and
/// normal turns of up to 180° the porgy and the procedural fish reached 1.01 bind radii
/// (`crates/render/tests/render/render_lod.rs` checks every skinned vertex); 1.35 leaves a third more for bendier
/// species and motions. A sphere too small would make fish at the screen edges vanish early,
/// one too large only draws a few fish just off screen.
pub const BEND_MARGIN: f32 = 1.35;

/// A sphere, world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius, length units.
    pub radius: f32,
}

/// A mesh's bounding sphere in bind (model) space: centre of its bounding box and the distance
/// to its farthest vertex.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshBounds {
    /// Centre, bind space.
    pub center: Vec3,
    /// Radius, bind-space length units.
    pub radius: f32,
}

impl MeshBounds {
    /// Bounds of `positions` (bind space). An empty slice gives a zero sphere at the origin.
    pub fn from_positions(positions: &[[f32; 3]]) -> Self {
        if positions.is_empty() {
            return Self {
                center: Vec3::ZERO,
                radius: 0.0,
            };
        }
        let (min, max) = positions.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(Vec3::from(*p)), hi.max(Vec3::from(*p))),
        );
        let center = (min + max) * 0.5;
        let radius = positions
            .iter()
            .map(|p| Vec3::from(*p).distance_squared(center))
            .fold(0.0f32, f32::max)
            .sqrt();
        Self { center, radius }
    }

    /// The culling sphere of a fish whose palette entry for joint 0 is `joint0` (world × model ×
    /// inverse bind, as uploaded), and that matrix's scale: the bind-space sphere carried by the
    /// matrix, its radius scaled by the matrix's largest axis scale and grown by
    /// [`BEND_MARGIN`]. For a one-joint mesh (a prop) `joint0` is the whole transform and the
    /// margin is only slack.
    pub fn world_sphere(&self, joint0: &Mat4) -> (Sphere, f32) {
        let scale = joint0
            .x_axis
            .truncate()
            .length_squared()
            .max(joint0.y_axis.truncate().length_squared())
            .max(joint0.z_axis.truncate().length_squared())
            .sqrt();
        let sphere = Sphere {
            center: joint0.transform_point3(self.center),
            radius: self.radius * scale * BEND_MARGIN,
        };
        (sphere, scale)
    }
}

/// The six planes of a view-projection matrix (wgpu clip space: x, y in −w..w, depth 0..w),
/// each `(n, d)` with unit `n` pointing inside, so `n · p + d` is a signed distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frustum {
    planes: [Vec4; 6],
}

impl Frustum {
    /// Extracts the planes from `view_proj` (world → clip), after Gribb and Hartmann.
    pub fn from_view_proj(view_proj: &Mat4) -> Self {
        let r0 = view_proj.row(0);
        let r1 = view_proj.row(1);
        let r2 = view_proj.row(2);
        let r3 = view_proj.row(3);
        let planes = [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2, r3 - r2].map(|p| {
            let len = p.truncate().length();
            if len > 0.0 { p / len } else { p }
        });
        Self { planes }
    }

    /// The planes, each `(n, d)`: left, right, bottom, top, near, far.
    pub fn planes(&self) -> [Vec4; 6] {
        self.planes
    }

    /// False only when `sphere` lies wholly outside a plane; a sphere touching the frustum, or
    /// one with a NaN in it (never hide what cannot be judged), counts as inside.
    pub fn intersects(&self, sphere: Sphere) -> bool {
        let c = sphere.center.extend(1.0);
        !self.planes.iter().any(|p| p.dot(c) < -sphere.radius)
    }
}

/// Where the fish shader's planar shadows land (`vs_shadow` in `shaders/fish.wgsl`): every
/// skinned point is pushed along the light direction down to just above the sand.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowProjection {
    /// Height of the shadow plane, world y.
    pub floor_y: f32,
    /// Horizontal shift per unit of height above the plane (x, z).
    shift: [f32; 2],
    /// How much the projection can stretch a distance (its largest singular value).
    stretch: f32,
}

/// Shadows lie this far above the sand (as `vs_shadow` draws them), length units.
pub const SHADOW_LIFT: f32 = 0.3;

impl ShadowProjection {
    /// The projection for a tank floor at `floor_y` and a unit light direction `light` (towards
    /// the light), matching `vs_shadow`: `p − light · max(p.y − y_f, 0) / max(light.y, 0.2)`,
    /// with y set to `y_f = floor_y + SHADOW_LIFT`.
    pub fn new(floor_y: f32, light: Vec3) -> Self {
        let ly = light.y.max(0.2);
        let shift = [light.x / ly, light.z / ly];
        Self {
            floor_y: floor_y + SHADOW_LIFT,
            shift,
            stretch: (1.0 + shift[0] * shift[0] + shift[1] * shift[1]).sqrt(),
        }
    }

    /// The shadow plane's height, the horizontal shift per unit of height (x, z) and the
    /// stretch (as the GPU culling pass takes them).
    pub fn parts(&self) -> (f32, [f32; 2], f32) {
        (self.floor_y, self.shift, self.stretch)
    }

    /// A sphere holding the shadow of everything inside `sphere`. The projection moves x and z by
    /// `−shift · max(y − y_f, 0)`; that is 1-Lipschitz in y, so points within r of the centre land
    /// within r·√(1 + |shift|²) of the centre's shadow.
    pub fn project(&self, sphere: Sphere) -> Sphere {
        let h = (sphere.center.y - self.floor_y).max(0.0);
        Sphere {
            center: Vec3::new(
                sphere.center.x - self.shift[0] * h,
                self.floor_y,
                sphere.center.z - self.shift[1] * h,
            ),
            radius: sphere.radius * self.stretch,
        }
    }
}

/// One level of detail of a mesh: a range of its index buffer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LodLevel {
    /// First index of the level in the mesh's index buffer.
    pub first_index: u32,
    /// Number of indices (three per triangle).
    pub num_indices: u32,
    /// How far this level strays from the original, bind-space length units: meshoptimizer's
    /// error (surface distance plus weighted normal and colour change, see
    /// [`LOD_ATTRIBUTE_WEIGHTS`]) times the mesh's largest extent. 0 for full detail; never less
    /// than a finer level's.
    pub error: f32,
}

impl LodLevel {
    /// Number of triangles.
    pub fn num_triangles(&self) -> u32 {
        self.num_indices / 3
    }
}

/// A mesh's levels of detail: one index buffer holding every level, finest first, all over the
/// mesh's one vertex buffer.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshLods {
    /// Every level's triangle list, one after the other.
    pub indices: Vec<u32>,
    /// The levels, full detail first (1 to [`MAX_LODS`]).
    pub levels: Vec<LodLevel>,
    /// The level shadows are drawn with, after the levels in [`MeshLods::indices`]: the mesh
    /// simplified by its positions alone (ignoring seams) to about [`SHADOW_TRIANGLE_RATIO`] of its triangles (a
    /// shadow is one flat dark colour, so only the outline counts), or `None` where that does not
    /// save a quarter of the coarsest level's (shadows then use the coarsest level).
    pub shadow: Option<LodLevel>,
}

/// Fish drawn at this level of detail or finer cast their shadow at this level (the porgy's 350
/// triangles, as every shadow was drawn before the outline level); coarser ones, a few pixels
/// long, cast the outline level ([`MeshLods::shadow`]).
pub const NEAR_SHADOW_LOD: usize = 2;

/// A shadow level aims at this fraction of the full mesh's triangles (the porgy: 5,616 → 22),
/// at least [`MIN_SHADOW_TRIANGLES`]: a shadow on the sand is a dark outline a few pixels across
/// in a large school, and at the coarsest fish level it was half of what a frame drew.
pub const SHADOW_TRIANGLE_RATIO: f32 = 1.0 / 256.0;

/// The fewest triangles a shadow level aims at.
pub const MIN_SHADOW_TRIANGLES: usize = 16;

/// Weights of the vertex normal (each component) and colour (each of r, g, b) against position
/// in the simplifier's error: an attribute change of Δ counts like moving the surface by
/// weight · Δ of the mesh's largest extent. Position-only simplification keeps the outline but
/// smears the fish's colour bands and fin shading over the big triangles left; with these
/// weights the levels keep them well enough that the reference images (fish 15 to 130 pixels
/// long) still match with the default tolerance.
pub const LOD_ATTRIBUTE_WEIGHTS: [f32; 2] = [1.0, 2.0];

/// Factor on [`LOD_ATTRIBUTE_WEIGHTS`] for the levels coarser than [`NEAR_SHADOW_LOD`], drawn
/// for fish a few pixels long: there a colour band is a pixel or two and the outline is what
/// shows, so the simplifier may trade colour for shape.
pub const COARSE_ATTRIBUTE_FACTOR: f32 = 0.25;

impl MeshLods {
    /// Builds the levels of a valid triangle mesh (as checked by [`super::Renderer::upload_mesh`]):
    /// level 0 is `mesh.indices` unchanged; each next level asks meshoptimizer's attribute-aware
    /// simplifier (`meshopt::simplify_with_attributes_and_locks`, nothing locked) for
    /// [`LOD_TRIANGLE_RATIOS`] of the previous level's triangles, simplifying the original each
    /// time (so every error is measured against the original), within [`MAX_SIMPLIFY_ERROR`]
    /// and weighing normals and colours by [`LOD_ATTRIBUTE_WEIGHTS`]. Meshes below
    /// [`MIN_TRIANGLES_FOR_LODS`] triangles keep one level; a level that saves less than a
    /// quarter of the triangles ends the chain. The simplifier only drops and re-links triangles,
    /// never moves or adds vertices, so every level reads the same vertex buffer.
    pub fn build(mesh: &super::MeshUpload<'_>) -> Self {
        let indices = mesh.indices;
        let mut out = Self {
            indices: indices.to_vec(),
            levels: vec![LodLevel {
                first_index: 0,
                num_indices: indices.len() as u32,
                error: 0.0,
            }],
            shadow: None,
        };
        let n = mesh.positions.len();
        if indices.len() / 3 < MIN_TRIANGLES_FOR_LODS
            || mesh.normals.len() != n
            || mesh.colors.len() != n
        {
            return out;
        }
        let Ok(adapter) =
            meshopt::VertexDataAdapter::new(bytemuck::cast_slice(mesh.positions), 12, 0)
        else {
            return out;
        };
        let scale = meshopt::simplify_scale(&adapter);
        let [wn, wc] = LOD_ATTRIBUTE_WEIGHTS;
        let weights_at = |level: usize| {
            let f = if level > NEAR_SHADOW_LOD {
                COARSE_ATTRIBUTE_FACTOR
            } else {
                1.0
            };
            [wn, wn, wn, wc, wc, wc].map(|w| w * f)
        };
        let attributes: Vec<f32> = mesh
            .normals
            .iter()
            .zip(mesh.colors)
            .flat_map(|(nrm, c)| [nrm[0], nrm[1], nrm[2], c[0], c[1], c[2]])
            .collect();
        let unlocked = vec![false; n];
        let mut previous = indices.len();
        let mut previous_error = 0.0f32;
        while out.levels.len() < MAX_LODS {
            let ratio = LOD_TRIANGLE_RATIOS[out.levels.len() - 1];
            let target = ((previous as f32 * ratio) as usize / 3).max(1) * 3;
            let mut relative_error = 0.0f32;
            // The coarsest level, for fish a few pixels long, is the sloppy simplifier's: it
            // ignores the seams and borders that stop the others near 110 triangles for the
            // porgy (losing its fins, error 0.27), and reaches 80 at 0.034.
            let simplified = if out.levels.len() == MAX_LODS - 1 {
                meshopt::simplify_sloppy(
                    indices,
                    &adapter,
                    target,
                    MAX_SIMPLIFY_ERROR,
                    Some(&mut relative_error),
                )
            } else {
                meshopt::simplify_with_attributes_and_locks(
                    indices,
                    &adapter,
                    &attributes,
                    &weights_at(out.levels.len()),
                    std::mem::size_of::<[f32; 6]>(),
                    &unlocked,
                    target,
                    MAX_SIMPLIFY_ERROR,
                    meshopt::SimplifyOptions::None,
                    Some(&mut relative_error),
                )
            };
            if simplified.is_empty()
                || simplified.len() as f32 > previous as f32 * (1.0 - MIN_LEVEL_SAVING)
            {
                break;
            }
            let error = (relative_error * scale).max(previous_error);
            out.levels.push(LodLevel {
                first_index: out.indices.len() as u32,
                num_indices: simplified.len() as u32,
                error,
            });
            out.indices.extend_from_slice(&simplified);
            previous = simplified.len();
            previous_error = error;
        }
        let shadow_target = ((indices.len() as f32 / 3.0 * SHADOW_TRIANGLE_RATIO) as usize)
            .max(MIN_SHADOW_TRIANGLES)
            * 3;
        let mut shadow_error = 0.0f32;
        // The sloppy simplifier ignores the mesh's topology (its seams and borders, which the
        // others keep and which stop the porgy at ~110 triangles): right for a flat shadow.
        let shadow = meshopt::simplify_sloppy(
            indices,
            &adapter,
            shadow_target,
            MAX_SIMPLIFY_ERROR,
            Some(&mut shadow_error),
        );
        if !shadow.is_empty() && (shadow.len() as f32) <= previous as f32 * (1.0 - MIN_LEVEL_SAVING)
        {
            out.shadow = Some(LodLevel {
                first_index: out.indices.len() as u32,
                num_indices: shadow.len() as u32,
                error: shadow_error * scale,
            });
            out.indices.extend_from_slice(&shadow);
        }
        out
    }

    /// The level shadows are drawn with: [`MeshLods::shadow`], else the coarsest level.
    pub fn shadow_level(&self) -> LodLevel {
        self.shadow
            .or(self.levels.last().copied())
            .expect("a mesh has at least its full-detail level")
    }
}

/// Groups each level's triangles by material (a triangle's material is that of its first
/// vertex, `vertex_material`; the simplifier never joins vertices of different primitives, so
/// its triangles keep one material), in place and stably, and returns each level's parts: the
/// index ranges of one material each, materials in increasing order. A level's own range is
/// unchanged, so the levels, their errors and [`MeshLods::indices`]' length stay as they are.
pub fn split_levels_by_material(
    indices: &mut [u32],
    levels: &[LodLevel],
    vertex_material: &[u16],
) -> Vec<Vec<shoal_core::skin::MeshPart>> {
    let material_of = |tri: &[u32]| vertex_material.get(tri[0] as usize).copied().unwrap_or(0);
    levels
        .iter()
        .map(|level| {
            let range =
                level.first_index as usize..(level.first_index + level.num_indices) as usize;
            let mut triangles: Vec<[u32; 3]> = indices[range.clone()]
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]])
                .collect();
            triangles.sort_by_key(|t| material_of(t));
            let mut parts: Vec<shoal_core::skin::MeshPart> = Vec::new();
            for (k, t) in triangles.iter().enumerate() {
                let at = range.start + 3 * k;
                indices[at..at + 3].copy_from_slice(t);
                let material = material_of(t);
                match parts.last_mut() {
                    Some(p) if p.material == material => p.num_indices += 3,
                    _ => parts.push(shoal_core::skin::MeshPart {
                        first_index: at as u32,
                        num_indices: 3,
                        material,
                    }),
                }
            }
            parts
        })
        .collect()
}

/// Picks a level of detail from a fish's projected geometric error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LodSelector {
    /// The eye, world space.
    pub eye: Vec3,
    /// Pixels per length unit at unit distance: half the view height in pixels times the
    /// projection's vertical focal factor `1 / tan(fov_y / 2)`.
    pub px_per_unit_at_unit_distance: f32,
    /// Largest projected error a coarser level may show, pixels (0: always full detail).
    pub tolerance_px: f32,
}

impl LodSelector {
    /// The selector for a camera at `eye` with vertical field of view `fov_y_rad` drawing
    /// `height_px` rows.
    pub fn new(eye: Vec3, fov_y_rad: f32, height_px: u32, tolerance_px: f32) -> Self {
        Self {
            eye,
            px_per_unit_at_unit_distance: 0.5 * height_px as f32 / (0.5 * fov_y_rad).tan(),
            tolerance_px,
        }
    }

    /// Index into `levels` of the coarsest level whose error, scaled by `scale` (the fish's
    /// world/bind scale) and seen from the nearest point of `sphere`, is within the tolerance.
    /// A camera inside the sphere gets full detail.
    pub fn select(&self, levels: &[LodLevel], sphere: Sphere, scale: f32) -> usize {
        let distance = sphere.center.distance(self.eye) - sphere.radius;
        if distance.is_nan() || distance <= 0.0 || levels.len() <= 1 {
            return 0;
        }
        let px_per_unit = self.px_per_unit_at_unit_distance * scale / distance;
        levels
            .iter()
            .rposition(|l| l.error * px_per_unit <= self.tolerance_px)
            .unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Camera;

    /// A sphere exactly touching the left plane is drawn, one a hair further out is culled; one
    /// behind the eye is culled; one around the target is drawn.
    #[test]
    fn frustum_keeps_touching_spheres_and_culls_outside_ones() {
        // Looking down −z from the origin, 90° vertical field of view, square view: the left
        // plane is x = z (for z < 0), i.e. through the origin with normal (1, 0, −1)/√2.
        let proj = glam::camera::rh::proj::directx::perspective(
            std::f32::consts::FRAC_PI_2,
            1.0,
            Camera::NEAR,
            Camera::FAR,
        );
        let frustum = Frustum::from_view_proj(&proj);
        let c = Vec3::new(-110.0, 0.0, -100.0);
        // Distance from c to the plane: (−110 + 100)/√2 = −7.071…
        let d = 10.0 / 2f32.sqrt();
        let touching = Sphere {
            center: c,
            radius: d,
        };
        assert!(frustum.intersects(touching));
        assert!(!frustum.intersects(Sphere {
            radius: d * 0.999,
            ..touching
        }));
        assert!(!frustum.intersects(Sphere {
            center: Vec3::new(0.0, 0.0, 50.0),
            radius: 10.0
        }));
        assert!(frustum.intersects(Sphere {
            center: Vec3::new(0.0, 0.0, -500.0),
            radius: 1.0
        }));
        // Beyond the far plane.
        assert!(!frustum.intersects(Sphere {
            center: Vec3::new(0.0, 0.0, -Camera::FAR - 20.0),
            radius: 10.0
        }));
        // NaN is never hidden.
        assert!(frustum.intersects(Sphere {
            center: Vec3::NAN,
            radius: 1.0
        }));
    }

    /// The bounding sphere of a box of points, carried by a scaled, moved matrix.
    #[test]
    fn mesh_bounds_follow_joint0_and_its_scale() {
        let b = MeshBounds::from_positions(&[[-2.0, -1.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 0.0]]);
        assert_eq!(b.center, Vec3::ZERO);
        assert!((b.radius - 5f32.sqrt()).abs() < 1e-6);
        let m = Mat4::from_scale_rotation_translation(
            Vec3::splat(3.0),
            glam::Quat::from_rotation_y(1.0),
            Vec3::new(10.0, 0.0, 0.0),
        );
        let (s, scale) = b.world_sphere(&m);
        assert!((scale - 3.0).abs() < 1e-5);
        assert!((s.center - Vec3::new(10.0, 0.0, 0.0)).length() < 1e-5);
        assert!((s.radius - 3.0 * 5f32.sqrt() * BEND_MARGIN).abs() < 1e-4);
    }

    /// Straight down light: the shadow sits under the sphere; slanted light moves it by the
    /// height over the light's slope and stretches it, and every point of the sphere's shadow
    /// (as `vs_shadow` computes it) lies inside the projected sphere.
    #[test]
    fn shadow_sphere_holds_the_shadow_of_the_sphere() {
        let down = ShadowProjection::new(0.0, Vec3::Y);
        let s = down.project(Sphere {
            center: Vec3::new(5.0, 100.0, 7.0),
            radius: 10.0,
        });
        assert_eq!(s.center, Vec3::new(5.0, SHADOW_LIFT, 7.0));
        assert_eq!(s.radius, 10.0);

        let light = Vec3::new(0.3, 1.0, 0.2).normalize();
        let proj = ShadowProjection::new(-20.0, light);
        let sphere = Sphere {
            center: Vec3::new(0.0, -15.0, 0.0),
            radius: 12.0,
        };
        let shadow = proj.project(sphere);
        let floor_y = -20.0 + SHADOW_LIFT;
        let shader = |p: Vec3| {
            let h = (p.y - floor_y).max(0.0);
            let q = p - light * (h / light.y.max(0.2));
            Vec3::new(q.x, floor_y, q.z)
        };
        for i in 0..400 {
            let u = i as f32 * 0.61803;
            let v = (i as f32 / 400.0) * 2.0 - 1.0;
            let dir = Vec3::new(
                (1.0 - v * v).sqrt() * u.cos(),
                v,
                (1.0 - v * v).sqrt() * u.sin(),
            );
            let p = shader(sphere.center + dir * sphere.radius);
            assert!(
                p.distance(shadow.center) <= shadow.radius + 1e-3,
                "{p} outside {shadow:?}"
            );
        }
    }

    /// Triangles of materials 1, 0, 1 in one level and 0 in the next come out grouped, in
    /// material order (stably: the two of material 1 keep their order), each level's range
    /// kept.
    #[test]
    fn levels_split_by_material_keep_their_ranges() {
        let mut indices = vec![3, 4, 5, 0, 1, 2, 5, 4, 3, 0, 1, 2];
        let levels = [
            LodLevel {
                first_index: 0,
                num_indices: 9,
                error: 0.0,
            },
            LodLevel {
                first_index: 9,
                num_indices: 3,
                error: 0.1,
            },
        ];
        // Vertices 0–2 are material 0, 3–5 material 1.
        let parts = split_levels_by_material(&mut indices, &levels, &[0, 0, 0, 1, 1, 1]);
        assert_eq!(indices, vec![0, 1, 2, 3, 4, 5, 5, 4, 3, 0, 1, 2]);
        let ranges: Vec<Vec<(u32, u32, u16)>> = parts
            .iter()
            .map(|l| {
                l.iter()
                    .map(|p| (p.first_index, p.num_indices, p.material))
                    .collect()
            })
            .collect();
        assert_eq!(ranges, vec![vec![(0, 3, 0), (3, 6, 1)], vec![(9, 3, 0)]]);
    }

    /// The coarsest level whose projected error fits: full detail close up, coarser far away,
    /// nothing coarser than a tolerance of 0 allows.
    #[test]
    fn lod_follows_projected_error() {
        let levels = [
            LodLevel {
                first_index: 0,
                num_indices: 300,
                error: 0.0,
            },
            LodLevel {
                first_index: 300,
                num_indices: 75,
                error: 0.1,
            },
            LodLevel {
                first_index: 375,
                num_indices: 18,
                error: 0.5,
            },
        ];
        // 500 px per unit at distance 1 (height 1000 px, 90° field of view).
        let sel = LodSelector::new(Vec3::ZERO, std::f32::consts::FRAC_PI_2, 1000, 1.0);
        assert!((sel.px_per_unit_at_unit_distance - 500.0).abs() < 1e-3);
        let at = |d: f32| Sphere {
            center: Vec3::new(0.0, 0.0, -d - 1.0),
            radius: 1.0,
        };
        // Level 1 fits from 50 units (0.1 · 500 / 50 = 1 px), level 2 from 250.
        assert_eq!(sel.select(&levels, at(49.0), 1.0), 0);
        assert_eq!(sel.select(&levels, at(50.0), 1.0), 1);
        assert_eq!(sel.select(&levels, at(249.0), 1.0), 1);
        assert_eq!(sel.select(&levels, at(250.0), 1.0), 2);
        // A fish twice the size shows twice the error.
        assert_eq!(sel.select(&levels, at(250.0), 2.0), 1);
        // Inside the sphere, or with no tolerance: full detail.
        assert_eq!(sel.select(&levels, at(-1.0), 1.0), 0);
        let exact = LodSelector {
            tolerance_px: 0.0,
            ..sel
        };
        assert_eq!(exact.select(&levels, at(10_000.0), 1.0), 0);
    }
}
