"""One typed training config: every hyperparameter, named presets, YAML files and CLI overrides.

Precedence (later wins): dataclass defaults (= the study's DDPG) < ``--preset`` < ``--config`` YAML
< ``--set key=value`` overrides. Unknown keys are errors, so a typo never silently trains the
wrong thing. Reward terms are written ``reward.<field>`` (the fields of ``cage_sim.mission.RewardConfig``).

A YAML file may start from another with ``extends: other.yaml`` (a path relative to the file): the
other file's keys first, then this file's (``reward`` merged term by term). So a variant names only
what it changes, and the expanded config is what every run records (``to_dict``).
"""
from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import yaml
from cage_sim.controller import REMEMBERED
from cage_sim.mission import EnvConfig, RewardConfig
from cage_sim.sonar import SonarConfigError, make_sonar


# "baseline": the classical controller on the observation alone (drift from its velocity part,
# returns static, no final approach); "flown": the baseline as evaluate and policy_node fly it
# (cage_sim.driver.FlownLabeller: drift from the DVL, returns' motion across scans, final approach).
EXPERTS = ("", "baseline", "flown")


@dataclass
class TrainConfig:
    # --- problem ------------------------------------------------------------------------
    scenario: str = "study2d"            # name, YAML file, or a mix "study2d:0.5,cage:0.5"
    motion: str = "study"                # "study" (the study's step) or "continuous" (the vehicle node)
    reward: dict = field(default_factory=dict)   # RewardConfig overrides, e.g. {"progress_weight": 1}
    planner: str = "none"                # training routes: none (straight), rrt, dense, dense_mix
    # --- sensor and observation (cage_sim.mission.EnvConfig; recorded in the policy's metadata) ---
    sensor: str = "study"                # sonar profile: study, multibeam360, fls, scanning
    sensor_settings: dict = field(default_factory=dict)  # the profile's settings overridden, YAML units
                                         # (cage_sim.sonar.make_sonar: beam_width_deg, n_beams, noise_std, ...)
    observation: str = "auto"            # v1 (the study's layout), v2, auto (v1 for plain study)
    velocity: bool = False               # v2: velocity over ground (DVL) in the observation
    memory_bins: int = 0                 # v2: egocentric memory of recent returns (0 = none)
    memory_horizon: float = 10.0         # v2: seconds a return stays in the memory
    scan_in_obs: bool = True             # v2: the raw scan in the observation (False: memory only)
    # --- budget -------------------------------------------------------------------------
    seed: int = 0
    total_steps: int = 0                 # env steps (all envs together); 0 = use episodes
    episodes: int = 10_000               # the study's 10,000 episodes (used when total_steps == 0)
    n_envs: int = 1                      # missions stepped together (CageNavVecEnv)
    threads: int = 1                     # torch intra-op threads
    env_workers: int = 1                 # > 1: envs + expert in that many worker processes, updates beside them
    # --- DDPG (the study's values) ------------------------------------------------------
    actor_hidden: tuple = (400, 300)
    critic_hidden: tuple = (400, 300)
    lr_actor: float = 1e-4
    lr_critic: float = 1e-3
    gamma: float = 0.99
    tau: float = 0.001
    batch_size: int = 64
    buffer_size: int = 150_000
    prefill_steps: int = 0               # random-action steps before learning; -1 = fill the buffer
    prefill_fraction: float = 0.3        # used when prefill_steps == 0: share of the budget (study ~3k/10k)
    noise: str = "ou"                    # "ou" (Ornstein-Uhlenbeck, DDPG paper) or "gaussian"
    noise_std: float = 0.2
    noise_theta: float = 0.15
    noise_final_std: float = -1.0        # < 0: constant; else linear decay to this value
    # --- improvements (off = the study) -------------------------------------------------
    updates_per_step: float = 1.0        # gradient updates per env step (update-to-data ratio)
    n_step: int = 1                      # n-step returns
    obs_norm: bool = False               # running observation normalisation
    twin_critic: bool = False            # TD3: clipped double Q
    policy_delay: int = 1                # TD3: actor/target update every k critic updates
    target_noise: float = 0.0            # TD3: target policy smoothing std (0 = off)
    target_noise_clip: float = 0.5
    grad_clip: float = 0.0               # max grad norm (0 = off)
    # --- expert guidance (off = plain DDPG/TD3; agent.py, train.py) ----------------------
    expert: str = ""                     # "baseline": the classical ArcController labels every observation
    expert_fraction: float = 0.0         # share of episodes flown by the expert (+ noise): demonstrations
    expert_fraction_final: float = -1.0  # < 0: constant; else linear decay to this share
    bc_weight: float = 0.0               # behaviour-cloning weight in the actor loss (TD3+BC normalised)
    bc_weight_final: float = -1.0        # < 0: constant; else linear decay to this weight
    q_filter: bool = True                # clone only where Q(s, expert) >= Q(s, actor) (Nair et al. 2018)
    residual: bool = False               # the actor moves the expert's action (networks.residual_action); needs expert: flown
    expert_pursuit: bool = False         # the expert (a residual policy's base) re-aims in one candidate (controller.py)
    expert_handover: float = 0.0         # m: the expert's rollouts stop being checked past an intermediate waypoint this near
    expert_handover_tail: int = 5        # ... after this many more decisions (controller.py, ``handover``)
    expert_remembered: str = "all"       # the remembered returns the expert counts (ArcController.remembered;
                                         # "cleared" needs expert: flown, which reads each mission's memory)
    near_bc_weight: float = 0.0          # cloning weight, unfiltered, where a return is within near_bc_range (agent.py)
    near_bc_range: float = 3.0           # m: nearest return (scan or memory) that counts as near
    # --- hard-case replay (off = every episode a fresh draw; hard_cases.py) ----------------
    replay_fraction: float = 0.0         # share of new episodes that re-fly a failed mission
    replay_max_tries: int = 3            # times one mission may be flown in all
    # --- the shield in the loop (off = the actor's actions are flown as they are; driver.ShieldFilter) ---
    shield_in_loop: bool = False         # every action passes the evaluator's safety shield before it is flown
    shield_penalty: float = 0.0          # reward taken off a step whose action the shield replaced
    # --- logging ------------------------------------------------------------------------
    eval_every: int = 0                  # env steps between evaluations (0 = only at the end)
    eval_episodes: int = 100
    eval_scenario: str = ""              # "" = the first scenario of the mix
    checkpoint_every: int = 0            # env steps between checkpoints (0 = only at the end)
    tensorboard: bool = True
    moving_average: int = 100

    # ------------------------------------------------------------------------------------
    def env_config(self) -> EnvConfig:
        return EnvConfig(reward=RewardConfig(**self.reward), motion=self.motion,
                         sonar=make_sonar(self.sensor, **self.sensor_settings),
                         observation=self.observation, velocity=self.velocity, memory_bins=self.memory_bins,
                         memory_horizon=self.memory_horizon, scan_in_obs=self.scan_in_obs)

    def validate(self) -> "TrainConfig":
        bad = set(self.reward) - {f.name for f in fields(RewardConfig)}
        if bad:
            raise ValueError(f"reward: unknown field(s) {sorted(bad)}")
        if not isinstance(self.sensor_settings, dict):
            raise ValueError(f"sensor_settings: must be a mapping of sonar settings, got {self.sensor_settings!r}")
        try:
            make_sonar(self.sensor, **self.sensor_settings)
        except SonarConfigError as err:
            raise ValueError(f"sensor / sensor_settings: {err}") from None
        if self.motion not in ("study", "continuous"):
            raise ValueError(f"motion: must be 'study' or 'continuous', got {self.motion!r}")
        if self.noise not in ("ou", "gaussian"):
            raise ValueError(f"noise: must be 'ou' or 'gaussian', got {self.noise!r}")
        for name in ("n_envs", "batch_size", "buffer_size", "n_step", "policy_delay"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name}: must be >= 1")
        if self.expert not in EXPERTS:
            raise ValueError(f"expert: must be one of {EXPERTS}, got {self.expert!r}")
        if (self.expert_fraction > 0 or self.bc_weight > 0) and not self.expert:
            raise ValueError("expert_fraction / bc_weight need an expert (expert: baseline)")
        if (self.expert_pursuit or self.expert_handover) and not self.expert:
            raise ValueError("expert_pursuit / expert_handover: need an expert (the controller they change)")
        if not (self.expert_handover >= 0 and 0 <= self.expert_handover_tail < 10):
            raise ValueError(f"expert_handover: must be >= 0 m, got {self.expert_handover!r}; "
                             f"expert_handover_tail: 0-9 decisions, got {self.expert_handover_tail!r}")
        if self.expert_remembered not in REMEMBERED:
            raise ValueError(f"expert_remembered: must be one of {', '.join(REMEMBERED)}, got {self.expert_remembered!r}")
        if self.expert_remembered == "cleared" and self.expert != "flown":
            raise ValueError("expert_remembered: cleared needs expert: flown (what the sonar has seen past is "
                             f"in each mission's memory, not in the observation), got expert: {self.expert!r}")
        if self.residual and self.expert != "flown":
            raise ValueError(f"residual: needs expert: flown (the base action is the flown baseline's), "
                             f"got expert: {self.expert!r}")
        if not 0.0 <= self.expert_fraction <= 1.0 or self.expert_fraction_final > 1.0:
            raise ValueError("expert_fraction: must be in [0, 1]")
        if not 0.0 <= self.replay_fraction <= 1.0 or self.replay_max_tries < 1:
            raise ValueError("replay_fraction: must be in [0, 1]; replay_max_tries: >= 1")
        if not 1 <= self.env_workers <= self.n_envs:
            raise ValueError(f"env_workers: must be between 1 and n_envs ({self.n_envs}), got {self.env_workers}")
        if self.bc_weight < 0:
            raise ValueError("bc_weight: must be >= 0")
        if self.near_bc_weight < 0 or self.near_bc_range <= 0:
            raise ValueError(f"near_bc_weight: must be >= 0, got {self.near_bc_weight!r}; "
                             f"near_bc_range: > 0 m, got {self.near_bc_range!r}")
        if self.near_bc_weight > 0 and not self.expert:
            raise ValueError("near_bc_weight: needs an expert (the action it clones near returns)")
        if not (self.shield_penalty >= 0 and math.isfinite(self.shield_penalty)):
            raise ValueError(f"shield_penalty: must be a finite number >= 0, got {self.shield_penalty!r}")
        if self.shield_penalty > 0 and not self.shield_in_loop:
            raise ValueError("shield_penalty: needs shield_in_loop: true (the overrides it charges)")
        if self.shield_in_loop and (self.motion != "continuous" or self.scenario == "study1d"):
            raise ValueError("shield_in_loop: needs motion: continuous on cage missions (the shield's rollouts "
                             f"are of that vehicle), got motion {self.motion!r}, scenario {self.scenario!r}")
        if self.total_steps <= 0 and self.episodes <= 0:
            raise ValueError("total_steps or episodes must be > 0")
        self.actor_hidden = tuple(int(h) for h in self.actor_hidden)
        self.critic_hidden = tuple(int(h) for h in self.critic_hidden)
        return self

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["actor_hidden"], d["critic_hidden"] = list(self.actor_hidden), list(self.critic_hidden)
        return d


