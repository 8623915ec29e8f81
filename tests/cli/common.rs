//! Helpers of the command line's tests: the script tests' helpers (which include the core ones).
#![allow(dead_code, unused_imports)]

#[path = "../../crates/script/tests/script/common.rs"]
mod script_common;
pub use script_common::*;
