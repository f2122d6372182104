//! `powertwin base-params`: the base parameter set of the loaded robot.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use powertwin::dynamics::base_params::{BaseParams, SamplingOptions};
use powertwin::dynamics::{DriveTerms, ParamLayout};
use serde_json::json;

use super::RobotArgs;

/// Arguments of `base-params`.
#[derive(Debug, Args)]
pub struct BaseParamsArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Include Coulomb and viscous friction columns (fc, fv per joint).
    #[arg(long)]
    friction: bool,
    /// Include rotor-inertia (armature) columns (Ia per joint).
    #[arg(long)]
    armature: bool,
    /// Drive file for the friction and rotor-inertia values [default: the built-in IRB 1200
    /// drive for the built-in robot, else the URDF <dynamics> friction and no rotor inertia].
    #[arg(long, value_name = "PATH")]
    drive: Option<PathBuf>,
    /// Number of random states stacked.
    #[arg(long, default_value_t = 200)]
    samples: usize,
    /// Seed of the random states.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Machine-readable JSON instead of text.
    #[arg(long)]
    json: bool,
}

/// Run `base-params`.
pub fn run(args: &BaseParamsArgs) -> Result<ExitCode> {
    let robot = args.robot.load()?;
    let mut o = String::new();
    let terms = match args.robot.drive(&robot, args.drive.as_ref())? {
        Some(d) => DriveTerms::from(&d),
        None => DriveTerms::from_urdf(&robot),
    };
    let layout = ParamLayout::new(&robot, args.friction, args.armature);
    let opts = SamplingOptions {
        samples: args.samples,
        seed: args.seed,
    };
    let bp = BaseParams::compute(&robot, layout, &opts)?;
    let values = bp.base_values(&layout.theta(&robot, &terms))?;
    let names = bp.base_names();
    let relations = bp.relations();
    if args.json {
        let out = json!({
            "robot": robot.name(),
            "layout": layout,
            "standard": layout.len(),
            "base": bp.rank(),
            "independent": names,
            "values": names.iter().zip(&values).map(|(n, v)| (n.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
            "relations": relations,
            "without_effect": bp.without_effect(),
        });
        outln!(o, "{}", serde_json::to_string_pretty(&out)?);
        super::emit(&o)?;
        return Ok(ExitCode::SUCCESS);
    }
    outln!(
        o,
        "{}: {} standard parameters, {} base parameters (friction {}, armature {})",
        robot.name(),
        layout.len(),
        bp.rank(),
        args.friction,
        args.armature
    );
    outln!(o, "\n{:<8} {:>14}  relation", "base", "value");
    for ((name, v), rel) in names.iter().zip(&values).zip(&relations) {
        let terms: String = rel
            .terms
            .iter()
            .map(|(n, c)| format!(" {} {:.6}*{n}", if *c < 0.0 { '-' } else { '+' }, c.abs()))
            .collect();
        outln!(o, "{name:<8} {v:>14.6e}  {}{terms}", rel.standard);
    }
    outln!(
        o,
        "\nno effect on the torques: {}",
        bp.without_effect().join(" ")
    );
    super::emit(&o)?;
    Ok(ExitCode::SUCCESS)
}
