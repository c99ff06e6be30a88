"""Typed, frozen configuration of the training stack: reward weights, domain randomisation,
training episodes, networks, PPO and distillation.

The defaults are tuned for CPU training with 64–256 envs on a few cores (see ``PPOConfig``).
``TrainConfig.to_rsl_rl`` turns them into the plain dict ``rsl_rl`` runners read. Fields marked
``Suppress`` are fixed constants of the recipe: recorded in every ``train_meta.json``, not
offered by ``selfright train --help``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Annotated, Any, Literal

from tyro.conf import Suppress

from selfright.env.randomization import RandomizationConfig
from selfright.env.rewards import RewardConfig

__all__ = [
    "Context", "Role", "RewardConfig", "RandomizationConfig", "EpisodeConfig", "PolicyConfig",
    "PPOConfig", "DistillationConfig", "ValidationConfig", "TrainConfig",
]

Context = Literal["flat", "rough", "incline"]
"""Training contexts (seed §V): flat plane, rough level ground, 20° smooth slope."""
Role = Literal["teacher", "student"]
"""Teacher: PPO on privileged observations. Student: distilled onto sensor-only observations."""


@dataclass(frozen=True, kw_only=True)
class EpisodeConfig:
    """Training episodes (evaluation episodes are defined by ``GoalConfig``)."""

    episode_s: Annotated[float, Suppress] = 10.0
    """Training episode length after settling (s): 500 control steps at 50 Hz."""
    off_tile_is_timeout: Annotated[bool, Suppress] = True
    """Leaving the tile ends a training episode as a time-out (PPO bootstraps the value), not
    as a terminal state. A robot lying on the ground earns a negative reward per step under
    Table I (height, collision and orientation terms), so a terminal state worth 0 pays it to
    end the episode: on the 20° incline, where rolling 3 m downhill off the tile is easy,
    teachers trained with a terminal end learn to do exactly that. The tile's edge is an
    artefact of simulating a finite patch of an unbounded slope; the benchmark still counts
    leaving it as a failure."""
    prepare_starts: Annotated[bool, Suppress] = True
    """Draw and settle each slot's next episode start ahead of time, in one batched rollout
    for every slot without one, instead of settling the 1–3 episodes that end at a control step
    on their own (2 s of physics on 1–3 threads while the rest idle). Same fall protocol,
    same distribution of starts; the random stream differs from ``False``. A slot's start
    waits at most one episode: a curriculum level change since it was drawn discards it."""
    terminate_low_stance_s: float = 0.0
    """End the episode as a terminal state (value 0) once the robot has stood upright on four
    feet with its trunk under the goal bar for this long without a break (s); 0 = off. The
    reward stays Table I term for term, but a terminal end forfeits the ~10 per second Table I
    pays a robot standing on four feet, so a crouch under the bar (where every Table I run
    drifts: docs/training.md, *Choices that are not in the seed*) is worth less than a stance
    above it. This brings the goal bar into training, so model cards flag it. A robot passing
    through a crouch on its way up is spared by the grace time."""
    low_stance_leaky: bool = False
    """With ``terminate_low_stance_s``: count a stance on three or four feet under the bar, let
    other steps outside the goal set only take one step off the count, and clear it in the
    goal set. Off, a single step with a foot lifted or above the bar clears the count, which a
    robot creeping downhill on the incline does all the time (docs/training.md, *Choices that are
    not in the seed*)."""
    curriculum: bool = False
    """Terrain curriculum: each env slot holds a level (the context's tiles from easy to hard:
    rough extents ascending, incline slopes ``incline_curriculum_deg``), starts at the
    easiest, moves up after an episode whose last ``curriculum_window_s`` were mostly in the
    goal set and down after one that ended with none (or off the tile)."""
    incline_curriculum_deg: Annotated[tuple[float, ...], Suppress] = (5.0, 10.0, 15.0, 20.0)
    """Slopes of the ``incline`` context's curriculum levels (deg); the last is the context's 20°."""
    curriculum_window_s: Annotated[float, Suppress] = 1.0
    """Final stretch of an episode that decides promotion (s)."""
    rough_variants: Annotated[int, Suppress] = 8
    """Tiles of the ``rough`` context, roughness extents evenly spaced up to ``rough_max_extent_m``;
    each is one fixed noise draw. The ``rough`` lineage trained on 8; 64 lift the rough teacher
    from 80.7 to 86.0 % on the benchmark's (fresh) tiles, seeds 0–7, but not its student
    (docs/training.md, *Tried, did not help*)."""
    rough_max_extent_m: Annotated[float, Suppress] = 0.35
    """Largest peak-to-peak roughness extent of the ``rough`` context (m). 0.35 m covers
    ``--grid rough`` (levels 4, 8, 12: 0.105, 0.21, 0.32 m) with a margin, so the policy is
    judged on roughness it trained on."""


@dataclass(frozen=True, kw_only=True)
class PolicyConfig:
    """Actor and critic networks (rsl_rl ``MLPModel``)."""

    hidden_dims: tuple[int, ...] = (256, 128, 64)
    """Hidden layer widths of actor and critic MLPs (units)."""
    activation: Annotated[str, Suppress] = "elu"
    """Hidden activation (an ``rsl_rl`` activation name)."""
    obs_normalization: Annotated[bool, Suppress] = True
    """Running mean/std normalisation of the inputs (stats are exported with the actor)."""
    init_std: Annotated[float, Suppress] = 0.5
    """Initial standard deviation of the Gaussian action noise (action units). 0.5 gives
    0.25 rad of target jitter with the 0.5 rad action scale, the exploration legged_gym's A1
    setup uses; 1.0 made the target random-walk so hard that standing was never found."""


@dataclass(frozen=True, kw_only=True)
class PPOConfig:
    """PPO hyper-parameters for CPU training with 64–256 envs.

    One iteration collects ``num_envs × steps_per_env`` transitions (1536 with 64 envs),
    split into ``num_mini_batches`` minibatches over ``num_learning_epochs`` epochs, so the
    update costs about as much as the collection on a CPU.
    """

    steps_per_env: Annotated[int, Suppress] = 24
    """Transitions collected per env per iteration (control steps)."""
    num_learning_epochs: Annotated[int, Suppress] = 5
    """Passes over each rollout."""
    num_mini_batches: Annotated[int, Suppress] = 4
    """Minibatches per epoch."""
    clip_param: Annotated[float, Suppress] = 0.2
    """PPO ratio clip (dimensionless)."""
    gamma: Annotated[float, Suppress] = 0.99
    """Discount per control step (dimensionless)."""
    lam: Annotated[float, Suppress] = 0.95
    """GAE λ (dimensionless)."""
    value_loss_coef: Annotated[float, Suppress] = 1.0
    """Weight of the value loss (dimensionless)."""
    entropy_coef: float = 0.005
    """Weight of the entropy bonus (dimensionless); 0.01 let the action noise grow steadily
    (std 1.0 → 1.3 in 2M steps) without finding the standing reward."""
    learning_rate: float = 1e-3
    """Initial Adam learning rate, adapted to hit ``desired_kl`` (1/update)."""
    schedule: Annotated[Literal["adaptive", "fixed"], Suppress] = "adaptive"
    """Learning-rate schedule."""
    desired_kl: float = 0.01
    """Target KL divergence per update for the adaptive schedule (nats)."""
    max_grad_norm: Annotated[float, Suppress] = 1.0
    """Gradient-norm clip (dimensionless)."""


@dataclass(frozen=True, kw_only=True)
class DistillationConfig:
    """Student distillation (rsl_rl ``Distillation``: behaviour cloning on the student's rollouts)."""

    steps_per_env: Annotated[int, Suppress] = 24
    """Transitions collected per env per iteration (control steps)."""
    num_learning_epochs: Annotated[int, Suppress] = 2
    """Passes over each rollout."""
    gradient_length: Annotated[int, Suppress] = 6
    """Env steps (of all envs) accumulated per gradient step; should divide
    ``steps_per_env × epochs``. 2 epochs of 24 steps in groups of 6 = 8 Adam steps per
    iteration (1 epoch of 2 × 12 gave 2: too few for the MLP to follow the teacher)."""
    learning_rate: Annotated[float, Suppress] = 1e-3
    """Adam learning rate (1/update)."""
    max_grad_norm: Annotated[float, Suppress] = 1.0
    """Gradient-norm clip (dimensionless)."""
    loss_type: Annotated[Literal["mse", "huber"], Suppress] = "mse"
    """Behaviour-cloning loss between student and teacher mean actions."""
    student_history: int = 1
    """Frames of the ``student`` observation the student reads, stacked oldest first (1 = the
    current one only). The issue allows a short history: on the incline a lying robot cannot
    tell the slope from one IMU reading, while a few frames show which way it slides.
    Deployment stacks frames the same way (``selfright.policies.history``)."""
    student_init_std: Annotated[float, Suppress] = 0.1
    """Action noise of the student while it collects its own rollouts (action units)."""


@dataclass(frozen=True, kw_only=True)
class ValidationConfig:
    """Benchmark evaluation of every saved checkpoint (``selfright.train.validation``)."""

    episodes: int = 0
    """Episodes per grid cell for each checkpoint; 0 = no validation."""
    seed: Annotated[int, Suppress] = 1
    """Run seed of the validation episodes (not 0, the seed model cards report)."""
    grid: str | None = None
    """Named grid to validate on; default: the training context's grid (flat, rough, incline)."""


@dataclass(frozen=True, kw_only=True)
class TrainConfig:
    """Everything a training run needs beyond the benchmark configuration."""

    reward: RewardConfig = field(default_factory=RewardConfig)
    randomization: RandomizationConfig = field(default_factory=RandomizationConfig)
    episode: EpisodeConfig = field(default_factory=EpisodeConfig)
    policy: PolicyConfig = field(default_factory=PolicyConfig)
    ppo: PPOConfig = field(default_factory=PPOConfig)
    distillation: DistillationConfig = field(default_factory=DistillationConfig)
    validation: ValidationConfig = field(default_factory=ValidationConfig)
    recenter_on_init: Annotated[bool, Suppress] = True
    """With ``--init-from``: observation features that never varied in the source run get the
    new context's mean as their normaliser mean (the rest of the statistics are kept). Without
    it such a feature is blown up: the slope angle is 0 with std 0 on the flat plane, so on the
    20° incline it enters the flat teacher's network as 0.35 rad / 0.01 (the normaliser's eps)
    = 35 standard deviations."""
    checkpoint_every_s: float = 300.0
    """Wall-clock time between checkpoints (s); one is also written at the end."""
    keep_checkpoints: int = 10
    """Most recent time-based checkpoints kept on disk; 0 = keep all."""

    def to_rsl_rl(self, role: Role, teacher_policy: PolicyConfig | None = None) -> dict[str, Any]:
        """The ``train_cfg`` dict of ``OnPolicyRunner`` (teacher) or ``DistillationRunner`` (student).

        ``teacher_policy`` is the network of the teacher being distilled (default: ``policy``).
        """
        pol = self.policy
        net = _mlp_cfg(pol)
        common = {"save_interval": 10**9, "logger": "tensorboard", "check_for_nan": True}
        if role == "teacher":
            p = self.ppo
            return {
                **common,
                "num_steps_per_env": p.steps_per_env,
                "obs_groups": {"actor": ["teacher"], "critic": ["teacher"]},
                "actor": {**net, "distribution_cfg": _gaussian(pol.init_std)},
                "critic": dict(net),
                "algorithm": {
                    "class_name": "PPO",
                    "num_learning_epochs": p.num_learning_epochs,
                    "num_mini_batches": p.num_mini_batches,
                    "clip_param": p.clip_param,
                    "gamma": p.gamma,
                    "lam": p.lam,
                    "value_loss_coef": p.value_loss_coef,
                    "entropy_coef": p.entropy_coef,
                    "learning_rate": p.learning_rate,
                    "max_grad_norm": p.max_grad_norm,
                    "schedule": p.schedule,
                    "desired_kl": p.desired_kl,
                    "use_clipped_value_loss": True,
                    "symmetry_cfg": None,
                },
            }
        d = self.distillation
        return {
            **common,
            "num_steps_per_env": d.steps_per_env,
            "obs_groups": {"student": [student_group(d.student_history)], "teacher": ["teacher"]},
            "student": {**net, "distribution_cfg": _gaussian(d.student_init_std)},
            # The teacher acts deterministically; init_std 0 as rsl_rl's maintainers advise
            # (its trained std is loaded with the weights and never used).
            "teacher": {**_mlp_cfg(teacher_policy or pol), "distribution_cfg": _gaussian(0.0)},
            "algorithm": {
                "class_name": "Distillation",
                "num_learning_epochs": d.num_learning_epochs,
                "gradient_length": d.gradient_length,
                "learning_rate": d.learning_rate,
                "max_grad_norm": d.max_grad_norm,
                "loss_type": d.loss_type,
            },
        }


def student_group(history: int) -> str:
    """Name of the observation group a student with ``history`` frames reads."""
    return "student" if history <= 1 else "student_history"


def _mlp_cfg(pol: PolicyConfig) -> dict[str, Any]:
    return {
        "class_name": "MLPModel",
        "hidden_dims": list(pol.hidden_dims),
        "activation": pol.activation,
        "obs_normalization": pol.obs_normalization,
    }


def _gaussian(init_std: float) -> dict[str, Any]:
    return {"class_name": "GaussianDistribution", "init_std": init_std, "std_type": "scalar"}
