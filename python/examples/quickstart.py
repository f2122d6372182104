"""Quickstart: identify an energy model from twin runs and predict a held-out motion.

Runs the built-in ABB IRB 1200 twin (realistic fidelity: unmodelled friction effects, a 10 %
wrong controller model, DC-bus power logged at 10 Hz with noise) along three random
rest-to-rest motions, identifies the model from the first two logs (as `powertwin identify`),
then predicts the third one from its log and from its plan alone (as `powertwin predict`)
and prints the figures. Units: s, rad, W, J.

    python python/examples/quickstart.py
"""

import numpy as np

import powertwin as pt


def plan(seed: int, dof: int, duration_s: float = 10.0, rate_hz: float = 100.0) -> dict:
    """A smooth rest-to-rest multi-sine motion of every joint (t_s in s, q_rad in rad)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s + 1e-9, 1.0 / rate_hz)
    envelope = np.sin(np.pi * t / duration_s) ** 2
    q = np.column_stack([
        rng.uniform(0.2, 0.5) * envelope * np.sin(2 * np.pi * rng.uniform(0.15, 0.5) * t + rng.uniform(0, 6.3))
        for _ in range(dof)
    ])
    return {"t_s": t, "q_rad": q}


def main() -> None:
    robot = pt.Robot.irb1200()
    plans = [plan(seed, robot.dof) for seed in (1, 2, 3)]
    runs = [pt.simulate(robot, p, truth="realistic", seed=k + 1) for k, p in enumerate(plans)]
    model = pt.identify(robot, [r["log"] for r in runs[:2]])
    print(f"{robot}: identified from 2 runs of {runs[0]['duration_s']:.1f} s -> {model}")

    held_out = runs[2]
    from_log = model.predict(held_out["log"])
    from_plan = model.predict_trajectory(plans[2]["t_s"], plans[2]["q_rad"])
    clipped = model.signal != "total"
    truth = held_out["energy_grid_J"] if clipped else held_out["energy_total_J"]
    print(f"held-out run ({model.signal} power): measured {from_log.measured_J:.1f} J")
    print(f"  predicted from its log:  {from_log.energy_J:.1f} ± {from_log.interval_J:.1f} J (95 %), "
          f"error {from_log.error_pct:+.2f} %, power RMSE {from_log.power_rmse_W:.2f} W")
    print(f"  predicted from its plan: {from_plan.energy_J:.1f} ± {from_plan.interval_J:.1f} J (95 %), "
          f"mean power {from_plan.mean_power_W:.1f} W over {from_plan.duration_s:.1f} s")
    print(f"  the twin's {'grid-side' if clipped else 'motor'} energy over the whole run (truth): {truth:.1f} J")
    assert abs(from_log.error_pct) < 25, "the model should predict a held-out motion within 25 %"


if __name__ == "__main__":
    main()
