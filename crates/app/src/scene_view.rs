//! Editing the scene in the 3D view: with "edit scene" on, a press on a rock, a current zone or
//! a fish group's start region picks it, and dragging moves it over the horizontal plane at its
//! own height (the floor plane raised to it), live; the whole drag is one undo step
//! ([`super::scene_edit::SceneEdits`]). Current zones and start regions, which the renderer
//! does not draw, are shown as overlay lines while editing, the picked item brighter.

use glam::{Vec2, Vec3};

use super::scene_edit::{Item, UNIT_DECIMALS, round_f32};
use shoal_render::{Camera, OverlayLine};
use shoal_script::scene::SceneDesc;

/// The drag in progress: what, and where it was grabbed relative to its centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Grab {
    /// The item dragged.
    pub item: Item,
    /// Its centre minus the grabbed point on its plane.
    offset: Vec3,
    /// Height of the plane it moves over.
    plane_y: f32,
}

/// The centre of `item` in `desc`, if it exists.
pub(super) fn centre(desc: &SceneDesc, item: Item) -> Option<Vec3> {
    match item {
        Item::Rock(i) => desc.obstacles.get(i).map(|o| Vec3::from_array(o.pos)),
        Item::Zone(i) => desc.currents.get(i).map(|c| Vec3::from_array(c.pos)),
        Item::Region(g) => desc
            .fish
            .get(g)
            .and_then(|f| f.region)
            .map(|r| (Vec3::from_array(r.min) + Vec3::from_array(r.max)) * 0.5),
    }
}

/// Moves `item`'s centre to `to` (values rounded to what the panel shows; a region keeps its
/// size).
pub(super) fn move_to(desc: &mut SceneDesc, item: Item, to: Vec3) {
    let r = |v: Vec3| v.to_array().map(|x| round_f32(x, UNIT_DECIMALS));
    match item {
        Item::Rock(i) => {
            if let Some(o) = desc.obstacles.get_mut(i) {
                o.pos = r(to);
            }
        }
        Item::Zone(i) => {
            if let Some(c) = desc.currents.get_mut(i) {
                c.pos = r(to);
            }
        }
        Item::Region(g) => {
            if let Some(b) = desc.fish.get_mut(g).and_then(|f| f.region.as_mut()) {
                let (min, max) = (Vec3::from_array(b.min), Vec3::from_array(b.max));
                let half = (max - min) * 0.5;
                b.min = r(to - half);
                b.max = r(to + half);
            }
        }
    }
}

