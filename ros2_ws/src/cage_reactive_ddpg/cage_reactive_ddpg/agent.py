"""DDPG (Lillicrap et al.) as the study ran it, with TD3's tricks as options.

With the study's config: one critic, actor updated every step, no target smoothing, OU noise,
soft target updates with tau. ``twin_critic`` / ``policy_delay`` / ``target_noise`` turn on clipped
double Q, delayed actor updates and target policy smoothing (Fujimoto et al.), which make DDPG's
over-estimation ("DDPG does not learn") much rarer.

Expert guidance (``bc_weight`` > 0, off by default): the actor's loss gains a behaviour-cloning
term towards the expert's actions stored with the transitions, as in TD3+BC (Fujimoto & Gu 2021:
the Q term normalised by its mean magnitude, so the weight means the same at any reward scale) with
the Q-filter of Nair et al. (2018): an expert action is imitated only where the critic rates it at
least as high as the actor's own. Why: the classical baseline already solves most sea missions, and
pure exploration spends hundreds of thousands of steps rediscovering it; decaying the weight lets
the critic take over where it knows better. ``near_bc_weight`` adds an unfiltered cloning term on
the rows with a return near the vehicle (``NearReturns``; see ``_guided_loss`` for why).
"""
from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from .buffer import Batch
from .config import TrainConfig
from .networks import Actor, CriticEnsemble


class OUNoise:
    """Ornstein-Uhlenbeck exploration noise, one process per env (temporally correlated turns)."""

    def __init__(self, n_envs: int, act_dim: int, theta: float, rng: np.random.Generator):
        self.theta, self.rng = theta, rng
        self.state = np.zeros((n_envs, act_dim))

    def __call__(self, std: float) -> np.ndarray:
        self.state += -self.theta * self.state + std * self.rng.standard_normal(self.state.shape)
        return self.state.copy()

    def reset(self, i: int) -> None:
        self.state[i] = 0.0


class GaussianNoise:
    def __init__(self, n_envs: int, act_dim: int, rng: np.random.Generator):
        self.shape, self.rng = (n_envs, act_dim), rng

    def __call__(self, std: float) -> np.ndarray:
        return std * self.rng.standard_normal(self.shape)

    def reset(self, i: int) -> None:
        pass


@dataclass(frozen=True)
class NearReturns:
    """Which rows of a batch have a return near the vehicle: the smallest of the first ``cols``
    observation entries (the scan and the memory, ranges / max_range) below ``threshold``.
    Built from the observation layout (``for_layout``), so the agent needs no sonar."""
    cols: int
    threshold: float

    @staticmethod
    def for_layout(layout, range_m: float) -> "NearReturns":
        cols = layout.n_scan + layout.memory_bins if hasattr(layout, "memory_bins") else layout.n_beams
        return NearReturns(cols, range_m / layout.max_range)

    def __call__(self, obs: torch.Tensor) -> torch.Tensor:
        return obs[:, :self.cols].min(1).values < self.threshold


