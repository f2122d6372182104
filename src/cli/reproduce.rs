//! `powertwin reproduce`: the main job.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;

/// Arguments of `reproduce`.
#[derive(Debug, Args)]
pub struct ReproduceArgs {
    /// Output directory.
    #[arg(long, default_value = "out")]
    out: PathBuf,
}

/// Not built yet: say what is missing and fail.
pub fn run(args: &ReproduceArgs) -> Result<ExitCode> {
    eprintln!(
        "powertwin reproduce is not built yet (nothing written to {}).\n\
         Available now: the model, kinematics, rigid-body dynamics and base parameters\n\
         (`powertwin model`, `powertwin dynamics`, `powertwin base-params`).\n\
         Missing: the Rapier twin that generates power datasets, excitation design and\n\
         identification from power, and the pick-and-place sweep and report.",
        args.out.display()
    );
    Ok(ExitCode::from(2))
}
