//! Body curve → joint angles (paper 3.4 Fig. 5 and 3.5.3).
//!
//! The motion functions give the midline's sideways displacement along the body. The vertebral
//! chain is rigid segments joined at the driven joints, so the curve is sampled at the head, at
//! each driven joint and at the tail tip; each segment's angle to the body axis follows from its
//! two end samples, and a joint's local yaw is the bend between the segment behind it and the one
//! in front, weighted by the joint's power after Fig. 5.

use glam::Vec3;

use super::{Body, MotionError, RootState};

/// Power weight of a joint at `x` (fraction of body length from the head), after Fig. 5.
///
/// Fig. 5 (from Altringham & Ellerby, the paper's ref. \[15\]) shows the instantaneous muscle power
/// at three places along the black porgy, A (anterior), B (middle) and C (posterior); in
/// carangiform swimmers the posterior myotomes deliver most of the power and the front of the body
/// mostly stiffens. We read the three curves' peaks as weights A = 0.6 at x = 0.3, B = 0.8 at
/// x = 0.55 and C = 1.0 at x = 0.8, interpolate linearly between them and hold the end values
/// outside. For the default six joints (x = 1/7 … 6/7) this gives 0.6, 0.6, 0.70, 0.83, 0.93, 1.0.
pub fn power_after_fig5(x: f32) -> f32 {
    const A: (f32, f32) = (0.3, 0.6);
    const B: (f32, f32) = (0.55, 0.8);
    const C: (f32, f32) = (0.8, 1.0);
    if x <= A.0 {
        A.1
    } else if x <= B.0 {
        A.1 + (x - A.0) / (B.0 - A.0) * (B.1 - A.1)
    } else if x <= C.0 {
        B.1 + (x - B.0) / (C.0 - B.0) * (C.1 - B.1)
    } else {
        C.1
    }
}

/// How strongly each driven joint bends, as a function of its place along the body.
///
/// The paper's Fig. 5 is the black porgy's (a carangiform fish: the rear myotomes deliver most of
/// the power). Anguilliform swimmers such as eels undulate and push along the whole body
/// (Gillis 1998; Müller et al. 2001: the flow beside a swimming eel grows almost linearly from
/// head to tail, thrust is made all along the body), so a species may choose uniform weights.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PowerProfile {
    /// [`power_after_fig5`] (the default, the paper's black porgy).
    #[default]
    Fig5,
    /// Every joint weight 1: the body bends as the wave says, all along.
    Uniform,
}

impl PowerProfile {
    /// The weight of a joint at `x` (fraction of body length from the head).
    pub fn weight(self, x: f32) -> f32 {
        match self {
            PowerProfile::Fig5 => power_after_fig5(x),
            PowerProfile::Uniform => 1.0,
        }
    }
}

impl Body {
    /// The paper's default: 7 vertebral segments of equal length, so 6 driven joints at
    /// x = 1/7 … 6/7, then the tail tip at 1; weights from [`power_after_fig5`].
    pub fn black_porgy() -> Self {
        Self::evenly_spaced(7)
    }

    /// `num_segments` equal segments (at least 2): driven joints at k/num_segments for
    /// k = 1 … num_segments − 1, the tail tip at 1, weights from [`power_after_fig5`].
    pub fn evenly_spaced(num_segments: usize) -> Self {
        let n = num_segments.max(2);
        let joints_x: Vec<f32> = (1..=n).map(|k| k as f32 / n as f32).collect();
        let power = joints_x[..n - 1]
            .iter()
            .map(|&x| power_after_fig5(x))
            .collect();
        Self {
            joints_x,
            power,
            mass: Vec::new(),
        }
    }

    /// Number of driven joints (entries of `yaw`); `joints_x` has one more (the tail tip).
    pub fn num_joints(&self) -> usize {
        self.power.len()
    }

