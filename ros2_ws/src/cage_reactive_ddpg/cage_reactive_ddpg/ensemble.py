"""Several trained policies of one observation as one policy file: the mean of their actions.

Why: training seeds of the same config end apart by more than their evaluations show (on the eight
0.5 m/s cells of the sea matrix, five residual seeds range over tens of collisions), and each errs
in other missions; the mean action keeps what the members agree on. The file is an ordinary policy
file (safetensors + JSON, loaded by ``policy.load_policy``, so ``evaluate --policy`` and
``policy_node policy:=`` take it as they take one actor): the tensors of member ``i`` are
``members.<i>.<name>``, the metadata is member 0's with ``network.ensemble`` (the member count) and
an ``ensemble`` record (each member's source, seed, config differences and own evaluation).

    python -m cage_reactive_ddpg.ensemble --out weights/policy_ensemble runs/seeds/seed_{0,1,2,3,4}/policy.safetensors

Members must read the same observation with the same network and (for residual actors) move the
same controller; a member that does not is refused, naming what differs.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path
from typing import Any

from .inference import read_state
from .policy import FORMAT, PolicyLoadError, load_policy, member_key, paths

#: Config keys that decide the observation and motion the evaluator builds (``policy.env_config_for``).
ENV_KEYS = ("sensor", "observation", "velocity", "memory_bins", "memory_horizon", "scan_in_obs", "motion")
#: Metadata of one training run that does not describe the ensemble: kept per member instead.
PER_MEMBER = ("evaluation", "evaluations", "training", "code_version")


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _same(meta0: dict, meta: dict, source: Path) -> None:
    """Refuse a member whose observation, action, network or base controller differ from member 0's."""
    diffs = [k for k in ("observation_layout", "action", "network", "residual_base") if meta.get(k) != meta0.get(k)]
    cfg0, cfg = meta0.get("config") or {}, meta.get("config") or {}
    diffs += [f"config.{k}" for k in ENV_KEYS if cfg.get(k) != cfg0.get(k)]
    if diffs:
        raise ValueError(f"member {source}: {', '.join(diffs)} differ from the first member's")


def pack(members: list[str | Path], out: str | Path) -> tuple[Path, Path]:
    """Write the ensemble of the policy files ``members`` (each checked by ``load_policy``) to ``out``
    (``x``, ``x.safetensors`` or ``x.json``); return the weights and metadata paths."""
    from safetensors.numpy import save_file
    if len(members) < 2:
        raise ValueError(f"an ensemble needs at least 2 members, got {len(members)}")
    pols = [load_policy(m) for m in members]
    if any(p.metadata.get("network", {}).get("ensemble") for p in pols):
        raise ValueError("a member is itself an ensemble: list its members instead")
    meta0 = pols[0].metadata
    for p in pols[1:]:
        _same(meta0, p.metadata, p.path)
    state = {member_key(i, k): v for i, p in enumerate(pols) for k, v in read_state(p.path).items()}
    wpath, mpath = paths(out)
    wpath.parent.mkdir(parents=True, exist_ok=True)
    save_file(state, str(wpath), metadata={"format": FORMAT})
    meta = {k: v for k, v in meta0.items() if k not in PER_MEMBER}
    meta["network"] = {**meta0["network"], "ensemble": len(pols)}
    meta["ensemble"] = {"combine": "the mean of the members' actions (inference.MeanActor)",
                        "members": [_member_record(p, meta0) for p in pols]}
    mpath.write_text(json.dumps(meta, indent=2))
    return wpath, mpath


def _member_record(pol, meta0: dict) -> dict[str, Any]:
    cfg0, cfg = meta0.get("config") or {}, pol.metadata.get("config") or {}
    return {"source": str(pol.path), "sha256": sha256(pol.path), "seed": cfg.get("seed"),
            "config_differences": {k: cfg.get(k) for k in sorted(set(cfg) | set(cfg0)) if cfg.get(k) != cfg0.get(k)},
            **{k: pol.metadata[k] for k in PER_MEMBER if k in pol.metadata}}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("members", nargs="+", help="policy files (.safetensors with their .json beside them)")
    ap.add_argument("--out", required=True, help="the ensemble's path (x, x.safetensors or x.json)")
    a = ap.parse_args(argv)
    try:
        wpath, mpath = pack(a.members, a.out)
    except (ValueError, PolicyLoadError) as err:
        print(f"ensemble: {err}", file=sys.stderr)
        return 2
    print(f"wrote {wpath} and {mpath}: {len(a.members)} members")
    return 0


if __name__ == "__main__":
    sys.exit(main())
