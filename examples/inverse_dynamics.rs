//! Library use in a few lines: load the built-in IRB 1200, evaluate joint torques along a
//! smooth motion with the estimated drive terms, and integrate mechanical energy.
//!
//! `cargo run --release --example inverse_dynamics`

use powertwin::dynamics::rnea::rnea;
use powertwin::dynamics::{DriveTerms, Workspace};
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::model::urdf::{LoadOptions, load_str};

fn main() -> powertwin::Result<()> {
    let robot = load_str(builtin::IRB1200_URDF, &LoadOptions::default())?;
    let drive = Drive::from_toml_str(builtin::IRB1200_DRIVE, "irb1200_7_70.drive.toml", &robot)?;
    let terms = DriveTerms::from(&drive);
    let n = robot.dof();
    let mut ws = Workspace::new(&robot);
    let (dt, duration) = (0.001, 10.0);
    let (mut q, mut dq, mut ddq, mut tau) =
        (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut energy_j = 0.0;
    let mut peak_w: f64 = 0.0;
    for k in 0..(duration / dt) as usize {
        let t = k as f64 * dt;
        // Each joint swings 0.4 rad at 0.1 Hz around a bent-arm pose.
        let w = 2.0 * std::f64::consts::PI * 0.1;
        for i in 0..n {
            let offset = [0.0, 0.3, 0.2, 0.0, 0.8, 0.0][i];
            q[i] = offset + 0.4 * (w * t).sin();
            dq[i] = 0.4 * w * (w * t).cos();
            ddq[i] = -0.4 * w * w * (w * t).sin();
        }
        rnea(&robot, &mut ws, &q, &dq, &ddq, Some(&terms), &mut tau);
        let power: f64 = tau.iter().zip(&dq).map(|(t, v)| t * v).sum();
        peak_w = peak_w.max(power.abs());
        energy_j += power * dt;
    }
    println!(
        "{}: 10 s of motion, net mechanical energy {energy_j:.1} J, peak |power| {peak_w:.1} W",
        robot.name()
    );
    Ok(())
}
