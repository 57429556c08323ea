#!/usr/bin/env bash
# Launch-free graph run: starts sim_node, vehicle_node, rrt_node, policy_node and navigator_node (one
# process each, via `ros2 run`, the same in both worlds), sends the scenario's goal, waits for the outcome, stops
# every process it started, and exits with the mission client's status (0 = goal reached).
# SIGINT/SIGTERM/SIGHUP stop every node it started (SIGINT, then SIGKILL after 5 s) and exit 130/143/129;
# a node that exits before the mission ends (refused to start, or crashed) is named, the rest are
# stopped, and the script exits 70. No node outlives the script, even one killed with SIGKILL.
#
# The graph runs in the namespace --ns (default /cage: topics /cage/scan, /cage/odom, ..., the
# navigator's action /cage/navigate); the mission client sends the scenario's goal on that action.
# --keep leaves the graph running after the first mission, for goal after goal
# (`ros2 action send_goal /cage/navigate ...`, or RViz's goal tool on --goal-topic) until Ctrl-C.
#
#   scripts/run_mission.sh [--scenario NAME|FILE] [--seed N] [--policy FILE|baseline] [--timeout S]
#                          [--time-scale X] [--record DIR] [--png FILE] [--out DIR] [--ns NS]
#                          [--goal-topic TOPIC] [--keep] [--sensor PROFILE] [--sim-param NAME:=VALUE ...]
#                          [--rrt-param NAME:=VALUE ...] [--policy-param NAME:=VALUE ...] [--shield on|off]
#                          [--replan on|off]
#
# --sensor (study | multibeam360 | fls | scanning) is the sim_node's sonar profile and the profile the
# policy_node checks the policy against (a policy of another profile is refused: exit 70 naming both);
# with no --policy, that profile's shipped driver flies (cage_reactive_ddpg.policy.DRIVERS);
# --sim-param passes a sim_node parameter, e.g. a sensor override (--sim-param noise_std:=0.0); a policy
# file's recorded sonar (profile, n_beams, max_range, beam_width_deg) goes to sim_node unless set here;
# --rrt-param passes an rrt_node parameter (--rrt-param obstacle_layer:=true, --rrt-param planner:=optimal);
# --policy-param passes a policy_node parameter (--policy-param replan_offset:=0.0);
# --shield off runs a learned policy raw (no safety shield); --replan off switches policy_node's replan
# requests off (as the offline evaluator, which plans once per mission).
#
# Isolated by ROS_DOMAIN_ID (unless set, a free one is picked: no DDS participant seen on it for
# 1 s). Node logs go to <out>/logs/.
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
scenario=full_cage seed=0 policy="" timeout=120 time_scale=20.0 record="" png="" out="$root/out"
ns=/cage goal_topic=/goal_pose keep=0 sensor="" sim_params=() rrt_extra=() policy_extra=() shield="" replan=""
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
    --ns) ns=$2; shift 2 ;;
    --goal-topic) goal_topic=$2; shift 2 ;;
    --keep) keep=1; shift ;;
    --sensor) sensor=$2; shift 2 ;;
    --sim-param) sim_params+=(-p "$2"); shift 2 ;;
    --rrt-param) rrt_extra+=(-p "$2"); shift 2 ;;
    --policy-param) policy_extra+=(-p "$2"); shift 2 ;;
    --shield) shield=$2; shift 2 ;;
    --replan) replan=$2; shift 2 ;;
    -h|--help) sed -n '2,30p' "$0"; exit 0 ;;
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
if [ -z "${ROS_DOMAIN_ID:-}" ]; then
  py=python3; [ -x "$root/.venv/bin/python" ] && py="$root/.venv/bin/python"
  if ! ROS_DOMAIN_ID=$("$py" "$root/scripts/free_domain.py"); then
    ROS_DOMAIN_ID=$(( (($$ + RANDOM) % 90) + 10 ))  # 10..99: clear of ephemeral ports
    echo "[run_mission] could not check for a free ROS_DOMAIN_ID: using $ROS_DOMAIN_ID unchecked" >&2
  fi
