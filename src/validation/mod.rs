//! The paper's experiments reproduced on the twin, with ground truth the paper never had.
//! Runners run the twin and identify from its logs; [`score`] alone compares with the truth.
//!
//! * [`steps`]: excitation and the six-step identification from total power (Table 3).
//! * [`payloads`]: tool and load cases on one trajectory (Table 4), by re-identifying the last
//!   link and by adding the known payload.
//! * [`estimators`]: the paper's steps against all-at-once estimators on the same data.
//! * [`idset`]: the identification set a user would run, identified by cross-validation.
//! * [`heldout`]: the held-out benchmark, motions no identification saw.
//! * [`family`]: the held-out benchmark across a family of truths, robots we did not build,
//!   each identified as a user would.
//! * [`sweep`]: the pick-and-place task over speeds and loads (Figure 14).
//! * [`optimized`]: an optimised task and the user's uniform plan on the twin, predicted and
//!   simulated savings.
//! * [`reproduce`]: all of the above in order, as `powertwin reproduce` runs them.
//! * [`score`]: scoring against the twin's truth: energy errors, the held-out scores and their
//!   spread, identified against true base parameters (Table 2).
//!
//! Two modules need no truth and work on a user's own logs: [`log_price`] prices a measured
//! log with a model as `predict` does, and [`holdout`] checks an identification out of sample
//! on the user's robot (`identify --holdout`).
//!
//! Every experiment runs the twin through a [`rig::Rig`] and reports progress through
//! [`rig::Progress`]. The physical-consistency check of an identified model needs no truth:
//! it is [`crate::identification::consistency`].

pub mod estimators;
pub mod family;
pub mod heldout;
pub mod holdout;
pub mod idset;
pub mod log_price;
pub mod optimized;
pub mod payloads;
pub mod reproduce;
pub mod rig;
pub mod score;
pub mod steps;
pub mod sweep;
