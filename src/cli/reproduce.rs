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
         Available now: model, dynamics, base-params, excite, simulate, dataset, identify,\n\
         predict.\n\
         Missing: the end-to-end pipeline (Table 3/4 reproduction, the pick-and-place\n\
         speed/load sweep, report and plots).",
        args.out.display()
    );
    Ok(ExitCode::from(2))
}
