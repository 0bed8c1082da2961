//! Pipeline (under construction).
