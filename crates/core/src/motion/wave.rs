//! The paper's wave equations (2)–(7), one small function per symbol.
//!
//! Symbols and units (see `docs/motion.md` for every interpretation the paper leaves open):
//! - `x`: position along the body from the head, length units (0 = head, `l` = tail tip).
//! - `p`: pivot position as a fraction of the body length; `l`: body length, length units.
//! - `x'` = x − p·l: position relative to the pivot, length units (negative in front of it).
//! - `lambda` (λ): body wavelength, length units; `lambda_prime` (λ') the stretched front one.
//! - `omega` (ω): dimensionless wave-speed factor of the species; `omega_prime` (ω') = s·p·ω the
//!   body wave's phase speed, length units per second.
//! - `phase` (φ): the wave's temporal phase, radians, integrated over time by the player
//!   (φ = 2π·ω'·t/λ at constant speed), so a change of speed never makes the wave jump.
//! - Displacements returned here are the paper's F, positive towards the fish's **right**
//!   (so that d = +1, "right", bends the tail to the right); the player reports `lateral`
//!   = −F, positive to the left, as the crate's conventions require.

use std::f32::consts::{PI, TAU};

/// Equation (2), the basic travelling wave F(x, t) = A·sin(2π/λ·(x − ω·t)).
///
/// `amplitude` (A) and `x`, `lambda` (λ) in length units, `t` in seconds, `omega` (ω) the phase
/// speed in length units per second. Crests travel towards +x, i.e. from head to tail.
pub fn f_basic(amplitude: f32, x: f32, t: f32, lambda: f32, omega: f32) -> f32 {
    amplitude * (TAU / lambda * (x - omega * t)).sin()
}

/// x' = x − p·l: position relative to the pivot, length units.
pub fn x_prime(x: f32, p: f32, l: f32) -> f32 {
    x - p * l
}

/// A(x) = ((x − p·l)/l)·maxAmp: the amplitude envelope, length units.
///
/// Signed: negative in front of the pivot, zero at it, (1 − p)·maxAmp at the tail tip. Using the
/// signed envelope for both F_f and F_b makes the body curve continuous, with a continuous
/// slope, at the pivot.
pub fn amplitude(x: f32, p: f32, l: f32, max_amp: f32) -> f32 {
    (x - p * l) / l * max_amp
}

/// Amplitude of the front wave F_f at the snout, as a fraction of the body length: 1/50.
///
/// Equation (3) prints F_f with no amplitude factor, i.e. an amplitude of one length unit; Table 1's
/// fish is l = 50 units long, so the snout swings 1/50 = 0.02 body lengths, the snout amplitude
/// of carangiform fish (Videler & Hess 1984, mackerel ≈ 0.02 L; Jayne & Lauder 1995, bass 0.004 –
/// 0.012 L). Table 1 and the carangiform species keep that ratio for every body length; a species
/// may choose its own (`MotionParams::front_amp`; see `docs/motion.md`).
pub const FRONT_AMPLITUDE_BODY_LENGTHS: f32 = 1.0 / 50.0;

/// How the front wave F_f's amplitude runs from the snout to the pivot: equation (3) prints F_f
/// with no amplitude factor at all, so this is a reading (`docs/motion.md`, readings 4 and 6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FrontWave {
    /// Zero at the pivot, growing linearly to the snout amplitude, on the side opposite to the
    /// body just behind the pivot: the front yaws about the pivot against the tail, the head
    /// recoil of carangiform fish. The body curve is continuous at the pivot (0 on both sides).
    #[default]
    Recoil,
    /// The snout amplitude all along the front, on the same side as the wave behind the pivot:
    /// the literal (3), a wave of constant amplitude running from the snout, as the whole body of
    /// an anguilliform swimmer undulates. The curve steps at the pivot from F_f to F_b = 0; on a
    /// body of rigid segments only the joints are sampled, so place the pivot just behind one.
    Travelling,
    /// **Not in the paper: an opt-in extension for anguilliform swimmers** (docs/motion.md,
    /// "The anguilliform envelope"). One wave of length λ runs over the whole body (the same
    /// F_b = A·sin(2π·x'/λ − φ) in front of the pivot as behind it, so there is no λ' and no
    /// step), with the amplitude [`anguilliform_amplitude`]: the snout amplitude at the head,
    /// rising smoothly and monotonically (no dip, no node) to equation (4)'s tail amplitude
    /// (1 − p)·maxAmp at the tail tip, as Gillis 1998 describes eels ("the most anterior
    /// regions … do not undergo significant undulation", a "nonlinear increase" of amplitude
    /// along the body). The pivot then only places turns.
    Anguilliform,
}

