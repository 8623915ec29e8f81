//! Culling and levels of detail on the GPU (`shaders/cull.wgsl`, issue 35): the same scene drawn
//! with the CPU's culling and with the GPU's gives the same picture and the same counts (fish
//! drawn and culled, per level, shadows, triangles), with shadows and without, at the default
//! tolerance and at 0; and the GPU path records as many draws for 10 fish as for 600.

use crate::common;
use crate::common::UploadPorgy as _;

use glam::{Mat4, Quat, Vec3};
use rand::{Rng, SeedableRng};
use shoal_render::props::PropMesh;
use shoal_render::{
    Camera, Culling, FishInstance, FrameInput, Gpu, Look, MeshId, OffscreenTarget, Prop,
    RenderTimings, Renderer, TankBounds,
};

const WIDTH: u32 = 320;
const HEIGHT: u32 = 200;

fn gpu() -> Gpu {
    Gpu::headless().expect("a GPU adapter (lavapipe in CI: apt install mesa-vulkan-drivers)")
}

/// `n` porgies scattered over and well beyond the default tank (some behind the camera, some
/// far off, some close), every one bent a little differently, a few tinted and one selected;
/// two rocks and a pellet.
#[derive(Clone)]
struct School {
    palettes: Vec<Mat4>,
    fish: Vec<(u32, [f32; 3], bool)>,
    props: Vec<(usize, Mat4)>,
}

fn school(rig: &common::PosedPorgy, n: usize) -> School {
    let nj = rig.num_joints();
    let mut rng = rand_pcg::Pcg32::seed_from_u64(35);
    let mut palettes = vec![Mat4::IDENTITY; n * nj];
    let mut fish = Vec::new();
    for i in 0..n {
        let pos = Vec3::new(
            rng.random_range(-900.0..900.0),
            rng.random_range(10.0..240.0),
            rng.random_range(-1_500.0..700.0),
        );
        let root = Mat4::from_rotation_translation(
            Quat::from_rotation_y(rng.random_range(0.0..std::f32::consts::TAU)),
            pos,
        );
        let phase: f32 = rng.random_range(0.0..std::f32::consts::TAU);
        let yaws: Vec<f32> = (0..rig.rig.body.num_joints())
            .map(|j| 0.15 * (phase + j as f32 * 0.8).sin())
            .collect();
        rig.palette(root, &yaws, &mut palettes[i * nj..(i + 1) * nj]);
        let tint = if i % 7 == 0 {
            [1.0, 0.6, 0.5]
        } else {
            [1.0; 3]
        };
        fish.push(((i * nj) as u32, tint, i == 3));
    }
    let props = vec![
        (
            0,
            Mat4::from_scale_rotation_translation(
                Vec3::splat(55.0),
                Quat::from_rotation_y(0.4),
                Vec3::new(150.0, 20.0, -80.0),
            ),
        ),
        (
            0,
            Mat4::from_scale_rotation_translation(
                Vec3::splat(35.0),
                Quat::IDENTITY,
                Vec3::new(-2_000.0, 10.0, 90.0),
            ),
        ),
        (
            1,
            Mat4::from_scale_rotation_translation(
                Vec3::splat(4.0),
                Quat::IDENTITY,
                Vec3::new(-40.0, 215.0, 20.0),
            ),
        ),
    ];
    School {
        palettes,
        fish,
        props,
    }
}

/// A renderer culling with `culling` at `tolerance_px`, with the porgy, the rock and the
/// pellet uploaded (meshes 0, 1 and 2).
fn renderer(gpu: &Gpu, rig: &common::PosedPorgy, culling: Culling, tolerance_px: f32) -> Renderer {
    let mut renderer = Renderer::new(gpu, OffscreenTarget::FORMAT).unwrap();
    assert_eq!(renderer.set_culling(culling), culling, "lavapipe runs both");
    renderer.set_lod_tolerance_px(tolerance_px);
    renderer.upload_mesh(gpu, &rig.upload()).unwrap();
    renderer
        .upload_mesh(gpu, &PropMesh::rock().upload())
        .unwrap();
    renderer
        .upload_mesh(gpu, &PropMesh::pellet().upload())
        .unwrap();
    renderer
}

