#!/usr/bin/env bash
# The README's main command: sets up .venv/ if needed, then runs the whole node graph on the built-in
# full-cage scenario with the shipped DDPG policy (scripts/run_mission.sh): progress and the outcome
# are printed, the track is plotted to out/mission_track.png and the run recorded to out/mission_bag/.
# Extra arguments go to run_mission.sh (e.g. --policy baseline, --scenario cage --seed 3).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash scripts/setup.sh
rm -rf out/mission_bag
exec bash scripts/run_mission.sh --scenario full_cage --seed 0 --record out/mission_bag --out out "$@"