/// The exponent of the [`FrontWave::Anguilliform`] envelope's rise along the body (1 would be
/// linear). Gillis 1998 gives the shape only in words ("nonlinear increase"); 1.5 puts the
/// mid-body amplitude near the measured sea lamprey's share of its tail amplitude (fishmechr's
/// `lampreydata`, tests/data/midline; docs/motion.md).
pub const ANGUILLIFORM_EXPONENT: f32 = 1.5;

/// The [`FrontWave::Anguilliform`] amplitude at `x` (length units from the head), length units:
/// a(x) = a₀ + (a₁ − a₀)·(x/l)^[`ANGUILLIFORM_EXPONENT`], with a₀ = `snout`·l at the snout and
/// a₁ = (1 − p)·`max_amp` at the tail tip (equation (4)'s tail amplitude). Positive everywhere
/// (the whole body undulates, in phase with the wave behind it); `x` outside [0, l] is clamped.
pub fn anguilliform_amplitude(x: f32, p: f32, l: f32, max_amp: f32, snout: f32) -> f32 {
    let u = (x / l).clamp(0.0, 1.0);
    let (head, tail) = (snout * l, (1.0 - p) * max_amp);
    head + (tail - head) * u.powf(ANGUILLIFORM_EXPONENT)
}

/// The swim wave's amplitude at `x` (length units from the head) under every profile:
/// [`front_amplitude`] in front of the pivot and [`amplitude`] behind it, or
/// [`anguilliform_amplitude`] along the whole body. Length units, signed like them.
pub fn swim_amplitude(x: f32, p: f32, l: f32, max_amp: f32, front: (f32, FrontWave)) -> f32 {
    match front.1 {
        FrontWave::Anguilliform => anguilliform_amplitude(x, p, l, max_amp, front.0),
        _ if x_prime(x, p, l) < 0.0 => front_amplitude(x, p, l, front.0, front.1),
        _ => amplitude(x, p, l, max_amp),
    }
}

/// The swim wave's spatial argument at `x_prime` (length units from the pivot), radians:
/// 2π·x'/λ' in front of the pivot (equation (3)) and 2π·x'/λ behind it (equation (4)), or
/// 2π·x'/λ along the whole body under [`FrontWave::Anguilliform`].
pub fn swim_argument(x_prime: f32, lambda: f32, lambda_prime: f32, profile: FrontWave) -> f32 {
    if x_prime < 0.0 && profile != FrontWave::Anguilliform {
        TAU * x_prime / lambda_prime
    } else {
        TAU * x_prime / lambda
    }
}

/// The front wave's amplitude A_f(x) for x ≤ p·l, length units, with the snout amplitude
/// `snout` a fraction of `l` (the paper's unit amplitude on Table 1's fish is
/// [`FRONT_AMPLITUDE_BODY_LENGTHS`]).
///
/// [`FrontWave::Recoil`]: zero at the pivot, growing linearly to −`snout`·l at the snout (x = 0),
/// signed like [`amplitude`] (negative in front of the pivot), so the snout swings opposite to the
/// tail near the pivot and the curve is continuous at the pivot. [`FrontWave::Travelling`]:
/// +`snout`·l everywhere in front of the pivot. Needs p > 0 (every valid pivot is).
pub fn front_amplitude(x: f32, p: f32, l: f32, snout: f32, profile: FrontWave) -> f32 {
    match profile {
        FrontWave::Recoil => (x - p * l) / p * snout,
        FrontWave::Travelling => snout * l,
        // Its value at the snout; along the body see anguilliform_amplitude.
        FrontWave::Anguilliform => snout * l,
    }
}

