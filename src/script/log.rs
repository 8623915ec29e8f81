//! The script log the panel's console reads: every distinct message once.
//!
//! A broken script fails the same way on every tick and for every fish running it; the log keeps
//! the first occurrence (with the fish and simulated time) and counts the repeats, so the console
//! shows one line per problem instead of a flood.

use std::collections::HashMap;

use crate::world::FishId;

/// How serious a log entry is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogLevel {
    /// `print` from a script.
    Info,
    /// A script error: a syntax error, a runtime error, a broken limit.
    Error,
}

/// One line of the script console.
#[derive(Debug, Clone, PartialEq)]
pub struct LogEntry {
    /// Simulated time of the first occurrence, seconds.
    pub time_s: f64,
    /// Error or print.
    pub level: LogLevel,
    /// `file:line: message`.
    pub message: String,
    /// The fish whose script produced it, if any.
    pub fish: Option<FishId>,
}

/// Deduplicating log: [`ScriptLog::push`] keeps a message only the first time it is seen.
#[derive(Debug, Default)]
pub struct ScriptLog {
    /// Message → number of times it was pushed.
    counts: HashMap<String, u64>,
    /// Entries not yet drained.
    pending: Vec<LogEntry>,
}

impl ScriptLog {
    /// Records `message`; returns true if it is new (and so was queued for the console and
    /// written to the process log).
    pub fn push(
        &mut self,
        level: LogLevel,
        message: &str,
        fish: Option<FishId>,
        time_s: f64,
    ) -> bool {
        if let Some(n) = self.counts.get_mut(message) {
            *n += 1;
            return false;
        }
        self.counts.insert(message.to_owned(), 1);
        match level {
            LogLevel::Error => log::warn!("{message}"),
            LogLevel::Info => log::info!("{message}"),
        }
        self.pending.push(LogEntry {
            time_s,
            level,
            message: message.to_owned(),
            fish,
        });
        true
    }

    /// Takes the entries logged since the last call.
    pub fn drain(&mut self) -> Vec<LogEntry> {
        std::mem::take(&mut self.pending)
    }

    /// How often `message` was pushed (0 if never).
    pub fn count(&self, message: &str) -> u64 {
        self.counts.get(message).copied().unwrap_or(0)
    }

    /// Forgets the messages that mention `file`, so that after a fix the same error, if it comes
    /// back, is shown again.
    pub fn forget_file(&mut self, file: &str) {
        self.counts.retain(|m, _| !m.contains(file));
    }
}
