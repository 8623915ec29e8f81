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

/// Whether the pointer at `pos` (physical pixels, as the window's latest event put it) belongs
/// to the panel or another egui area rather than to the 3D view. `panel`: the side panel's
/// rect in physical pixels, as last drawn; `pixels_per_point`: egui's scale.
///
/// Decided from `pos`, not from egui's own hover state: egui learns where the pointer is only
/// when it runs its next frame, so right after the pointer leaves the panel,
/// `egui_wants_pointer_input` (and the `consumed` flag egui-winit derives from it) still say
/// "over the panel". Trusting them ate the first click in the view after the pointer left
/// the panel — for a whole frame, which on a software renderer is a quarter of a second. A
/// drag egui is carrying out (a slider, the panel's resize edge) stays egui's wherever the
/// pointer is, and so does a press on the panel's resize edge, which reaches just outside it.
pub fn pointer_over_ui(
    ctx: &egui::Context,
    pos: Vec2,
    panel: Option<egui::Rect>,
    pixels_per_point: f32,
) -> bool {
    let px = egui::pos2(pos.x, pos.y);
    // The panel's resize edge reaches a few points outside it: a press there resizes the
    // panel and must not also turn the camera.
    let grab = ctx.global_style().interaction.resize_grab_radius_side * pixels_per_point;
    if panel.is_some_and(|r| r.expand(grab).contains(px)) || ctx.egui_is_using_pointer() {
        return true;
    }
    // Windows, pop-ups and other interactable areas over the view, where they were last drawn.
    let point = px / pixels_per_point.max(f32::MIN_POSITIVE);
    ctx.layer_id_at(point)
        .is_some_and(|layer| layer.order != egui::Order::Background)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One egui frame of a window 800×600 points with a 200-point panel on the right holding
    /// a slider, the pointer events `events` fed in first.
    fn frame(ctx: &egui::Context, events: Vec<egui::Event>, value: &mut f32) -> egui::Rect {
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(800.0, 600.0),
            )),
            events,
            ..Default::default()
        };
        let mut panel = egui::Rect::NOTHING;
        let mut output = ctx.run_ui(input, |ui| {
            let shown = egui::Panel::right("tuning")
                .exact_size(200.0)
                .show(ui, |ui| {
                    ui.add(egui::Slider::new(value, 0.0..=1.0).text("speed"));
                });
            panel = shown.response.rect;
        });
        output.textures_delta.clear(); // no renderer to hand the font atlas to
        panel
    }

    #[test]
    fn a_click_just_after_leaving_the_panel_is_the_views() {
        let ctx = egui::Context::default();
        let mut value = 0.5;
        let moved = |x: f32, y: f32| egui::Event::PointerMoved(egui::pos2(x, y));
        frame(&ctx, vec![], &mut value);
        // egui's last frame saw the pointer over the panel.
        let panel = frame(&ctx, vec![moved(700.0, 300.0)], &mut value);
        assert!(panel.contains(egui::pos2(700.0, 300.0)), "{panel:?}");
        assert!(
            ctx.egui_wants_pointer_input(),
            "egui still thinks it has the pointer"
        );
        // The pointer has since moved into the view (no frame in between): the press there is
        // the view's, while one on the panel stays the panel's.
        let view = Vec2::new(300.0, 300.0);
        assert!(!pointer_over_ui(&ctx, view, Some(panel), 1.0));
        assert!(pointer_over_ui(
            &ctx,
            Vec2::new(700.0, 300.0),
            Some(panel),
            1.0
        ));
        // At 2 physical pixels per point the panel rect comes in pixels and areas in points.
        let panel_px = panel * 2.0;
        assert!(!pointer_over_ui(&ctx, view * 2.0, Some(panel_px), 2.0));
        assert!(pointer_over_ui(
            &ctx,
            Vec2::new(1400.0, 600.0),
            Some(panel_px),
            2.0
        ));
    }

    /// The resize edge is grabbed up to `resize_grab_radius_side` points outside the panel: a
    /// press there resizes the panel, so the view must not take it as the start of an orbit.
    #[test]
    fn a_press_on_the_panel_s_resize_edge_is_not_the_view_s() {
        let ctx = egui::Context::default();
        let mut value = 0.5;
        let panel = frame(&ctx, vec![], &mut value);
        let y = panel.center().y;
        let grab = ctx.global_style().interaction.resize_grab_radius_side;
        assert!(grab >= 2.0, "egui grabs the edge {grab} points out");
        let on_edge = Vec2::new(panel.left() - 0.5 * grab, y);
        assert!(pointer_over_ui(&ctx, on_edge, Some(panel), 1.0));
        assert!(pointer_over_ui(&ctx, on_edge * 2.0, Some(panel * 2.0), 2.0));
        let beyond = Vec2::new(panel.left() - grab - 2.0, y);
        assert!(!pointer_over_ui(&ctx, beyond, Some(panel), 1.0));
    }

    #[test]
    fn a_drag_egui_is_carrying_out_stays_egui_s_over_the_view() {
        let ctx = egui::Context::default();
        let mut value = 0.5;
        let button = |pos: egui::Pos2, pressed: bool| egui::Event::PointerButton {
            pos,
            button: egui::PointerButton::Primary,
            pressed,
            modifiers: egui::Modifiers::NONE,
        };
        let panel = frame(&ctx, vec![], &mut value);
        // Find the slider: press on the panel's first row and drag left into the view.
        let start = egui::pos2(panel.left() + 40.0, panel.top() + 12.0);
        frame(
            &ctx,
            vec![egui::Event::PointerMoved(start), button(start, true)],
            &mut value,
        );
        let into_view = egui::pos2(300.0, 300.0);
        frame(&ctx, vec![egui::Event::PointerMoved(into_view)], &mut value);
        assert!(ctx.egui_is_using_pointer(), "the slider is being dragged");
        assert!(pointer_over_ui(
            &ctx,
            Vec2::new(into_view.x, into_view.y),
            Some(panel),
            1.0
        ));
        // Released: the view has the pointer again.
        frame(&ctx, vec![button(into_view, false)], &mut value);
        frame(&ctx, vec![], &mut value);
        assert!(!ctx.egui_is_using_pointer());
        assert!(!pointer_over_ui(
            &ctx,
            Vec2::new(into_view.x, into_view.y),
            Some(panel),
            1.0
        ));
    }

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
