//! The panel's unsaved tuning: which motion values the sliders changed since the species file was
//! read or last saved, saving them into that file ([`shoal_script::edit::save`]: only those
//! literals change) and what to ask the designer when saving cannot simply go ahead (a value
//! written as an expression; the file changed on disk meanwhile).

use std::collections::BTreeMap;
use std::path::PathBuf;

use shoal_core::motion::MotionParams;
use shoal_script::edit::{self, Edit, EditError, EditOptions, KeyPath, LuaValue};

/// The motion fields the sliders tune, by their key in a species file's `motion` table.
pub(super) const FIELDS: [&str; 10] = [
    "p",
    "s",
    "l",
    "max_amp",
    "lambda",
    "omega",
    "front_amp",
    "tt",
    "f",
    "turn_angle",
];

/// Decimals each slider of [`FIELDS`] shows and steps by (the turn angle's: of its degrees).
pub(super) const DECIMALS: [usize; 10] = [2, 1, 1, 2, 1, 2, 3, 2, 2, 1];

/// `v` rounded to `decimals` places, as the nearest `f32` (what a slider showing that many
/// shows).
pub(super) fn round_to(v: f32, decimals: usize) -> f32 {
    format!("{v:.decimals$}").parse().unwrap_or(v)
}

/// The text saved for motion field `name` tuned to `v`: the value the slider shows, not the
/// float noise under it (a speed dragged to 63.27586 while the slider shows 63.3 is saved as
/// 63.3). The turn angle shows degrees and is saved in radians: the shortest decimal whose
/// degrees show the same.
pub(super) fn saved_number(name: &str, v: f32) -> LuaValue {
    let i = FIELDS.iter().position(|k| *k == name).unwrap_or(0);
    let d = DECIMALS[i];
    if name != "turn_angle" {
        return LuaValue::from_f32(round_to(v, d));
    }
    let shown = round_to(v.to_degrees(), d);
    (0..=8)
        .map(|k| round_to(v, k))
        .find(|r| round_to(r.to_degrees(), d) == shown)
        .map_or(LuaValue::from_f32(v), LuaValue::from_f32)
}

/// The value a file holding [`saved_number`]'s text gives.
fn reread(value: &LuaValue, fallback: f32) -> f32 {
    match value {
        LuaValue::Number(t) => t.parse().unwrap_or(fallback),
        _ => fallback,
    }
}

fn field(p: &MotionParams, name: &str) -> f32 {
    match name {
        "p" => p.p,
        "s" => p.s,
        "l" => p.l,
        "max_amp" => p.max_amp,
        "lambda" => p.lambda,
        "omega" => p.omega,
        "front_amp" => p.front_amp,
        "tt" => p.tt,
        "f" => p.f,
        _ => p.turn_angle,
    }
}

fn set_field(p: &mut MotionParams, name: &str, v: f32) {
    match name {
        "p" => p.p = v,
        "s" => p.s = v,
        "l" => p.l = v,
        "max_amp" => p.max_amp = v,
        "lambda" => p.lambda = v,
        "omega" => p.omega = v,
        "front_amp" => p.front_amp = v,
        "tt" => p.tt = v,
        "f" => p.f = v,
        _ => p.turn_angle = v,
    }
}

/// One species' values as last read from or written to its file.
#[derive(Debug, Clone)]
struct Baseline {
    /// The motion values the file gives.
    params: MotionParams,
    /// The file's text then (to notice a change by hand before saving over it).
    disk: Option<String>,
    /// What the sliders set since (`None`: nothing unsaved).
    tuned: Option<MotionParams>,
}

/// A question to the designer before a save can go on.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Ask {
    /// The file writes a tuned value as an expression: replace it (the old one kept in a
    /// comment)?
    Expression {
        /// Species index.
        species: usize,
        /// The editor's message (names the key, the line and the expression).
        why: String,
    },
    /// The file changed on disk while the panel had unsaved values for it.
    DiskChanged {
        /// Species index.
        species: usize,
        /// The file.
        file: PathBuf,
    },
}

/// Unsaved panel values per species, and the open question, if any.
#[derive(Debug, Default)]
pub(super) struct Tuned {
    species: BTreeMap<usize, Baseline>,
    /// The question shown in the panel until answered.
    pub ask: Option<Ask>,
}

/// What [`Tuned::observe`] wants the caller to do with the live species.
#[derive(Debug, PartialEq)]
pub(super) enum Keep {
    /// Nothing.
    Nothing,
    /// The live values changed under the panel (the file was reloaded): put the tuned ones back
    /// until the designer answers.
    Restore(MotionParams),
}

impl Tuned {
    /// Called each frame with the live values of `species` (read from `file`).
    pub fn observe(&mut self, species: usize, live: MotionParams, file: Option<&PathBuf>) -> Keep {
        let b = self.species.entry(species).or_insert_with(|| Baseline {
            params: live,
            disk: file.and_then(|f| std::fs::read_to_string(f).ok()),
            tuned: None,
        });
        match b.tuned {
            Some(t) if t != live => {
                // The hot reload applied the file: its values are the new baseline, the values
                // the designer tuned stay live on top of it (the others take the file's), and the
                // designer decides.
                let mut merged = live;
                for k in FIELDS {
                    if field(&b.params, k) != field(&t, k) {
                        set_field(&mut merged, k, field(&t, k));
                    }
                }
                b.params = live;
                b.tuned = (merged != live).then_some(merged);
                if let Some(file) = file {
                    self.ask = Some(Ask::DiskChanged {
                        species,
                        file: file.clone(),
                    });
                }
                Keep::Restore(merged)
            }
            Some(_) => Keep::Nothing,
            None => {
                if b.params != live {
                    // Reloaded with nothing unsaved: the file's values are the baseline.
                    b.params = live;
                    b.disk = file.and_then(|f| std::fs::read_to_string(f).ok());
                }
                Keep::Nothing
            }
        }
    }

