#!/usr/bin/env bash
# The README's main command: sets up .venv/ if needed, then runs the main job on the built-in
# full-cage scenario. (Until the node graph lands this is the offline episode with the classical
# controller; see scripts/run_mission.sh once it exists.)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash scripts/setup.sh
export MPLBACKEND=Agg PYTHONUNBUFFERED=1
exec .venv/bin/cage_demo --scenario full_cage --seed 0 --png out/demo_track.png "$@"
