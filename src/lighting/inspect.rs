//! CLI helpers (under construction).
