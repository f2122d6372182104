#!/usr/bin/env bash
# The real-robot journey on a Universal Robots UR5, end to end: design an identification set
# for the robot's cell, run it on the robot, identify from the runs' logs, price a plan nobody
# has run, and find the cheapest timing of a task. Run from anywhere:
#   bash examples/your_robot.sh [WORKDIR]
# Here the twin stands in for your robot at step 2 and writes its logs as a data logger would
# (time, joint positions, DC-bus power at 25 Hz); with your own UR, run the URScript programs
# of step 1 on the controller, record RTDE (docs/guide/your-robot.md#universal-robots-cb3-e-series)
# and save each log where runs.toml says. `tests/your_robot.rs` runs this script in CI.
set -euo pipefail
cd "$(dirname "$0")/.."
W=$(realpath -m "${1:-$(mktemp -d)}")
mkdir -p "$W"
if [ -n "${POWERTWIN:-}" ]; then
  P=$POWERTWIN
else
  cargo build --release --quiet
  P=./target/release/powertwin
fi
ROBOT=(--robot models/ur5.urdf --drive models/ur5.drive.toml)
GRIPPER=models/robotiq_2f85.payload.toml
LOADED="$GRIPPER+models/load_2kg.payload.toml"

# 0. The cell: a table 2 cm below the robot's base, half the rated joint speeds.
cat > "$W/cell.toml" <<'EOF'
floor_z_m = -0.02
floor_margin_m = 0.05
speed_scaling = 0.5
EOF

# 1. An identification set: six 20 s excitations designed together, three with the bare
#    flange and three carrying the gripper and a 2 kg part, as URScript programs and CSVs,
#    with the runs manifest to fill.
LOADS=(none none none "$LOADED" "$LOADED" "$LOADED")
$P excite "${ROBOT[@]}" --set 6 --loads "$(IFS=,; echo "${LOADS[*]}")" --cell "$W/cell.toml" \
  --duration 20 --format urscript --out "$W/set"

# 2. "Your robot" runs each excitation with its load (the realistic twin: unmodelled losses,
#    a controller whose model is 10 % wrong, DC-bus power, 25 Hz). The logs go where the
#    manifest says; the manifest's power default is the DC bus.
mkdir -p "$W/set/logs"
for k in 1 2 3 4 5 6; do
  id=$(printf "%02d" "$k")
  load=${LOADS[$((k - 1))]}
  payload=()
  if [ "$load" != none ]; then payload=(--payload "$GRIPPER" --payload models/load_2kg.payload.toml); fi
  $P simulate "${ROBOT[@]}" --trajectory "$W/set/excitation_$id.csv" "${payload[@]}" \
    --sample-rate 25 --substeps 3 --noise-seed "$k" --format csv --out "$W/twin/run_$id" > /dev/null
  cp "$W/twin/run_$id/measured.csv" "$W/set/logs/excitation_$id.csv"
done
sed -i 's/^# *power = .*/power = "bus"/' "$W/set/runs.toml"

# 3. Identify from the logs alone: the URDF and drive file are the prior for what the runs
#    cannot see; every 4th run is held out first and predicted (out of sample, on this robot).
$P identify "${ROBOT[@]}" --runs "$W/set/runs.toml" --out "$W/model.json" --json > "$W/identify.json"

# 4. What does a plan cost that nobody has run? A motion as a joint trajectory CSV, and the
#    UR5 pick and place at 0.5 m/s with 2 kg, priced by the model with their 95 % intervals.
$P excite --robot models/ur5.urdf --seed 9 --evals 200 --out "$W/plan.csv" > /dev/null
$P predict --robot models/ur5.urdf --model "$W/model.json" --trajectory "$W/plan.csv"
$P predict --robot models/ur5.urdf --model "$W/model.json" \
  --scenario scenarios/ur5_pick_and_place.toml --speed 0.5 --load 2

# 5. The cheapest timing of the task in the same cycle time, priced by the model alone: the
#    twin is not your robot, so no twin checks it (--twin none).
$P optimize "${ROBOT[@]}" --model "$W/model.json" --scenario scenarios/ur5_pick_and_place.toml \
  --speed 0.5 --load 2 --twin none --out "$W/optimize"
echo "Everything is in $W (set/, model.json, identify.json, optimize/)."