/// Draws `school` with `culling` at `tolerance_px`; the image and the counts (read back from
/// the GPU when it culled).
fn draw(
    gpu: &Gpu,
    rig: &common::PosedPorgy,
    school: &School,
    culling: Culling,
    tolerance_px: f32,
    shadows: bool,
) -> (image::RgbaImage, RenderTimings) {
    let mut renderer = renderer(gpu, rig, culling, tolerance_px);
    // Twice: the second frame reuses every buffer the first one grew.
    let (image, _) = draw_with(gpu, &mut renderer, school, shadows, 2);
    (image, renderer.read_gpu_counts(gpu).unwrap())
}

/// Draws `school` `frames` times with `renderer` (set up by [`renderer`]); the last image and
/// the renderer's timings after it, counts not read back (those read without waiting).
fn draw_with(
    gpu: &Gpu,
    renderer: &mut Renderer,
    school: &School,
    shadows: bool,
    frames: usize,
) -> (image::RgbaImage, RenderTimings) {
    draw_named(gpu, renderer, school, shadows, frames, None)
}

/// [`draw_with`], the instances named by `revision` ([`FrameInput::instances_revision`]).
fn draw_named(
    gpu: &Gpu,
    renderer: &mut Renderer,
    school: &School,
    shadows: bool,
    frames: usize,
    revision: Option<u64>,
) -> (image::RgbaImage, RenderTimings) {
    let (porgy, rock, pellet) = (MeshId(0), MeshId(1), MeshId(2));
    let instances: Vec<FishInstance> = school
        .fish
        .iter()
        .map(|&(palette_offset, tint, selected)| FishInstance {
            mesh: porgy,
            palette_offset,
            tint,
            selected,
        })
        .collect();
    let props: Vec<Prop> = school
        .props
        .iter()
        .map(|&(k, transform)| Prop {
            mesh: [rock, pellet][k],
            transform,
            tint: [1.0; 3],
        })
        .collect();
    let tank = TankBounds::default();
    let input = FrameInput {
        gpu_pose: None,
        palettes: &school.palettes,
        instances: &instances,
        instances_revision: revision,
        camera: camera(),
        tank,
        time_s: 1.0,
        props: &props,
        overlay: &[],
        look: Look {
            shadows,
            ..Look::default()
        },
    };
    let target = OffscreenTarget::new(gpu, WIDTH, HEIGHT);
    for _ in 0..frames {
        renderer
            .render(gpu, target.view(), target.size(), &input)
            .unwrap();
    }
    (target.read_rgba8(gpu).unwrap(), renderer.timings())
}

/// The tests' camera: the default tank from 700 units.
fn camera() -> Camera {
    Camera {
        target: TankBounds::default().center(),
        yaw_rad: 0.35,
        pitch_rad: 0.25,
        distance: 700.0,
        fov_y_rad: 50f32.to_radians(),
    }
}

/// Mean and largest difference over the RGB channels of two images.
fn difference(a: &image::RgbaImage, b: &image::RgbaImage) -> (f64, u8) {
    let mut sum = 0u64;
    let mut most = 0u8;
    for (p, q) in a.pixels().zip(b.pixels()) {
        for c in 0..3 {
            let d = p[c].abs_diff(q[c]);
            sum += u64::from(d);
            most = most.max(d);
        }
    }
    (sum as f64 / (3.0 * f64::from(a.width() * a.height())), most)
}

/// Asserts that `img`, frame `name` of `school` just drawn by the kept renderer `kept`, is what
/// a fresh renderer draws: the same counts (read back from `kept`, returned) and the picture
/// within 0.05 grey levels on average.
fn assert_drawn_as_fresh(
    gpu: &Gpu,
    rig: &common::PosedPorgy,
    kept: &mut Renderer,
    name: &str,
    school: &School,
    img: &image::RgbaImage,
) -> RenderTimings {
    let t = kept.read_gpu_counts(gpu).unwrap();
    let (fresh_img, fresh) = draw(gpu, rig, school, Culling::Gpu, 1.0, true);
    assert_eq!(counts(&t), counts(&fresh), "frame {name}: {t:?} {fresh:?}");
    let (mean, most) = difference(img, &fresh_img);
    assert!(
        mean < 0.05,
        "frame {name}: {mean} (largest {most}) from a new renderer's"
    );
    t
}

