"""The yaw study: heading geometry, the turn of a settled fall, determinism and resume."""

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from selfright.config import BenchmarkConfig, GoalConfig, SimConfig
from selfright.env.world import build_world
from selfright.evaluate.results import ResultsError
from selfright.evaluate.runner import context_config
from selfright.evaluate.yaw import (
    DIRECTION_DEG, HEADING_WINDOW_DEG, HeadingEnv, angle_diff_deg, draw_heading, heading_deg, run_yaw_study,
    slope_cell, slope_frame, travel, turn_state,
)
from selfright.evaluate.yaw_results import read_yaw_episodes
from selfright.policies.registry import make_policy
from selfright.sim.batch import STATE_SPEC

# Short episodes keep the tier fast; the logic is the same at 10 s.
CFG = BenchmarkConfig(goal=GoalConfig(episode_s=1.0, hold_s=0.2), sim=SimConfig(threads=1))


def run(out: Path, episodes: int = 2, seed: int = 0, slopes=(15.0,)):
    return run_yaw_study(make_policy("open-loop", CFG), policy_name="open-loop", slopes_deg=slopes, episodes=episodes,
                         seed=seed, out_dir=out, cfg=CFG, progress=False)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("yaw")
    run(out)
    return out


def test_slope_frame_is_orthonormal_and_downhill_goes_down():
    n, down, left = slope_frame(100 * math.tan(math.radians(18)))
    basis = np.stack([n, down, left])
    assert np.allclose(basis @ basis.T, np.eye(3))
    assert down[2] < 0 and n[2] > 0 and math.isclose(math.degrees(math.asin(-down[2])), 18)
    assert heading_deg(down[None], 100 * math.tan(math.radians(18)))[0] == pytest.approx(0)
    assert abs(heading_deg(-down[None], 100 * math.tan(math.radians(18)))[0]) == pytest.approx(180)


def test_travel_labels_follow_the_fall_line():
    pct = 30.0
    assert travel(np.array([-0.5, 0.0]), pct)[0] == "down"
    assert travel(np.array([0.5, 0.1]), pct)[0] == "up"
    assert travel(np.array([0.05, -0.5]), pct)[0] == "cross"
    assert travel(np.array([0.01, 0.01]), pct)[0] == "none"
    label, deg, downhill = travel(np.array([-1.0, 0.0]), pct)
    assert deg == pytest.approx(0) and downhill == pytest.approx(math.hypot(1.0, 0.3))


def test_headings_are_drawn_inside_their_window():
    rng = np.random.default_rng(0)
    for d in ("down", "up", "cross"):
        for _ in range(200):
            h = draw_heading(d, rng)
            centre = min((DIRECTION_DEG[d], -DIRECTION_DEG[d]), key=lambda c: abs(angle_diff_deg(h, c)))
            assert abs(angle_diff_deg(h, centre)) <= HEADING_WINDOW_DEG


def test_turning_a_settled_fall_keeps_every_geom_at_its_distance_to_the_slope():
    cell = slope_cell(18.0)
    world = build_world(cell, CFG, context_config(CFG), 0)
    env = HeadingEnv(CFG, [world], 1)
    starts = env.settle(np.array([0]), [np.random.default_rng(3)], [world.model])
    normal, _, _ = slope_frame(cell.slope_pct)
    m, d = world.model, mujoco.MjData(world.model)

    def geoms(state):
        mujoco.mj_setState(m, d, state, STATE_SPEC)
        mujoco.mj_forward(m, d)
        return d.geom_xpos.copy(), d.xmat[m.body("trunk").id].reshape(3, 3)[:, 0].copy()

    before, _ = geoms(starts.state[0])
    for target in (0.0, 100.0, -170.0):
        after, forward = geoms(turn_state(starts.state[0], env.sl, cell.slope_pct, target))
        assert heading_deg(forward[None], cell.slope_pct)[0] == pytest.approx(target, abs=1e-6)
        assert np.allclose(before @ normal, after @ normal, atol=1e-9)  # the plane passes through the origin
    env.close()


def test_heading_window_is_met_at_policy_start(reference):
    rows = read_yaw_episodes(reference / "episodes.csv")
    assert len(rows) == 3 * 2
    for r in rows:
        centre = DIRECTION_DEG[r["direction"]]
        off = min(abs(angle_diff_deg(r["heading_deg"], c)) for c in (centre, -centre))
        assert off <= HEADING_WINDOW_DEG + 1e-3, r
    # One fall per episode index, turned to each heading (a paired design).
    assert len({r["seed"] for r in rows if r["episode"] == 0}) == 1


def test_same_seed_same_table_and_resume_gives_identical_files(reference, tmp_path):
    again = tmp_path / "again"
    run(again)
    for name in ("yaw.csv", "episodes.csv"):
        assert (again / name).read_bytes() == (reference / name).read_bytes()
    header, *lines = (reference / "episodes.csv").read_text().splitlines()
    resumed = tmp_path / "resumed"
    resumed.mkdir()
    (resumed / "run.json").write_bytes((reference / "run.json").read_bytes())
    (resumed / "episodes.csv").write_text("\n".join([header, *lines[:3], lines[3][:20]]) + "\n")  # killed mid-write
    res = run(resumed)
    assert res.episodes_run == 3
    for name in ("yaw.csv", "episodes.csv"):
        assert (resumed / name).read_bytes() == (reference / name).read_bytes()


def test_refuses_to_resume_another_run(reference):
    with pytest.raises(ResultsError, match="differs in"):
        run(reference, seed=1)
