#!/usr/bin/env bash
# Build-time (and run-time) smoke check of the image: fails the `docker build` when the venv, the
# real rclpy, the RMW, the generated messages or the pinned wheels are not what the image promises.
# Run it in a container with: docker run --rm IMAGE bash docker/smoke_check.sh
# Expects the ROS and workspace setup files to be sourced (the entrypoint does it).
set -eo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
py="$root/.venv/bin/python"
fail() { echo "smoke_check: FAIL: $*" >&2; exit 1; }

[ -x "$py" ] || fail "$py missing"
[ "${RMW_IMPLEMENTATION:-}" = rmw_cyclonedds_cpp ] || fail "RMW_IMPLEMENTATION=${RMW_IMPLEMENTATION:-unset}"

# The nodes must run on the venv's interpreter (torch, numba, ompl live there), so their console
# scripts' shebang must name it: colcon was run as `python -m colcon` from the venv for that.
for pkg_exe in cage_sim/sim_node cage_sim/vehicle_node cage_global_rrt/rrt_node cage_reactive_ddpg/policy_node; do
  pkg=${pkg_exe%/*} exe=${pkg_exe#*/}
  f="$root/ros2_ws/install/$pkg/lib/$pkg/$exe"
  [ -f "$f" ] || fail "$f missing (ros2 run $pkg $exe would fail)"
  head -n 1 "$f" | grep -q "$root/.venv/bin/python" || fail "$f shebang is '$(head -n 1 "$f")', not the venv"
done
ros2 pkg executables cage_sim | grep -q 'cage_sim sim_node' || fail "ros2 pkg executables cage_sim lacks sim_node"

"$py" - "$root" <<'PY'
import re
import sys
from pathlib import Path

root = Path(sys.argv[1])
assert sys.version_info[:2] == (3, 12), sys.version

import rclpy
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.utilities import get_rmw_implementation_identifier

assert rclpy.__file__.startswith("/opt/ros/"), f"rclpy comes from {rclpy.__file__}, not ROS 2 Jazzy"
assert get_rmw_implementation_identifier() == "rmw_cyclonedds_cpp", get_rmw_implementation_identifier()

# Message C extensions of ROS Jazzy were compiled against numpy 1.26; the venv runs numpy 2.x.
# Round-trip the field kinds that go through numpy (fixed float64[36]) and array.array (float32[]).
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from cage_planner_msgs.msg import CageMap, HeadingSetpoint, MissionEvent, Obstacle

odom = Odometry()
odom.pose.covariance[35] = 0.25
odom.child_frame_id = "base_link"
back = deserialize_message(serialize_message(odom), Odometry)
assert back.pose.covariance[35] == 0.25 and back.child_frame_id == "base_link"
scan = LaserScan(ranges=[1.0, float("inf"), 2.5])
back = deserialize_message(serialize_message(scan), LaserScan)
assert list(back.ranges)[2] == 2.5
sp = HeadingSetpoint(heading=1.25, decision=7, source=HeadingSetpoint.SOURCE_POLICY)
back = deserialize_message(serialize_message(sp), HeadingSetpoint)
assert back.heading == 1.25 and back.decision == 7
cmap = CageMap(net_radius=30.0, obstacles=[Obstacle(shape=Obstacle.SHAPE_CIRCLE, x=1.0, y=2.0, size=0.5)])
assert deserialize_message(serialize_message(cmap), CageMap).obstacles[0].size == 0.5
assert MissionEvent.GOAL_REACHED == 2

# The pinned wheels, torch from the CPU index.
pins = {}
for line in (root / "requirements.txt").read_text().splitlines():
    line = line.split("#", 1)[0].strip()
    m = re.fullmatch(r"([A-Za-z0-9_.\-]+)==([^\s;]+)", line)
    if m:
        pins[m.group(1).lower()] = m.group(2)
from importlib.metadata import version
for name, want in pins.items():
    have = version(name)
    assert have.split("+", 1)[0] == want, f"{name}: installed {have}, pinned {want}"
import torch
assert torch.version.cuda is None, f"torch is a CUDA build ({torch.__version__})"
import gymnasium, numba, numpy, ompl  # noqa: F401,E401
import cage_sim, cage_global_rrt, cage_reactive_ddpg  # noqa: F401,E401
print(f"smoke_check: python {sys.version.split()[0]}, rclpy {rclpy.__file__}, "
      f"{get_rmw_implementation_identifier()}, torch {torch.__version__}, numpy {numpy.__version__}")
PY
echo "smoke_check: OK"
