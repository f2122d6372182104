//! Datasets: what one twin run produced, as a directory of files. [`meta`] describes the run.

pub mod meta;