    /// Checks that `joints_x` rises strictly inside (0, 1) and ends at the tail tip 1.0, and that
    /// there is one finite, non-negative power weight per driven joint.
    pub fn validate(&self) -> Result<(), MotionError> {
        let bad = |why: String| Err(MotionError::InvalidBody { why });
        if self.joints_x.len() < 2 {
            return bad(format!(
                "joints_x has {} entries; it needs at least one driven joint and the tail tip",
                self.joints_x.len()
            ));
        }
        if self.power.len() + 1 != self.joints_x.len() {
            return bad(format!(
                "{} power weights for {} driven joints (joints_x has {} entries including the tail tip)",
                self.power.len(),
                self.joints_x.len() - 1,
                self.joints_x.len()
            ));
        }
        let mut previous = 0.0;
        for (i, &x) in self.joints_x.iter().enumerate() {
            if !x.is_finite() || x <= previous || x > 1.0 {
                return bad(format!(
                    "joints_x[{i}] = {x} must be finite, above the previous entry ({previous}) and at most 1"
                ));
            }
            previous = x;
        }
        if self.joints_x[self.joints_x.len() - 1] != 1.0 {
            return bad(format!(
                "the last entry of joints_x is {}, but it must be the tail tip 1.0",
                self.joints_x[self.joints_x.len() - 1]
            ));
        }
        for (i, &w) in self.power.iter().enumerate() {
            if !w.is_finite() || w < 0.0 {
                return bad(format!(
                    "power[{i}] = {w} must be a finite, non-negative weight"
                ));
            }
        }
        if !self.mass.is_empty() {
            if self.mass.len() != self.joints_x.len() {
                return bad(format!(
                    "{} mass shares for {} segments (one per joints_x entry, or none)",
                    self.mass.len(),
                    self.joints_x.len()
                ));
            }
            if let Some((i, m)) = self
                .mass
                .iter()
                .enumerate()
                .find(|(_, m)| !m.is_finite() || **m < 0.0)
            {
                return bad(format!(
                    "mass[{i}] = {m} must be a finite, non-negative share"
                ));
            }
            let total: f32 = self.mass.iter().sum();
            if (total - 1.0).abs() > 1e-3 {
                return bad(format!("the mass shares sum to {total}, not 1"));
            }
        }
        Ok(())
    }

    /// The sideways position of the posed body's centre of mass, length units (positive left):
    /// each segment's share of [`Body::mass`] at the mean of its two ends' displacement.
    /// `head_lateral` is the head's displacement, `lateral` each `joints_x` entry's. 0 when the
    /// body has no mass model.
    ///
    /// A swimming fish is not held on a rail: the water pushes its undulating body sideways and
    /// back, and the body recoils so that its centre of mass travels nearly straight (Lighthill's
    /// recoil). Posing subtracts this from the midline, which is why a real carangiform fish
    /// keeps a few thousandths of a body length at its quietest point instead of a still node
    /// (docs/motion.md, "Readings of the paper", 19).
    pub fn recoil(&self, head_lateral: f32, lateral: &[f32]) -> f32 {
        let mut front = head_lateral;
        let mut centre = 0.0;
        for (&m, &y) in self.mass.iter().zip(lateral) {
            centre += m * 0.5 * (front + y);
            front = y;
        }
        centre
    }
}

/// Each segment's share of the body's mass — head to the first driven joint, joint to joint, the
/// last ending at the tail tip (x = 1) — from the body's cross-sections: `sections` holds, for
/// `n` equal slices from the snout (x = 0) to the tail tip, the extent of the body across
/// (`width`) and up (`depth`) in any unit, and a slice's mass is the area of the ellipse they
/// span times its length (a uniform density). Slices with no extent (no vertex fell in them) take
/// the mean of their nearest neighbours that have one. Returns an empty list when the sections
/// carry no area (no recoil).
pub fn mass_shares(joints_x: &[f32], sections: &[(f32, f32)]) -> Vec<f32> {
    let n = sections.len();
    let mut area: Vec<Option<f32>> = sections
        .iter()
        .map(|&(w, d)| {
            let a = std::f32::consts::FRAC_PI_4 * w * d;
            (a.is_finite() && a > 0.0).then_some(a)
        })
        .collect();
    let known: Vec<usize> = (0..n).filter(|&i| area[i].is_some()).collect();
    if known.is_empty() {
        return Vec::new();
    }
    for i in 0..n {
        if area[i].is_none() {
            let before = known.iter().rev().find(|&&k| k < i).and_then(|&k| area[k]);
            let after = known.iter().find(|&&k| k > i).and_then(|&k| area[k]);
            area[i] = match (before, after) {
                (Some(a), Some(b)) => Some(0.5 * (a + b)),
                (a, b) => a.or(b),
            };
        }
    }
    let mut shares = vec![0.0f32; joints_x.len()];
    for (i, a) in area.iter().enumerate() {
        let x = (i as f32 + 0.5) / n as f32;
        let segment = joints_x
            .iter()
            .position(|&j| x < j)
            .unwrap_or(joints_x.len() - 1);
        shares[segment] += a.unwrap_or(0.0);
    }
    let total: f32 = shares.iter().sum();
    if !(total.is_finite() && total > 0.0) {
        return Vec::new();
    }
    shares.iter_mut().for_each(|m| *m /= total);
    shares
}

