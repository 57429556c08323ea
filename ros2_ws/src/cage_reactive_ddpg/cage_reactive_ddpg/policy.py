"""Saving and loading a trained policy: safetensors weights + a JSON metadata file beside them.

Why this shape: safetensors holds tensors only (no pickled code, safe to load from anywhere); the
JSON says what the tensors mean (observation layout, action scale, network sizes, normalisation,
training config, evaluation results, code version). ``load_policy`` refuses a file that does not
fit this build (layout, action scale, sizes, missing or corrupt files) with a ``PolicyLoadError``
naming what differs, instead of driving the vehicle with a policy that reads the scan wrongly.

Loading does not import torch: the weights are read with ``safetensors.numpy`` and the actor runs in
NumPy (``inference.NumpyActor``, equal to the torch actor to 1e-6), so the policy node stays small
(<= 100 MB resident) on a vehicle computer. Only ``save_policy`` (the trainer) imports torch.
"""
from __future__ import annotations

import json
import math
import subprocess
from dataclasses import dataclass, fields
from importlib import resources
from pathlib import Path
from typing import Any

from typing import TYPE_CHECKING

import numpy as np
from cage_sim.controller import REMEMBERED, ArcController
from cage_sim.observation import ObservationLayout, layout_from_dict
from cage_sim.vehicle import VehicleParams

from . import __version__
from .inference import MeanActor, NumpyActor, read_state, with_base

if TYPE_CHECKING:   # the trainer's side only; loading a policy never imports torch
    from .networks import Actor

FORMAT = "cage_reactive_ddpg/policy-v1"
SHIPPED = "policy.safetensors"
# Each sensor profile's shipped driver: the weights file flown for that profile when none is named
# (``policy_node`` with ``sensor:=`` alone, ``run_mission.sh --sensor``, ``evaluate --sensor``). The
# one place that says which of a profile's shipped files is its driver; README "Shipped policies" says why.
DRIVERS = {"study": SHIPPED, "fls": "policy_fls_s54.safetensors", "multibeam360": "policy_mb360.safetensors",
           "scanning": "policy_scanning_near.safetensors"}


class PolicyLoadError(RuntimeError):
    """A policy file that cannot be used with this build; the message says why."""


def code_version() -> str:
    """``git describe`` of the source tree when there is one, else the package version."""
    try:
        out = subprocess.run(["git", "describe", "--always", "--dirty", "--tags"], capture_output=True,
                             text=True, timeout=5, cwd=Path(__file__).resolve().parent)
        if out.returncode == 0 and out.stdout.strip():
            return f"{__version__}+{out.stdout.strip()}"
    except (OSError, subprocess.SubprocessError):
        pass
    return __version__


def paths(path: str | Path) -> tuple[Path, Path]:
    """(weights, metadata) for ``x.safetensors``, ``x.json`` or the stem ``x``."""
    p = Path(path)
    stem = p.with_suffix("") if p.suffix in (".safetensors", ".json") else p
    return stem.with_suffix(".safetensors"), stem.with_suffix(".json")


def save_policy(path: str | Path, actor: "Actor", metadata: dict[str, Any],
                layout: ObservationLayout | None = None, base: ArcController | None = None) -> tuple[Path, Path]:
    """Write the actor's weights and ``metadata`` (plus layout/action/network facts) next to each other.

    ``layout``: the observation layout the actor was trained on (default: this build's default).
    ``base``: a residual actor's base controller (default: the default ``ArcController``)."""
    from safetensors.torch import save_file
    layout = layout or ObservationLayout()
    wpath, mpath = paths(path)
    wpath.parent.mkdir(parents=True, exist_ok=True)
    state = {k: v.detach().contiguous().clone() for k, v in actor.state_dict().items()}
    save_file(state, str(wpath), metadata={"format": FORMAT})
    meta = {"format": FORMAT, "observation_layout": layout.to_dict(),
            "observation_normalisation": "running mean/var in the weights (norm.*), applied by the actor",
            "action": {"dim": actor.act_dim, "max_turn_deg": math.degrees(VehicleParams().max_turn),
                       "meaning": "change of heading per decision = action * max_turn"},
            "network": {"obs_dim": actor.obs_dim, "actor_hidden": list(actor.hidden),
                        "activation": "relu", "output": "tanh", "residual": bool(getattr(actor, "residual", False))},
            "obs_norm": bool(actor.norm.enabled), "code_version": code_version(), **metadata}
    if meta["network"]["residual"]:
        base = base or ArcController(layout)
        meta["residual_base"] = {"controller": "cage_sim.controller.ArcController",
                                 "params": base.tunables(), "remembered": base.remembered,
                                 "input": "the observation, then the controller's action on it (last input)",
                                 "perception": "as the baseline is flown (cage_sim.driver.decide_batch)",
                                 "action": "residual_action(base, tanh(MLP)) (inference.py)"}
    mpath.write_text(json.dumps(meta, indent=2, default=_json_default))
    return wpath, mpath


