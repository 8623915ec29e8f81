//! placeholder: filled in by the skin work