/// λ' = (132·p − 18.8)·λ: the stretched wavelength of the front wave F_f, length units.
///
/// Positive only for p > 18.8/132 ≈ 0.1424 ([`P_MIN`]); [`crate::motion::MotionParams::validate`]
/// rejects smaller pivots.
pub fn lambda_prime(p: f32, lambda: f32) -> f32 {
    (132.0 * p - 18.8) * lambda
}

/// The smallest pivot for which λ' > 0: p must exceed 18.8 / 132.
pub const P_MIN: f32 = 18.8 / 132.0;

/// ω' = s·p·ω: the body wave's phase speed, length units per second.
///
/// `s` is the speed in length units per second, `p` the pivot fraction and `omega` (ω) the
/// species' dimensionless wave-speed factor. (The paper prints both s·p·p and s·p·ω; we use
/// s·p·ω, see `docs/motion.md`.) The tail-beat frequency is ω'/λ hertz.
pub fn omega_prime(s: f32, p: f32, omega: f32) -> f32 {
    s * p * omega
}

/// Tail-beat frequency of the swim wave, hertz: ω'/λ = s·p·ω/λ.
pub fn tail_beat_hz(s: f32, p: f32, omega: f32, lambda: f32) -> f32 {
    omega_prime(s, p, omega) / lambda
}

/// Equation (3), the front wave F_f = A_f(x)·sin(2π·x'/λ' − φ), for x' ≤ 0.
///
/// The paper prints F_f without an amplitude factor (an amplitude of one length unit) and with
/// its own time term ω'·t/λ'. `amplitude` is [`front_amplitude`]: the literal unit amplitude at
/// the snout on Table 1's 50-unit fish, tapered to zero at the pivot so the curve is continuous
/// there. F_f is driven by the back wave's phase φ (so head and tail beat at the same frequency,
/// as in every fish). Returns length units.
pub fn f_front(amplitude: f32, x_prime: f32, lambda_prime: f32, phase: f32) -> f32 {
    amplitude * (TAU * x_prime / lambda_prime - phase).sin()
}

/// Equation (4), the back wave F_b = A(x)·sin(2π/λ·(x' − ω'·t)) = A(x)·sin(2π·x'/λ − φ),
/// for x' ≥ 0. Returns length units; crests travel from the pivot to the tail.
pub fn f_back(amplitude: f32, x_prime: f32, lambda: f32, phase: f32) -> f32 {
    amplitude * (TAU * x_prime / lambda - phase).sin()
}

/// Equation (5), the normal-turn wave F_nt = A(x)·(sin(2π·x'/λ − φ) + d)·f.
///
/// `d` ∈ {−1, 0, 1} is the paper's side (−1 left, 1 right, 0 straight), `f` ∈ [1, 2] the
/// amplitude weight. With d = ±1 the tail only ever swings to side d. Length units.
pub fn f_nt(amplitude: f32, x_prime: f32, lambda: f32, phase: f32, d: f32, f: f32) -> f32 {
    amplitude * ((TAU * x_prime / lambda - phase).sin() + d) * f
}

/// λ'' = 2·Tt: the period of the quick/serial turn wave, seconds (`tt` in seconds).
///
/// The paper writes it where a wavelength goes; read as a duration it agrees with ω'': one lobe
/// of |sin| (half a period) lasts exactly Tt. The player turns it into a wavelength along the body
/// by multiplying with the swim wave's phase speed ω' (see `docs/motion.md`).
pub fn lambda_2(tt: f32) -> f32 {
    2.0 * tt
}

