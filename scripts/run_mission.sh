#!/usr/bin/env bash
# Launch-free graph run: starts sim_node, vehicle_node, rrt_node and policy_node (one process each,
# via `ros2 run`, the same in both worlds), sends the scenario's goal, waits for the outcome, stops
# every process it started, and exits with the mission client's status (0 = goal reached).
#
#   scripts/run_mission.sh [--scenario NAME|FILE] [--seed N] [--policy FILE|baseline] [--timeout S]
#                          [--time-scale X] [--record DIR] [--png FILE] [--out DIR]
#
# Isolated by ROS_DOMAIN_ID (a free one is picked unless set). Node logs go to <out>/logs/.
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
scenario=full_cage seed=0 policy="" timeout=120 time_scale=20.0 record="" png="" out="$root/out"
while [ $# -gt 0 ]; do
  case "$1" in
    --scenario) scenario=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --policy) policy=$2; shift 2 ;;
    --timeout) timeout=$2; shift 2 ;;
    --time-scale) time_scale=$2; shift 2 ;;
    --record) record=$2; shift 2 ;;
    --png) png=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    -h|--help) sed -n '2,10p' "$0"; exit 0 ;;
    *) echo "run_mission.sh: unknown argument $1" >&2; exit 64 ;;
  esac
done
[ -n "$png" ] || png="$out/mission_track.png"
as_float() { case "$1" in *.*|*e*) echo "$1" ;; *) echo "$1.0" ;; esac; }  # ROS parameter types are strict
timeout=$(as_float "$timeout"); time_scale=$(as_float "$time_scale")
if ! command -v ros2 >/dev/null 2>&1 && [ -x "$root/.venv/bin/ros2" ]; then
  export PATH="$root/.venv/bin:$PATH"
fi
command -v ros2 >/dev/null || { echo "run_mission.sh: no ros2 command (run scripts/setup.sh, or source ROS 2)" >&2; exit 69; }
export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-$(( (($$ + RANDOM) % 90) + 10 ))}  # 10..99: clear of ephemeral ports
export PYTHONUNBUFFERED=1 MPLBACKEND=Agg
logs="$out/logs"
mkdir -p "$logs"
cfg="$root/ros2_ws/src"
shared=(--params-file "$cfg/cage_sim/config/graph.yaml" -p "scenario:=$scenario" -p "seed:=$seed" -p "time_scale:=$time_scale")
pids=()

start() {  # start <log name> <ros2 run args...>
  local name=$1; shift
  ros2 run "$@" >"$logs/$name.log" 2>&1 &
  pids+=($!)
}

stop_all() {
  local pid
  for pid in "${pids[@]}"; do kill -INT "$pid" 2>/dev/null; done
  for _ in $(seq 50); do
    local alive=0
    for pid in "${pids[@]}"; do kill -0 "$pid" 2>/dev/null && alive=1; done
    [ $alive -eq 0 ] && return
    sleep 0.1
  done
  for pid in "${pids[@]}"; do kill -KILL "$pid" 2>/dev/null; done
}
trap stop_all EXIT
trap 'exit 130' INT TERM

echo "[run_mission] scenario=$scenario seed=$seed policy=${policy:-shipped} ROS_DOMAIN_ID=$ROS_DOMAIN_ID time_scale=$time_scale"
policy_args=()
[ -n "$policy" ] && policy_args=(-p "policy:=$policy")
[ -n "$record" ] && start recorder cage_sim recorder_node --ros-args -p "output:=$record"
start policy_node cage_reactive_ddpg policy_node --ros-args "${shared[@]}" "${policy_args[@]}"
start rrt_node cage_global_rrt rrt_node --ros-args --params-file "$cfg/cage_global_rrt/config/rrt.yaml" "${shared[@]}"
start vehicle_node cage_sim vehicle_node --ros-args "${shared[@]}"
start sim_node cage_sim sim_node --ros-args "${shared[@]}"

ros2 run cage_sim mission_client --ros-args "${shared[@]}" -p "timeout:=$timeout" -p "png:=$png" \
  2> >(tee "$logs/mission_client.log" >&2)
rc=$?
if [ $rc -ne 0 ]; then
  echo "[run_mission] mission failed (exit $rc); last node log lines:" >&2
  for f in "$logs"/*.log; do echo "--- $f" >&2; tail -n 5 "$f" >&2; done
fi
stop_all
trap - EXIT
for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null; done
exit $rc
