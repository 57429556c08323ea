#!/usr/bin/env bash
# Creates .venv/ in the repo root and installs the pinned dependencies and the project's packages.
# Idempotent and quick once done (a stamp of the inputs' hash skips reinstalling). The no-ROS runtime
# (runtime/) is installed only where no real rclpy is importable, so it never shadows ROS 2.
# --with-ray also installs the optional Ray Tune + Optuna extra (requirements-ray.txt: `sweep`,
# `train --seeds N` on Ray; about 40 s and 540 MB), constrained by requirements.txt.
set -euo pipefail
with_ray=0
[ "${1:-}" = "--with-ray" ] && with_ray=1
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
py=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "[setup] creating .venv with $($py --version)"
  "$py" -m venv .venv
fi
vpy=.venv/bin/python
stamp=.venv/.cage_setup_stamp
log=.venv/setup.log
pipq() {  # pip, quiet; its full output goes to .venv/setup.log and is shown only if it fails
  if ! "$vpy" -m pip install -q --disable-pip-version-check "$@" >>"$log" 2>&1; then
    cat "$log" >&2
    echo "[setup] pip install $* failed (log: $log)" >&2
    exit 1
  fi
}
want=$(cat requirements.txt ros2_ws/src/*/setup.py ros2_ws/src/*/package.xml runtime/pyproject.toml 2>/dev/null | sha256sum | cut -d' ' -f1)
ray_extra() {
  if [ "$with_ray" = 1 ] && ! "$vpy" -c 'import ray.tune, optuna' 2>/dev/null; then
    echo "[setup] installing the Ray extra (requirements-ray.txt)"
    pipq -r requirements-ray.txt -c requirements.txt
  fi
}
if [ "$(cat "$stamp" 2>/dev/null)" = "$want" ]; then
  ray_extra
  exit 0
fi
echo "[setup] installing pinned dependencies into .venv (first run takes about a minute)"
: >"$log"
pipq -r requirements.txt
pkgs=()
for p in cage_sim cage_global_rrt cage_reactive_ddpg; do
  [ -f "ros2_ws/src/$p/setup.py" ] && pkgs+=(-e "ros2_ws/src/$p")
done
pipq --no-deps "${pkgs[@]}"
origin=$("$vpy" -c 'import rclpy; print(rclpy.__file__)' 2>/dev/null || true)
if [ -f runtime/pyproject.toml ] && { [ -z "$origin" ] || [[ "$origin" == "$root/runtime/"* ]]; }; then
  echo "[setup] no real rclpy found: installing the project's rclpy-compatible runtime (runtime/)"
  pipq --no-deps -e runtime
else
  echo "[setup] using the real rclpy at ${origin}"
fi
echo "$want" > "$stamp"
ray_extra
echo "[setup] done"
