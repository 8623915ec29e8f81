//! Steering helpers (issue 5): pure functions over plain values that a behaviour combines into a
//! desired heading, depth and speed ([`Steer`]), and [`plan_steer`], which turns such a wish into
//! the motion layer's requests (which turn kind, ascend/descend, accelerate).
//!
//! The World wraps each helper for a fish handle, feeding it neighbours from the spatial grid
//! (`World::steer_*`). Angles are radians (heading counter-clockwise seen from above, 0 = +x),
//! depth is world units below the tank's surface, speed world units per second.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};
use rand::Rng;
use rand_pcg::Pcg32;

use super::sense::{bearing, forward, heading_of, tank_distances, wrap_angle};
use super::{Obstacle, Tank};
use crate::motion::{MotionKind, MotionRequest, RootState, Side, TurnKind};

/// What a behaviour wants: a heading (radians), a depth below the surface (world units) and a
/// speed (world units per second).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Steer {
    /// Desired heading, radians counter-clockwise seen from above (0 = +x).
    pub heading: f32,
    /// Desired depth below the surface, world units (positive = down).
    pub depth: f32,
    /// Desired forward speed, world units per second.
    pub speed: f32,
}

/// The steering fish, as the helpers see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Agent {
    /// Root (head) position, world units.
    pub pos: Vec3,
    /// Heading, radians.
    pub heading: f32,
    /// Pitch, radians, positive nose-up.
    pub pitch: f32,
    /// Current speed, world units per second.
    pub speed: f32,
    /// y of the water surface (the tank's `max.y`), so helpers can express depth.
    pub surface_y: f32,
    /// How far ahead a direction is followed to turn it into a depth, world units (one body
    /// length is a good default).
    pub lookahead: f32,
}

impl Agent {
    /// Current depth below the surface, world units.
    pub fn depth(&self) -> f32 {
        self.surface_y - self.pos.y
    }

    /// Keep going as now.
    pub fn hold(&self) -> Steer {
        Steer {
            heading: self.heading,
            depth: self.depth(),
            speed: self.speed,
        }
    }

    /// Swim along `dir` at `speed`: the heading of its horizontal part (the current heading if
    /// it has none) and the depth reached after `lookahead` along it.
    pub fn toward(&self, dir: Vec3, speed: f32) -> Steer {
        let Some(unit) = dir.try_normalize() else {
            return Steer {
                speed,
                ..self.hold()
            };
        };
        let heading = if unit.x.abs() + unit.z.abs() > 1e-6 {
            heading_of(unit)
        } else {
            self.heading
        };
        Steer {
            heading,
            depth: self.surface_y - (self.pos.y + unit.y * self.lookahead),
            speed,
        }
    }
}

/// Head for `target` at `speed`, aiming for the target's depth.
pub fn seek(agent: &Agent, target: Vec3, speed: f32) -> Steer {
    let d = target - agent.pos;
    let heading = if d.x.abs() + d.z.abs() > 1e-6 {
        heading_of(d)
    } else {
        agent.heading
    };
    Steer {
        heading,
        depth: agent.surface_y - target.y,
        speed,
    }
}

/// Head directly away from `threat` at `speed`.
pub fn flee(agent: &Agent, threat: Vec3, speed: f32) -> Steer {
    let away = agent.pos - threat;
    if away.length_squared() <= f32::EPSILON {
        // On top of the threat: any way out will do; keep the heading, dart.
        return Steer {
            speed,
            ..agent.hold()
        };
    }
    agent.toward(away, speed)
}

/// Seek `target`, slowing linearly to a halt inside `slow_radius` (world units).
pub fn arrive(agent: &Agent, target: Vec3, slow_radius: f32, speed: f32) -> Steer {
    let dist = agent.pos.distance(target);
    let scale = if slow_radius > 0.0 {
        (dist / slow_radius).min(1.0)
    } else {
        1.0
    };
    Steer {
        speed: speed * scale,
        ..seek(agent, target, speed)
    }
}