/// Distance along the ray to where it enters the box (0 inside it).
fn enter_box(origin: Vec3, dir: Vec3, min: Vec3, max: Vec3) -> Option<f32> {
    let (mut enter, mut exit) = (0.0f32, f32::INFINITY);
    for axis in 0..3 {
        let (o, d) = (origin[axis], dir[axis]);
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
    (enter <= exit).then_some(enter)
}

/// The item under the pixel `at` of a `size` view: the nearest rock or zone the ray hits, else
/// the nearest start region (a region surrounds what it holds, so it comes last).
pub(super) fn pick(camera: &Camera, at: Vec2, size: Vec2, desc: &SceneDesc) -> Option<Item> {
    let ray = camera.ray_through_pixel(at, size);
    let mut best: Option<(Item, f32)> = None;
    let keep = |best: &mut Option<(Item, f32)>, item: Item, t: Option<f32>| {
        if let Some(t) = t
            && best.is_none_or(|(_, bt)| t < bt)
        {
            *best = Some((item, t));
        }
    };
    for (i, o) in desc.obstacles.iter().enumerate() {
        keep(
            &mut best,
            Item::Rock(i),
            ray.hit_sphere(Vec3::from_array(o.pos), o.radius.max(4.0)),
        );
    }
    for (i, c) in desc.currents.iter().enumerate() {
        keep(
            &mut best,
            Item::Zone(i),
            ray.hit_sphere(Vec3::from_array(c.pos), c.radius),
        );
    }
    if best.is_some() {
        return best.map(|(item, _)| item);
    }
    for (g, f) in desc.fish.iter().enumerate() {
        if let Some(r) = f.region {
            let t = enter_box(
                ray.origin,
                ray.dir,
                Vec3::from_array(r.min),
                Vec3::from_array(r.max),
            );
            keep(&mut best, Item::Region(g), t);
        }
    }
    best.map(|(item, _)| item)
}

/// Where the ray through `at` meets the horizontal plane at height `y`.
fn on_plane(camera: &Camera, at: Vec2, size: Vec2, y: f32) -> Option<Vec3> {
    let ray = camera.ray_through_pixel(at, size);
    if ray.dir.y.abs() < 1e-4 {
        return None;
    }
    let t = (y - ray.origin.y) / ray.dir.y;
    (t > 0.0).then(|| ray.origin + ray.dir * t)
}

/// A press in the view at `at` with "edit scene" on, over the live scene `desc`: the item
/// there, if any, and the drag it starts (`None` when the pointer is off its plane).
pub(super) fn press(
    camera: &Camera,
    desc: &SceneDesc,
    at: Vec2,
    size: Vec2,
) -> Option<(Item, Option<Grab>)> {
    let item = pick(camera, at, size, desc)?;
    let c = centre(desc, item).unwrap_or_default();
    let grab = on_plane(camera, at, size, c.y).map(|hit| Grab {
        item,
        offset: c - hit,
        plane_y: c.y,
    });
    Some((item, grab))
}

/// The pointer moved to `at` while dragging `grab`: the live scene `desc` with the dragged item
/// there (kept in the tank), or `None` when the pointer is off the plane.
pub(super) fn dragged(
    camera: &Camera,
    grab: Grab,
    desc: &SceneDesc,
    at: Vec2,
    size: Vec2,
    tank: (Vec3, Vec3),
) -> Option<SceneDesc> {
    let hit = on_plane(camera, at, size, grab.plane_y)?;
    let mut desc = desc.clone();
    let to = (hit + grab.offset).clamp(tank.0, tank.1);
    move_to(&mut desc, grab.item, to);
    Some(desc)
}

/// Colour of the scene items' outlines while editing.
const ZONE: [f32; 4] = [0.2, 0.7, 1.0, 1.0];
const REGION: [f32; 4] = [1.0, 0.8, 0.2, 1.0];
const PICKED: [f32; 4] = [1.0, 1.0, 1.0, 1.0];

/// A horizontal circle of `n` segments.
fn circle(c: Vec3, r: f32, color: [f32; 4], out: &mut Vec<OverlayLine>) {
    let n = 32;
    let p = |k: usize| {
        let a = k as f32 / n as f32 * std::f32::consts::TAU;
        c + Vec3::new(a.cos() * r, 0.0, a.sin() * r)
    };
    for k in 0..n {
        out.push(OverlayLine {
            a: p(k),
            b: p(k + 1),
            color,
        });
    }
}

/// The twelve edges of a box.
fn box_edges(min: Vec3, max: Vec3, color: [f32; 4], out: &mut Vec<OverlayLine>) {
    let corner = |i: usize| {
        Vec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
    };
    for i in 0..8 {
        for bit in [1, 2, 4] {
            if i & bit == 0 {
                out.push(OverlayLine {
                    a: corner(i),
                    b: corner(i | bit),
                    color,
                });
            }
        }
    }
}

/// Outlines of the current zones and start regions (the picked item white), and a ring around
/// the picked rock.
pub(super) fn overlay(desc: &SceneDesc, picked: Option<Item>, out: &mut Vec<OverlayLine>) {
    let color = |item: Item, base: [f32; 4]| if picked == Some(item) { PICKED } else { base };
    for (i, c) in desc.currents.iter().enumerate() {
        let p = Vec3::from_array(c.pos);
        let col = color(Item::Zone(i), ZONE);
        circle(p, c.radius, col, out);
        circle(p + Vec3::Y * c.radius * 0.5, c.radius * 0.87, col, out);
        circle(p - Vec3::Y * c.radius * 0.5, c.radius * 0.87, col, out);
        out.push(OverlayLine {
            a: p,
            b: p + Vec3::from_array(c.velocity).normalize_or_zero() * c.radius * 0.8,
            color: col,
        });
    }
    for (g, f) in desc.fish.iter().enumerate() {
        if let Some(r) = f.region {
            let col = color(Item::Region(g), REGION);
            box_edges(Vec3::from_array(r.min), Vec3::from_array(r.max), col, out);
        }
    }
    if let Some(Item::Rock(i)) = picked
        && let Some(o) = desc.obstacles.get(i)
    {
        let p = Vec3::from_array(o.pos);
        circle(p, o.radius * 1.15, PICKED, out);
        circle(p, o.radius * 1.2, PICKED, out);
    }
}
