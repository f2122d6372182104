//! The held-out benchmark: motions no identification saw, drawn from their own seed (random
//! Fourier motions about random centres, random point-to-point moves, linear TCP moves at
//! 0.05–1 m/s), each with a known payload from none to the rated payload, run on the twin and
//! predicted by an identified model from the logged stream (states smoothed from the 10 Hz
//! positions) and from the commanded trajectory. The twin's truth only scores.
//!
//! Per motion ([`score::heldout_motion`]): the error of the predicted energy (of the measured signal) and of the energy
//! above standby, the mean-power error, the power RMSE at the logged samples, whether the
//! 95 % interval covers the truth, and the same for a baseline a user has without
//! identification: the URDF's rigid bodies and friction with the data-sheet efficiency.

use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use crate::dataset::Dataset;
use crate::dataset::schedule::longest_first;
use crate::dynamics::ParamLayout;
use crate::error::{Error, Result};
use crate::identification::data::Route;
use crate::identification::model::{DATASHEET_EFFICIENCY, PowerModel};
use crate::kinematics::fk::flange_pose;
use crate::model::Robot;
use crate::model::drive::Drive;
use crate::model::payload::{Payload, PayloadEvent};
use crate::trajectory::Trajectory;
use crate::trajectory::limits::{IRB1200_ACCEL_LIMITS, default_accel_limits};
use crate::trajectory::linear_move::{LinearMoveOptions, MotionLimits, ViaPose, plan};
use crate::trajectory::random::{
    RandomFourierOptions, RandomPointToPointOptions, position_range, random_fourier,
    random_point_to_point,
};
use crate::validation::rig::{Progress, Rig};
use crate::validation::score::{self, MotionResult, RouteSummary, Spread};

/// Route from a logged stream to states for prediction: rests held still and the least-jerk
/// quintic spline through the samples between them, smoothed for the log's own encoder noise,
/// leaving and reaching each rest inside a sample interval where the displacements place it
/// ([`crate::identification::states::from_spline`]).
pub const LOG_ROUTE: Route = Route::Spline;

/// Settings of the benchmark.
#[derive(Debug, Clone, PartialEq)]
pub struct HeldoutOptions {
    /// Motions (a third of each kind, in turn).
    pub count: usize,
    /// Seed of the motions (keep it apart from every identification seed).
    pub seed: u64,
    /// Largest payload, kg (the rated payload).
    pub max_payload_kg: f64,
    /// Efficiency of the baseline (data sheet).
    pub baseline_efficiency: f64,
    /// Route from a logged stream to states for the predictions from logs.
    pub route: Route,
    /// Joint acceleration bounds of every motion, rad/s^2 (one per joint).
    pub accel_limits: Vec<f64>,
    /// Range of each joint's position at the start of a linear move, rad (one per joint).
    pub linear_start: Vec<(f64, f64)>,
}

/// Start poses of the IRB 1200's linear moves, rad per joint: the arm reaching forward, over
/// half of the base's turn, with the wrist bent (joint 5 at 0.4-1.4 rad) away from its
/// singularity.
const IRB1200_LINEAR_START: [(f64, f64); 6] = [
    (-1.5, 1.5),
    (-0.2, 0.7),
    (-0.3, 0.5),
    (-1.0, 1.0),
    (0.4, 1.4),
    (-1.0, 1.0),
];

impl HeldoutOptions {
    /// 30 motions from seed 90 210, payloads up to the IRB 1200's rated 7 kg, baseline
    /// efficiency 0.87 (the middle of the paper's 83–92 %), the IRB 1200's acceleration bounds
    /// ([`IRB1200_ACCEL_LIMITS`]) and linear moves from working poses in front of it.
    pub fn irb1200(count: usize) -> HeldoutOptions {
        HeldoutOptions {
            count,
            seed: 90_210,
            max_payload_kg: 7.0,
            baseline_efficiency: DATASHEET_EFFICIENCY,
            route: LOG_ROUTE,
            accel_limits: IRB1200_ACCEL_LIMITS.to_vec(),
            linear_start: IRB1200_LINEAR_START.to_vec(),
        }
    }