# Study budgets are in episodes; our presets in env steps (vectorised envs finish episodes in bulk).
PRESETS: dict[str, dict[str, Any]] = {
    "study": {},
    "study_low_lr": {"lr_actor": 1e-5, "lr_critic": 1e-4},
    "study_extra_layer": {"actor_hidden": (400, 300, 200), "critic_hidden": (400, 300, 200)},
    # Ours: many envs, small nets, big batches, TD3 tricks, n-step, progress/clearance shaping,
    # trained on a mix of the study's case and the full cage with the vehicle node's motion model.
    "fast": {
        "scenario": "study2d:0.3,cage:0.7", "motion": "continuous", "planner": "dense_mix",
        "reward": {"goal": 10.0, "collision": -10.0, "wander": -10.0, "distance_weight": 0.0,
                   "heading_weight": 0.0, "progress_weight": 1.0, "clearance_weight": 1.0,
                   "clearance_margin": 1.5, "overtime_penalty": 0.0},
        "total_steps": 1_000_000, "n_envs": 16, "actor_hidden": (128, 128), "critic_hidden": (128, 128),
        "lr_actor": 3e-4, "lr_critic": 1e-3, "gamma": 0.98, "tau": 0.005, "batch_size": 256,
        "buffer_size": 500_000, "prefill_steps": 10_000, "noise": "gaussian", "noise_std": 0.3,
        "noise_final_std": 0.1, "updates_per_step": 0.25, "n_step": 3, "twin_critic": True,
        "policy_delay": 2, "target_noise": 0.2, "eval_every": 50_000, "eval_episodes": 200,
        "eval_scenario": "cage", "checkpoint_every": 100_000,
    },
}
# "rrt": "fast" trained on the routes the graph really flies: the global planner's corner waypoints
# (cage_global_rrt, the rrt_node's own options) instead of straight lines cut every metre.
PRESETS["rrt"] = {**PRESETS["fast"], "planner": "rrt"}


