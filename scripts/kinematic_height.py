"""How well the leg-kinematics trunk height (``selfright.robots.kinematics.KinematicHeight``,
sensors only) tracks the true height above the ground beneath the trunk (the teacher
observation's), while a policy runs on a grid: the error over every upright step, and each
episode's last reading, true and estimated, for successes and failures apart.

    python scripts/kinematic_height.py --policy flat --grid flat --episodes 64 --seed 0
"""

from __future__ import annotations

import csv
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
import tyro

from selfright.config import BenchmarkConfig
from selfright.env.observations import joint_pos_columns, teacher_height_column
from selfright.evaluate.runner import evaluate_grid
from selfright.policies.base import Policy
from selfright.policies.registry import make_policy
from selfright.robots import get_robot
from selfright.robots.kinematics import KinematicHeight

UPRIGHT_UP_Z = 0.8
"""An upright step: the trunk's up axis within about 37° of world z."""


@dataclass(frozen=True)
class Args:
    policy: str = "flat"
    grid: str = "flat"
    episodes: int = 64
    seed: int = 0


class Probe(Policy):
    """``inner`` unchanged; records (episode, true height, estimate, up_z) at every step."""

    def __init__(self, inner: Policy, robot_name: str):
        robot = get_robot(robot_name)
        self.inner, self.kh = inner, KinematicHeight(robot)
        self.groups = tuple(sorted(set(inner.groups) | {"student", "teacher"}))
        self.action_mapping, self.name, self.digest = inner.action_mapping, inner.name, inner.digest
        self.nominal = torch.as_tensor(robot.nominal_pose, dtype=torch.float32)
        self.height, self.q = teacher_height_column(robot.num_joints), joint_pos_columns(robot.num_joints)
        self.rows: list[tuple[int, float, float, float]] = []

    def reset(self, ids, seeds=None):
        self.inner.reset(ids, seeds)

    def act(self, obs, ids, contexts):
        s = obs["student"]
        est = self.kh(s[:, 0:3], s[:, self.q] + self.nominal)
        for i, e in enumerate(ids):
            self.rows.append((int(e), float(obs["teacher"][i, self.height]), float(est[i]), float(-s[i, 2])))
        return self.inner.act({g: v for g, v in obs.items() if g in self.inner.groups}, ids, contexts)


def main(a: Args) -> None:
    cfg = BenchmarkConfig()
    probe = Probe(make_policy(a.policy, cfg), cfg.robot.name)
    with tempfile.TemporaryDirectory() as tmp:
        evaluate_grid(probe, policy_name=a.policy, grid=a.grid, episodes=a.episodes, seed=a.seed,
                      out_dir=Path(tmp), cfg=cfg, progress=False)
        with (Path(tmp) / "episodes.csv").open() as fh:
            success = {int(r["episode"]): r["success"] == "1" for r in csv.DictReader(fh)}
    r = np.array(probe.rows)
    up = r[r[:, 3] > UPRIGHT_UP_Z]
    if not len(up):
        raise SystemExit(f"kinematic_height: {a.policy} was never upright on {a.grid} [seed {a.seed}]")
    err = up[:, 2] - up[:, 1]
    print(f"{a.policy} on {a.grid} [seed {a.seed}]: estimate - true over {len(up)} upright steps: "
          f"mean {err.mean():+.4f} m, p5 {np.percentile(err, 5):+.4f}, p95 {np.percentile(err, 95):+.4f}")
    last = {int(e): (t, k, u) for e, t, k, u in r}  # the last row of each episode
    for label, want in (("successes", True), ("failures", False)):
        ends = np.array([last[e] for e in sorted(last) if success.get(e) == want and last[e][2] > UPRIGHT_UP_Z])
        if len(ends):
            print(f"  {label} ending upright ({len(ends)}): true {ends[:, 0].min():.3f}-{ends[:, 0].max():.3f} m, "
                  f"estimate {ends[:, 1].min():.3f}-{ends[:, 1].max():.3f} m")


if __name__ == "__main__":
    main(tyro.cli(Args))
