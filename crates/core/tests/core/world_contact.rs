//! Hard contact: whatever a fish's motion does, its body stays in the tank and out of rocks.

use glam::Vec3;
use shoal_core::motion::RootState;
use shoal_core::world::sense::forward;
use shoal_core::world::{CONTACT_MARGIN_LENGTHS, Current, Obstacle, Tank, drift, resolve_contact};

const L: f32 = 10.0;

fn tank() -> Tank {
    Tank {
        min: Vec3::ZERO,
        max: Vec3::new(100.0, 40.0, 60.0),
    }
}

#[test]
fn a_fish_driven_into_every_wall_stays_inside_with_its_whole_body() {
    let tank = tank();
    let margin = CONTACT_MARGIN_LENGTHS * L;
    // Headings towards +x, −z, −x, +z, and pitched into the floor and the surface.
    let aims = [
        (0.0, 0.0),
        (std::f32::consts::FRAC_PI_2, 0.0),
        (std::f32::consts::PI, 0.0),
        (-std::f32::consts::FRAC_PI_2, 0.0),
        (0.7, -1.2),
        (-2.0, 1.3),
    ];
    for (heading, pitch) in aims {
        let mut root = RootState {
            pos: Vec3::new(50.0, 20.0, 30.0),
            heading,
            pitch,
            speed: 300.0,
        };
        let mut touched = 0;
        for _ in 0..600 {
            // A runaway motion: 5 units per tick straight ahead, whatever is there.
            root.pos += forward(heading, pitch) * 5.0;
            if resolve_contact(&mut root, L, &tank, &[]) {
                touched += 1;
            }
            assert!(tank.contains(root.pos), "head left the tank: {root:?}");
            let tail = root.pos - forward(heading, pitch) * L;
            assert!(
                tail.cmpge(tank.min + margin - 1e-3).all()
                    && tail.cmple(tank.max - margin + 1e-3).all(),
                "tail left the tank: {tail} ({root:?})"
            );
        }
        assert!(
            touched > 500,
            "contact is reported while pressing: {touched}"
        );
    }
}

#[test]
fn a_fish_driven_through_a_rock_is_stopped_at_its_surface() {
    let tank = tank();
    let rock = Obstacle {
        pos: Vec3::new(60.0, 20.0, 30.0),
        radius: 8.0,
    };
    let mut root = RootState {
        pos: Vec3::new(20.0, 20.0, 30.0),
        heading: 0.0,
        pitch: 0.0,
        speed: 60.0,
    };
    let mut contact = false;
    for _ in 0..300 {
        root.pos += Vec3::X * 1.0;
        contact |= resolve_contact(&mut root, L, &tank, &[rock]);
        for t in [0.0, 0.5, 1.0] {
            let p = root.pos - Vec3::X * L * t;
            assert!(
                p.distance(rock.pos) >= rock.radius - 1e-3,
                "body inside the rock at {p}"
            );
        }
    }
    assert!(contact);
    // Head-on, the fish ends pressed against the rock's near side.
    assert!(root.pos.x < rock.pos.x - rock.radius + 1e-3, "{root:?}");
}

#[test]
fn a_free_fish_is_not_touched() {
    let mut root = RootState {
        pos: Vec3::new(50.0, 20.0, 30.0),
        heading: 0.3,
        pitch: 0.1,
        speed: 10.0,
    };
    let before = root;
    assert!(!resolve_contact(&mut root, L, &tank(), &[]));
    assert_eq!(root, before);
}

#[test]
fn currents_drift_inside_and_fade_at_the_edge() {
    let c = Current {
        pos: Vec3::ZERO,
        radius: 10.0,
        velocity: Vec3::new(2.0, 0.0, 0.0),
    };
    assert_eq!(
        drift(&[c], Vec3::new(5.0, 0.0, 0.0)),
        Vec3::new(2.0, 0.0, 0.0)
    );
    // 9 is halfway through the fading outer fifth (8..10).
    assert!(drift(&[c], Vec3::new(9.0, 0.0, 0.0)).abs_diff_eq(Vec3::new(1.0, 0.0, 0.0), 1e-5));
    assert_eq!(drift(&[c], Vec3::new(11.0, 0.0, 0.0)), Vec3::ZERO);
    // Zones add up.
    assert_eq!(drift(&[c, c], Vec3::ZERO), Vec3::new(4.0, 0.0, 0.0));
}