/// The counts the two paths must share.
fn counts(t: &RenderTimings) -> (u32, u32, [u32; 5], u32, u32, u64) {
    (
        t.num_fish_drawn,
        t.num_fish_culled,
        t.num_fish_per_lod,
        t.num_shadows_drawn,
        t.num_outline_shadows,
        t.num_triangles,
    )
}

#[test]
fn gpu_culling_draws_what_cpu_culling_draws() {
    let gpu = gpu();
    let rig = common::PosedPorgy::load();
    let school = school(&rig, 600);
    for (tolerance, shadows) in [(1.0, true), (0.0, true), (1.0, false)] {
        let (cpu_img, cpu) = draw(&gpu, &rig, &school, Culling::Cpu, tolerance, shadows);
        let (gpu_img, on_gpu) = draw(&gpu, &rig, &school, Culling::Gpu, tolerance, shadows);
        let case = format!("tolerance {tolerance}, shadows {shadows}");
        // The scene has something in each class, or the comparison would prove little.
        assert!(cpu.num_fish_culled > 50, "{case}: {cpu:?}");
        assert!(cpu.num_fish_drawn > 100, "{case}: {cpu:?}");
        if tolerance > 0.0 {
            assert!(
                cpu.num_fish_per_lod.iter().filter(|&&n| n > 0).count() >= 3,
                "{case}: {cpu:?}"
            );
        }
        assert_eq!(
            cpu.num_shadows_drawn > 0,
            shadows,
            "{case}: shadows drawn {cpu:?}"
        );
        assert_eq!(
            counts(&cpu),
            counts(&on_gpu),
            "{case}: CPU {cpu:?}, GPU {on_gpu:?}"
        );
        // Only the order of instances within a draw differs (the GPU groups them by atomic
        // counters): where two fish overlap at equal depth a pixel may differ.
        let (mean, most) = difference(&cpu_img, &gpu_img);
        assert!(
            mean < 0.05,
            "{case}: mean difference {mean} (largest {most})"
        );
        let picture = difference(&cpu_img, &image::RgbaImage::new(WIDTH, HEIGHT)).0;
        assert!(picture > 20.0, "{case}: something is drawn ({picture})");
    }
}

/// The GPU path records a fixed set of draws, whatever the number of fish in view.
#[test]
fn gpu_culling_records_as_many_draws_for_10_fish_as_for_600() {
    let gpu = gpu();
    let rig = common::PosedPorgy::load();
    let (_, few) = draw(&gpu, &rig, &school(&rig, 10), Culling::Gpu, 1.0, true);
    let (_, many) = draw(&gpu, &rig, &school(&rig, 600), Culling::Gpu, 1.0, true);
    assert!(
        many.num_fish_drawn > 10 * few.num_fish_drawn.max(1) / 2,
        "{few:?} {many:?}"
    );
    assert_eq!(few.num_draw_calls, many.num_draw_calls);
}

/// Adds a palette for one straight porgy at `pos` to `school`; its palette offset.
fn add_palette(rig: &common::PosedPorgy, school: &mut School, pos: Vec3) -> u32 {
    let offset = school.palettes.len();
    school
        .palettes
        .resize(offset + rig.num_joints(), Mat4::IDENTITY);
    let yaws = vec![0.0; rig.rig.body.num_joints()];
    rig.palette(
        Mat4::from_translation(pos),
        &yaws,
        &mut school.palettes[offset..],
    );
    offset as u32
}