class DDPGAgent:
    """Actor, critic ensemble (1 = DDPG, 2 = TD3's twins), their targets and optimisers.

    Speed (``benchmarks/bench_train.py``): the critics are one module (one batched matmul per layer
    for the online pair and one for the target pair), Adam is fused (one pass over each network's
    parameters), the actor's loss goes through detached critic weights instead of toggling
    ``requires_grad``, soft updates are one ``_foreach_lerp_`` over prebuilt lists, and the losses
    stay tensors (``update`` returns them; the caller calls ``float`` only when it logs).
    """

    def __init__(self, cfg: TrainConfig, obs_dim: int, act_dim: int = 1, near: NearReturns | None = None):
        self.cfg, self.near = cfg, near
        self.actor = Actor(obs_dim, cfg.actor_hidden, act_dim, residual=cfg.residual)
        self.critic = CriticEnsemble(obs_dim, cfg.critic_hidden, act_dim, n=2 if cfg.twin_critic else 1)
        self.actor_target = copy.deepcopy(self.actor)
        self.critic_target = copy.deepcopy(self.critic)
        for p in list(self.actor_target.parameters()) + list(self.critic_target.parameters()):
            p.requires_grad_(False)
        self.actor_opt = torch.optim.Adam(self.actor.parameters(), lr=cfg.lr_actor, fused=True)
        self.critic_opt = torch.optim.Adam(self.critic.parameters(), lr=cfg.lr_critic, fused=True)
        self._pairs = [(list(t.parameters()), list(s.parameters()))
                       for t, s in ((self.actor_target, self.actor), (self.critic_target, self.critic))]
        self.n_updates = 0

    # --- acting ---------------------------------------------------------------------------
    @torch.no_grad()
    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.actor(torch.as_tensor(obs, dtype=torch.float32)).numpy()

    def observe(self, obs: np.ndarray) -> None:
        """Feed observations to the running normaliser (when on); all networks share its stats."""
        if not self.cfg.obs_norm:
            return
        self.actor.norm.update(torch.as_tensor(obs, dtype=torch.float32))
        state = self.actor.norm.state_dict()
        for net in (self.critic, self.actor_target, self.critic_target):
            net.norm.load_state_dict(state)

    # --- learning -------------------------------------------------------------------------
    def update(self, b: Batch, bc_weight: float = 0.0) -> dict[str, torch.Tensor]:
        """One critic step (and, every ``policy_delay``, an actor step and soft target updates).
        ``bc_weight``: the behaviour-cloning term's weight this update (0 = plain DDPG/TD3).
        Returns detached loss tensors: ``float()`` them only when logging."""
        cfg = self.cfg
        obs, act = torch.from_numpy(b.obs), torch.from_numpy(b.act)
        rew, nxt, disc = torch.from_numpy(b.rew), torch.from_numpy(b.next_obs), torch.from_numpy(b.discount)
        with torch.no_grad():
            a2 = self.actor_target(nxt)
            if cfg.target_noise > 0:
                eps = (torch.randn_like(a2) * cfg.target_noise).clamp(-cfg.target_noise_clip, cfg.target_noise_clip)
                a2 = (a2 + eps).clamp(-1.0, 1.0)
            q2 = self.critic_target(nxt, a2)
            target = rew + disc * (q2[0] if q2.shape[0] == 1 else q2.min(0).values)
        q = self.critic(obs, act)                           # (n_critics, batch)
        critic_loss = (q - target).pow(2).mean(1).sum()     # each critic's MSE, summed
        self.critic_opt.zero_grad(set_to_none=True)
        critic_loss.backward()
        if cfg.grad_clip > 0:
            nn.utils.clip_grad_norm_(self.critic.parameters(), cfg.grad_clip)
        self.critic_opt.step()
        self.n_updates += 1
        info = {"critic_loss": critic_loss.detach(), "q": q[0].detach().mean()}
        if self.n_updates % cfg.policy_delay == 0:
            pi = self.actor(obs)
            q_pi = self.critic(obs, pi, members=1, frozen=True)
            if (bc_weight > 0 or self._near_on()) and b.expert is not None:
                actor_loss = self._guided_loss(obs, pi, q_pi, torch.from_numpy(b.expert), bc_weight, info)
            else:
                actor_loss = -q_pi.mean()
            self.actor_opt.zero_grad(set_to_none=True)
            actor_loss.backward()
            if cfg.grad_clip > 0:
                nn.utils.clip_grad_norm_(self.actor.parameters(), cfg.grad_clip)
            self.actor_opt.step()
            self.soft_update()
            info["actor_loss"] = actor_loss.detach()
        return info

    def _near_on(self) -> bool:
        return self.near is not None and self.cfg.near_bc_weight > 0

    def _guided_loss(self, obs: torch.Tensor, pi: torch.Tensor, q_pi: torch.Tensor, expert: torch.Tensor,
                     weight: float, info: dict) -> torch.Tensor:
        """-Q / mean|Q| + weight * mean over the batch of the (Q-filtered) squared distance to the
        expert's action; rows without an expert label (NaN) get no cloning term.

        With ``near_bc_weight`` the rows with a return near the vehicle (``NearReturns``) are cloned
        once more, unfiltered. Why: the raw residual policies collide 1.5-2.9 times as often as
        the controller they move (session 47's sea matrix), and the Q-filter lets the actor leave
        the controller wherever the critic, which has seen few collisions, rates its own action
        higher; near returns that estimate is least trustworthy and a wrong turn costs the most."""
        labelled = torch.isfinite(expert).all(1)
        a_exp = torch.nan_to_num(expert)
        sq = (pi - a_exp).pow(2).sum(1)
        keep = labelled
        if self.cfg.q_filter:
            with torch.no_grad():
                q_exp = self.critic(obs, a_exp, members=1, frozen=True)[0]
            keep = labelled & (q_exp >= q_pi[0].detach())
        bc = (sq * keep).mean()
        info["bc_loss"], info["bc_kept"] = bc.detach(), keep.float().mean()
        loss = -q_pi.mean() / q_pi.abs().mean().detach().clamp_min(1e-6) + weight * bc
        if self._near_on():
            near = labelled & self.near(obs)
            near_bc = (sq * near).mean()
            info["near_bc_loss"], info["near_share"] = near_bc.detach(), near.float().mean()
            loss = loss + self.cfg.near_bc_weight * near_bc
        return loss

    @torch.no_grad()
    def soft_update(self) -> None:
        """target <- (1 - tau) target + tau online, all tensors in one foreach call per network."""
        for tgt, src in self._pairs:
            torch._foreach_lerp_(tgt, src, self.cfg.tau)
        if self.cfg.obs_norm:
            for t, s in ((self.actor_target, self.actor), (self.critic_target, self.critic)):
                for tb, sb in zip(t.buffers(), s.buffers()):
                    tb.copy_(sb)

    # --- persistence ----------------------------------------------------------------------
    def state_dict(self) -> dict:
        return {"actor": self.actor.state_dict(), "critic": self.critic.state_dict(),
                "actor_target": self.actor_target.state_dict(),
                "critic_target": self.critic_target.state_dict(),
                "actor_opt": self.actor_opt.state_dict(), "critic_opt": self.critic_opt.state_dict(),
                "n_updates": self.n_updates}

    def load_state_dict(self, s: dict) -> None:
        self.actor.load_state_dict(s["actor"])
        self.critic.load_state_dict(s["critic"])
        self.actor_target.load_state_dict(s["actor_target"])
        self.critic_target.load_state_dict(s["critic_target"])
        self.actor_opt.load_state_dict(s["actor_opt"])
        self.critic_opt.load_state_dict(s["critic_opt"])
        self.n_updates = int(s["n_updates"])
