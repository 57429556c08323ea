"""DDPG (Lillicrap et al.) as the study ran it, with TD3's tricks as options.

With the study's config: one critic, actor updated every step, no target smoothing, OU noise,
soft target updates with tau. ``twin_critic`` / ``policy_delay`` / ``target_noise`` turn on clipped
double Q, delayed actor updates and target policy smoothing (Fujimoto et al.), which make DDPG's
over-estimation ("DDPG does not learn") much rarer.
"""
from __future__ import annotations

import copy

import numpy as np
import torch
from torch import nn

from .buffer import Batch
from .config import TrainConfig
from .networks import Actor, Critic


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


def soft_update(target: nn.Module, source: nn.Module, tau: float) -> None:
    with torch.no_grad():
        torch._foreach_lerp_(list(target.parameters()), list(source.parameters()), tau)
        for t, s in zip(target.buffers(), source.buffers()):
            t.copy_(s)


class DDPGAgent:
    def __init__(self, cfg: TrainConfig, obs_dim: int, act_dim: int = 1):
        self.cfg = cfg
        self.actor = Actor(obs_dim, cfg.actor_hidden, act_dim)
        n_critics = 2 if cfg.twin_critic else 1
        self.critics = nn.ModuleList([Critic(obs_dim, cfg.critic_hidden, act_dim) for _ in range(n_critics)])
        self.actor_target = copy.deepcopy(self.actor)
        self.critics_target = copy.deepcopy(self.critics)
        for p in list(self.actor_target.parameters()) + list(self.critics_target.parameters()):
            p.requires_grad_(False)
        # foreach: one kernel per step for all tensors (on CPU PyTorch defaults to a Python loop).
        self.actor_opt = torch.optim.Adam(self.actor.parameters(), lr=cfg.lr_actor, foreach=True)
        self.critic_opt = torch.optim.Adam(self.critics.parameters(), lr=cfg.lr_critic, foreach=True)
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
        for net in [*self.critics, self.actor_target, *self.critics_target]:
            net.norm.load_state_dict(state)

    # --- learning -------------------------------------------------------------------------
    def update(self, b: Batch) -> dict[str, float]:
        cfg = self.cfg
        obs, act = torch.from_numpy(b.obs), torch.from_numpy(b.act)
        rew, nxt, disc = torch.from_numpy(b.rew), torch.from_numpy(b.next_obs), torch.from_numpy(b.discount)
        with torch.no_grad():
            a2 = self.actor_target(nxt)
            if cfg.target_noise > 0:
                eps = (torch.randn_like(a2) * cfg.target_noise).clamp(-cfg.target_noise_clip, cfg.target_noise_clip)
                a2 = (a2 + eps).clamp(-1.0, 1.0)
            q2 = torch.stack([c(nxt, a2) for c in self.critics_target]).min(0).values
            target = rew + disc * q2
        qs = [c(obs, act) for c in self.critics]
        critic_loss = sum(((q - target) ** 2).mean() for q in qs)
        self.critic_opt.zero_grad(set_to_none=True)
        critic_loss.backward()
        if cfg.grad_clip > 0:
            nn.utils.clip_grad_norm_(self.critics.parameters(), cfg.grad_clip)
        self.critic_opt.step()
        self.n_updates += 1
        info = {"critic_loss": critic_loss.item(), "q": qs[0].detach().mean().item()}
        if self.n_updates % cfg.policy_delay == 0:
            for p in self.critics.parameters():
                p.requires_grad_(False)
            actor_loss = -self.critics[0](obs, self.actor(obs)).mean()
            self.actor_opt.zero_grad(set_to_none=True)
            actor_loss.backward()
            if cfg.grad_clip > 0:
                nn.utils.clip_grad_norm_(self.actor.parameters(), cfg.grad_clip)
            self.actor_opt.step()
            for p in self.critics.parameters():
                p.requires_grad_(True)
            soft_update(self.actor_target, self.actor, cfg.tau)
            soft_update(self.critics_target, self.critics, cfg.tau)
            info["actor_loss"] = actor_loss.item()
        return info

    # --- persistence ----------------------------------------------------------------------
    def state_dict(self) -> dict:
        return {"actor": self.actor.state_dict(), "critics": self.critics.state_dict(),
                "actor_target": self.actor_target.state_dict(),
                "critics_target": self.critics_target.state_dict(),
                "actor_opt": self.actor_opt.state_dict(), "critic_opt": self.critic_opt.state_dict(),
                "n_updates": self.n_updates}

    def load_state_dict(self, s: dict) -> None:
        self.actor.load_state_dict(s["actor"])
        self.critics.load_state_dict(s["critics"])
        self.actor_target.load_state_dict(s["actor_target"])
        self.critics_target.load_state_dict(s["critics_target"])
        self.actor_opt.load_state_dict(s["actor_opt"])
        self.critic_opt.load_state_dict(s["critic_opt"])
        self.n_updates = int(s["n_updates"])
