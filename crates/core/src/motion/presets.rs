//! The four experiments of Table 1 as named presets `ex1` … `ex4`.
//!
//! | preset | motion | p | s | l | d | Tt | f |
//! |---|---|---|---|---|---|---|---|
//! | ex1 | swim | 0.40 | 50 | 50 | – | – | – |
//! | ex2 | normal turn | 0.45 | 20 | 50 | −1 | – | 2.0 |
//! | ex3 | quick turn | 0.20 | 40 | 50 | −1 | 2000 ms | – |
//! | ex4 | serial turn | 0.40 | 35 | 50 | −1 | 2400 ms | – |
//!
//! Entries the table leaves blank ("N/A") keep the values of [`MotionParams::TABLE_1`]; the
//! turn angle is 90°.

use super::{MotionError, MotionParams, MotionRequest, RootState, Side, TurnKind};

/// One Table 1 experiment: parameters and the motion it demonstrates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Preset {
    /// `ex1` … `ex4`.
    pub name: &'static str,
    /// Table 1's p, s, l, Tt (in seconds), f over the black porgy defaults.
    pub params: MotionParams,
    /// The turn the experiment shows (`None`: a straight swim).
    pub turn: Option<TurnKind>,
    /// The paper's d: −1 left, 0 straight, 1 right.
    pub d: i32,
}

impl Preset {
    /// Names of all presets, in order.
    pub const NAMES: [&'static str; 4] = ["ex1", "ex2", "ex3", "ex4"];

    /// The preset called `name` (`ex1` … `ex4`).
    pub fn by_name(name: &str) -> Result<Self, MotionError> {
        let base = MotionParams::TABLE_1;
        let preset = match name {
            "ex1" => Self {
                name: "ex1",
                params: MotionParams {
                    p: 0.40,
                    s: 50.0,
                    ..base
                }
                .with_length(50.0),
                turn: None,
                d: 0,
            },
            "ex2" => Self {
                name: "ex2",
                params: MotionParams {
                    p: 0.45,
                    s: 20.0,
                    f: 2.0,
                    ..base
                }
                .with_length(50.0),
                turn: Some(TurnKind::Normal),
                d: -1,
            },
            "ex3" => Self {
                name: "ex3",
                params: MotionParams {
                    p: 0.20,
                    s: 40.0,
                    tt: 2.0,
                    ..base
                }
                .with_length(50.0),
                turn: Some(TurnKind::Quick),
                d: -1,
            },
            "ex4" => Self {
                name: "ex4",
                params: MotionParams {
                    p: 0.40,
                    s: 35.0,
                    tt: 2.4,
                    ..base
                }
                .with_length(50.0),
                turn: Some(TurnKind::Serial),
                d: -1,
            },
            other => {
                return Err(MotionError::UnknownPreset {
                    name: other.to_owned(),
                });
            }
        };
        Ok(preset)
    }

    /// All four presets.
    pub fn all() -> [Self; 4] {
        Self::NAMES.map(|name| Self::by_name(name).expect("built-in preset"))
    }

    /// Checks the parameters and `d`.
    pub fn validate(&self) -> Result<(), MotionError> {
        self.params.validate()?;
        Side::from_d(self.d)?;
        Ok(())
    }

    /// The request that demonstrates this preset: a turn of `params.turn_angle` to side `d`, or a
    /// steady swim at `s` when there is no turn or d = 0.
    pub fn request(&self) -> Result<MotionRequest, MotionError> {
        let side = Side::from_d(self.d)?;
        Ok(match (self.turn, side) {
            (Some(kind), Some(side)) => MotionRequest::Turn {
                kind,
                angle: self.params.turn_angle,
                side,
            },
            _ => MotionRequest::Swim {
                speed: self.params.s,
            },
        })
    }

    /// The root at the origin, heading +x, already cruising at `s`.
    pub fn initial_root(&self) -> RootState {
        RootState {
            speed: self.params.s,
            ..RootState::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_presets_match_table_1() {
        let [ex1, ex2, ex3, ex4] = Preset::all();
        assert_eq!(
            (ex1.params.p, ex1.params.s, ex1.params.l),
            (0.40, 50.0, 50.0)
        );
        assert_eq!(ex1.turn, None);
        assert_eq!(
            (
                ex2.params.p,
                ex2.params.s,
                ex2.params.l,
                ex2.d,
                ex2.params.f
            ),
            (0.45, 20.0, 50.0, -1, 2.0)
        );
        assert_eq!(ex2.turn, Some(TurnKind::Normal));
        assert_eq!(
            (ex3.params.p, ex3.params.s, ex3.d, ex3.params.tt),
            (0.20, 40.0, -1, 2.0)
        );
        assert_eq!(ex3.turn, Some(TurnKind::Quick));
        assert_eq!(
            (ex4.params.p, ex4.params.s, ex4.d, ex4.params.tt),
            (0.40, 35.0, -1, 2.4)
        );
        assert_eq!(ex4.turn, Some(TurnKind::Serial));
        for preset in Preset::all() {
            preset.validate().unwrap();
            assert_eq!(preset.params.turn_angle, std::f32::consts::FRAC_PI_2);
        }
    }

    #[test]
    fn test_unknown_preset_is_named() {
        let err = Preset::by_name("ex5").unwrap_err();
        assert_eq!(
            err.to_string(),
            "unknown motion preset \"ex5\": expected one of ex1, ex2, ex3, ex4"
        );
    }

    #[test]
    fn test_preset_requests() {
        let ex3 = Preset::by_name("ex3").unwrap();
        assert_eq!(
            ex3.request().unwrap(),
            MotionRequest::Turn {
                kind: TurnKind::Quick,
                angle: std::f32::consts::FRAC_PI_2,
                side: Side::Left
            }
        );
        let straight = Preset { d: 0, ..ex3 };
        assert_eq!(
            straight.request().unwrap(),
            MotionRequest::Swim { speed: 40.0 }
        );
        let bad = Preset { d: 2, ..ex3 };
        assert!(bad.request().unwrap_err().to_string().contains("d = 2"));
    }
}