    /// The benchmark for any serial arm, with payloads up to `max_payload_kg` (its rated
    /// payload): [`HeldoutOptions::irb1200`] for the IRB 1200 (robot `abb_irb1200_7_70`),
    /// else its acceleration bounds by [`default_accel_limits`] and linear moves starting
    /// with each joint in the middle half of its range (`[-pi, pi]` where unlimited).
    ///
    /// Errors: a joint whose limits leave no range.
    pub fn for_robot(robot: &Robot, count: usize, max_payload_kg: f64) -> Result<HeldoutOptions> {
        let base = HeldoutOptions::irb1200(count);
        if robot.name() == crate::model::builtin::IRB1200_NAME
            && robot.dof() == IRB1200_LINEAR_START.len()
        {
            return Ok(HeldoutOptions {
                max_payload_kg,
                ..base
            });
        }
        let linear_start = robot
            .joints()
            .iter()
            .map(|j| {
                let (lo, hi) = position_range(robot, j, 0.0)?;
                Ok((0.75 * lo + 0.25 * hi, 0.25 * lo + 0.75 * hi))
            })
            .collect::<Result<_>>()?;
        Ok(HeldoutOptions {
            max_payload_kg,
            accel_limits: default_accel_limits(robot),
            linear_start,
            ..base
        })
    }
}

/// One held-out motion.
pub struct Motion {
    /// `fourier`, `point-to-point` or `linear`.
    pub kind: &'static str,
    /// The commanded trajectory.
    pub trajectory: Box<dyn Trajectory + Send + Sync>,
    /// Known payload timeline.
    pub events: Vec<PayloadEvent>,
    /// Payload mass, kg.
    pub payload_kg: f64,
    /// TCP speed of a linear motion, m/s.
    pub tcp_speed_m_s: Option<f64>,
}

/// Draw the motions of `opts` for `robot`.
///
/// Errors: `opts.accel_limits` or `opts.linear_start` of the wrong length, a start range that
/// is not finite and ordered; no motion of a kind within the limits after 50 draws.
pub fn motions(robot: &Robot, opts: &HeldoutOptions) -> Result<Vec<Motion>> {
    check_motion_options(robot, opts)?;
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    (0..opts.count)
        .map(|k| {
            let (payload_kg, events) = draw_payload(k, opts.max_payload_kg, &mut rng)?;
            let (kind, trajectory, speed) = draw_trajectory(k, robot, opts, &mut rng)?;
            Ok(Motion {
                kind,
                trajectory,
                events,
                payload_kg,
                tcp_speed_m_s: speed,
            })
        })
        .collect()
}

/// Checks that `opts.accel_limits` and `opts.linear_start` have one entry per joint and that
/// every start range (rad) is finite and ordered.
fn check_motion_options(robot: &Robot, opts: &HeldoutOptions) -> Result<()> {
    robot.check_len(&opts.accel_limits, "accel_limits")?;
    if opts.linear_start.len() != robot.dof() {
        return Err(Error::InvalidInput(format!(
            "linear_start has {} ranges, the robot has {} joints",
            opts.linear_start.len(),
            robot.dof()
        )));
    }
    if let Some((i, r)) = opts
        .linear_start
        .iter()
        .enumerate()
        .find(|(_, r)| !(r.0.is_finite() && r.1.is_finite() && r.0 <= r.1))
    {
        return Err(Error::InvalidInput(format!(
            "linear_start[{}] = [{}, {}] rad must be a finite range",
            i + 1,
            r.0,
            r.1
        )));
    }
    Ok(())
}

/// The payload of motion `k`: none for every fourth motion, else a cube of uniformly drawn
/// mass up to `max_payload_kg`, held from the start. Returns the mass (kg) and the payload
/// timeline.
fn draw_payload(
    k: usize,
    max_payload_kg: f64,
    rng: &mut ChaCha8Rng,
) -> Result<(f64, Vec<PayloadEvent>)> {
    let payload_kg = if k.is_multiple_of(4) {
        0.0
    } else {
        rng.random_range(0.5..=max_payload_kg)
    };
    let events = if payload_kg > 0.0 {
        vec![PayloadEvent {
            t_s: 0.0,
            payload: Some(Payload::cube(
                &format!("load {payload_kg:.2} kg"),
                payload_kg,
                [0.0, 0.0, 0.06].into(),
            )?),
        }]
    } else {
        Vec::new()
    };
    Ok((payload_kg, events))
}