    /// The sliders set `params` on `species`.
    pub fn tune(&mut self, species: usize, params: MotionParams) {
        if let Some(b) = self.species.get_mut(&species) {
            b.tuned = (params != b.params).then_some(params);
        }
    }

    /// `(key, saved value, tuned value)` of each unsaved change of `species`.
    pub fn changes(&self, species: usize) -> Vec<(&'static str, f32, f32)> {
        let Some(b) = self.species.get(&species) else {
            return Vec::new();
        };
        let Some(t) = &b.tuned else {
            return Vec::new();
        };
        FIELDS
            .iter()
            .filter(|k| field(&b.params, k) != field(t, k))
            .map(|k| (*k, field(&b.params, k), field(t, k)))
            .collect()
    }

    /// The values last read from or written to the file (what "revert" goes back to).
    pub fn saved(&self, species: usize) -> Option<MotionParams> {
        self.species.get(&species).map(|b| b.params)
    }

    /// Forgets the unsaved values of `species` (after "revert" or "take the file's values").
    pub fn discard(&mut self, species: usize, file: Option<&PathBuf>) {
        if let Some(b) = self.species.get_mut(&species) {
            b.tuned = None;
            b.disk = file.and_then(|f| std::fs::read_to_string(f).ok());
        }
        self.ask = None;
    }

    /// Writes the unsaved values of `species` into `file`. `force` saves although the file
    /// changed on disk; `replace_expressions` replaces values written as expressions. A
    /// question for the designer comes back as [`SaveOutcome::Asked`].
    pub fn save(
        &mut self,
        species: usize,
        file: &PathBuf,
        force: bool,
        replace_expressions: bool,
    ) -> SaveOutcome {
        let Some(b) = self.species.get_mut(&species) else {
            return SaveOutcome::Nothing;
        };
        let Some(tuned) = b.tuned else {
            return SaveOutcome::Nothing;
        };
        let now = std::fs::read_to_string(file).ok();
        if !force && now != b.disk {
            self.ask = Some(Ask::DiskChanged {
                species,
                file: file.clone(),
            });
            return SaveOutcome::Asked;
        }
        let edits: Vec<Edit> = FIELDS
            .iter()
            .filter(|k| field(&b.params, k) != field(&tuned, k))
            .map(|k| Edit {
                path: KeyPath::keys(&["motion", k]),
                value: saved_number(k, field(&tuned, k)),
            })
            .collect();
        // What the file says once written (the panel puts it live, so the reload changes
        // nothing).
        let mut written = tuned;
        for (k, e) in FIELDS
            .iter()
            .filter(|k| field(&b.params, k) != field(&tuned, k))
            .zip(&edits)
        {
            set_field(&mut written, k, reread(&e.value, field(&tuned, k)));
        }
        match edit::save(
            file,
            &edits,
            EditOptions {
                replace_expressions,
            },
        ) {
            Ok(_) => {
                b.params = written;
                b.tuned = None;
                b.disk = std::fs::read_to_string(file).ok();
                self.ask = None;
                SaveOutcome::Saved(edits.len())
            }
            Err(e @ EditError::Expression { .. }) => {
                self.ask = Some(Ask::Expression {
                    species,
                    why: e.to_string(),
                });
                SaveOutcome::Asked
            }
            Err(e) => SaveOutcome::Failed(e.to_string()),
        }
    }
}

/// What a save did.
#[derive(Debug, PartialEq)]
pub(super) enum SaveOutcome {
    /// Nothing was unsaved.
    Nothing,
    /// This many values written.
    Saved(usize),
    /// A question is open ([`Tuned::ask`]).
    Asked,
    /// Refused (the message names the file and why).
    Failed(String),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_is_saved_as_its_slider_shows_it() {
        assert_eq!(saved_number("s", 63.27586).text(), "63.3");
        assert_eq!(saved_number("s", 70.0).text(), "70");
        assert_eq!(saved_number("front_amp", 0.012_345_6).text(), "0.012");
        assert_eq!(saved_number("p", 0.299_999_98).text(), "0.3");
        // The turn angle shows degrees (one decimal) and is saved in radians: the shortest
        // decimal showing the same degrees.
        let right = 90f32.to_radians();
        assert_eq!(saved_number("turn_angle", right).text(), "1.57");
        assert_eq!(round_to(1.57f32.to_degrees(), 1), 90.0);
        let odd = 37.4f32.to_radians();
        let text = saved_number("turn_angle", odd).text();
        let back: f32 = text.parse().unwrap();
        assert_eq!(round_to(back.to_degrees(), 1), 37.4, "{text}");
        assert!(
            text.len() < format!("{odd}").len(),
            "{text} is shorter than {odd}"
        );
    }
}
