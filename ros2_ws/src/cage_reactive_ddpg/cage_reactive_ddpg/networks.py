"""Actor and critic networks: the one definition the trainer, the policy loader and the node share.

Why one module: a policy file is only a state dict plus sizes; whoever loads it must rebuild exactly
the same modules, so the modules live here and nowhere else.

Actor: obs -> MLP (ReLU) -> tanh, an action in [-1, 1] (the vehicle scales it to +-max_turn).
A residual actor (``residual=True``) reads the observation plus a base action (the classical
controller's, last input) and moves that action by the MLP's output (``residual_action``).
CriticEnsemble: n critics [obs, action] -> MLP (ReLU) -> Q (linear), one batched matmul per layer.
Both carry an ``ObsNormalizer`` (identity unless observation normalisation is switched on) so a saved
actor normalises its inputs by itself.
"""
from __future__ import annotations

from typing import Sequence

import torch
from torch import nn

from .inference import residual_action


class ObsNormalizer(nn.Module):
    """Running mean/variance of observations, stored as buffers so they travel in the state dict.

    ``enabled`` is a buffer too: a policy saved without normalisation loads as the identity.
    """

    def __init__(self, obs_dim: int, clip: float = 5.0, eps: float = 1e-4):
        super().__init__()
        self.clip, self.eps = clip, eps
        self.register_buffer("mean", torch.zeros(obs_dim))
        self.register_buffer("var", torch.ones(obs_dim))
        self.register_buffer("count", torch.tensor(0.0))
        self.register_buffer("enabled", torch.tensor(0.0))

    @torch.no_grad()
    def update(self, batch: torch.Tensor) -> None:
        """Chan's parallel update of mean/var with a batch of observations."""
        b_mean, b_var, n = batch.mean(0), batch.var(0, unbiased=False), batch.shape[0]
        tot = self.count + n
        delta = b_mean - self.mean
        self.mean += delta * n / tot
        self.var = (self.var * self.count + b_var * n + delta.pow(2) * self.count * n / tot) / tot
        self.count.fill_(float(tot))
        self.enabled.fill_(1.0)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        if not bool(self.enabled):
            return obs
        return ((obs - self.mean) / torch.sqrt(self.var + self.eps)).clamp(-self.clip, self.clip)


def mlp(in_dim: int, hidden: Sequence[int], out_dim: int) -> nn.Sequential:
    layers: list[nn.Module] = []
    for h in hidden:
        layers += [nn.Linear(in_dim, h), nn.ReLU()]
        in_dim = h
    layers.append(nn.Linear(in_dim, out_dim))
    return nn.Sequential(*layers)


class Actor(nn.Module):
    """Deterministic policy mu(s) in [-1, 1]^act_dim. ``residual``: the last input is a base
    action and the output is ``residual_action(base, tanh(MLP(s)))`` (residual policy learning,
    Silver et al. 2018; Johannink et al. 2019): the small initial last layer starts it at the base."""

    def __init__(self, obs_dim: int, hidden: Sequence[int] = (400, 300), act_dim: int = 1,
                 residual: bool = False):
        super().__init__()
        self.obs_dim, self.act_dim, self.hidden = obs_dim, act_dim, tuple(int(h) for h in hidden)
        self.residual = bool(residual)
        self.norm = ObsNormalizer(obs_dim)
        self.net = mlp(obs_dim, self.hidden, act_dim)
        # Small last layer, as in the DDPG paper: start near a = 0 (straight ahead), not saturated.
        nn.init.uniform_(self.net[-1].weight, -3e-3, 3e-3)
        nn.init.uniform_(self.net[-1].bias, -3e-3, 3e-3)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        out = torch.tanh(self.net(self.norm(obs)))
        if not self.residual:
            return out
        return residual_action(obs[..., -self.act_dim:].clamp(-1.0, 1.0), out)


class CriticEnsemble(nn.Module):
    """``n`` critics Q_k(s, a) in one module: each layer is one batched matmul over the members.

    Why: TD3's twin critics (and the target pair) cost one kernel per layer instead of two, and the
    trainer makes one Python call per critic pass. With ``n = 1`` it is the study's single critic.
    Each member is initialised like ``nn.Linear`` (uniform +-1/sqrt(fan_in)), the last layer small
    (+-3e-3, the DDPG paper). ``forward`` returns shape (n, batch).
    """

    def __init__(self, obs_dim: int, hidden: Sequence[int] = (400, 300), act_dim: int = 1, n: int = 1):
        super().__init__()
        self.n, self.hidden = int(n), tuple(int(h) for h in hidden)
        self.norm = ObsNormalizer(obs_dim)
        dims = [obs_dim + act_dim, *self.hidden, 1]
        self.weights = nn.ParameterList()
        self.biases = nn.ParameterList()
        for i, (d_in, d_out) in enumerate(zip(dims[:-1], dims[1:])):
            bound = 3e-3 if i == len(dims) - 2 else 1.0 / d_in ** 0.5
            self.weights.append(nn.Parameter(torch.empty(self.n, d_in, d_out).uniform_(-bound, bound)))
            self.biases.append(nn.Parameter(torch.empty(self.n, 1, d_out).uniform_(-bound, bound)))

    def forward(self, obs: torch.Tensor, act: torch.Tensor, members: int | None = None,
                frozen: bool = False) -> torch.Tensor:
        """Q of the first ``members`` critics (all by default); ``frozen`` detaches the weights so
        the actor's loss reaches the action without computing critic weight gradients."""
        k = self.n if members is None else members
        x = torch.cat([self.norm(obs), act], dim=-1)
        h = None
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases)):
            # one member (the study's single critic, TD3's actor loss): plain addmm, whose backward
            # is ~6 % cheaper per update than the batched kernels' (bench_train at SB3's settings)
            w, b = (w[0], b[0, 0]) if k == 1 else (w[:k], b[:k])
            if frozen:
                w, b = w.detach(), b.detach()
            if k == 1:
                h = torch.addmm(b, x if h is None else h, w)
            else:
                h = torch.matmul(x, w) + b if h is None else torch.baddbmm(b, h, w)
            if i < last:
                h = torch.relu(h)
        return h.T if k == 1 else h.squeeze(-1)