/// A random walk: the heading drifts by up to ±`max_turn` radians and the depth by up to
/// ±`max_depth_change` world units per call, drawn from the fish's own generator (so a seeded
/// fish wanders the same way every run).
pub fn wander(
    rng: &mut Pcg32,
    agent: &Agent,
    max_turn: f32,
    max_depth_change: f32,
    speed: f32,
) -> Steer {
    let turn = max_turn.abs() * (2.0 * rng.random::<f32>() - 1.0);
    let dive = max_depth_change.abs() * (2.0 * rng.random::<f32>() - 1.0);
    Steer {
        heading: wrap_angle(agent.heading + turn),
        depth: agent.depth() + dive,
        speed,
    }
}

/// Move away from neighbours closer than `radius`, each weighted by 1/distance (closer pushes
/// harder). `None` when no neighbour is that close (or they cancel out).
pub fn separation(
    agent: &Agent,
    neighbours: impl IntoIterator<Item = Vec3>,
    radius: f32,
    speed: f32,
) -> Option<Steer> {
    let mut push = Vec3::ZERO;
    for n in neighbours {
        let away = agent.pos - n;
        let d = away.length();
        if d > f32::EPSILON && d < radius {
            push += away / (d * d);
        }
    }
    (push.length_squared() > 1e-12).then(|| agent.toward(push, speed))
}

/// Swim the way the neighbours swim: the circular mean of their headings. `None` with no
/// neighbours or when their headings cancel out.
pub fn alignment(
    agent: &Agent,
    headings: impl IntoIterator<Item = f32>,
    speed: f32,
) -> Option<Steer> {
    let sum: Vec2 = headings
        .into_iter()
        .map(|h| Vec2::new(h.cos(), h.sin()))
        .sum();
    (sum.length_squared() > 1e-8).then(|| Steer {
        heading: sum.y.atan2(sum.x),
        depth: agent.depth(),
        speed,
    })
}

/// Head for the neighbours' centroid. `None` without neighbours.
pub fn cohesion(
    agent: &Agent,
    positions: impl IntoIterator<Item = Vec3>,
    speed: f32,
) -> Option<Steer> {
    let (sum, n) = positions
        .into_iter()
        .fold((Vec3::ZERO, 0u32), |(s, n), p| (s + p, n + 1));
    (n > 0).then(|| seek(agent, sum / n as f32, speed))
}

/// Steer round the first sphere the fish would hit within `lookahead` world units along its
/// current heading, keeping `clearance` world units from its surface: the desired heading is the
/// tangent to the inflated sphere on the side the fish already leans to. Inside the inflated
/// sphere, flee its centre. `None` when the way ahead is clear.
pub fn avoid_obstacles(
    agent: &Agent,
    obstacles: &[Obstacle],
    lookahead: f32,
    clearance: f32,
    speed: f32,
) -> Option<Steer> {
    let fwd = forward(agent.heading, 0.0);
    let mut nearest: Option<(f32, &Obstacle)> = None;
    for o in obstacles {
        let r = o.radius + clearance;
        let to_c = o.pos - agent.pos;
        let dist = to_c.length();
        if dist < r {
            return Some(agent.toward(agent.pos - o.pos, speed));
        }
        // Closest approach of the horizontal ray to the centre, and the ray parameter there.
        let t = to_c.dot(fwd);
        if t <= 0.0 || t - r > lookahead {
            continue;
        }
        let miss = (to_c - fwd * t).length();
        if miss < r && nearest.is_none_or(|(best, _)| t < best) {
            nearest = Some((t, o));
        }
    }
    let (_, o) = nearest?;
    let r = o.radius + clearance;
    let dist = agent.pos.distance(o.pos);
    let centre_bearing = bearing(agent.pos, agent.heading, o.pos);
    let offset = (r / dist).min(1.0).asin();
    // Obstacle to the left (positive bearing): pass it on the right, and vice versa.
    let heading = if centre_bearing >= 0.0 {
        agent.heading + centre_bearing - offset
    } else {
        agent.heading + centre_bearing + offset
    };
    Some(Steer {
        heading: wrap_angle(heading),
        depth: agent.depth(),
        speed,
    })
}