def _coerce(name: str, value: Any, current: Any) -> Any:
    """Parse a CLI string to the type of the field it overrides (YAML syntax: 1e-3, [64, 64], true)."""
    if isinstance(value, str) and not isinstance(current, str):   # a str field keeps "" and "None"
        value = yaml.safe_load(value)
    if isinstance(current, bool):
        if not isinstance(value, bool):
            raise ValueError(f"{name}: expected true/false, got {value!r}")
        return value
    if isinstance(current, tuple):
        if not isinstance(value, (list, tuple)):
            raise ValueError(f"{name}: expected a list like [256, 256], got {value!r}")
        return tuple(value)
    if isinstance(current, float) and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if isinstance(current, float) and isinstance(value, str):
        try:            # YAML 1.1 reads 5e-4 (no dot) as a string; a float field still means 0.0005
            return float(value)
        except ValueError:
            raise ValueError(f"{name}: expected float, got {value!r}") from None
    if isinstance(current, str) and not isinstance(value, str):
        return str(value)
    if current is not None and not isinstance(value, type(current)):
        raise ValueError(f"{name}: expected {type(current).__name__}, got {value!r}")
    return value


def apply(cfg: TrainConfig, updates: dict[str, Any]) -> TrainConfig:
    """Apply a mapping of overrides; ``reward.x`` keys (or a ``reward`` mapping) merge into reward."""
    names = {f.name for f in fields(TrainConfig)}
    for key, value in updates.items():
        if key.startswith("reward."):
            cfg.reward = {**cfg.reward, key.split(".", 1)[1]: float(_coerce(key, value, 0.0))}
        elif key == "reward":
            cfg.reward = {**cfg.reward, **dict(value)}
        elif key in names:
            setattr(cfg, key, _coerce(key, value, getattr(cfg, key)))
        else:
            raise ValueError(f"{key}: unknown config key (see cage_reactive_ddpg/config.py)")
    return cfg