/// Most midline segments (head segment included) the four-lane path of [`curve_to_yaw`] takes;
/// longer bodies take the one-by-one path. A multiple of four, above the world's 16 driven
/// joints + 1.
const LANE_SEGMENTS: usize = 20;

/// The arctangent of each of the first `n` entries of `x` (n ≤ [`LANE_SEGMENTS`]), four at a
/// time.
#[inline]
fn atan_four_at_a_time(x: &[f32; LANE_SEGMENTS], n: usize) -> [f32; LANE_SEGMENTS] {
    let mut out = [0.0; LANE_SEGMENTS];
    for (i, o) in x
        .chunks_exact(4)
        .zip(out.chunks_exact_mut(4))
        .take(n.div_ceil(4))
    {
        let v = wide::f32x4::new([i[0], i[1], i[2], i[3]]).atan();
        o.copy_from_slice(&v.to_array());
    }
    out
}

/// Turns midline samples into joint yaws. Returns the head segment's yaw relative to the heading
/// (radians, counter-clockwise seen from above).
///
/// `lateral_head` is the displacement at the head (x = 0), `lateral` at each entry of `joints_x`
/// (length units, positive to the fish's left). Segment k runs from joint k to the next sample;
/// its angle θ_k = atan2(Δlateral, Δx·l) leans towards the left as it goes tail-wards. Joint k's
/// yaw is power[k]·(θ_k − θ_{k−1}), with θ_{−1} the head segment's angle. Lengths are asserted.
///
/// A valid body's segments all run tail-wards (Δx > 0), where atan2(rise, run) is atan(rise/run):
/// those angles are taken four at a time (`wide`'s vector arctangent, within about an ulp of
/// the scalar one); any other body, or one with more than [`LANE_SEGMENTS`] segments, takes
/// [`segment_angle`] one by one.
pub(crate) fn curve_to_yaw(
    l: f32,
    joints_x: &[f32],
    power: &[f32],
    lateral_head: f32,
    lateral: &[f32],
    yaw: &mut [f32],
) -> f32 {
    assert_eq!(
        lateral.len(),
        joints_x.len(),
        "lateral: one entry per joints_x"
    );
    assert_eq!(
        yaw.len() + 1,
        joints_x.len(),
        "yaw: one entry per driven joint"
    );
    assert_eq!(power.len(), yaw.len(), "power: one entry per driven joint");
    // Segment k's rise and run: k = 0 is the head segment, k > 0 the one behind joint k − 1.
    let segment = |k: usize| {
        if k == 0 {
            (lateral[0] - lateral_head, joints_x[0] * l)
        } else {
            (
                lateral[k] - lateral[k - 1],
                (joints_x[k] - joints_x[k - 1]) * l,
            )
        }
    };
    let n = joints_x.len();
    let mut slope = [0.0; LANE_SEGMENTS];
    let lanes = n <= LANE_SEGMENTS
        && (0..n).all(|k| {
            let (rise, run) = segment(k);
            slope[k] = rise / run;
            run > 0.0
        });
    if !lanes {
        let (rise, run) = segment(0);
        let theta_head = segment_angle(rise, run);
        let mut theta_prev = theta_head;
        for k in 0..yaw.len() {
            let (rise, run) = segment(k + 1);
            let theta = segment_angle(rise, run);
            yaw[k] = power[k] * (theta - theta_prev);
            theta_prev = theta;
        }
        return -theta_head;
    }
    let theta = atan_four_at_a_time(&slope, n);
    for k in 0..yaw.len() {
        yaw[k] = power[k] * (theta[k + 1] - theta[k]);
    }
    -theta[0]
}

/// A segment's angle to the body axis, radians: atan2(`rise`, `run`), with `rise` its sideways
/// and `run` its lengthwise extent (length units).
///
/// A valid body's segments all run tail-wards (`run` > 0), where atan2(rise, run) is
/// atan(rise/run): the same angle, and the single-argument function costs less than half as much
/// (glibc's `atan2f` is a wrapper, special-case checks and then `atanf` of the same quotient, so
/// the values are identical there; elsewhere they differ at most by the quotient's rounding).
/// Any other `run` (an invalid body) takes `atan2`.
#[inline]
fn segment_angle(rise: f32, run: f32) -> f32 {
    if run > 0.0 {
        (rise / run).atan()
    } else {
        rise.atan2(run)
    }
}