/// ω'' = 0.5/Tt: the temporal frequency of the quick/serial turn wave, hertz (`tt` in seconds).
pub fn omega_2(tt: f32) -> f32 {
    0.5 / tt
}

/// Equation (6), the quick/serial-turn wave F_st = A(x)·d·|sin(2π·x'/Λ'' − 2π·ω''·t)|.
///
/// `wavelength` (Λ'') is the turn wave's length along the body, length units; `t` seconds since
/// the stroke began; `tt` (Tt) seconds. Because of the |·| the body bends to side `d` only and
/// returns straight once per Tt ("ends in one direction at once"). Length units.
pub fn f_st(amplitude: f32, x_prime: f32, wavelength: f32, t: f32, tt: f32, d: f32) -> f32 {
    amplitude
        * d
        * (TAU * x_prime / wavelength - TAU * omega_2(tt) * t)
            .sin()
            .abs()
}

/// The interpolation function of (7), I_p(t) = |sin(π·t/t_p)|, dimensionless in [0, 1].
///
/// `t` and `t_p` in seconds. Zero at the start and end of every stroke of length t_p, one in its
/// middle, so a turn starts and ends in the swim shape.
pub fn i_p(t: f32, t_p: f32) -> f32 {
    (PI * t / t_p).sin().abs()
}

/// Equation (7), T_locomotion = S·(1 − I_p) + T·I_p: the swim wave `s_wave` blended with the turn
/// wave `t_wave` by `ip` = I_p(t). Length units in, length units out.
pub fn t_locomotion(s_wave: f32, t_wave: f32, ip: f32) -> f32 {
    s_wave * (1.0 - ip) + t_wave * ip
}

/// The swim wave S(x, t) of (3)/(4): F_f (amplitude [`front_amplitude`] with snout amplitude
/// `front_amp`, a fraction of `l`, and profile `front_wave`) in front of the pivot, F_b
/// (amplitude [`amplitude`]) behind it. Length units.
///
/// `x` length units from the head; `gain` scales the whole wave (the player's speed gain).
#[allow(clippy::too_many_arguments)]
pub fn swim_wave(
    x: f32,
    p: f32,
    l: f32,
    max_amp: f32,
    lambda: f32,
    lambda_prime: f32,
    front: (f32, FrontWave),
    phase: f32,
    gain: f32,
) -> f32 {
    let xp = x_prime(x, p, l);
    let a = swim_amplitude(x, p, l, max_amp, front) * gain;
    (swim_argument(xp, lambda, lambda_prime, front.1) - phase).sin() * a
}