def _read_one(path: Path) -> dict[str, Any]:
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except OSError as err:
        raise ValueError(f"{path}: cannot read ({err.strerror or err})") from None
    except yaml.YAMLError as err:
        raise ValueError(f"{path}: not valid YAML ({' '.join(str(err).split())})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a mapping of config keys")
    return data


def read_file(file: str | Path, _seen: tuple[Path, ...] = ()) -> dict[str, Any]:
    """A config file's keys with its ``extends:`` chain resolved: parents first, the file's own keys
    win, ``reward`` merged term by term. A cycle or a missing parent is an error naming the file."""
    path = Path(file)
    key = path.resolve()
    if key in _seen:
        chain = " -> ".join(p.name for p in (*_seen, key))
        raise ValueError(f"{path}: extends itself ({chain})")
    data = _read_one(path)
    parent = data.pop("extends", None)
    if parent is None:
        return data
    if not isinstance(parent, str) or not parent:
        raise ValueError(f"{path}: extends: expected a file name, got {parent!r}")
    parent_path = path.parent / parent
    if not parent_path.is_file():
        raise ValueError(f"{path}: extends {parent}: no such file ({parent_path})")
    base = read_file(parent_path, (*_seen, key))
    merged = {**base, **data}
    if isinstance(base.get("reward"), dict) and isinstance(data.get("reward"), dict):
        merged["reward"] = {**base["reward"], **data["reward"]}
    return merged


def build(preset: str | None = None, file: str | Path | None = None,
          overrides: list[str] | dict | None = None, base: TrainConfig | None = None) -> TrainConfig:
    """Defaults (or ``base``, e.g. a checkpoint's config) < preset < YAML file < overrides
    (``key=value`` strings or a dict)."""
    cfg = dataclasses.replace(base) if base is not None else TrainConfig()
    data = read_file(file) if file else {}
    preset = preset or data.pop("preset", None)
    data.pop("preset", None)
    if preset:
        if preset not in PRESETS:
            raise ValueError(f"preset: {preset!r} is not one of {', '.join(PRESETS)}")
        apply(cfg, PRESETS[preset])
    apply(cfg, data)
    if isinstance(overrides, dict):
        apply(cfg, overrides)
    else:
        for item in overrides or []:
            if "=" not in item:
                raise ValueError(f"--set {item!r}: expected key=value")
            k, v = item.split("=", 1)
            apply(cfg, {k.strip(): v.strip()})
    return cfg.validate()


def from_dict(d: dict) -> TrainConfig:
    """Rebuild a config stored in a policy's metadata or a checkpoint."""
    return apply(TrainConfig(), d).validate()


def dumps(cfg: TrainConfig) -> str:
    return json.dumps(cfg.to_dict(), indent=2)


def to_yaml(cfg: TrainConfig) -> str:
    """The expanded config as a YAML file ``--config`` reads back (a run's ``config.yaml``)."""
    return yaml.safe_dump(cfg.to_dict(), sort_keys=False)
