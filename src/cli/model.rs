//! `powertwin model`: describe the loaded robot.

use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use powertwin::Robot;
use powertwin::dynamics::ParamLayout;
use powertwin::dynamics::base_params::{BaseParams, SamplingOptions};
use powertwin::model::frames::{MdhRow, mdh_table};
use powertwin::model::inertia::STANDARD_NAMES;
use serde_json::json;

use super::RobotArgs;

/// Arguments of `model`.
#[derive(Debug, Args)]
pub struct ModelArgs {
    #[command(flatten)]
    robot: RobotArgs,
    /// Print only the modified-DH table (paper Table 1 form); fails if the chain is not
    /// MDH-expressible.
    #[arg(long)]
    mdh: bool,
    /// Machine-readable JSON instead of text.
    #[arg(long)]
    json: bool,
}

fn base_counts(robot: &Robot) -> Result<[usize; 3]> {
    let mut out = [0; 3];
    for (k, (f, a)) in [(false, false), (true, false), (true, true)]
        .into_iter()
        .enumerate()
    {
        let layout = ParamLayout::new(robot, f, a);
        out[k] = BaseParams::compute(robot, layout, &SamplingOptions::default())?.rank();
    }
    Ok(out)
}

/// Run `model`.
pub fn run(args: &ModelArgs) -> Result<ExitCode> {
    let robot = args.robot.load()?;
    let mdh = mdh_table(&robot);
    if args.mdh {
        super::emit(&mdh_only(&robot, &mdh?, args.json)?)?;
        return Ok(ExitCode::SUCCESS);
    }
    let counts = base_counts(&robot)?;
    let std = robot.standard_params();
    let o = if args.json {
        description_json(&robot, &mdh, &std, counts)?
    } else {
        description_text(&robot, &mdh, &std, counts)
    };
    super::emit(&o)?;
    Ok(ExitCode::SUCCESS)
}

/// `--mdh`: only the MDH table `rows`, as JSON or as text.
fn mdh_only(robot: &Robot, rows: &[MdhRow], json: bool) -> Result<String> {
    let mut o = String::new();
    if json {
        outln!(o, "{}", serde_json::to_string_pretty(&rows)?);
    } else {
        o.push_str(&mdh_text(robot, rows));
    }
    Ok(o)
}

/// `--json`: the robot's joints (limits in rad, rad/s, N m; friction), links (mass in kg,
/// centre of mass in m, standard parameters `std`), MDH table or why there is none, and the
/// base-parameter `counts` of [`base_counts`].
fn description_json(
    robot: &Robot,
    mdh: &powertwin::Result<Vec<MdhRow>>,
    std: &[[f64; 10]],
    counts: [usize; 3],
) -> Result<String> {
    let joints: Vec<_> = robot
        .joints()
        .iter()
        .map(|j| {
            json!({
                "name": j.name,
                "lower_rad": finite_or_null(j.limits.lower),
                "upper_rad": finite_or_null(j.limits.upper),
                "velocity_rad_s": finite_or_null(j.limits.velocity),
                "effort_Nm": j.limits.effort,
                "coulomb_Nm": j.friction.coulomb,
                "viscous_Nms_rad": j.friction.viscous,
            })
        })
        .collect();
    let links: Vec<_> = robot
        .links()
        .iter()
        .zip(std)
        .map(|(l, p)| {
            json!({
                "name": l.name,
                "mass_kg": l.inertia.mass,
                "com_m": [l.inertia.com.x, l.inertia.com.y, l.inertia.com.z],
                "standard": STANDARD_NAMES.iter().zip(p).map(|(n, v)| (n.to_string(), json!(v))).collect::<serde_json::Map<_, _>>(),
            })
        })
        .collect();
    let out = json!({
        "name": robot.name(),
        "dof": robot.dof(),
        "flange": robot.flange_name(),
        "joints": joints,
        "links": links,
        "standard_param_order": STANDARD_NAMES,
        "mdh": mdh.as_ref().ok(),
        "mdh_error": mdh.as_ref().err().map(|e| e.to_string()),
        "base_params": {"inertial": counts[0], "with_friction": counts[1], "with_friction_and_armature": counts[2]},
    });
    let mut o = String::new();
    outln!(o, "{}", serde_json::to_string_pretty(&out)?);
    Ok(o)
}