fi
export ROS_DOMAIN_ID
export PYTHONUNBUFFERED=1 MPLBACKEND=Agg
logs="$out/logs"
mkdir -p "$logs"
cfg="$root/ros2_ws/src"
shared=(-r "__ns:=$ns" --params-file "$cfg/cage_sim/config/graph.yaml" -p "scenario:=$scenario" -p "seed:=$seed"
        -p "time_scale:=$time_scale")
rrt_params=(--params-file "$cfg/cage_global_rrt/config/rrt.yaml")
pids=() names=()
stopping=0

# Each node runs under a guard that asks the kernel to SIGINT it when this script dies, however it
# dies (kill -9 included), so no node outlives the script; nodes stay in the script's process group,
# so `timeout -k` (which signals the whole group) reaches them too.
guard='import ctypes, os, signal, sys
ctypes.CDLL(None).prctl(1, signal.SIGINT)          # PR_SET_PDEATHSIG
if os.getppid() != int(sys.argv[1]): sys.exit(1)   # the script died before prctl
os.execvp(sys.argv[2], sys.argv[2:])'
py=$(command -v python3 || command -v python)

start() {  # start <log name> <ros2 run args...>
  local name=$1; shift
  "$py" -c "$guard" $$ ros2 run "$@" >"$logs/$name.log" 2>&1 &
  pids+=($!) names+=("$name")
}

