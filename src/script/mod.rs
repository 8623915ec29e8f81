//! placeholder: filled in by the script work
