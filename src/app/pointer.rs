//! [`Pointer`]: which mouse presses belong to the 3D view (orbit, pan, pick) and which to the
//! panel.

use glam::Vec2;
use winit::event::MouseButton;

/// Distance in physical pixels a press may move and still count as a click.
const CLICK_SLOP_PX: f32 = 4.0;

/// The mouse as the 3D view sees it: where it is and which button went down in the view.
///
/// A press that egui took (over the panel) is not the view's: its drag does not orbit and its
/// release picks no fish. A release picks only when its press was the view's, with the left
/// button, and the pointer did not move further than [`CLICK_SLOP_PX`] in between.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Pointer {
    /// Last cursor position, physical pixels from the top-left.
    pub cursor: Vec2,
    /// The button pressed in the view and where.
    press: Option<(MouseButton, Vec2)>,
    dragged: bool,
}

impl Pointer {
    /// The cursor moved to `p`; returns the button held in the view and the move, if dragging.
    pub fn moved(&mut self, p: Vec2) -> Option<(MouseButton, Vec2)> {
        let delta = p - self.cursor;
        self.cursor = p;
        let (button, start) = self.press?;
        if (p - start).length() > CLICK_SLOP_PX {
            self.dragged = true;
        }
        Some((button, delta))
    }

    /// A button went down at the cursor; `over_ui` when egui has the pointer there.
    pub fn pressed(&mut self, button: MouseButton, over_ui: bool) {
        self.press = (!over_ui).then_some((button, self.cursor));
        self.dragged = false;
    }

    /// A button came up; returns where to pick a fish when this ends a click in the view.
    pub fn released(&mut self, button: MouseButton) -> Option<Vec2> {
        let press = self.press.take()?;
        (press.0 == button && button == MouseButton::Left && !self.dragged).then_some(self.cursor)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_click_in_the_view_picks_and_a_click_egui_took_does_not() {
        let mut p = Pointer::default();
        p.moved(Vec2::new(100.0, 100.0));
        p.pressed(MouseButton::Left, false);
        assert_eq!(p.released(MouseButton::Left), Some(Vec2::new(100.0, 100.0)));
        // Over the panel: the press is egui's, so its release picks nothing.
        p.pressed(MouseButton::Left, true);
        assert_eq!(p.released(MouseButton::Left), None);
        // A press on the panel dragged into the view neither orbits nor picks.
        p.pressed(MouseButton::Left, true);
        assert_eq!(p.moved(Vec2::new(300.0, 100.0)), None);
        assert_eq!(p.released(MouseButton::Left), None);
    }

    #[test]
    fn a_drag_in_the_view_orbits_and_does_not_pick() {
        let mut p = Pointer::default();
        p.moved(Vec2::new(10.0, 10.0));
        p.pressed(MouseButton::Left, false);
        assert_eq!(
            p.moved(Vec2::new(40.0, 10.0)),
            Some((MouseButton::Left, Vec2::new(30.0, 0.0)))
        );
        assert_eq!(p.released(MouseButton::Left), None, "a drag is not a click");
        // A right click never picks.
        p.pressed(MouseButton::Right, false);
        assert_eq!(p.released(MouseButton::Right), None);
        // Moving less than the slop still clicks.
        p.pressed(MouseButton::Left, false);
        p.moved(Vec2::new(42.0, 11.0));
        assert_eq!(p.released(MouseButton::Left), Some(Vec2::new(42.0, 11.0)));
    }
}