/// The GPU keeps each fish's culling record between frames and the renderer writes only the
/// ones that changed: a renderer that drew one frame must draw the next exactly as a new
/// renderer draws it, when fish are re-pointed at other palettes (into the view, then out of
/// it), tinted, selected and removed; and when a fish moves (its palette changes, its record
/// does not) nothing is written, yet it is drawn where it now is.
#[test]
fn a_fish_whose_record_changes_is_drawn_where_and_as_it_now_is() {
    let gpu = gpu();
    let rig = common::PosedPorgy::load();
    let a = school(&rig, 300);
    let mut kept = renderer(&gpu, &rig, Culling::Gpu, 1.0);
    let (img_a, t_a) = draw_with(&gpu, &mut kept, &a, true, 2);
    assert_eq!(
        t_a.num_records_written, 0,
        "a steady frame writes nothing: {t_a:?}"
    );

    let centre = TankBounds::default().center();
    let eye = camera().eye();
    // Near the camera, in the middle of the view: a large fish.
    let near = centre + (eye - centre) * 0.75;
    let behind = eye + (eye - centre).normalize() * 300.0;
    let mut b = a.clone();
    let near_offset = add_palette(&rig, &mut b, near);
    let behind_offset = add_palette(&rig, &mut b, behind);
    b.fish[5].0 = near_offset;
    b.fish[20].1 = [0.2, 1.0, 0.2];
    b.fish[3].2 = false;
    b.fish[40].2 = true;
    b.fish.truncate(280);
    // C: fish 5 leaves the view (behind the camera).
    let mut c = b.clone();
    c.fish[5].0 = behind_offset;
    // D: the palette fish 5 points at moves back in front of the camera; no record changes.
    let mut d = c.clone();
    d.palettes.truncate(behind_offset as usize);
    add_palette(&rig, &mut d, near);

    let mut frames = Vec::new();
    for (name, next) in [("B", &b), ("C", &c), ("D", &d)] {
        let (img, _) = draw_with(&gpu, &mut kept, next, true, 1);
        let t = assert_drawn_as_fresh(&gpu, &rig, &mut kept, name, next, &img);
        frames.push((img, t));
    }
    let [(img_b, t_b), (img_c, t_c), (img_d, t_d)] = frames.try_into().unwrap();
    // B: fish 3, 5, 20, 40 changed (one run 3..21, one at 40) and the props' records moved
    // (their palette entries follow the fish's, and fish 280.. are gone): 22 written.
    assert_eq!(t_b.num_records_written, 18 + 1 + 3, "{t_b:?}");
    assert_eq!(t_c.num_records_written, 1, "{t_c:?}");
    assert_eq!(t_d.num_records_written, 0, "{t_d:?}");
    assert_eq!(t_c.num_fish_drawn + 1, t_b.num_fish_drawn);
    assert_eq!(t_c.num_fish_culled, t_b.num_fish_culled + 1);
    assert_eq!(t_d.num_fish_drawn, t_b.num_fish_drawn);
    // The changes show: a stale record would leave these pictures alike.
    for (what, x, y) in [
        ("A and B", &img_a, &img_b),
        ("B and C", &img_b, &img_c),
        ("C and D", &img_c, &img_d),
    ] {
        // Three times the most a new renderer's picture of the same frame may differ by.
        let (mean, _) = difference(x, y);
        assert!(mean > 0.15, "{what} differ by only {mean}");
    }
    // A steady frame after them writes nothing.
    let (_, t) = draw_with(&gpu, &mut kept, &d, true, 1);
    assert_eq!(t.num_records_written, 0, "{t:?}");
}