/// A drawn trajectory: its kind, the trajectory and the TCP speed of a linear one, m/s.
type DrawnTrajectory = (&'static str, Box<dyn Trajectory + Send + Sync>, Option<f64>);

/// The trajectory of motion `k`, cycling through a random Fourier motion, a random
/// point-to-point move and linear TCP moves.
fn draw_trajectory(
    k: usize,
    robot: &Robot,
    opts: &HeldoutOptions,
    rng: &mut ChaCha8Rng,
) -> Result<DrawnTrajectory> {
    let drawn: DrawnTrajectory = match k % 3 {
        0 => {
            let o = RandomFourierOptions {
                base_freq_hz: rng.random_range(0.1..=0.25),
                min_amplitude: 0.3,
                accel_limits: opts.accel_limits.clone(),
                ..RandomFourierOptions::default()
            };
            ("fourier", Box::new(random_fourier(robot, rng, &o)?), None)
        }
        1 => {
            let o = RandomPointToPointOptions {
                points: 4,
                max_slowdown: 3.0,
                dwell_s: 0.3,
                accel_limits: opts.accel_limits.clone(),
                ..RandomPointToPointOptions::default()
            };
            (
                "point-to-point",
                Box::new(random_point_to_point(robot, rng, &o)?),
                None,
            )
        }
        _ => {
            let (m, v) = linear(robot, opts, rng)?;
            ("linear", Box::new(m), Some(v))
        }
    };
    Ok(drawn)
}

/// Random linear TCP moves: from a random working pose (each joint within
/// `opts.linear_start`; tool orientation kept) through three points 0.1–0.3 m apart, at a
/// log-uniform TCP speed in 0.05–1 m/s, within `opts.accel_limits`. Draws again (up to 50
/// times) when a plan is unreachable or breaks a joint limit.
fn linear<R: Rng + ?Sized>(
    robot: &Robot,
    opts: &HeldoutOptions,
    rng: &mut R,
) -> Result<(crate::trajectory::linear_move::LinearMotion, f64)> {
    let mut last = None;
    for _ in 0..50 {
        let q0: Vec<f64> = opts
            .linear_start
            .iter()
            .map(|&(lo, hi)| rng.random_range(lo..=hi))
            .collect();
        let start = flange_pose(robot, &q0);
        let mut via = vec![ViaPose {
            name: "start".into(),
            tcp: start,
        }];
        let mut p = start;
        for k in 0..3 {
            let dir = nalgebra::Vector3::new(
                rng.random_range(-1.0..=1.0),
                rng.random_range(-1.0..=1.0),
                rng.random_range(-0.6..=0.6),
            )
            .normalize();
            let len: f64 = rng.random_range(0.1..=0.3);
            p.translation.vector += dir * len;
            via.push(ViaPose {
                name: format!("P{}", k + 1),
                tcp: p,
            });
        }
        let speed = (rng.random_range(0.05f64.ln()..=0.0)).exp();
        let options = LinearMoveOptions {
            dwell_s: 0.2,
            limits: MotionLimits {
                accel_m_s2: 4.0,
                joint_accel_rad_s2: opts.accel_limits.clone(),
                ..MotionLimits::default()
            },
            ..LinearMoveOptions::default()
        };
        match plan(
            robot,
            &nalgebra::Isometry3::identity(),
            &q0,
            &via,
            speed,
            &options,
        ) {
            Ok(m) => return Ok((m, speed)),
            Err(e) => last = Some(e),
        }
    }
    Err(last.unwrap_or_else(|| Error::InvalidInput("no linear move found".into())))
}

/// The benchmark's outcome.
#[derive(Debug, Clone, Serialize)]
pub struct Heldout {
    /// Seed of the motions.
    pub seed: u64,
    /// Per motion.
    pub motions: Vec<MotionResult>,
    /// The identified model, from the logs.
    pub from_log: RouteSummary,
    /// The identified model, from the commanded trajectories.
    pub from_plan: RouteSummary,
    /// The baseline, from the logs.
    pub baseline: RouteSummary,
    /// Power RMSE at the logged samples, predicted from the logs, W.
    #[serde(rename = "power_rmse_W")]
    pub power_rmse_w: Spread,
    /// The same, predicted from the commanded trajectories, W.
    #[serde(rename = "plan_power_rmse_W")]
    pub plan_power_rmse_w: Spread,
    /// The same for the baseline, W.
    #[serde(rename = "baseline_power_rmse_W")]
    pub baseline_power_rmse_w: Spread,
}

/// The model a user has without identification: the URDF's rigid bodies and friction
/// (no rotor inertia, no standby or copper loss), with every power divided by the
/// data-sheet `efficiency`, of the same power signal as `like`.
pub fn baseline(robot: &Robot, like: &PowerModel, efficiency: f64) -> Result<PowerModel> {
    let layout = ParamLayout::new(robot, true, true);
    let mut m = PowerModel::new(robot, layout, true)?;
    let base = m.base_params(robot)?;
    let theta = layout.theta(
        robot,
        &crate::dynamics::DriveTerms::from(&Drive::from_urdf(robot)),
    );
    for (t, v) in m.theta.iter_mut().zip(base.base_values(&theta)?) {
        *t = v / efficiency;
    }
    m.signal = like.signal;
    Ok(m)
}

/// The benchmark's motions run on the twin: what [`evaluate`] predicts and scores. They do not
/// depend on any model, so they can run while the model is identified.
pub struct Runs {
    motions: Vec<Motion>,
    datasets: Vec<Dataset>,
}

/// Run every motion of the benchmark on `rig`.
pub fn simulate(rig: &Rig, opts: &HeldoutOptions, progress: &dyn Progress) -> Result<Runs> {
    let motions = motions(rig.robot, opts)?;
    progress.stage("held-out motions: twin runs", motions.len());
    // Longest runs first, so that no long run is left alone on one core at the end.
    let indexed: Vec<(usize, &Motion)> = motions.iter().enumerate().collect();
    let datasets = longest_first(
        &indexed,
        |(_, m)| m.trajectory.duration(),
        |&(k, m)| {
            let description = serde_json::json!({
                "kind": m.kind,
                "experiment": "held-out benchmark",
                "index": k + 1,
                "payload_kg": m.payload_kg,
                "tcp_speed_m_s": m.tcp_speed_m_s,
            });
            let ds = rig
                .run(
                    m.trajectory.as_ref(),
                    &m.events,
                    10_000 + k as u64,
                    description,
                )
                .map_err(|e| e.context(&format!("held-out motion {}", k + 1)))?;
            progress.advance();
            Ok(ds)
        },
    )
    .into_iter()
    .collect::<Result<_>>()?;
    Ok(Runs { motions, datasets })
}

/// Score `model` (and the baseline) on the benchmark's `runs` against the truth; returns
/// the outcome and the runs' datasets.
pub fn evaluate(
    rig: &Rig,
    model: &PowerModel,
    opts: &HeldoutOptions,
    runs: Runs,
    progress: &dyn Progress,
) -> Result<(Heldout, Vec<Dataset>)> {
    let base_model = baseline(rig.robot, model, opts.baseline_efficiency)?;
    progress.stage("held-out motions: predictions", runs.motions.len());
    let motions: Vec<MotionResult> = runs
        .motions
        .par_iter()
        .zip(&runs.datasets)
        .enumerate()
        .map(|(k, (m, ds))| {
            let r = score::heldout_motion(rig, model, &base_model, k, m, ds, opts)?;
            progress.advance();
            Ok(r)
        })
        .collect::<Result<_>>()?;
    let h = Heldout {
        seed: opts.seed,
        from_log: RouteSummary::of(motions.iter().map(|m| &m.from_log)),
        from_plan: RouteSummary::of(motions.iter().map(|m| &m.from_plan)),
        baseline: RouteSummary::of(motions.iter().map(|m| &m.baseline)),
        power_rmse_w: Spread::of(motions.iter().map(|m| m.power_rmse_w)),
        plan_power_rmse_w: Spread::of(motions.iter().map(|m| m.plan_power_rmse_w)),
        baseline_power_rmse_w: Spread::of(motions.iter().map(|m| m.baseline_power_rmse_w)),
        motions,
    };
    Ok((h, runs.datasets))
}

/// Run every motion on `rig` and score `model` (and the baseline) against the truth:
/// [`simulate`], then [`evaluate`].
pub fn run(
    rig: &Rig,
    model: &PowerModel,
    opts: &HeldoutOptions,
    progress: &dyn Progress,
) -> Result<(Heldout, Vec<Dataset>)> {
    let runs = simulate(rig, opts, progress)?;
    evaluate(rig, model, opts, runs, progress)
}
