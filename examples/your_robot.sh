#!/usr/bin/env bash
# Walk-through: from a robot's logs to a model, a task prediction, the identified robot as a
# twin, and a look at it in Rerun. Run from the repository root:
#   bash examples/your_robot.sh [WORKDIR]
# Here the twin stands in for your robot and writes its logs as a data logger would (time,
# joint positions, DC-bus power); with your own arm, start at step 1 with your CSV/Parquet
# logs and a column map (docs/guide/your-robot.md, docs/guide/log-columns.md, `--columns ur-rtde`).
set -euo pipefail
W=${1:-$(mktemp -d)}
mkdir -p "$W"
cargo build --release --quiet
P=./target/release/powertwin

# 0. "Your robot": three designed excitations (10 s periods at 0.1 Hz) carrying the 1.32 kg
#    tool, run on the realistic twin (unmodelled losses, DC-bus power meter, 10 Hz log).
for s in 1 2 3; do
  $P excite --seed "$s" --periods 2 --evals 300 --out "$W/ex$s.csv" > /dev/null
  $P simulate --trajectory "$W/ex$s.csv" --payload tool --format csv --noise-seed "$s" \
    --out "$W/run$s" > /dev/null
done

# 1. Identify from the logs alone: measured.csv holds t_s, q1_rad.., p_elec1_W.., p_total_W;
#    the power is the DC bus (never negative) and the tool is known. The estimator is chosen
#    by cross-validation; the identified robot is exported as URDF + drive file.
$P identify --log "$W"/run{1,2,3}/measured.csv --power bus --payload tool --base-freq 0.1 \
  --out "$W/model.json" --export-urdf "$W/robot.urdf" --export-drive "$W/robot.drive.toml"

# 2. What does a task cost? The pick-and-place scenario at 0.5 m/s with 2 kg, predicted by
#    the model from the plan beside the twin.
$P sweep --model "$W/model.json" --speeds 0.5 --loads 2 --out "$W/sweep"

# 3. The identified robot as a twin of its own, on a motion it was not identified on,
#    recorded for the Rerun viewer (`rerun "$W/twin_b.rrd"`; rerun-sdk 0.36).
$P excite --seed 4 --periods 1 --evals 300 --out "$W/ex4.csv" > /dev/null
$P simulate --robot "$W/robot.urdf" --drive "$W/robot.drive.toml" --truth exact \
  --trajectory "$W/ex4.csv" --out "$W/twin_b" --save "$W/twin_b.rrd" > /dev/null
$P predict --model "$W/model.json" --data "$W/twin_b"
echo "Everything is in $W (model.json, robot.urdf, robot.drive.toml, sweep/, twin_b.rrd)."