/// The smoothstep every speed change and blend uses (written once, in [`crate::math`]).
pub use crate::math::smoothstep;

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's unit front amplitude on Table 1's fish, as a recoil.
    const U: f32 = FRONT_AMPLITUDE_BODY_LENGTHS;
    const R: (f32, FrontWave) = (U, FrontWave::Recoil);

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn test_anguilliform_envelope_rises_smoothly_over_the_whole_body() {
        // l = 70, p = 0.2, maxAmp = 7 → tail (1 − 0.2)·7 = 5.6 units = 0.08 L; snout 0.01 L.
        let (p, l, max_amp, snout) = (0.2, 70.0, 7.0, 0.01);
        let a = |x: f32| anguilliform_amplitude(x * l, p, l, max_amp, snout) / l;
        assert!(close(a(0.0), 0.01, 1e-6));
        assert!(close(a(1.0), 0.08, 1e-6));
        // Halfway: 0.01 + 0.07·0.5^1.5.
        assert!(close(a(0.5), 0.01 + 0.07 * 0.5f32.powf(1.5), 1e-6));
        // Rising everywhere, no node: every sample positive and above the one before.
        for i in 1..=100 {
            let (x0, x1) = ((i - 1) as f32 / 100.0, i as f32 / 100.0);
            assert!(a(x1) > a(x0) && a(x0) > 0.0, "{x0}");
        }
        // One wave of length λ over the whole body: the front uses λ, not λ'.
        let front = (snout, FrontWave::Anguilliform);
        let lp = lambda_prime(p, 49.0);
        let y = swim_wave(0.0, p, l, max_amp, 49.0, lp, front, 0.3, 1.0);
        let want = a(0.0) * l * (TAU * x_prime(0.0, p, l) / 49.0 - 0.3).sin();
        assert!(close(y, want, 1e-5), "{y} vs {want}");
        // The paper's profiles keep their amplitudes.
        let recoil = swim_amplitude(0.0, p, l, max_amp, (snout, FrontWave::Recoil));
        assert!(close(
            recoil,
            front_amplitude(0.0, p, l, snout, FrontWave::Recoil),
            1e-6
        ));
        let back = swim_amplitude(0.6 * l, p, l, max_amp, (snout, FrontWave::Travelling));
        assert!(close(back, amplitude(0.6 * l, p, l, max_amp), 1e-6));
    }

    #[test]
    fn test_f_basic_hand_values() {
        // A = 2, λ = 4, ω = 1: at x = 1, t = 0 the argument is 2π/4·1 = π/2 → 2·1 = 2.
        assert!(close(f_basic(2.0, 1.0, 0.0, 4.0, 1.0), 2.0, 1e-6));
        // One second later the crest has moved one unit tail-wards: x = 2 now holds it.
        assert!(close(f_basic(2.0, 2.0, 1.0, 4.0, 1.0), 2.0, 1e-6));
        // x = 0, t = 1: argument −π/2 → −2.
        assert!(close(f_basic(2.0, 0.0, 1.0, 4.0, 1.0), -2.0, 1e-6));
    }

    #[test]
    fn test_pivot_symbols_hand_values() {
        // Table 1, Ex1: p = 0.4, l = 50 → pivot at 20 length units.
        assert!(close(x_prime(35.0, 0.4, 50.0), 15.0, 1e-5));
        // A(50) = (50 − 20)/50 · 10 = 6; A(20) = 0; A(0) = −4.
        assert!(close(amplitude(50.0, 0.4, 50.0, 10.0), 6.0, 1e-5));
        assert!(close(amplitude(20.0, 0.4, 50.0, 10.0), 0.0, 1e-6));
        assert!(close(amplitude(0.0, 0.4, 50.0, 10.0), -4.0, 1e-5));
        // λ' = (132·0.4 − 18.8)·50 = 34·50 = 1700; p = 0.2 → 7.6·50 = 380.
        assert!(close(lambda_prime(0.4, 50.0), 1700.0, 1e-2));
        assert!(close(lambda_prime(0.2, 50.0), 380.0, 1e-2));
        assert!(lambda_prime(P_MIN, 50.0).abs() < 1e-3);
        assert!(lambda_prime(0.14, 50.0) < 0.0);
        // ω' = 50·0.4·3.75 = 75 length units/s; tail beat 75/50 = 1.5 Hz.
        assert!(close(omega_prime(50.0, 0.4, 3.75), 75.0, 1e-4));
        assert!(close(tail_beat_hz(50.0, 0.4, 3.75, 50.0), 1.5, 1e-6));
    }

    #[test]
    fn test_front_and_back_waves_hand_values() {
        // F_b: A = 6, x' = 12.5, λ = 50, φ = 0 → 6·sin(π/2) = 6.
        assert!(close(f_back(6.0, 12.5, 50.0, 0.0), 6.0, 1e-5));
        // φ = π/2 turns it into 6·sin(0) = 0.
        assert!(close(f_back(6.0, 12.5, 50.0, PI / 2.0), 0.0, 1e-5));
        // (4) as printed, with ω'·t: φ = 2π·ω'·t/λ gives the same value.
        let (w, t, lam) = (75.0, 0.1, 50.0);
        let printed = 6.0 * (TAU / lam * (12.5 - w * t)).sin();
        assert!(close(
            f_back(6.0, 12.5, lam, TAU * w * t / lam),
            printed,
            1e-5
        ));
        // F_f: A = −4 at the head (x' = −20), λ' = 1700, φ = −π/2:
        // −4·sin(2π·(−20)/1700 + π/2) = −4·cos(0.073921) = −3.98908.
        assert!(close(
            f_front(-4.0, -20.0, 1700.0, -PI / 2.0),
            -3.98908,
            1e-4
        ));
    }

    #[test]
    fn test_swim_wave_continuous_at_pivot() {
        let (p, l, amp, lam) = (0.4, 50.0, 10.0, 50.0);
        let lp = lambda_prime(p, lam);
        for k in 0..16 {
            let phase = k as f32 * 0.4;
            let eps = 1e-3;
            let before = swim_wave(20.0 - eps, p, l, amp, lam, lp, R, phase, 1.0);
            let after = swim_wave(20.0 + eps, p, l, amp, lam, lp, R, phase, 1.0);
            assert!(
                close(before, after, 1e-3),
                "jump at pivot: {before} vs {after}"
            );
            // One-sided slopes at the pivot: behind it A'(x)·sin(−φ) = amp/l·sin(−φ); in front
            // A_f'(x)·sin(−φ) = 0.02/p·sin(−φ) (snout amplitude 0.02·l over p·l). A kink, not a
            // jump: the front is nearly still while the back carries the wave.
            let h = 0.05;
            let pivot = swim_wave(20.0, p, l, amp, lam, lp, R, phase, 1.0);
            let back = (swim_wave(20.0 + h, p, l, amp, lam, lp, R, phase, 1.0) - pivot) / h;
            let front = (pivot - swim_wave(20.0 - h, p, l, amp, lam, lp, R, phase, 1.0)) / h;
            assert!(close(back, amp / l * (-phase).sin(), 2e-3), "{back}");
            assert!(close(front, 0.02 / p * (-phase).sin(), 2e-3), "{front}");
        }
    }

    #[test]
    fn test_front_amplitude_is_the_literal_unit_amplitude_on_table_1s_fish() {
        // Eq. (3) has amplitude 1: on the l = 50 fish the snout swings exactly one unit.
        assert!(close(
            front_amplitude(0.0, 0.4, 50.0, U, FrontWave::Recoil),
            -1.0,
            1e-6
        ));
        assert!(close(
            front_amplitude(0.0, 0.2, 50.0, U, FrontWave::Recoil),
            -1.0,
            1e-6
        ));
        // Zero at the pivot, half way in between; scales with the body (l = 80 → 1.6).
        assert!(close(
            front_amplitude(20.0, 0.4, 50.0, U, FrontWave::Recoil),
            0.0,
            1e-6
        ));
        assert!(close(
            front_amplitude(10.0, 0.4, 50.0, U, FrontWave::Recoil),
            -0.5,
            1e-6
        ));
        assert!(close(
            front_amplitude(0.0, 0.3, 80.0, U, FrontWave::Recoil),
            -1.6,
            1e-5
        ));
        // The swim wave uses it ahead of the pivot: φ = −π/2 puts the snout at A_f·sin(~π/2).
        let lp = lambda_prime(0.4, 50.0);
        let s = swim_wave(0.0, 0.4, 50.0, 10.0, 50.0, lp, R, -PI / 2.0, 1.0);
        assert!(close(s, -(TAU * -20.0 / lp + PI / 2.0).sin(), 1e-5), "{s}");
    }

    #[test]
    fn test_travelling_front_wave_keeps_its_amplitude_to_the_pivot() {
        // Travelling: the snout amplitude (0.035·70 = 2.45) all along the front, on the side of
        // the wave behind the pivot.
        let (p, l, snout) = (0.15, 70.0, 0.035);
        for x in [0.0, 5.0, 10.0, 10.4] {
            let a = front_amplitude(x, p, l, snout, FrontWave::Travelling);
            assert!(close(a, 2.45, 1e-5), "{x}: {a}");
        }
        // p = 0.15 makes λ' = (132·0.15 − 18.8)·λ = λ: one wave from snout to tail.
        assert!(close(lambda_prime(0.15, 49.0), 49.0, 1e-3));
        let front = (snout, FrontWave::Travelling);
        for k in 0..16 {
            let phase = k as f32 * 0.4;
            // Just in front of the pivot F_f = 2.45·sin(−φ); just behind it F_b → 0 with the
            // same sign: the curve steps at the pivot but never swings against the body behind.
            let before = swim_wave(10.5 - 1e-3, p, l, 8.0, 49.0, 49.0, front, phase, 1.0);
            let behind = swim_wave(10.5 + 1.0, p, l, 8.0, 49.0, 49.0, front, phase, 1.0);
            assert!(close(before, 2.45 * (-phase).sin(), 1e-3), "{before}");
            assert!(
                before * behind >= -1e-6 || behind.abs() < 0.02,
                "{before} {behind}"
            );
        }
    }

    #[test]
    fn test_turn_waves_hand_values() {
        // F_nt: A = 6, sin term 1 (x' = 12.5, λ = 50, φ = 0), d = −1, f = 2 → 6·(1 − 1)·2 = 0.
        assert!(close(f_nt(6.0, 12.5, 50.0, 0.0, -1.0, 2.0), 0.0, 1e-5));
        // d = +1 → 6·2·2 = 24; at a trough (φ = π) the tail is back on the centre line.
        assert!(close(f_nt(6.0, 12.5, 50.0, 0.0, 1.0, 2.0), 24.0, 1e-4));
        assert!(close(f_nt(6.0, 12.5, 50.0, PI, 1.0, 2.0), 0.0, 1e-4));
        // λ'' = 2·Tt, ω'' = 0.5/Tt: Tt = 2 s → 4 s and 0.25 Hz.
        assert!(close(lambda_2(2.0), 4.0, 1e-6));
        assert!(close(omega_2(2.0), 0.25, 1e-6));
        // F_st at x' = 0, Tt = 2 s, t = 1 s: |sin(−2π·0.25·1)| = 1 → A·d = −6.
        assert!(close(f_st(6.0, 0.0, 100.0, 1.0, 2.0, -1.0), -6.0, 1e-5));
        // Never on the other side: sample a whole period.
        for k in 0..40 {
            let t = k as f32 * 0.1;
            assert!(f_st(6.0, 7.0, 100.0, t, 2.0, -1.0) <= 0.0);
            assert!(f_st(6.0, 7.0, 100.0, t, 2.0, 1.0) >= 0.0);
        }
    }

    #[test]
    fn test_interpolation_and_blend_hand_values() {
        assert!(close(i_p(0.0, 2.0), 0.0, 1e-6));
        assert!(close(i_p(1.0, 2.0), 1.0, 1e-6));
        assert!(close(i_p(2.0, 2.0), 0.0, 1e-6));
        // |·| makes the second stroke a second positive lobe: I_p(2.5, 2) = |sin(1.25π)| = 0.7071.
        assert!(close(i_p(2.5, 2.0), std::f32::consts::FRAC_1_SQRT_2, 1e-5));
        // (7): S = 2, T = 10, I_p = 0.25 → 2·0.75 + 10·0.25 = 4.
        assert!(close(t_locomotion(2.0, 10.0, 0.25), 4.0, 1e-6));
        assert!(close(t_locomotion(2.0, 10.0, 0.0), 2.0, 1e-6));
        assert!(close(t_locomotion(2.0, 10.0, 1.0), 10.0, 1e-6));
    }

    #[test]
    fn test_smoothstep_hand_values() {
        assert_eq!(smoothstep(-1.0), 0.0);
        assert_eq!(smoothstep(0.5), 0.5);
        assert_eq!(smoothstep(2.0), 1.0);
        assert!(close(smoothstep(0.25), 0.15625, 1e-6));
    }
}