/// Keep `margin` world units from the tank's side walls, floor and surface. Heading into a wall
/// closer than `margin`, the desired heading is the reflection of the heading off that wall (off
/// the sum of the walls' normals in a corner); too near the floor or surface, the desired depth
/// is moved back inside. `None` when nothing is near or the fish already swims away from it.
pub fn avoid_walls(agent: &Agent, tank: &Tank, margin: f32, speed: f32) -> Option<Steer> {
    let p = agent.pos;
    let fwd = forward(agent.heading, 0.0);
    let walls = [
        (p.x - tank.min.x, Vec3::X),
        (tank.max.x - p.x, Vec3::NEG_X),
        (p.z - tank.min.z, Vec3::Z),
        (tank.max.z - p.z, Vec3::NEG_Z),
    ];
    let normal: Vec3 = walls
        .iter()
        .filter(|(d, n)| *d < margin && fwd.dot(*n) < 0.0)
        .map(|(d, n)| *n * (1.0 - (d / margin).max(0.0)).max(0.05))
        .sum();
    let (to_floor, to_surface, _, _) = tank_distances(tank, p);
    let height = tank.max.y - tank.min.y;
    let depth = agent.depth();
    let depth_margin = margin.min(height * 0.5);
    let target_depth = if to_surface < depth_margin {
        depth_margin
    } else if to_floor < depth_margin {
        height - depth_margin
    } else {
        depth
    };
    let heading = match normal.try_normalize() {
        Some(n) => {
            let reflected = fwd - 2.0 * fwd.dot(n) * n;
            // Head-on, the reflection is straight back; lean left so the turn has a side.
            if reflected.dot(fwd) < -0.999 {
                wrap_angle(agent.heading + PI - 1e-3)
            } else {
                heading_of(reflected)
            }
        }
        None if target_depth != depth => agent.heading,
        None => return None,
    };
    Some(Steer {
        heading,
        depth: target_depth,
        speed,
    })
}

/// Weighted blend of several wishes: circular mean of headings, mean of depths and speeds.
/// `None` if no weight is positive or the headings cancel out.
pub fn blend(parts: &[(Steer, f32)]) -> Option<Steer> {
    let mut dir = Vec2::ZERO;
    let (mut depth, mut speed, mut total) = (0.0, 0.0, 0.0);
    for &(s, w) in parts {
        if w.is_nan() || w <= 0.0 {
            continue;
        }
        dir += Vec2::new(s.heading.cos(), s.heading.sin()) * w;
        depth += s.depth * w;
        speed += s.speed * w;
        total += w;
    }
    (total > 0.0 && dir.length_squared() > 1e-10).then(|| Steer {
        heading: dir.y.atan2(dir.x),
        depth: depth / total,
        speed: speed / total,
    })
}

/// Thresholds of [`plan_steer`]. `Copy`, with defaults a cruising fish looks natural with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SteerParams {
    /// Cruising speed `s` of the species, world units per second.
    pub cruise_speed: f32,
    /// Body length `l`, world units.
    pub body_length: f32,
    /// Heading errors below this are ignored, radians (default 8°).
    pub heading_deadband: f32,
    /// Heading errors from this up are "large": quick or serial turn, radians (default 60°).
    pub large_turn: f32,
    /// Below this fraction of the cruising speed a large turn is a quick turn (default 0.5).
    pub slow_fraction: f32,
    /// A turn in progress is re-planned only if the wish moves further than this from where the
    /// turn is heading, radians (default 30°).
    pub retarget: f32,
    /// Depth errors below this fraction of a body length are ignored (default 0.25).
    pub depth_deadband_lengths: f32,
    /// Speed changes below this fraction of the cruising speed are ignored (default 0.1).
    pub speed_deadband: f32,
    /// Acceleration used to size an `Accelerate`'s duration, body lengths per second² (default 1).
    pub accel_lengths_per_s2: f32,
}

impl SteerParams {
    /// Defaults for a species with cruising speed `cruise_speed` and body length `body_length`.
    pub fn new(cruise_speed: f32, body_length: f32) -> Self {
        Self {
            cruise_speed,
            body_length,
            heading_deadband: 8f32.to_radians(),
            large_turn: 60f32.to_radians(),
            slow_fraction: 0.5,
            retarget: 30f32.to_radians(),
            depth_deadband_lengths: 0.25,
            speed_deadband: 0.1,
            accel_lengths_per_s2: 1.0,
        }
    }
}

/// What the last requests issued by [`plan_steer`] aim at, kept per fish so that a wish already
/// being carried out is not requested again.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SteerMemo {
    /// Heading the current turn ends at, radians.
    pub turn_target: Option<f32>,
    /// Depth the current ascent/descent ends at, world units below the surface.
    pub depth_target: Option<f32>,
    /// Speed the current accelerate/stop ends at, world units per second.
    pub speed_target: Option<f32>,
}

