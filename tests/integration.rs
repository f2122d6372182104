//! The integration tests, one module per file beside this one, in one test binary: one link
//! of the library instead of one per file (the cold test build; docs/experiments.md#one-test-binary).
//! Run one file's tests with `cargo test --release --test integration <file>::`.
//! `viz_spawn` stays its own binary: it empties PATH for the whole process.

mod common;

mod arms;
mod base_params;
mod cli;
mod cli_doc;
mod consistent;
mod dataset;
mod dynamics;
mod excite_set;
mod export;
mod family;
mod fuzz;
mod heldout;
mod identification;
mod identify_cli;
mod idset;
mod intervals;
mod kinematics;
mod logs;
mod model_files;
mod optimize;
mod plot;
mod predict_plan;
mod prior;
mod reproduce;
mod results_doc;
mod runs_manifest;
mod sampled;
mod sampling;
mod simulate_cli;
mod spline_route;
mod task;
mod trajectory;
mod twin;
mod twin_choice;
mod urdf_loader;
mod validation;
mod viz;
mod viz_cli;
mod your_robot;
