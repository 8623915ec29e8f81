//! Helpers of the app tests: the script tests' helpers (which include the core ones).
#![allow(dead_code, unused_imports)]

#[path = "../../../script/tests/script/common.rs"]
mod script_common;
pub use script_common::*;
