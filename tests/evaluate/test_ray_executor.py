"""The Ray executor: the rows of the local executor, resumable, and no episode lost when a
worker dies. The Ray tests start a two-CPU Ray head on loopback (slow tier; skipped without
``pip install -e ".[ray]"``); the message without Ray is checked in the fast tier."""

import os
import sys
from pathlib import Path

import pytest

from selfright.config import BenchmarkConfig, GoalConfig, SimConfig
from selfright.evaluate.runner import evaluate_grid
from selfright.policies.base import Policy
from selfright.policies.registry import make_policy

CFG = BenchmarkConfig(goal=GoalConfig(episode_s=1.0, hold_s=0.2), sim=SimConfig(threads=1))
HERE = Path(__file__).resolve().parent


def run(out: Path, policy="random", episodes=2, executor="ray", policy_obj=None) -> bytes:
    evaluate_grid(policy_obj or make_policy(policy, CFG), policy_name=policy, grid="tiny", episodes=episodes, seed=0,
                  out_dir=out, cfg=CFG, progress=False, executor=executor)
    return (out / "episodes.csv").read_bytes()


def test_without_ray_the_executor_says_how_to_install_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray fails
    with pytest.raises(RuntimeError, match=r'pip install -e "\.\[ray\]"'):
        run(tmp_path, executor="ray")


@pytest.fixture(scope="module")
def ray_head():
    ray = pytest.importorskip("ray")
    # Workers import this module (the dying policy) by name.
    path = os.environ.get("PYTHONPATH", "")
    os.environ["PYTHONPATH"] = os.pathsep.join(p for p in (str(HERE), path) if p)
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, _node_ip_address="127.0.0.1")
    try:
        yield ray
    finally:
        ray.shutdown()
        os.environ["PYTHONPATH"] = path


@pytest.fixture(scope="module")
def local(tmp_path_factory) -> bytes:
    return run(tmp_path_factory.mktemp("local"), executor="local")


@pytest.mark.slow
def test_ray_rows_are_the_local_rows(ray_head, local, tmp_path):
    assert run(tmp_path, executor="ray") == local


@pytest.mark.slow
def test_a_ray_run_resumes_without_recomputing_or_duplicating(ray_head, local, tmp_path):
    run(tmp_path)
    csv = tmp_path / "episodes.csv"
    lines = csv.read_text().splitlines(keepends=True)
    csv.write_text("".join(lines[:1] + lines[6:0:-2]) + lines[7][:9])  # an interrupted run: 3 rows in any order, a torn one
    res = evaluate_grid(make_policy("random", CFG), policy_name="random", grid="tiny", episodes=2, seed=0, out_dir=tmp_path,
                        cfg=CFG, progress=False, executor="ray")
    assert res.episodes_run == 5 and csv.read_bytes() == local
    res = evaluate_grid(make_policy("random", CFG), policy_name="random", grid="tiny", episodes=2, seed=0,
                        out_dir=tmp_path, cfg=CFG, progress=False, executor="ray")
    assert res.episodes_run == 0 and csv.read_bytes() == local


class DiesOnce(Policy):
    """``inner``, except that the first worker to act kills its own process (once per marker file)."""

    def __init__(self, inner: Policy, marker: Path):
        self.inner, self.marker = inner, marker
        self.groups, self.digest = inner.groups, inner.digest

    def reset(self, ids, seeds=None):
        self.inner.reset(ids, seeds)

    def act(self, obs, ids, cells):
        if not self.marker.exists():
            self.marker.write_text("died")
            os._exit(1)
        return self.inner.act(obs, ids, cells)


@pytest.mark.slow
def test_a_task_whose_worker_dies_is_retried_and_no_episode_is_lost(ray_head, local, tmp_path):
    marker = tmp_path / "died"
    out = tmp_path / "out"
    assert run(out, policy_obj=DiesOnce(make_policy("random", CFG), marker)) == local
    assert marker.exists()