/// The default text: the joint table, the MDH table or why there is none, the standard
/// parameters `std` per link and the base-parameter `counts` of [`base_counts`].
fn description_text(
    robot: &Robot,
    mdh: &powertwin::Result<Vec<MdhRow>>,
    std: &[[f64; 10]],
    counts: [usize; 3],
) -> String {
    let mut o = joints_text(robot);
    match mdh {
        Ok(rows) => {
            outln!(o, "\nmodified DH (Craig):");
            o.push_str(&mdh_text(robot, rows));
        }
        Err(e) => outln!(o, "\nmodified DH: not expressible ({e})"),
    }
    o.push_str(&standard_params_text(robot, std));
    outln!(
        o,
        "\nbase parameters: {} inertial, {} with Coulomb+viscous friction, {} with rotor inertia as well",
        counts[0],
        counts[1],
        counts[2]
    );
    o
}

/// The robot's name line and its joint table: limits (rad, rad/s), effort (N m) and
/// friction (N m, N m s/rad).
fn joints_text(robot: &Robot) -> String {
    let mut o = String::new();
    outln!(
        o,
        "robot {} ({} joints, flange '{}')",
        robot.name(),
        robot.dof(),
        robot.flange_name()
    );
    outln!(
        o,
        "\n{:<4} {:<14} {:>10} {:>10} {:>12} {:>10} {:>9} {:>12}",
        "#",
        "joint",
        "lower_rad",
        "upper_rad",
        "vel_rad_s",
        "effort_Nm",
        "fc_Nm",
        "fv_Nms_rad"
    );
    for (i, j) in robot.joints().iter().enumerate() {
        let l = &j.limits;
        outln!(
            o,
            "{:<4} {:<14} {:>10.4} {:>10.4} {:>12.4} {:>10} {:>9.3} {:>12.3}",
            i + 1,
            j.name,
            l.lower,
            l.upper,
            l.velocity,
            l.effort.map_or("-".into(), |e| format!("{e:.1}")),
            j.friction.coulomb,
            j.friction.viscous
        );
    }
    o
}

/// The table of standard inertial parameters `std`, one row per link.
fn standard_params_text(robot: &Robot, std: &[[f64; 10]]) -> String {
    let mut o = String::new();
    outln!(
        o,
        "\nstandard inertial parameters in the MDH link frames (kg m^2 about the frame origin, kg m, kg):"
    );
    out!(o, "{:<4}", "link");
    for n in STANDARD_NAMES {
        out!(o, " {n:>11}");
    }
    outln!(o);
    for (i, (l, p)) in robot.links().iter().zip(std).enumerate() {
        out!(o, "{:<4}", i + 1);
        for v in p {
            out!(o, " {v:>11.4e}");
        }
        outln!(o, "   {}", l.name);
    }
    o
}

/// The MDH table as text, one row per joint and a last row for the flange.
fn mdh_text(robot: &Robot, rows: &[MdhRow]) -> String {
    let mut o = String::new();
    outln!(
        o,
        "{:<6} {:>10} {:>12} {:>10} {:>12}",
        "link",
        "a_m",
        "alpha_rad",
        "d_m",
        "theta_rad"
    );
    for (i, r) in rows.iter().enumerate() {
        let name = if i < robot.dof() {
            (i + 1).to_string()
        } else {
            "flange".into()
        };
        outln!(
            o,
            "{name:<6} {:>10.4} {:>12.6} {:>10.4} {:>12.6}",
            r.a,
            r.alpha,
            r.d,
            r.theta
        );
    }
    o
}

fn finite_or_null(v: f64) -> serde_json::Value {
    if v.is_finite() {
        json!(v)
    } else {
        serde_json::Value::Null
    }
}
