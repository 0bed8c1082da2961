//! Rain physics (under construction).