def _json_default(o: Any):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, (tuple, np.ndarray)):
        return list(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


@dataclass
class LoadedPolicy:
    """A trained actor behind the ``cage_sim.controller.Policy`` protocol (NumPy inference)."""

    actor: NumpyActor | MeanActor   # MeanActor: an ensemble file (``ensemble.py``)
    layout: ObservationLayout
    metadata: dict
    path: Path
    residual_base: ArcController | None = None   # a residual policy: the controller it moves

    def act(self, obs: np.ndarray) -> np.ndarray:
        """(D,) -> (1,) or (B, D) -> (B, 1), float32 in [-1, 1]. A residual policy's base action is
        then the controller's on the observation alone; ``driver.decide_batch`` instead gives it the
        controller's action with the vehicle's perception (``act_residual``), as in training."""
        o = self._check(obs)
        if self.residual_base is not None:
            return self.act_residual(o, self.residual_base.act(o))
        return self.actor(o)

    def act_residual(self, obs: np.ndarray, base: np.ndarray) -> np.ndarray:
        """A residual policy's action(s) moving the ``base`` action(s) (B,) or (B, 1)."""
        return self.actor(with_base(self._check(obs), base))

    def _check(self, obs: np.ndarray) -> np.ndarray:
        o = np.asarray(obs, dtype=np.float32)
        if o.shape[-1] != self.layout.size:
            raise ValueError(f"observation has {o.shape[-1]} values, the policy's layout has {self.layout.size}")
        return o

    @property
    def profile(self) -> str:
        """The sensor profile the policy was trained for (files older than profiles: ``study``)."""
        return profile_of(self.metadata)

    @property
    def max_turn(self) -> float:
        """Action scale in radians (what action = +-1 means)."""
        return math.radians(self.metadata["action"]["max_turn_deg"])


def shipped_path(profile: str | None = None) -> Path:
    """The shipped driver's weights for a sensor profile (``DRIVERS``; None: the default, ``study``).
    An unknown profile raises ``PolicyLoadError`` naming the known ones."""
    if profile is not None and profile not in DRIVERS:
        raise PolicyLoadError(f"no shipped policy for sensor profile {profile!r} (shipped: {', '.join(DRIVERS)})")
    return Path(str(resources.files("cage_reactive_ddpg") / "weights" / DRIVERS[profile or "study"]))


def profile_of(meta: dict) -> str:
    """The sensor profile recorded in a policy's metadata (``study`` for files from before profiles)."""
    lay = meta.get("observation_layout") or {}
    cfg = meta.get("config") or {}
    return str(meta.get("sensor_profile") or lay.get("profile") or cfg.get("sensor") or "study")


def sonar_of(meta: dict):
    """The sonar a policy was trained on: every setting its metadata records (``sonar``, written
    since session 40), else its profile's defaults by name (older files; the shipped ones trained
    before a profile's defaults changed record theirs by hand). A bad record: ``PolicyLoadError``."""
    from cage_sim.sonar import SonarConfigError, make_sonar
    rec = meta.get("sonar")
    if rec is None:
        return make_sonar((meta.get("config") or {}).get("sensor", "study"))
    try:
        return make_sonar(dict(rec))
    except (SonarConfigError, TypeError, ValueError) as err:
        raise PolicyLoadError(f"policy metadata: sonar record {rec!r} is invalid: {err}") from None


def sim_sonar_params(spec: str | Path) -> list[str]:
    """The ``sim_node`` parameters (``name:=value``) that give the graph the sonar a policy file learnt
    on (``sonar_of``: profile, beam count, range, beam width), so the graph scans as ``evaluate`` does.
    ``scripts/run_mission.sh --policy FILE`` passes them. Unreadable files raise (OSError, ValueError)."""
    s = sonar_of(json.loads(paths(spec)[1].read_text())).to_dict()
    return [f"sensor:={s['profile']}", f"n_beams:={int(s['n_beams'])}", f"max_range:={float(s['max_range'])!r}",
            f"beam_width_deg:={float(s['beam_width_deg'])!r}"]


def env_config_for(meta: dict, motion: str | None = None):
    """The ``EnvConfig`` a policy was trained with (sensor, observation options, motion): the
    evaluator must build the same observations. Files from before profiles: the study's v1."""
    from cage_sim.mission import EnvConfig
    cfg = meta.get("config") or {}
    return EnvConfig(motion=motion or cfg.get("motion") or "continuous", sonar=sonar_of(meta),
                     observation=cfg.get("observation", "auto"), velocity=bool(cfg.get("velocity", False)),
                     memory_bins=int(cfg.get("memory_bins", 0)),
                     memory_horizon=float(cfg.get("memory_horizon", 10.0)),
                     scan_in_obs=bool(cfg.get("scan_in_obs", True)))


def load_policy(path: str | Path | None = None, layout: ObservationLayout | None = None,
                vehicle: VehicleParams | None = None, profile: str | None = None) -> LoadedPolicy:
    """Load a policy and check it against this build's layout and vehicle. No ``path``: the shipped
    driver of ``profile`` (``shipped_path``), the default one without a profile.

    ``layout``: the observation layout the caller will build (default: the one the file records, v1
    or v2); ``profile``: the sensor profile the caller runs; a policy trained for another is refused,
    naming both.
    """
    wpath, mpath = paths(path if path is not None else shipped_path(profile))
    vehicle = vehicle or VehicleParams()
    for p, what in ((wpath, "weights"), (mpath, "metadata")):
        if not p.is_file():
            raise PolicyLoadError(f"policy {what} file not found: {p}")
    try:
        meta = json.loads(mpath.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise PolicyLoadError(f"policy metadata {mpath} is not valid JSON: {err}") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise PolicyLoadError(f"policy metadata {mpath}: format is {meta.get('format') if isinstance(meta, dict) else None!r}, "
                              f"expected {FORMAT!r}")
    if profile is not None and profile_of(meta) != profile:
        raise PolicyLoadError(f"policy {wpath} was trained for sensor profile {profile_of(meta)!r}, "
                              f"this sonar is profile {profile!r}")
    try:
        if layout is None:
            layout = layout_from_dict(meta.get("observation_layout") or {})
        layout.check_compatible(meta.get("observation_layout") or {})
    except (ValueError, TypeError, KeyError) as err:
        raise PolicyLoadError(f"policy {wpath} does not fit this build: {err}") from None
    file_turn = meta.get("action", {}).get("max_turn_deg")
    if file_turn is None or not math.isclose(file_turn, math.degrees(vehicle.max_turn), rel_tol=1e-6):
        raise PolicyLoadError(f"policy {wpath}: action scale max_turn_deg is {file_turn!r} in the file, "
                              f"this vehicle uses {math.degrees(vehicle.max_turn):g}")
    net = meta.get("network", {})
    residual = bool(net.get("residual", False))
    if net.get("obs_dim") != layout.size + residual:
        raise PolicyLoadError(f"policy {wpath}: network obs_dim is {net.get('obs_dim')!r}, the layout has {layout.size}"
                              + (" (+ 1 base action: residual)" if residual else ""))
    base = _residual_base(meta, layout, vehicle, mpath) if residual else None
    if (net.get("activation", "relu"), net.get("output", "tanh")) != ("relu", "tanh"):   # what NumpyActor runs
        raise PolicyLoadError(f"policy metadata {mpath}: network activation {net.get('activation')!r}, output "
                              f"{net.get('output')!r}: this build runs relu hidden layers and a tanh output")
    try:
        state = read_state(wpath)
    except (OSError, ValueError) as err:
        raise PolicyLoadError(f"policy weights {wpath} are corrupt or not safetensors: {err}") from None
    try:
        hidden = [int(h) for h in net.get("actor_hidden", [])]
        act_dim = int(meta["action"].get("dim", 1))
    except (TypeError, ValueError) as err:
        raise PolicyLoadError(f"policy metadata {mpath}: network.actor_hidden / action.dim: {err}") from None
    expected = expected_shapes(layout.size + residual, hidden, act_dim)
    members = net.get("ensemble", 0)
    if members:
        actor = _ensemble_actor(state, expected, members, residual, wpath)
    else:
        _check_state(expected, state, wpath)
        actor = NumpyActor(state, residual)
    return LoadedPolicy(actor, layout, meta, wpath, base)


def member_key(i: int, name: str) -> str:
    """The name of member ``i``'s tensor ``name`` in an ensemble file."""
    return f"members.{i}.{name}"


def _ensemble_actor(state: dict, expected: dict, members, residual: bool, wpath: Path) -> MeanActor:
    """An ensemble file's actors (``network.ensemble`` members of the network in its metadata,
    tensors ``members.<i>.<name>``) as one MeanActor; refused when a member's tensors do not fit."""
    if not isinstance(members, int) or isinstance(members, bool) or members < 2:
        raise PolicyLoadError(f"policy {wpath}: network.ensemble is {members!r}, expected a member count >= 2")
    _check_state({member_key(i, k): v for i in range(members) for k, v in expected.items()}, state, wpath)
    return MeanActor([NumpyActor({k: state[member_key(i, k)] for k in expected}, residual) for i in range(members)])


# The base controller's options a residual policy's file chooses, with their values when absent
# (the controller's own defaults: off).
CHOICES = {f.name: f.default for f in fields(ArcController) if f.name in ("pursuit", "handover", "handover_tail")}
_KIND = {bool: "true or false", float: "a number", int: "an integer"}


def _residual_base(meta: dict, layout, vehicle: VehicleParams, mpath: Path) -> ArcController:
    """The controller a residual policy moves; refused when its parameters differ from this build's
    (the policy learnt to correct that controller, not another), naming each. ``CHOICES`` are
    taken from the file (absent in files written before they existed: their defaults, off), and
    so is ``remembered``, the memory the base counted in training (absent: "all")."""
    rec = (meta.get("residual_base") or {}).get("params")
    if not isinstance(rec, dict):
        raise PolicyLoadError(f"policy metadata {mpath}: a residual policy without residual_base.params")
    rec = {**CHOICES, **rec}
    for k, default in CHOICES.items():
        if type(rec[k]) is not type(default) and not (isinstance(default, float) and type(rec[k]) is int):
            raise PolicyLoadError(f"policy metadata {mpath}: residual_base.params.{k} is {rec[k]!r}, "
                                  f"expected {_KIND[type(default)]}")
    if rec["handover"] < 0 or rec["handover_tail"] < 0:
        raise PolicyLoadError(f"policy metadata {mpath}: residual_base.params.handover and handover_tail "
                              f"must be >= 0, got {rec['handover']!r} and {rec['handover_tail']!r}")
    remembered = meta["residual_base"].get("remembered", "all")   # absent before session 55: all
    if remembered not in REMEMBERED:
        raise PolicyLoadError(f"policy metadata {mpath}: residual_base.remembered is {remembered!r}, "
                              f"expected one of {', '.join(REMEMBERED)}")
    base = ArcController(layout, vehicle, remembered=remembered, **{k: rec[k] for k in CHOICES})
    mine = base.tunables()
    diffs = [f"{k}: file has {rec.get(k)!r}, this build uses {v!r}" for k, v in mine.items()
             if not (isinstance(rec.get(k), (int, float)) and math.isclose(rec[k], v, rel_tol=1e-9))]
    diffs += [f"{k}: unknown to this build's controller" for k in rec if k not in mine]
    if diffs:
        raise PolicyLoadError(f"policy metadata {mpath}: residual base controller differs: " + "; ".join(diffs))
    return base


def expected_shapes(obs_dim: int, hidden: list[int], act_dim: int) -> dict[str, tuple[int, ...]]:
    """Tensor names and shapes of ``networks.Actor(obs_dim, hidden, act_dim)``'s state dict."""
    out: dict[str, tuple[int, ...]] = {"norm.mean": (obs_dim,), "norm.var": (obs_dim,),
                                       "norm.count": (), "norm.enabled": ()}
    prev = obs_dim
    for i, h in enumerate(list(hidden) + [act_dim]):
        out[f"net.{2 * i}.weight"], out[f"net.{2 * i}.bias"] = (h, prev), (h,)
        prev = h
    return out


def _check_state(expected: dict[str, tuple[int, ...]], state: dict, wpath: Path) -> None:
    missing, extra = sorted(set(expected) - set(state)), sorted(set(state) - set(expected))
    diffs = [f"{k}: file {tuple(state[k].shape)}, metadata says {v}"
             for k, v in expected.items() if k in state and tuple(state[k].shape) != v]
    if missing or extra or diffs:
        parts = ([f"missing tensors {missing}"] if missing else []) + \
                ([f"unexpected tensors {extra}"] if extra else []) + diffs
        raise PolicyLoadError(f"policy weights {wpath} do not match the network in its metadata: " + "; ".join(parts))
    bad = [k for k, v in state.items() if np.issubdtype(v.dtype, np.floating) and not np.isfinite(v).all()]
    if bad:
        raise PolicyLoadError(f"policy weights {wpath} hold non-finite values in {bad}")
