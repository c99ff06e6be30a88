import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from selfright.config import FallConfig, TerrainConfig
from selfright.env.fall import SelfCollisionChecker, flip_if_upright, initial_qpos, sample_joints, sample_orientation
from selfright.robots import get_robot
from selfright.terrain import make_tile

UP = np.array([0.0, 0.0, 1.0])


def test_flip_rule_inverts_upright_and_keeps_inverted():
    upright = Rotation.from_euler("xyz", [0.2, -0.3, 1.0])
    assert upright.apply(UP)[2] > 0
    flipped = flip_if_upright(upright)
    # 180° about world y: (x, y, z) -> (-x, y, -z) of the up axis.
    u, f = upright.apply(UP), flipped.apply(UP)
    assert f == pytest.approx([-u[0], u[1], -u[2]])
    inverted = Rotation.from_euler("x", 2.5)
    assert flip_if_upright(inverted).apply(UP) == pytest.approx(inverted.apply(UP))


def test_sampled_orientations_are_never_upright_and_cover_yaw():
    rng = np.random.default_rng(0)
    rots = [sample_orientation(rng) for _ in range(500)]
    assert all(r.apply(UP)[2] <= 0 for r in rots)
    headings = np.array([r.apply([1.0, 0, 0])[:2] for r in rots])
    yaw = np.arctan2(headings[:, 1], headings[:, 0])
    assert np.histogram(yaw, bins=4, range=(-np.pi, np.pi))[0].min() > 60


def test_joint_samples_within_limits_and_collision_free():
    robot = get_robot("a1")
    checker = SelfCollisionChecker(robot)
    rng = np.random.default_rng(1)
    for _ in range(50):
        q = sample_joints(rng, robot, checker, 1000)
        assert np.all(q >= robot.joint_low) and np.all(q <= robot.joint_high)
        assert not checker.collides(q)


def test_checker_detects_a_known_self_collision():
    robot = get_robot("a1")
    checker = SelfCollisionChecker(robot)
    # Front-right and rear-right thighs pointing at each other horizontally.
    q = robot.nominal_pose.copy()
    q[1], q[2] = 1.5708, -0.95   # FR thigh points backward
    q[7], q[8] = -1.0, -0.95     # RR thigh points forward
    assert checker.collides(q)


def test_initial_state_reproducible_and_above_ground():
    robot = get_robot("a1")
    checker = SelfCollisionChecker(robot)
    tcfg = TerrainConfig()
    tile = make_tile(slope_pct=30, roughness_extent_m=0.3, size_m=tcfg.tile_size_m, resolution_m=tcfg.resolution_m,
                     noise_wavelength_m=tcfg.noise_wavelength_m, rng=np.random.default_rng(0))
    a = initial_qpos(np.random.default_rng(7), robot, checker, tile, FallConfig(), tcfg, False)
    b = initial_qpos(np.random.default_rng(7), robot, checker, tile, FallConfig(), tcfg, False)
    assert np.array_equal(a, b)
    assert a[2] - tile.height_at(a[None, :2])[0] >= 0.5 - 1e-9
    assert np.all(np.abs(a[:2]) <= 0.4 * tcfg.spawn_size_m + 1e-9)
