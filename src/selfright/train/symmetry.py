"""Left-right symmetry for PPO: rsl_rl's ``Symmetry`` extension with the robot's mirror.

The robot, the fall protocol and every training context are symmetric under mirroring the
world in the trunk's sagittal plane (uniform orientations and joint angles, flat or
all-headings incline, rough tiles drawn from a mirror-invariant distribution). So a
transition and its mirror image are equally likely, and rsl_rl can (a) append the mirrored
observation/action pairs to every PPO minibatch (``PPOConfig.symmetry_augmentation``) and/or
(b) penalise the policy for acting differently on mirrored observations
(``PPOConfig.mirror_loss_coef``; Mittal et al., ICRA 2024). Neither touches the reward.
"""

from __future__ import annotations

import functools

import numpy as np
import torch
from tensordict import TensorDict

from selfright.env.observations import privileged_mirror, student_mirror
from selfright.robots import RobotSpec, get_robot


@functools.cache
def group_mirrors(robot_name: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """(index, sign) of each observation group's mirror (``student``, ``teacher``) and of the
    actions (``actions``); ``ValueError`` if the robot declares no mirror."""
    robot: RobotSpec = get_robot(robot_name)
    if robot.mirror_joints is None or robot.mirror_signs is None:
        raise ValueError(f"robot {robot_name!r} declares no left-right mirror (RobotSpec.mirror_joints); train without symmetry")
    joints, signs = robot.mirror_joints, robot.mirror_signs
    s_idx, s_sgn = student_mirror(joints, signs)
    p_idx, p_sgn = privileged_mirror()
    return {
        "student": (s_idx, s_sgn),
        "teacher": (np.concatenate([s_idx, len(s_idx) + p_idx]), np.concatenate([s_sgn, p_sgn])),
        "actions": (joints, signs),
    }


def mirror(x: torch.Tensor, index: np.ndarray, sign: np.ndarray) -> torch.Tensor:
    """(..., D) -> (..., D): ``x[..., index] * sign``."""
    if x.shape[-1] != len(index):
        raise ValueError(f"mirror of a {x.shape[-1]}-wide tensor with a {len(index)}-wide map")
    idx = torch.as_tensor(index, device=x.device)
    return x[..., idx] * torch.as_tensor(sign, dtype=x.dtype, device=x.device)


def augment_left_right(
    env, obs: TensorDict | None = None, actions: torch.Tensor | None = None
) -> tuple[TensorDict | None, torch.Tensor | None]:
    """rsl_rl ``data_augmentation_func``: each of ``obs`` (batch B) and ``actions`` (B, J)
    returned with its mirror image appended, batch 2B (originals first); None stays None.

    ``env`` is the ``RecoveryVecEnv`` (its robot names the mirror).
    """
    maps = group_mirrors(env.env.robot.name)
    out_obs = None
    if obs is not None:
        groups = {k: torch.cat([v, mirror(v, *maps[k])], dim=0) for k, v in obs.items()}
        out_obs = TensorDict(groups, batch_size=[2 * obs.batch_size[0]], device=obs.device)
    out_act = None if actions is None else torch.cat([actions, mirror(actions, *maps["actions"])], dim=0)
    return out_obs, out_act