/// One motion request chosen by [`plan_steer`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SteerPlan {
    /// The request.
    pub request: MotionRequest,
    /// Whether to drop what is playing (true) or queue behind it.
    pub interrupt: bool,
}

fn is_background(motion: MotionKind) -> bool {
    matches!(
        motion,
        MotionKind::Swim | MotionKind::Idle | MotionKind::Accelerate | MotionKind::Stop
    )
}

fn is_climb(motion: MotionKind) -> bool {
    matches!(motion, MotionKind::Ascend | MotionKind::Descend)
}

/// Turns a wish into at most one motion request, given what the fish is doing (`playing`, the
/// motion player's current motion) and what was requested before (`memo`, updated here when
/// a request is returned). Turning comes first, then depth, then speed: one request per call, so
/// calling this every behaviour tick carries out the whole wish in a few ticks.
///
/// - heading error below `heading_deadband`: no turn;
/// - below `large_turn`: a normal turn by the error;
/// - larger: a quick turn when slower than `slow_fraction`·cruise, else a serial turn.
///
/// A turn interrupts swimming or a depth change so the fish reacts at once; a turn in progress is
/// left alone while the wish stays within `retarget` of where it is heading (no jitter).
pub fn plan_steer(
    now: &RootState,
    surface_y: f32,
    playing: MotionKind,
    memo: &mut SteerMemo,
    want: Steer,
    params: &SteerParams,
) -> Option<SteerPlan> {
    if !playing.is_turn() {
        memo.turn_target = None;
    }
    if !is_climb(playing) {
        memo.depth_target = None;
    }
    if !matches!(playing, MotionKind::Accelerate | MotionKind::Stop) {
        memo.speed_target = None;
    }

    // Turning.
    if let Some(target) = memo.turn_target
        && wrap_angle(want.heading - target).abs() <= params.retarget
    {
        return None;
    }
    let error = wrap_angle(want.heading - now.heading);
    if error.abs() > params.heading_deadband {
        let kind = if error.abs() < params.large_turn {
            TurnKind::Normal
        } else if now.speed < params.slow_fraction * params.cruise_speed {
            TurnKind::Quick
        } else {
            TurnKind::Serial
        };
        let side = if error > 0.0 { Side::Left } else { Side::Right };
        memo.turn_target = Some(wrap_angle(want.heading));
        return Some(SteerPlan {
            request: MotionRequest::Turn {
                kind,
                angle: error.abs(),
                side,
            },
            // Small corrections wait for a depth change to finish; anything else goes now.
            interrupt: playing.is_turn()
                || is_background(playing)
                || error.abs() >= params.large_turn,
        });
    }
    if playing.is_turn() {
        // Heading is close enough, but the turn still playing may overshoot; let it finish.
        return None;
    }

    // Depth.
    let depth_now = surface_y - now.pos.y;
    let deadband = params.depth_deadband_lengths * params.body_length;
    let depth_error = want.depth - depth_now;
    let depth_busy = memo
        .depth_target
        .is_some_and(|d| (d - want.depth).abs() <= deadband);
    if depth_error.abs() > deadband && !depth_busy {
        memo.depth_target = Some(want.depth);
        let request = if depth_error > 0.0 {
            MotionRequest::Descend { depth: depth_error }
        } else {
            MotionRequest::Ascend {
                height: -depth_error,
            }
        };
        return Some(SteerPlan {
            request,
            interrupt: is_background(playing) || is_climb(playing),
        });
    }
    if is_climb(playing) {
        return None;
    }

    // Speed.
    let speed = want.speed.max(0.0);
    let current = memo.speed_target.unwrap_or(now.speed);
    let deadband = (params.speed_deadband * params.cruise_speed).max(1e-3);
    let idle_but_asked_to_swim = playing == MotionKind::Idle && speed > deadband;
    if (speed - current).abs() > deadband || idle_but_asked_to_swim {
        let change = (speed - now.speed).abs();
        let accel = (params.accel_lengths_per_s2 * params.body_length).max(1e-3);
        let duration = (change / accel).clamp(0.25, 3.0);
        memo.speed_target = Some(speed);
        let request = if speed <= deadband {
            MotionRequest::Stop { duration }
        } else {
            MotionRequest::Accelerate { speed, duration }
        };
        return Some(SteerPlan {
            request,
            interrupt: true,
        });
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use std::f32::consts::FRAC_PI_2;

    fn agent(pos: Vec3, heading: f32) -> Agent {
        Agent {
            pos,
            heading,
            pitch: 0.0,
            speed: 10.0,
            surface_y: 100.0,
            lookahead: 10.0,
        }
    }

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn seek_points_at_the_target_and_takes_its_depth() {
        let a = agent(Vec3::new(0.0, 50.0, 0.0), 0.0);
        let s = seek(&a, Vec3::new(0.0, 40.0, -20.0), 7.0);
        // Target along −z: a quarter turn to the left.
        assert!(close(s.heading, FRAC_PI_2, 1e-6), "{s:?}");
        assert!(close(s.depth, 60.0, 1e-6));
        assert_eq!(s.speed, 7.0);
    }

    #[test]
    fn flee_points_away_and_climbs_away_from_a_threat_below() {
        let a = agent(Vec3::new(0.0, 50.0, 0.0), 0.0);
        let s = flee(&a, Vec3::new(10.0, 40.0, 0.0), 20.0);
        assert!(close(s.heading.abs(), PI, 1e-5), "{s:?}");
        assert!(s.depth < a.depth(), "climbs: {s:?}");
    }

    #[test]
    fn arrive_slows_inside_the_radius() {
        let a = agent(Vec3::ZERO, 0.0);
        assert_eq!(arrive(&a, Vec3::new(5.0, 0.0, 0.0), 10.0, 8.0).speed, 4.0);
        assert_eq!(arrive(&a, Vec3::new(50.0, 0.0, 0.0), 10.0, 8.0).speed, 8.0);
    }

    #[test]
    fn wander_stays_within_its_bounds_and_repeats_with_the_seed() {
        let a = agent(Vec3::new(0.0, 50.0, 0.0), 1.0);
        let mut r1 = Pcg32::seed_from_u64(9);
        let mut r2 = Pcg32::seed_from_u64(9);
        for _ in 0..100 {
            let s1 = wander(&mut r1, &a, 0.3, 2.0, 5.0);
            let s2 = wander(&mut r2, &a, 0.3, 2.0, 5.0);
            assert_eq!(s1, s2);
            assert!(wrap_angle(s1.heading - 1.0).abs() <= 0.3 + 1e-6);
            assert!((s1.depth - 50.0).abs() <= 2.0 + 1e-5);
        }
    }

    #[test]
    fn separation_pushes_away_from_the_close_neighbour() {
        let a = agent(Vec3::new(0.0, 50.0, 0.0), 0.0);
        // One neighbour just ahead-left (−z is left), a far one ignored.
        let s = separation(
            &a,
            [Vec3::new(1.0, 50.0, -1.0), Vec3::new(100.0, 50.0, 0.0)],
            5.0,
            3.0,
        )
        .unwrap();
        // Away from (1, −1) is (−1, +1): heading −3π/4 (behind and to the right).
        assert!(close(s.heading, -3.0 * PI / 4.0, 1e-5), "{s:?}");
        assert!(separation(&a, [Vec3::new(100.0, 0.0, 0.0)], 5.0, 3.0).is_none());
    }

    #[test]
    fn alignment_averages_headings() {
        let a = agent(Vec3::ZERO, 0.0);
        let s = alignment(&a, [0.2, 0.6], 1.0).unwrap();
        assert!(close(s.heading, 0.4, 1e-5), "{s:?}");
        // Across the ±π seam the mean is π, not 0.
        let s = alignment(&a, [PI - 0.1, -PI + 0.1], 1.0).unwrap();
        assert!(close(s.heading.abs(), PI, 1e-5), "{s:?}");
        assert!(alignment(&a, [], 1.0).is_none());
    }

    #[test]
    fn cohesion_seeks_the_centroid() {
        let a = agent(Vec3::new(0.0, 50.0, 0.0), 0.0);
        let s = cohesion(
            &a,
            [Vec3::new(10.0, 50.0, 10.0), Vec3::new(10.0, 50.0, -10.0)],
            1.0,
        )
        .unwrap();
        assert!(close(s.heading, 0.0, 1e-6), "{s:?}");
    }

    #[test]
    fn avoid_obstacles_turns_away_from_the_side_the_obstacle_is_on() {
        let a = agent(Vec3::new(0.0, 50.0, 0.0), 0.0);
        // Sphere ahead, slightly to the left (−z): pass on the right (heading decreases).
        let rock = Obstacle {
            pos: Vec3::new(20.0, 50.0, -2.0),
            radius: 5.0,
        };
        let s = avoid_obstacles(&a, &[rock], 30.0, 1.0, 5.0).unwrap();
        assert!(s.heading < 0.0, "{s:?}");
        // The new heading's ray clears the inflated sphere (tangent).
        let f = forward(s.heading, 0.0);
        let t = (rock.pos - a.pos).dot(f);
        let miss = (rock.pos - a.pos - f * t).length();
        assert!(miss >= 6.0 - 1e-3, "miss {miss}");
        // Out of reach or behind: nothing to do.
        assert!(avoid_obstacles(&a, &[rock], 5.0, 1.0, 5.0).is_none());
        let behind = Obstacle {
            pos: Vec3::new(-20.0, 50.0, 0.0),
            radius: 5.0,
        };
        assert!(avoid_obstacles(&a, &[behind], 30.0, 1.0, 5.0).is_none());
    }

    #[test]
    fn avoid_walls_reflects_the_heading_off_a_near_wall() {
        let tank = Tank {
            min: Vec3::ZERO,
            max: Vec3::splat(100.0),
        };
        // Near the +x wall, heading 30° left of +x: reflect to 150°.
        let a = agent(Vec3::new(95.0, 50.0, 50.0), 30f32.to_radians());
        let s = avoid_walls(&a, &tank, 10.0, 5.0).unwrap();
        assert!(close(s.heading, 150f32.to_radians(), 1e-4), "{s:?}");
        // Same place but swimming away: nothing to do.
        let a = agent(Vec3::new(95.0, 50.0, 50.0), PI);
        assert!(avoid_walls(&a, &tank, 10.0, 5.0).is_none());
        // Near the surface: go deeper.
        let a = agent(Vec3::new(50.0, 98.0, 50.0), 0.0);
        let s = avoid_walls(&a, &tank, 10.0, 5.0).unwrap();
        assert!(close(s.depth, 10.0, 1e-5), "{s:?}");
    }

    #[test]
    fn blend_weights_headings_on_the_circle() {
        let a = Steer {
            heading: 0.0,
            depth: 10.0,
            speed: 2.0,
        };
        let b = Steer {
            heading: FRAC_PI_2,
            depth: 20.0,
            speed: 4.0,
        };
        let s = blend(&[(a, 1.0), (b, 1.0)]).unwrap();
        assert!(close(s.heading, PI / 4.0, 1e-6));
        assert!(close(s.depth, 15.0, 1e-6) && close(s.speed, 3.0, 1e-6));
        assert!(blend(&[(a, 0.0)]).is_none());
    }

    fn root(heading: f32, speed: f32, y: f32) -> RootState {
        RootState {
            pos: Vec3::new(0.0, y, 0.0),
            heading,
            pitch: 0.0,
            speed,
        }
    }

    fn want(heading: f32, depth: f32, speed: f32) -> Steer {
        Steer {
            heading,
            depth,
            speed,
        }
    }

    #[test]
    fn plan_steer_picks_the_turn_kind() {
        let p = SteerParams::new(50.0, 50.0);
        let mut memo = SteerMemo::default();
        // Small error: normal turn to the left by the error.
        let plan = plan_steer(
            &root(0.0, 50.0, 50.0),
            100.0,
            MotionKind::Swim,
            &mut memo,
            want(0.3, 50.0, 50.0),
            &p,
        )
        .unwrap();
        assert_eq!(
            plan.request,
            MotionRequest::Turn {
                kind: TurnKind::Normal,
                angle: 0.3,
                side: Side::Left
            }
        );
        assert!(plan.interrupt);
        // Large error while fast: serial turn; to the right.
        let mut memo = SteerMemo::default();
        let plan = plan_steer(
            &root(0.0, 50.0, 50.0),
            100.0,
            MotionKind::Swim,
            &mut memo,
            want(-2.0, 50.0, 50.0),
            &p,
        )
        .unwrap();
        assert_eq!(
            plan.request,
            MotionRequest::Turn {
                kind: TurnKind::Serial,
                angle: 2.0,
                side: Side::Right
            }
        );
        // Large error while slow: quick turn.
        let mut memo = SteerMemo::default();
        let plan = plan_steer(
            &root(0.0, 10.0, 50.0),
            100.0,
            MotionKind::Swim,
            &mut memo,
            want(2.0, 50.0, 10.0),
            &p,
        )
        .unwrap();
        assert!(matches!(
            plan.request,
            MotionRequest::Turn {
                kind: TurnKind::Quick,
                side: Side::Left,
                ..
            }
        ));
        // Tiny error: nothing.
        let mut memo = SteerMemo::default();
        assert!(
            plan_steer(
                &root(0.0, 50.0, 50.0),
                100.0,
                MotionKind::Swim,
                &mut memo,
                want(0.05, 50.0, 50.0),
                &p
            )
            .is_none()
        );
    }

    #[test]
    fn plan_steer_does_not_repeat_a_turn_in_progress() {
        let p = SteerParams::new(50.0, 50.0);
        let mut memo = SteerMemo::default();
        let now = root(0.0, 50.0, 50.0);
        assert!(
            plan_steer(
                &now,
                100.0,
                MotionKind::Swim,
                &mut memo,
                want(1.0, 50.0, 50.0),
                &p
            )
            .is_some()
        );
        // Half-way through the turn, the same wish (slightly moved) requests nothing.
        let half = root(0.5, 50.0, 50.0);
        assert!(
            plan_steer(
                &half,
                100.0,
                MotionKind::NormalTurn,
                &mut memo,
                want(1.1, 50.0, 50.0),
                &p
            )
            .is_none()
        );
        // A wish on the other side re-plans at once, interrupting.
        let plan = plan_steer(
            &half,
            100.0,
            MotionKind::NormalTurn,
            &mut memo,
            want(-1.0, 50.0, 50.0),
            &p,
        )
        .unwrap();
        assert!(plan.interrupt);
        assert!(matches!(
            plan.request,
            MotionRequest::Turn {
                side: Side::Right,
                ..
            }
        ));
    }

    #[test]
    fn plan_steer_changes_depth_then_speed() {
        let p = SteerParams::new(50.0, 50.0);
        let mut memo = SteerMemo::default();
        // Depth now 50 (surface 100, y 50); want 80: descend 30.
        let now = root(0.0, 50.0, 50.0);
        let plan = plan_steer(
            &now,
            100.0,
            MotionKind::Swim,
            &mut memo,
            want(0.0, 80.0, 50.0),
            &p,
        )
        .unwrap();
        assert_eq!(plan.request, MotionRequest::Descend { depth: 30.0 });
        // While descending, the same wish asks nothing more.
        assert!(
            plan_steer(
                &now,
                100.0,
                MotionKind::Descend,
                &mut memo,
                want(0.0, 80.0, 50.0),
                &p
            )
            .is_none()
        );
        // Want to go up: ascend.
        let mut memo = SteerMemo::default();
        let plan = plan_steer(
            &now,
            100.0,
            MotionKind::Swim,
            &mut memo,
            want(0.0, 20.0, 50.0),
            &p,
        )
        .unwrap();
        assert_eq!(plan.request, MotionRequest::Ascend { height: 30.0 });
        // On heading and depth, faster: accelerate, once.
        let mut memo = SteerMemo::default();
        let plan = plan_steer(
            &now,
            100.0,
            MotionKind::Swim,
            &mut memo,
            want(0.0, 50.0, 100.0),
            &p,
        )
        .unwrap();
        assert!(matches!(
            plan.request,
            MotionRequest::Accelerate { speed: 100.0, .. }
        ));
        assert!(
            plan_steer(
                &now,
                100.0,
                MotionKind::Accelerate,
                &mut memo,
                want(0.0, 50.0, 100.0),
                &p
            )
            .is_none()
        );
        // Speed zero: stop.
        let mut memo = SteerMemo::default();
        let plan = plan_steer(
            &now,
            100.0,
            MotionKind::Swim,
            &mut memo,
            want(0.0, 50.0, 0.0),
            &p,
        )
        .unwrap();
        assert!(matches!(plan.request, MotionRequest::Stop { .. }));
    }
}
