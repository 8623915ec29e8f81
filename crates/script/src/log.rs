//! The script log the panel's console and `shoal test` read.
//!
//! Errors: a broken script fails the same way on every tick and for every fish running it; the
//! log keeps each distinct error's first occurrence (with the fish and simulated time) and counts
//! the repeats, so the console shows one line per problem instead of a flood.
//!
//! Prints: every `print` is kept, with its simulated time, fish and `file:line`; the same line
//! printed again by the same fish before the log is drained is counted on the pending entry
//! ([`LogEntry::repeats`]) rather than queued again.

use std::collections::HashMap;

use shoal_core::world::FishId;

/// How serious a log entry is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogLevel {
    /// `print` from a script.
    Info,
    /// A script error: a syntax error, a runtime error, a broken limit.
    Error,
    /// Something the designer should know that is not itself a script error (a behaviour
    /// switched off after repeated errors); kept once, like errors.
    Warning,
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
    /// Further identical prints of the same fish folded into this entry (0: printed once).
    pub repeats: u64,
}

impl std::fmt::Display for LogEntry {
    /// `[12.35 s] fish #3 behaviors/shy.lua:12: text (×4)`; errors say `error` after the time.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "[{:.2} s]", self.time_s)?;
        match self.level {
            LogLevel::Error => write!(f, " error")?,
            LogLevel::Warning => write!(f, " warning")?,
            LogLevel::Info => {}
        }
        if let Some(id) = self.fish {
            write!(f, " fish #{}", id.index)?;
        }
        write!(f, " {}", self.message)?;
        if self.repeats > 0 {
            write!(f, " (×{})", self.repeats + 1)?;
        }
        Ok(())
    }
}

/// Most entries kept waiting for a drain; past it the oldest prints are dropped and counted
/// (a script printing every decision with nobody reading must not grow memory without bound).
pub const MAX_PENDING: usize = 10_000;

/// Deduplicating log: [`ScriptLog::push`] keeps a message only the first time it is seen.
#[derive(Debug, Default)]
pub struct ScriptLog {
    /// Message → number of times it was pushed.
    counts: HashMap<String, u64>,
    /// Entries not yet drained.
    pending: Vec<LogEntry>,
    /// Entries dropped past [`MAX_PENDING`].
    dropped: u64,
}

impl ScriptLog {
    /// Records `message`; returns true if it was queued for the console (an error the first
    /// time it is seen, every print) and written to the process log.
    pub fn push(
        &mut self,
        level: LogLevel,
        message: &str,
        fish: Option<FishId>,
        time_s: f64,
    ) -> bool {
        if level == LogLevel::Info {
            self.push_print(message, fish, time_s);
            return true;
        }
        if let Some(n) = self.counts.get_mut(message) {
            *n += 1;
            return false;
        }
        self.counts.insert(message.to_owned(), 1);
        log::warn!("{message}");
        self.queue(LogEntry {
            time_s,
            level,
            message: message.to_owned(),
            fish,
            repeats: 0,
        });
        true
    }

    fn push_print(&mut self, message: &str, fish: Option<FishId>, time_s: f64) {
        let same =
            |e: &LogEntry| e.level == LogLevel::Info && e.fish == fish && e.message == message;
        // The same fish printing the same line again (every decision, say) is counted.
        if let Some(e) = self.pending.iter_mut().rev().take(64).find(|e| same(e)) {
            e.repeats += 1;
            return;
        }
        log::debug!("{message}");
        self.queue(LogEntry {
            time_s,
            level: LogLevel::Info,
            message: message.to_owned(),
            fish,
            repeats: 0,
        });
    }

    fn queue(&mut self, entry: LogEntry) {
        if self.pending.len() >= MAX_PENDING {
            if let Some(i) = self.pending.iter().position(|e| e.level == LogLevel::Info) {
                self.pending.remove(i);
                self.dropped += 1;
            } else {
                self.dropped += 1;
                return;
            }
        }
        self.pending.push(entry);
    }

    /// Log entries dropped because nobody drained the log in time.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Takes the entries logged since the last call.
    pub fn drain(&mut self) -> Vec<LogEntry> {
        std::mem::take(&mut self.pending)
    }

    /// How often the error `message` was pushed (0 if never).
    pub fn count(&self, message: &str) -> u64 {
        self.counts.get(message).copied().unwrap_or(0)
    }

    /// Forgets the messages that mention `file`, so that after a fix the same error, if it comes
    /// back, is shown again.
    pub fn forget_file(&mut self, file: &str) {
        self.counts.retain(|m, _| !m.contains(file));
    }
}
