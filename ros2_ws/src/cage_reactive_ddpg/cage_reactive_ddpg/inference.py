"""Torch-free inference of a saved actor: the shipped MLP evaluated in NumPy.

Why: a vehicle computer runs the policy node for hours next to other processes; importing torch
costs ~200 MB of resident memory and a second of start-up for a 128-128 MLP that NumPy evaluates in
microseconds. Training keeps torch (``networks.Actor``); this module reads the same safetensors
state dict (``safetensors.numpy``, no torch) and computes the same function:

    obs -> [normalise: (obs - mean) / sqrt(var + eps), clipped to +-clip, when enabled]
        -> (Linear -> ReLU)* -> Linear -> tanh
        [residual: -> residual_action(last input, that)]

The arithmetic is float32, as torch's forward pass: on the shipped policy the two agree to better
than 1e-6 (tested), while either differs from the exact (float64) result by up to ~3e-6 for
out-of-distribution inputs, so float64 here would "disagree" with torch by more than float32 does. ``networks.ObsNormalizer``'s ``eps`` and ``clip``
are the constants below; a change there must be made here too (the equality test catches it).
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Mapping

import numpy as np

NORM_EPS = 1e-4      # networks.ObsNormalizer.eps
NORM_CLIP = 5.0      # networks.ObsNormalizer.clip
_LINEAR = re.compile(r"^net\.(\d+)\.weight$")


class NumpyActor:
    """The actor MLP as NumPy arrays (float32), built from an ``Actor`` state dict."""

    def __init__(self, state: Mapping[str, np.ndarray], residual: bool = False):
        self.residual = bool(residual)
        idx = sorted(int(m.group(1)) for k in state if (m := _LINEAR.match(k)))
        if not idx:
            raise ValueError("no linear layers (net.<i>.weight) in the state dict")
        self.weights = [np.asarray(state[f"net.{i}.weight"], dtype=np.float32).T.copy() for i in idx]
        self.biases = [np.asarray(state[f"net.{i}.bias"], dtype=np.float32) for i in idx]
        self.obs_dim = self.weights[0].shape[0]
        self.act_dim = self.weights[-1].shape[1]
        self.hidden = tuple(w.shape[1] for w in self.weights[:-1])
        enabled = state.get("norm.enabled")
        self.normalise = bool(enabled is not None and float(np.asarray(enabled)) != 0.0)
        if self.normalise:
            self.mean = np.asarray(state["norm.mean"], dtype=np.float32)
            self.std = np.sqrt(np.asarray(state["norm.var"], dtype=np.float32) + np.float32(NORM_EPS))

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """(D,) -> (A,) or (B, D) -> (B, A), float32 in [-1, 1]."""
        h = np.asarray(obs, dtype=np.float32)
        if self.normalise:   # as torch: divide by sqrt(var + eps) (not multiply by its inverse)
            h = np.clip((h - self.mean) / self.std, -NORM_CLIP, NORM_CLIP)
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases)):
            h = h @ w + b
            if i < last:
                np.maximum(h, 0.0, out=h)
        out = np.tanh(h).astype(np.float32)
        if not self.residual:
            return out
        base = np.clip(np.asarray(obs, dtype=np.float32)[..., -self.act_dim:], -1.0, 1.0)
        return residual_action(base, out).astype(np.float32)


class MeanActor:
    """Several actors of one shape as one policy: the mean of their actions (an ensemble of training
    seeds of one config, ``ensemble.py``). Why: seeds of the same config differ most where the
    policy is least sure (near a net pushed in by a strong current), and the mean keeps what they
    agree on; for residual actors, each member's action is its own move of the same base action."""

    def __init__(self, members: list[NumpyActor]):
        if len(members) < 2:
            raise ValueError(f"an ensemble needs at least 2 members, got {len(members)}")
        first = members[0]
        for i, m in enumerate(members[1:], 1):
            if (m.obs_dim, m.act_dim, m.residual) != (first.obs_dim, first.act_dim, first.residual):
                raise ValueError(f"member {i}: obs_dim / act_dim / residual {(m.obs_dim, m.act_dim, m.residual)} "
                                 f"differ from member 0's {(first.obs_dim, first.act_dim, first.residual)}")
        self.members = list(members)
        self.residual, self.obs_dim, self.act_dim = first.residual, first.obs_dim, first.act_dim
        self.hidden = first.hidden

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """(D,) -> (A,) or (B, D) -> (B, A), float32 in [-1, 1]: the members' mean action."""
        return np.mean([m(obs) for m in self.members], axis=0).astype(np.float32)


def residual_action(base, r):
    """The action a residual ``r`` in [-1, 1] makes of a ``base`` action in [-1, 1]: ``r`` is the
    share of the way from the base to the end of the range on its side (r = 0: the base; r = +1:
    full left; r = -1: full right). Why not ``clip(base + r)``: the clip has no gradient at the
    ends, where the base often sits (a full turn), so the critic could never pull the action back;
    here the slope is 1 - base towards +1 and 1 + base towards -1, never both zero. Plain
    arithmetic, so the torch actor (``networks.Actor``) and this NumPy one share it."""
    sign = (r > 0) * 1.0 - (r < 0) * 1.0
    return base + r * (1.0 - sign * base)


def read_state(path: str | Path) -> dict[str, np.ndarray]:
    """A safetensors file as NumPy arrays (no torch import). Raises ValueError/OSError if unreadable."""
    from safetensors import SafetensorError
    from safetensors.numpy import load_file
    try:
        return load_file(str(path))
    except SafetensorError as err:
        raise ValueError(str(err)) from None


def with_base(obs: np.ndarray, base: np.ndarray | None) -> np.ndarray:
    """A residual actor's input: the observation(s) with the base action appended (float32)."""
    o = np.asarray(obs, np.float32)
    if base is None:
        return o
    b = np.asarray(base, np.float32).reshape(o.shape[:-1] + (1,))
    return np.concatenate([o, b], axis=-1)
