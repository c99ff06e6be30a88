"""Training an escape specialist inside its composite: a frozen policy acts wherever the
trunk is upright within a tilt, and only the remaining (tilted) steps are the trained
policy's.

The composites that ship as students (docs/training.md, *A composite that hands over by tilt*)
pair a stand-up teacher, acting while the trunk is within 45° of upright, with an escape
specialist that acts when it is tilted more. The specialists were trained alone, from tilted
starts, for whole episodes: most of their Table I return, and so most of their learning, came
from the upright phase they never act in once deployed. With this override the training
episodes run the composite itself (``EpisodeConfig.upright_policy``): the frozen stand-up
policy's action replaces the trained policy's in every upright state, so the specialist's
return is the composite's, and what it learns is to hand the robot over in states from which
the stand-up policy succeeds.

PPO still stores the trained policy's own sampled action in the overridden steps; there it has
no effect on what follows, so its advantage carries no signal about it and adds only noise,
while the critic learns the composite's values (``EpisodeConfig.upright_masked`` drops those
steps from the policy gradient: ``selfright.train.override_mask``). Reward, observations (the previous action is
the one applied) and the benchmark are unchanged.

The other way round (``EpisodeConfig.tilted_policy``, ``acts_when="tilted"``), a frozen escape
teacher acts in every tilted step, and the trained policy, typically a student of the stand-up
teacher, acts only once the robot is within the tilt: it then learns on the states the
composite's escape phase hands over, with none of its capacity spent on imitating the escape.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import torch

from selfright.config import ActionConfig
from selfright.policies.actor import ActorMLP
from selfright.policies.reference import ReferenceShift, reference_offset
from selfright.policies.stall import TiltSwitch
from selfright.robots import RobotSpec
from selfright.train.commands import load_checkpoint_actor


class UprightOverride:
    """Replaces actions by ``actor``'s wherever the trunk is within ``tilt_deg`` of upright
    (``acts_when="upright"``), or wherever it is tilted more (``"tilted"``).

    Args:
        actor: the frozen policy; reads the ``teacher`` observation (k, D).
        tilt_deg: the hand-over tilt (deg).
        num_envs: env slots.
        offset: (J,) (actor's reference pose − the env's) / action scale when the actor was
            trained around another fixed pose than the env's ``--action-reference``; None if
            the same.
        acts_when: on which side of the tilt the frozen policy acts.
    """

    def __init__(self, actor: ActorMLP, tilt_deg: float, num_envs: int, offset: torch.Tensor | None = None,
                 acts_when: Literal["upright", "tilted"] = "upright"):
        if actor.meta.obs_group != "teacher" or actor.recurrent or actor.meta.obs_history > 1:
            raise ValueError("the frozen policy must be a feed-forward teacher (it reads the teacher observation)")
        self.actor = actor.eval()
        self.acts_when = acts_when
        self.switch = TiltSwitch(tilt_deg)
        self.shift = ReferenceShift(offset, num_envs)
        self.overridden = torch.zeros(num_envs, dtype=torch.bool)
        """Slots overridden at the latest step (what ``selfright.train.override_mask`` records)."""

    @torch.no_grad()
    def __call__(self, teacher_obs: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """``actions`` (n, J) with the overridden slots' replaced by the frozen policy's (a copy)."""
        x = teacher_obs.detach().cpu().float()
        tilted = self.switch.step(x, None)
        rows = tilted if self.acts_when == "tilted" else ~tilted
        out = actions.detach().cpu().clone()
        if rows.any():
            out[rows] = self.shift.action(self.actor(self.shift.obs(x[rows], rows)))
        self.shift.stepped()
        self.overridden = rows
        return out

    @property
    def share(self) -> torch.Tensor:
        """Fraction of the slots overridden at the latest step (a 0-d tensor, for the log)."""
        return self.overridden.float().mean()

    def reset(self, ids: torch.Tensor) -> None:
        """Slots ``ids`` start new episodes."""
        self.shift.reset(ids)


def load_upright_override(
    path: Path, tilt_deg: float, num_envs: int, robot: RobotSpec, action: ActionConfig,
    acts_when: Literal["upright", "tilted"] = "upright",
) -> UprightOverride:
    """``UprightOverride`` of the teacher checkpoint (or run folder) ``path``, loaded as
    ``selfright export`` loads one; its recorded action mapping is converted to ``action`` if it
    differs. User errors raise ``ValueError``."""
    actor, _ = load_checkpoint_actor(path)
    trained = (actor.meta.action_reference or "stand", actor.meta.action_scale_rad or None)
    try:
        offset = reference_offset(robot, trained, action)
    except ValueError as e:
        raise ValueError(f"--train.episode.{acts_when}-policy {path}: {e}; only fixed poses (stand / tall) convert") from None
    return UprightOverride(actor, tilt_deg, num_envs, None if offset is None else torch.as_tensor(offset, dtype=torch.float32),
                           acts_when)