/// Fish records kept by the caller's revision ([`FrameInput::instances_revision`]): while the
/// revision stays, the renderer neither builds nor compares the fish's records (only the
/// props'), so a steady frame costs the CPU nothing per fish; each change under a new revision
/// — a fish tinted, another selected, one despawned (the last moved into its place) — is drawn
/// as a new renderer draws it, with exactly its records written; props that come under a kept
/// revision are written, the fish's records too when the buffer has to grow for them.
#[test]
fn changes_named_by_a_new_revision_are_drawn_and_a_kept_revision_keeps_the_records() {
    let gpu = gpu();
    let rig = common::PosedPorgy::load();
    // 506 fish and 3 props: 509 records, in a buffer of 512 (it grows by powers of two).
    let mut a = school(&rig, 506);
    let centre = TankBounds::default().center();
    let near = centre + (camera().eye() - centre) * 0.75;
    // Fish 5 near the camera, large in the view: its changes show.
    a.fish[5].0 = add_palette(&rig, &mut a, near);
    let mut kept = renderer(&gpu, &rig, Culling::Gpu, 1.0);
    let rev_a = shoal_render::next_instances_revision();
    let (img_a, t) = draw_named(&gpu, &mut kept, &a, true, 2, Some(rev_a));
    assert_eq!(
        t.num_records_written, 0,
        "a steady frame writes nothing: {t:?}"
    );

    // The same revision with other instances (a promise broken on purpose): the fish's
    // records are not looked at, so nothing changes on the GPU.
    let mut lie = a.clone();
    lie.fish[5].1 = [0.1, 0.1, 1.0];
    lie.fish.swap(5, 100);
    let (img, t) = draw_named(&gpu, &mut kept, &lie, true, 1, Some(rev_a));
    assert_eq!(t.num_records_written, 0, "{t:?}");
    let (mean, _) = difference(&img, &img_a);
    assert!(mean < 0.01, "the kept records were rebuilt: {mean}");

    // B: fish 5 tinted; C: fish 40 selected too; D: fish 5 despawned, the last in its place.
    let mut b = a.clone();
    b.fish[5].1 = [0.1, 1.0, 0.1];
    let mut c = b.clone();
    c.fish[40].2 = true;
    let mut d = c.clone();
    d.fish.swap_remove(5);
    let mut previous = img_a;
    // D: fish 5 changed, and the props' records moved down one place (3).
    for (name, next, written) in [("B", &b, 1), ("C", &c, 1), ("D", &d, 1 + 3)] {
        let rev = shoal_render::next_instances_revision();
        let (img, t) = draw_named(&gpu, &mut kept, next, true, 1, Some(rev));
        assert_eq!(t.num_records_written, written, "frame {name}: {t:?}");
        assert_drawn_as_fresh(&gpu, &rig, &mut kept, name, next, &img);
        // The change shows: a missed one would leave the picture as it was (the rest of the
        // frame is the same, to the pixel).
        let (mean, most) = difference(&img, &previous);
        assert!(
            most > 40,
            "frame {name} differs from the one before by only {mean} (largest {most})"
        );
        // Kept: the next frame writes nothing.
        let (_, t) = draw_named(&gpu, &mut kept, next, true, 1, Some(rev));
        assert_eq!(t.num_records_written, 0, "after frame {name}: {t:?}");
        previous = img;
    }

    // E: pellets dropped, the fish kept (same revision): the props are written; 505 fish and
    // 8 props need a bigger buffer, so the fish's records go in again from the CPU's copy.
    let rev_d = shoal_render::next_instances_revision();
    draw_named(&gpu, &mut kept, &d, true, 1, Some(rev_d));
    let mut e = d.clone();
    for k in 0..5 {
        let pos = near + Vec3::new(8.0 * k as f32 - 16.0, 12.0, 0.0);
        e.props.push((
            1,
            Mat4::from_scale_rotation_translation(Vec3::splat(4.0), Quat::IDENTITY, pos),
        ));
    }
    let (img, t) = draw_named(&gpu, &mut kept, &e, true, 1, Some(rev_d));
    assert_eq!(t.num_records_written, 505 + 8, "{t:?}");
    assert_drawn_as_fresh(&gpu, &rig, &mut kept, "E", &e, &img);
    // F: the fish kept, a pellet eaten (the records after it are alike: a prop's place is in
    // the palette) and the first rock turned into a pellet: one record written.
    let mut f = e.clone();
    f.props.remove(4);
    f.props[0].0 = 1;
    let (img, t) = draw_named(&gpu, &mut kept, &f, true, 1, Some(rev_d));
    assert_eq!(t.num_records_written, 1, "{t:?}");
    let (fresh_img, _) = draw(&gpu, &rig, &f, Culling::Gpu, 1.0, true);
    let (mean, most) = difference(&img, &fresh_img);
    assert!(
        mean < 0.05,
        "frame F: {mean} (largest {most}) from a new renderer's"
    );
}

