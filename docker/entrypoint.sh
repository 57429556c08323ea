#!/usr/bin/env bash
# Entry point of the cage planner image: sources ROS 2 Jazzy and the workspace's install space,
# then runs the given command (default: a bash shell). Used as
#   docker run --rm IMAGE                      -> the image's CMD (scripts/run_mission.sh)
#   docker run --rm IMAGE bash scripts/test.sh -> the test suite on real rclpy
set -e
# ROS setup scripts read unset variables: nounset stays off while sourcing them.
# shellcheck disable=SC1090,SC1091
source "/opt/ros/${ROS_DISTRO:-jazzy}/setup.bash"
ws_setup="${CAGE_WS:-/ws}/ros2_ws/install/setup.bash"
if [ -f "$ws_setup" ]; then
  # shellcheck disable=SC1090
  source "$ws_setup"
else
  echo "entrypoint: $ws_setup not found: the workspace is not built (bind-mounted source?)." >&2
  echo "entrypoint: build it with: python -m colcon --log-base ros2_ws/log build --base-paths ros2_ws/src --build-base ros2_ws/build --install-base ros2_ws/install --symlink-install" >&2
fi
export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_cyclonedds_cpp}"
if [ "$#" -eq 0 ]; then
  set -- bash
fi
exec "$@"