stop_all() {  # SIGINT everything started, SIGKILL what is left after the grace period, reap all
  [ ${#pids[@]} -eq 0 ] && return
  local i pid alive
  for pid in "${pids[@]}"; do kill -INT "$pid" 2>/dev/null; done
  for _ in $(seq 50); do
    alive=0
    for pid in "${pids[@]}"; do kill -0 "$pid" 2>/dev/null && alive=1; done
    [ $alive -eq 0 ] && break
    sleep 0.1
  done
  for i in "${!pids[@]}"; do
    if kill -0 "${pids[$i]}" 2>/dev/null; then
      echo "[run_mission] ${names[$i]} did not stop within 5 s of SIGINT: SIGKILL" >&2
      kill -KILL "${pids[$i]}" 2>/dev/null
    fi
  done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null; done
  pids=() names=()
}

on_signal() {  # on_signal <name> <exit status>
  [ $stopping -eq 1 ] && return
  stopping=1
  echo "[run_mission] SIG$1: stopping every node this script started" >&2
  stop_all
  echo "[run_mission] stopped (SIG$1)" >&2
  exit "$2"
}
trap stop_all EXIT
trap 'on_signal INT 130' INT
trap 'on_signal TERM 143' TERM
trap 'on_signal HUP 129' HUP

# --sensor alone: the profile's shipped driver, named as its file so sim_node scans as it learnt (below)
if [ -z "$policy" ] && [ -n "$sensor" ]; then
  policy=$("$py" -c 'import sys
from cage_reactive_ddpg.policy import PolicyLoadError, shipped_path
try:
    print(shipped_path(sys.argv[1]))
except PolicyLoadError:
    pass   # not a profile: policy_node names the bad sensor' "$sensor")
fi
echo "[run_mission] scenario=$scenario seed=$seed policy=${policy:-shipped} ROS_DOMAIN_ID=$ROS_DOMAIN_ID time_scale=$time_scale ns=$ns"
policy_args=()
[ -n "$policy" ] && policy_args=(-p "policy:=$policy")
[ "$shield" = off ] && policy_args+=(-p "shield:=false")
[ "$replan" = off ] && policy_args+=(-p "replan_offset:=0.0" -p "replan_after:=1000000")
policy_args+=("${policy_extra[@]}")
[ -n "$sensor" ] && policy_args+=(-p "sensor:=$sensor") && sim_params+=(-p "sensor:=$sensor")
# A policy file records the sonar it learnt on (its JSON's `sonar`): sim_node scans with its profile and
# beams (count, width, range), so the graph flies it as `evaluate` does; --sensor and --sim-param still win.
if [ -n "$policy" ] && [ "$policy" != baseline ]; then
  beams=$("$py" -c 'import sys
from cage_reactive_ddpg.policy import PolicyLoadError, sim_sonar_params
try:
    print(" ".join(sim_sonar_params(sys.argv[1])))
except (OSError, ValueError, KeyError, TypeError, AttributeError, PolicyLoadError):
    pass   # policy_node names what is wrong with the file' "$policy")
  for b in $beams; do sim_params=(-p "$b" "${sim_params[@]}"); done
fi
[ -n "$record" ] && start recorder cage_sim recorder_node --ros-args -r "__ns:=$ns" -p "output:=$record"
start policy_node cage_reactive_ddpg policy_node --ros-args "${shared[@]}" "${policy_args[@]}"
start rrt_node cage_global_rrt rrt_node --ros-args "${rrt_params[@]}" "${shared[@]}" "${rrt_extra[@]}"
start navigator_node cage_sim navigator_node --ros-args "${shared[@]}" -r "goal_pose:=$goal_topic" \
  -p "planner_config:=$cfg/cage_global_rrt/config/rrt.yaml"
start vehicle_node cage_sim vehicle_node --ros-args "${shared[@]}"
start sim_node cage_sim sim_node --ros-args "${shared[@]}" "${sim_params[@]}"

start mission_client cage_sim mission_client --ros-args "${shared[@]}" -p "timeout:=$timeout" -p "png:=$png"
client=$!
# The client's progress on the console. tail follows the client's PID: once the client has exited
# it prints what is left of the log (the RESULT line) and stops by itself.
tail -n +1 -F -s 0.1 --pid="$client" "$logs/mission_client.log" 2>/dev/null &
tailer=$!

# Wait for the client; a node that exits first (start-up refused, or a crash mid-mission) ends the
# run at once: say which, stop the rest, exit 70. `wait -n` returns on any child, and on a signal.
node_died() {  # node_died <index> <status>: say which node died and why (its last log lines)
  echo "[run_mission] ${names[$1]} exited with status $2 before the mission ended; stopping the rest" >&2
  tail -n 5 "$logs/${names[$1]}.log" | sed "s/^/[${names[$1]}] /" >&2
}
rc=""
while [ -z "$rc" ]; do
  wait -n "${pids[@]}" 2>/dev/null
  for i in "${!pids[@]}"; do
    pid=${pids[$i]}
    kill -0 "$pid" 2>/dev/null && continue
    wait "$pid"; status=$?
    if [ "$pid" = "$client" ]; then rc=$status; unset "pids[$i]" "names[$i]"; break; fi
    node_died "$i" "$status"
    rc=70
    break
  done
done
if [ $keep -eq 1 ] && [ "$rc" -ne 70 ]; then
  echo "[run_mission] the graph keeps running (ROS_DOMAIN_ID=$ROS_DOMAIN_ID, action $ns/navigate, goals on" \
       "$goal_topic); Ctrl-C stops it"
  while [ "$rc" -ne 70 ]; do   # until Ctrl-C, or a node dies
    wait -n "${pids[@]}" 2>/dev/null
    for i in "${!pids[@]}"; do
      kill -0 "${pids[$i]}" 2>/dev/null && continue
      wait "${pids[$i]}"; node_died "$i" $?; rc=70; break
    done
  done
fi
for _ in $(seq 50); do kill -0 "$tailer" 2>/dev/null || break; sleep 0.1; done   # let it print the last lines
kill "$tailer" 2>/dev/null; wait "$tailer" 2>/dev/null
if [ "$rc" -ne 0 ] && [ "$rc" -ne 70 ]; then
  echo "[run_mission] mission failed (exit $rc); last node log lines:" >&2
  for f in "$logs"/*.log; do echo "--- $f" >&2; tail -n 5 "$f" >&2; done
fi
stop_all
trap - EXIT
exit $rc
