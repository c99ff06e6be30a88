"""A trunk-velocity estimator inside the student, trained beside it on the privileged velocity.

The incline stand-up teacher leans on its trunk linear velocity: read as 0 at evaluation, its
composite drops from 63 to 40 % (docs/training.md, *Where the incline student loses its
composite's points*). A student sees no velocity; it must infer it from its history of IMU
and joint readings, and the behaviour-cloning loss is only an indirect signal for that. The
legged-locomotion remedy is a concurrently trained state estimator (Ji et al., "Concurrent
training of a control policy and a state estimator", RA-L 2022): a second network regresses
the privileged quantity from the student's own input, and the actor reads the estimate.

Here (``EstimatorMLPModel``, an rsl_rl ``MLPModel``):

    x  = normalise(student input)                      (k, D)
    v̂  = estimator(x)                                   (k, 3)  trunk linear velocity, body frame (m/s)
    a  = mlp([x, stop_gradient(v̂)])                     (k, J)

The estimator learns only from its regression loss (mean squared error against the teacher
observation's body-frame velocity, over each rollout: ``EstimatorTrainer``), the actor only from
the behaviour-cloning loss, on the estimate (not the true velocity), so it trains on what it
will read when deployed. Deployment (``selfright.policies.actor.ActorMLP``) needs nothing but the
student's observations: the estimator ships inside the policy file and the ONNX graph.
"""

from __future__ import annotations

from typing import Any

import torch
from rsl_rl.models import MLPModel
from rsl_rl.modules import MLP
from tensordict import TensorDict

from selfright.env.observations import privileged_columns
from selfright.policies.actor import ESTIMATE_DIM

TARGET_GROUP = "teacher"
"""Observation group the regression target is read from (never an input of the student)."""
OPTIMIZER_KEY = "velocity_estimator_optimizer_state_dict"
"""Checkpoint key of the estimator's own optimiser state."""


def velocity_columns(obs: TensorDict) -> slice:
    """Columns of the body-frame trunk velocity in ``obs[TARGET_GROUP]``, from the student frame's
    size (6 + 3J)."""
    num_joints = (int(obs["student"].shape[-1]) - 6) // 3
    return privileged_columns(num_joints)["velocity"]


class EstimatorMLPModel(MLPModel):
    """rsl_rl's MLP student with a velocity estimator between its normaliser and its MLP.

    Args (besides ``MLPModel``'s):
        estimator_dims: hidden widths of the estimator MLP (same activation as the actor).
    """

    def __init__(self, obs: TensorDict, obs_groups: dict[str, list[str]], obs_set: str, output_dim: int,
                 *, estimator_dims: tuple[int, ...] | list[int], **kwargs: Any):
        if not estimator_dims:
            raise ValueError("a velocity estimator needs at least one hidden layer")
        if TARGET_GROUP in obs_groups[obs_set]:
            raise ValueError(f"the estimator's target group {TARGET_GROUP!r} must not be an input of the student")
        super().__init__(obs, obs_groups, obs_set, output_dim, **kwargs)
        self.estimator = MLP(self.obs_dim, ESTIMATE_DIM, tuple(estimator_dims), kwargs.get("activation", "elu"))
        self.target_columns = velocity_columns(obs)

    def _get_latent_dim(self) -> int:
        return self.obs_dim + ESTIMATE_DIM

    def get_latent(self, obs: TensorDict, masks: torch.Tensor | None = None, hidden_state: Any = None) -> torch.Tensor:
        """[normalised input, its velocity estimate] (k, D + 3); no gradient flows into the estimator."""
        x = super().get_latent(obs, masks, hidden_state)
        return torch.cat([x, self.estimator(x).detach()], dim=-1)

    def estimate(self, obs: TensorDict) -> torch.Tensor:
        """(k, 3) velocity estimate, with gradient (for the regression loss)."""
        return self.estimator(super().get_latent(obs))

    def target(self, obs: TensorDict) -> torch.Tensor:
        """(k, 3) the true body-frame trunk velocity, read from the privileged group."""
        return obs[TARGET_GROUP][..., self.target_columns]


class EstimatorTrainer:
    """Fits the estimator on each rollout: ``epochs`` passes of ``minibatches`` Adam steps over
    the rollout's shuffled (step, env) samples, mean squared error in (m/s)².

    Args:
        model: the (raw, uncompiled) student.
        learning_rate: Adam learning rate.
        generator: the shuffling's random stream.
    """

    def __init__(self, model: EstimatorMLPModel, learning_rate: float, generator: torch.Generator,
                 epochs: int = 2, minibatches: int = 4):
        self.model, self.generator = model, generator
        self.epochs, self.minibatches = epochs, minibatches
        self.optimizer = torch.optim.Adam(model.estimator.parameters(), lr=learning_rate)

    def fit(self, rollout: TensorDict) -> tuple[float, float]:
        """Train on ``rollout`` (steps, envs) of observation groups; returns the mean loss and
        the share of the rollout's velocity variance the estimator explained before this fit
        (its R² as it acted)."""
        flat = rollout.flatten(0, 1)
        with torch.no_grad():
            target = self.model.target(flat)
            error = (self.model.estimate(flat) - target).pow(2).sum(-1).mean()
            r2 = 1.0 - error / target.var(0, unbiased=False).sum().clamp_min(1e-12)
        n = flat.batch_size[0]
        size = max(1, n // self.minibatches)
        total, count = 0.0, 0
        for _ in range(self.epochs):
            order = torch.randperm(n, generator=self.generator).to(flat.device)
            for start in range(0, size * self.minibatches, size):
                batch = flat[order[start : start + size]]
                loss = torch.nn.functional.mse_loss(self.model.estimate(batch), self.model.target(batch))
                self.optimizer.zero_grad()
                loss.backward()
                self.optimizer.step()
                total, count = total + loss.item(), count + 1
        return total / count, float(r2)


def attach_velocity_estimator(alg: Any, learning_rate: float, seed: int) -> EstimatorTrainer:
    """Make rsl_rl's ``Distillation`` ``alg`` fit its student's estimator on every rollout before
    the behaviour-cloning update (logged as the ``velocity`` loss, (m/s)², and ``velocity_r2``, the
    share of the rollout's velocity variance the estimator explained while the student acted), and
    save / restore the estimator's optimiser with the checkpoint."""
    student = alg._raw_student
    if not isinstance(student, EstimatorMLPModel):
        raise TypeError("attach_velocity_estimator needs an EstimatorMLPModel student")
    trainer = EstimatorTrainer(student, learning_rate, torch.Generator().manual_seed(seed))
    update, save, load = alg.update, alg.save, alg.load

    def update_with_estimator(*args: Any, **kwargs: Any) -> dict[str, float]:
        loss, r2 = trainer.fit(alg.storage.observations)  # before update(): it clears the storage
        return {**update(*args, **kwargs), "velocity": loss, "velocity_r2": r2}

    def save_with_estimator() -> dict:
        return {**save(), OPTIMIZER_KEY: trainer.optimizer.state_dict()}

    def load_with_estimator(loaded: dict, load_cfg: dict | None, strict: bool) -> bool:
        out = load(loaded, load_cfg, strict)
        if OPTIMIZER_KEY in loaded:
            trainer.optimizer.load_state_dict(loaded[OPTIMIZER_KEY])
        return out

    alg.update, alg.save, alg.load = update_with_estimator, save_with_estimator, load_with_estimator
    return trainer