/// The instances are checked once per revision, but again when the meshes change: a fish whose
/// mesh is gone (the meshes cleared) is refused under the revision it was drawn with, and a bad
/// instance under a new revision is refused too.
#[test]
fn instances_kept_by_a_revision_are_checked_again_when_the_meshes_change() {
    let gpu = gpu();
    let rig = common::PosedPorgy::load();
    let a = school(&rig, 10);
    let mut r = renderer(&gpu, &rig, Culling::Gpu, 1.0);
    let rev = shoal_render::next_instances_revision();
    draw_named(&gpu, &mut r, &a, true, 1, Some(rev));
    let target = OffscreenTarget::new(&gpu, 32, 32);
    let instances = [FishInstance {
        mesh: MeshId(0),
        palette_offset: 0,
        tint: [1.0; 3],
        selected: false,
    }];
    let input = FrameInput {
        gpu_pose: None,
        palettes: &a.palettes,
        instances: &instances,
        instances_revision: Some(rev),
        camera: camera(),
        tank: TankBounds::default(),
        time_s: 0.0,
        props: &[],
        overlay: &[],
        look: Look::default(),
    };
    r.clear_meshes();
    let err = r
        .render(&gpu, target.view(), target.size(), &input)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("fish 0 uses mesh 0 but only 0 meshes"),
        "{err}"
    );
    r.upload_mesh(&gpu, &rig.upload()).unwrap();
    let past_the_palette = [FishInstance {
        palette_offset: a.palettes.len() as u32,
        ..instances[0]
    }];
    let err = r
        .render(
            &gpu,
            target.view(),
            target.size(),
            &FrameInput {
                instances: &past_the_palette,
                instances_revision: Some(shoal_render::next_instances_revision()),
                ..input
            },
        )
        .unwrap_err()
        .to_string();
    assert!(err.contains("fish 0 needs palette entries"), "{err}");
}

/// The draw counts: the GPU path records every level's draw but counts as drawing only those
/// with instances, which are the draws the CPU path records; and the counts read without
/// waiting say which frame they are from, and are that frame's.
#[test]
fn timings_count_the_draws_that_drew_and_name_the_frame_of_their_counts() {
    let gpu = gpu();
    let rig = common::PosedPorgy::load();
    let full = school(&rig, 600);
    let (_, cpu) = draw(&gpu, &rig, &full, Culling::Cpu, 1.0, true);
    let (_, on_gpu) = draw(&gpu, &rig, &full, Culling::Gpu, 1.0, true);
    assert_eq!(cpu.num_nonempty_draw_calls, cpu.num_draw_calls, "{cpu:?}");
    assert_eq!(
        on_gpu.num_nonempty_draw_calls, cpu.num_draw_calls,
        "{on_gpu:?}"
    );
    assert!(
        on_gpu.num_draw_calls > on_gpu.num_nonempty_draw_calls,
        "some levels are empty: {on_gpu:?}"
    );
    assert_eq!((cpu.frame, cpu.counts_frame), (2, 2));
    assert_eq!((on_gpu.frame, on_gpu.counts_frame), (2, 2));

    // Frame f draws 100 + 60 f fish; the CPU path says how many of them are in view.
    let mut kept = renderer(&gpu, &rig, Culling::Gpu, 1.0);
    let mut reference = renderer(&gpu, &rig, Culling::Cpu, 1.0);
    let mut in_view = Vec::new();
    let mut read = 0;
    for f in 1..=8u64 {
        let mut s = full.clone();
        s.fish.truncate(100 + 60 * f as usize);
        let (_, t) = draw_with(&gpu, &mut reference, &s, true, 1);
        in_view.push(t.num_fish_drawn);
        let (_, t) = draw_with(&gpu, &mut kept, &s, true, 1);
        assert_eq!(t.frame, f);
        assert!(
            t.counts_frame < f,
            "read without waiting: an earlier frame's: {t:?}"
        );
        if t.counts_frame > 0 {
            read += 1;
            let of = in_view[t.counts_frame as usize - 1];
            assert_eq!(
                t.num_fish_drawn, of,
                "frame {f}'s counts of {}",
                t.counts_frame
            );
        }
    }
    assert!(in_view.windows(2).all(|w| w[0] < w[1]), "{in_view:?}");
    assert!(
        read >= 3,
        "counts arrive without waiting ({read} of 8 frames)"
    );
    let t = kept.read_gpu_counts(&gpu).unwrap();
    assert_eq!(
        (t.frame, t.counts_frame, t.num_fish_drawn),
        (8, 8, in_view[7])
    );
}
