//! Low-level numerical solvers shared across the crate: [`lm`], the one bounded
//! Levenberg–Marquardt loop that the power fit, the consistent projection and the inverse
//! kinematics run.

pub mod lm;
