"""How far from left-right symmetric is a policy? Replays a grid evaluation's episodes (same
seeds, same falls as ``selfright evaluate``) and, at every control step, compares the
policy's action on the mirrored observations with the mirror of its action:

    asymmetry = mean ‖π(M o) − M π(o)‖²  /  mean ‖π(o)‖²

0 for a mirror-symmetric policy; about 1 when the mirrored action is as far off as the action
is large (e.g. a policy that always rolls to the same side). ``--train.ppo.symmetry-augmentation``
assumes a symmetric policy (docs/training.md, *Left-right symmetry*). The policy is asked
twice per step, so this is for memoryless policies (trained MLPs), not ``zero``/``open-loop``.

    python scripts/mirror_asymmetry.py --policy flat-teacher --grid flat --episodes 64
"""

from __future__ import annotations

import numpy as np
import torch
import tyro

from selfright.evaluate.runner import ReplayArgs, replay_batches, replay_env, rollout_batch
from selfright.policies.base import Policy
from selfright.policies.registry import make_policy
from selfright.train.symmetry import group_mirrors, mirror


class _MirrorProbe(Policy):
    """Acts as ``inner`` and accumulates ‖π(M o) − M π(o)‖² and ‖π(o)‖² over the steps."""

    def __init__(self, inner: Policy, robot_name: str):
        self.inner, self.groups, self.action_mapping = inner, inner.groups, inner.action_mapping
        self.maps = group_mirrors(robot_name)
        self.gap = self.power = 0.0

    def reset(self, ids, seeds=None):
        self.inner.reset(ids, seeds)

    def act(self, obs, ids, contexts):
        a = self.inner.act(obs, ids, contexts)
        mirrored = self.inner.act({k: mirror(v, *self.maps[k]) for k, v in obs.items()}, ids, contexts)
        self.gap += float((mirrored - mirror(a, *self.maps["actions"])).square().sum())
        self.power += float(a.square().sum())
        return a


def main(a: ReplayArgs) -> None:
    cfg = a.bench_config()
    probe = _MirrorProbe(make_policy(a.policy, cfg), cfg.robot.name)
    env, cells = replay_env(a, cfg)
    for k, cell in enumerate(cells):
        probe.gap = probe.power = 0.0
        for eps, seeds in replay_batches(a, cell, env.num_envs):
            with torch.no_grad():
                rollout_batch(env, probe, np.full(len(eps), k), seeds, [cell.context] * len(eps))
        print(
            f"cell slope {cell.slope_pct:g} %, roughness level {cell.roughness_level}: "
            f"asymmetry {probe.gap / max(probe.power, 1e-12):.3f} ({a.episodes} episodes)"
        )
    env.close()


if __name__ == "__main__":
    main(tyro.cli(ReplayArgs))
