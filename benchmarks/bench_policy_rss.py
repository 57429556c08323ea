"""Resident memory of a process that loads the shipped policy and acts: what a vehicle computer pays.

Each row is a fresh Python process that imports a set of modules, loads the shipped policy, acts
(and shields) on 1000 observations, then reports its peak RSS (ru_maxrss), its RSS at the end and
whether torch / numba were imported. Rows: the bare policy (NumPy + safetensors), the policy behind
the shield, everything ``policy_node`` imports (rclpy or the no-ROS runtime on Cyclone DDS, the
message packages, cage_sim's node helpers), and the old torch path for comparison. Target (issue 11
item 5): the policy node's process <= 100 MB RSS. For the running node itself see bench_latency.py.

    .venv/bin/python benchmarks/bench_policy_rss.py
"""
from __future__ import annotations

import json
import subprocess
import sys

ACT = """
import numpy as np
from cage_reactive_ddpg.policy import load_policy
pol = load_policy()
obs = np.ones((1000, pol.layout.size), np.float32); obs[:, -1] = np.linspace(-1, 1, 1000)
drv = pol
if SHIELD:
    from cage_sim.driver import fallback_for
    from cage_sim.shield import SafetyShield
    drv = SafetyShield(pol, fallback_for(pol, pol.layout))
for o in obs:
    drv.act(o)
"""
TORCH = """
import numpy as np, torch
from safetensors.torch import load_file
from cage_reactive_ddpg.networks import Actor
from cage_reactive_ddpg.policy import load_policy, shipped_path
pol = load_policy(); m = pol.metadata
n = m["network"]
actor = Actor(n["obs_dim"], n["actor_hidden"], residual=n.get("residual", False))
actor.load_state_dict(load_file(str(shipped_path())))
torch.set_num_threads(1)
with torch.no_grad():
    for o in np.ones((1000, n["obs_dim"]), np.float32):   # a residual policy: the base action is the last input
        actor(torch.from_numpy(o))
"""
REPORT = """
import resource, sys
from pathlib import Path
rss = [int(l.split()[1]) / 1024 for l in Path('/proc/self/status').read_text().splitlines() if l.startswith('VmRSS:')][0]
print({'peak_mb': resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 'rss_mb': rss,
       'torch': 'torch' in sys.modules, 'numba': 'numba' in sys.modules})
"""
ROWS = {
    "policy (numpy + safetensors)": "SHIELD = False\n" + ACT,
    "policy + shield": "SHIELD = True\n" + ACT,
    "policy_node's imports + policy + shield": "import cage_reactive_ddpg.nodes.policy_node\nSHIELD = True\n" + ACT,
    "torch actor (before)": TORCH,
}


def measure(code: str) -> dict:
    out = subprocess.run([sys.executable, "-c", code + REPORT], capture_output=True, text=True, timeout=300)
    if out.returncode != 0:
        return {"error": out.stderr.strip().splitlines()[-1] if out.stderr.strip() else f"exit {out.returncode}"}
    import ast
    return ast.literal_eval(out.stdout.strip().splitlines()[-1])


def main() -> int:
    res = {name: measure(code) for name, code in ROWS.items()}
    print(f"{'process':<42}{'peak RSS':>10}{'RSS end':>10}  torch  numba   target <= 100 MB")
    for name, r in res.items():
        if "error" in r:
            print(f"{name:<42}  error: {r['error']}")
            continue
        print(f"{name:<42}{r['peak_mb']:>9.1f}M{r['rss_mb']:>9.1f}M  {str(r['torch']):<6} {str(r['numba']):<6}")
    print(json.dumps({"bench": "policy_rss", "rows": res}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
