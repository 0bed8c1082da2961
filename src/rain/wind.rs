//! Wind (under construction).
