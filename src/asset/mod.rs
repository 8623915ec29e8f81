//! placeholder: filled in by the asset work