/// Places the posed vertebral chain in the world: the head, each driven joint and the tail tip.
///
/// Forward kinematics of the rigid planar chain in the root's frame (pitch included): the head sits
/// `head_lateral` to the fish's left of `root.pos`, the head segment points along
/// `root.heading + head_yaw`, and each joint bends the part behind it by its `yaw` (positive to the
/// left). Segment lengths are the rest lengths Δx·l. Used by the plots and tests; never allocates.
#[derive(Debug)]
pub struct MidlinePoseJob<'a> {
    /// The root (position at the head end, heading, pitch).
    pub root: &'a RootState,
    /// The body the yaws belong to.
    pub body: &'a Body,
    /// Body length, length units.
    pub l: f32,
    /// The head's sideways offset from `root.pos`, length units, positive left
    /// ([`super::MotionPlayer::head_lateral`]).
    pub head_lateral: f32,
    /// The head segment's yaw relative to the heading, radians CCW ([`super::MotionPlayer::head_yaw`]).
    pub head_yaw: f32,
    /// One local yaw per driven joint, radians, positive bends towards the left.
    pub yaw: &'a [f32],
    /// Output: head, then each driven joint, then the tail tip (`joints_x.len() + 1` points).
    pub points: &'a mut [Vec3],
}

impl MidlinePoseJob<'_> {
    /// Checks the body and that `yaw` and `points` have the sizes the body implies.
    pub fn validate(&self) -> Result<(), MotionError> {
        self.body.validate()?;
        if self.yaw.len() != self.body.num_joints() {
            return Err(MotionError::InvalidBody {
                why: format!(
                    "yaw has {} entries, expected {} (one per driven joint)",
                    self.yaw.len(),
                    self.body.num_joints()
                ),
            });
        }
        if self.points.len() != self.body.joints_x.len() + 1 {
            return Err(MotionError::InvalidBody {
                why: format!(
                    "points has {} entries, expected {} (head, driven joints, tail tip)",
                    self.points.len(),
                    self.body.joints_x.len() + 1
                ),
            });
        }
        if !self.l.is_finite() || self.l <= 0.0 {
            return Err(MotionError::InvalidParam {
                name: "l",
                value: self.l,
                why: "body length must be positive".to_owned(),
            });
        }
        Ok(())
    }

    /// Validates, then writes the points.
    pub fn run(self) -> Result<(), MotionError> {
        self.validate()?;
        let rotation = self.root.rotation();
        // Body frame: +x forward, −z left. (back, left) → (−back, 0, −left).
        let to_world =
            |back: f32, left: f32| self.root.pos + rotation * Vec3::new(-back, 0.0, -left);
        let mut back = 0.0;
        let mut left = self.head_lateral;
        // Angle of the tail-ward direction, measured from straight back towards the left.
        let mut alpha = -self.head_yaw;
        let mut x_prev = 0.0;
        self.points[0] = to_world(back, left);
        for (k, &x) in self.body.joints_x.iter().enumerate() {
            if k > 0 {
                alpha += self.yaw[k - 1];
            }
            let len = (x - x_prev) * self.l;
            back += len * alpha.cos();
            left += len * alpha.sin();
            x_prev = x;
            self.points[k + 1] = to_world(back, left);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// curve_to_yaw as atan2 of each segment, one by one (the definition).
    fn yaw_by_definition(
        l: f32,
        joints_x: &[f32],
        power: &[f32],
        head: f32,
        lateral: &[f32],
    ) -> (f32, Vec<f32>) {
        let angle = |k: usize| {
            let (rise, run) = if k == 0 {
                (lateral[0] - head, joints_x[0] * l)
            } else {
                (
                    lateral[k] - lateral[k - 1],
                    (joints_x[k] - joints_x[k - 1]) * l,
                )
            };
            rise.atan2(run)
        };
        let yaw = (0..power.len())
            .map(|k| power[k] * (angle(k + 1) - angle(k)))
            .collect();
        (-angle(0), yaw)
    }

    #[test]
    fn test_curve_to_yaw_four_at_a_time_is_the_definition_to_rounding() {
        // Bodies of 3 to 24 segments (the four-lane path up to 20, one by one beyond), bent
        // gently and sharply (slopes up to ±3, past the arctangent's polynomial ranges).
        for n in 3..=24usize {
            let joints_x: Vec<f32> = (1..=n).map(|k| k as f32 / n as f32).collect();
            let power: Vec<f32> = (0..n - 1).map(|k| 0.5 + 0.1 * k as f32).collect();
            for amp in [0.01f32, 0.3, 3.0] {
                let lateral: Vec<f32> = (0..n)
                    .map(|k| amp * (k as f32 * 1.7).sin() * (1.0 + k as f32))
                    .collect();
                let head = -0.4 * amp;
                let mut yaw = vec![0.0; n - 1];
                let head_yaw = curve_to_yaw(2.0, &joints_x, &power, head, &lateral, &mut yaw);
                let (want_head, want) = yaw_by_definition(2.0, &joints_x, &power, head, &lateral);
                assert!((head_yaw - want_head).abs() < 1e-6, "n {n}, amp {amp}");
                for (k, (got, want)) in yaw.iter().zip(&want).enumerate() {
                    assert!(
                        (got - want).abs() < 2e-6,
                        "n {n}, amp {amp}, joint {k}: {got} vs {want}"
                    );
                }
            }
        }
        // A segment that does not run tail-wards takes atan2 (the scalar path): a joint at the
        // head, so the head segment has no length.
        let mut yaw = [0.0];
        let head_yaw = curve_to_yaw(1.0, &[0.0, 1.0], &[1.0], 0.0, &[0.5, 0.5], &mut yaw);
        assert_eq!(head_yaw, -std::f32::consts::FRAC_PI_2);
        assert_eq!(yaw[0], -std::f32::consts::FRAC_PI_2);
    }

    #[test]
    fn test_power_profile_values() {
        assert_eq!(power_after_fig5(0.1), 0.6);
        assert!((power_after_fig5(0.425) - 0.7).abs() < 1e-6);
        assert!((power_after_fig5(0.675) - 0.9).abs() < 1e-6);
        assert_eq!(power_after_fig5(0.95), 1.0);
        let body = Body::black_porgy();
        assert_eq!(body.num_joints(), 6);
        assert_eq!(body.joints_x.len(), 7);
        assert_eq!(body.joints_x[6], 1.0);
        assert!((body.joints_x[0] - 1.0 / 7.0).abs() < 1e-6);
        body.validate().unwrap();
    }

    #[test]
    fn test_curve_to_yaw_hand_values() {
        // Three samples after the head: joints at x = 0.5, tip at 1; l = 2, so both segments are 1
        // long. Head at 0, joint at 0 (straight head segment), tip 1 to the left: the tail segment
        // leans 45° left, so the joint yaws +π/4 (weight 1) and the head segment is straight.
        let mut yaw = [0.0];
        let head_yaw = curve_to_yaw(2.0, &[0.5, 1.0], &[1.0], 0.0, &[0.0, 1.0], &mut yaw);
        assert!((yaw[0] - std::f32::consts::FRAC_PI_4).abs() < 1e-6);
        assert_eq!(head_yaw, 0.0);
        // Head 1 to the right of the joint: the head segment leans 45° left going tail-wards, so
        // the head points 45° right of the heading (−π/4), and a straight continuation bends 0.
        let head_yaw = curve_to_yaw(2.0, &[0.5, 1.0], &[0.5], -1.0, &[0.0, 1.0], &mut yaw);
        assert!((head_yaw + std::f32::consts::FRAC_PI_4).abs() < 1e-6);
        assert!(yaw[0].abs() < 1e-6);
    }

    #[test]
    fn test_midline_pose_validity_names_each_bad_input() {
        let body = Body::black_porgy();
        let root = RootState::default();
        let yaw = [0.0; 6];
        let mut points = [Vec3::ZERO; 8];
        let mut job = MidlinePoseJob {
            root: &root,
            body: &body,
            l: 50.0,
            head_lateral: 0.0,
            head_yaw: 0.0,
            yaw: &yaw,
            points: &mut points,
        };
        assert!(job.validate().is_ok());
        job.l = f32::NAN;
        assert!(matches!(
            job.validate(),
            Err(MotionError::InvalidParam { name: "l", .. })
        ));
        job.l = 50.0;
        job.yaw = &yaw[..5];
        let err = job.validate().unwrap_err().to_string();
        assert!(err.contains("yaw has 5 entries, expected 6"), "{err}");
        job.yaw = &yaw;
        let mut short = [Vec3::ZERO; 7];
        job.points = &mut short;
        let err = job.validate().unwrap_err().to_string();
        assert!(err.contains("points has 7 entries, expected 8"), "{err}");
        let mut bad_body = Body::black_porgy();
        bad_body.joints_x[2] = 0.1;
        let err = bad_body.validate().unwrap_err().to_string();
        assert!(err.contains("joints_x[2] = 0.1"), "{err}");
        let mut bad_body = Body::black_porgy();
        bad_body.power.pop();
        assert!(
            bad_body
                .validate()
                .unwrap_err()
                .to_string()
                .contains("5 power weights")
        );
        let mut bad_body = Body::black_porgy();
        bad_body.joints_x[6] = 0.99;
        assert!(bad_body.validate().is_err());
    }

    #[test]
    fn test_mass_shares_hand_values() {
        // Four slices of 0.25; ellipse areas π/4·w·d = π/4·(4, 0 → filled, 2, 1·2); joints at
        // 0.5 and the tail tip. The empty slice takes the mean of its neighbours, 3.
        let sections = [(2.0, 2.0), (0.0, 0.0), (1.0, 2.0), (2.0, 1.0)];
        let shares = mass_shares(&[0.5, 1.0], &sections);
        assert_eq!(shares.len(), 2);
        assert!((shares[0] - 7.0 / 11.0).abs() < 1e-6, "{shares:?}");
        assert!((shares[1] - 4.0 / 11.0).abs() < 1e-6, "{shares:?}");
        assert!(mass_shares(&[0.5, 1.0], &[(0.0, 0.0); 4]).is_empty());
        assert!(mass_shares(&[0.5, 1.0], &[(f32::NAN, 1.0); 4]).is_empty());
    }

    #[test]
    fn test_recoil_hand_value_and_mass_validity() {
        let mut body = Body {
            joints_x: vec![0.5, 1.0],
            power: vec![1.0],
            mass: vec![0.75, 0.25],
        };
        body.validate().unwrap();
        // Segment 0 runs from the head (2) to the joint (0): mean 1; segment 1 from 0 to −4:
        // mean −2. Centre: 0.75·1 + 0.25·(−2) = 0.25.
        assert!((body.recoil(2.0, &[0.0, -4.0]) - 0.25).abs() < 1e-6);
        body.mass = vec![0.5];
        assert!(
            body.validate()
                .unwrap_err()
                .to_string()
                .contains("1 mass shares")
        );
        body.mass = vec![0.5, f32::NAN];
        assert!(body.validate().unwrap_err().to_string().contains("mass[1]"));
        body.mass = vec![0.5, 0.2];
        assert!(
            body.validate()
                .unwrap_err()
                .to_string()
                .contains("sum to 0.7")
        );
        body.mass.clear();
        body.validate().unwrap();
        assert_eq!(body.recoil(2.0, &[0.0, -4.0]), 0.0);
    }

    #[test]
    fn test_midline_pose_straight_and_bent() {
        // Two segments of 1 (l = 2, joint at 0.5); heading 90° (facing −z), root at the origin.
        let body = Body {
            joints_x: vec![0.5, 1.0],
            power: vec![1.0],
            mass: Vec::new(),
        };
        let root = RootState {
            heading: std::f32::consts::FRAC_PI_2,
            ..RootState::default()
        };
        let mut points = [Vec3::ZERO; 3];
        MidlinePoseJob {
            root: &root,
            body: &body,
            l: 2.0,
            head_lateral: 0.0,
            head_yaw: 0.0,
            yaw: &[std::f32::consts::FRAC_PI_2],
            points: &mut points,
        }
        .run()
        .unwrap();
        // Facing −z, the body trails towards +z; the tail segment bends 90° to the fish's left,
        // which for a fish facing −z is −x.
        assert!(points[0].abs_diff_eq(Vec3::ZERO, 1e-6));
        assert!(
            points[1].abs_diff_eq(Vec3::new(0.0, 0.0, 1.0), 1e-6),
            "{:?}",
            points[1]
        );
        assert!(
            points[2].abs_diff_eq(Vec3::new(-1.0, 0.0, 1.0), 1e-6),
            "{:?}",
            points[2]
        );
    }
}
