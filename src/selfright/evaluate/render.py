"""Render a recorded episode (``selfright replay``'s folder) offscreen: ``episode.gif`` (a
camera following the trunk, a green frame while the robot is in the goal set) and
``filmstrip.png`` (a few frames side by side, with their times).

Reads only ``scene.xml``, ``trajectory.npz`` and ``trace.csv``. Needs an OpenGL context
without a window: run it as its own process so ``MUJOCO_GL`` can be set before MuJoCo loads
(``selfright replay`` does this, with ``MUJOCO_GL=egl`` unless you set it)::

    MUJOCO_GL=egl python -m selfright.evaluate.render results/replay_flat_3
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro

GOAL_RGB = (40, 200, 60)
"""Colour of the frame drawn around images whose state is in the goal set."""


@dataclass(frozen=True)
class RenderArgs:
    """Render a replay folder to episode.gif and filmstrip.png."""

    folder: tyro.conf.Positional[Path]
    """Folder written by ``selfright replay``."""
    width: int = 320
    """Image width (pixels)."""
    height: int = 240
    """Image height (pixels)."""
    fps: float = 25.0
    """Frames per second of the GIF (plays in real time; at most the 50 Hz of the record)."""
    frames: int = 6
    """Frames in the filmstrip."""
    distance_m: float = 1.8
    """Camera distance from the trunk (m)."""
    azimuth_deg: float = 135.0
    """Camera azimuth (degrees, MuJoCo's convention)."""
    elevation_deg: float = -20.0
    """Camera elevation (degrees; negative looks down)."""


def _in_goal(folder: Path, n: int) -> np.ndarray:
    with open(folder / "trace.csv", newline="") as f:
        flags = np.array([int(r["in_goal"]) for r in csv.DictReader(f)], dtype=bool)
    if len(flags) != n:
        raise ValueError(f"{folder}: trace.csv has {len(flags)} rows for {n} states; re-run selfright replay")
    return flags


def render_frames(a: RenderArgs, indices: np.ndarray) -> dict[int, np.ndarray]:
    """Images (height, width, 3) of the recorded states ``indices``, by index."""
    import mujoco

    from selfright.sim.batch import STATE_SPEC

    folder = Path(a.folder)
    states = np.load(folder / "trajectory.npz")["states"]
    model = mujoco.MjModel.from_xml_string((folder / "scene.xml").read_text())
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, a.width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, a.height)
    data = mujoco.MjData(model)
    goal = _in_goal(folder, len(states))
    trunk = model.body("trunk").id
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.distance, cam.azimuth, cam.elevation = a.distance_m, a.azimuth_deg, a.elevation_deg
    wanted = {int(i) for i in indices}
    lookat: np.ndarray | None = None
    images: dict[int, np.ndarray] = {}
    with mujoco.Renderer(model, a.height, a.width) as renderer:
        for i in range(max(wanted) + 1):
            mujoco.mj_setState(model, data, states[i], STATE_SPEC)
            mujoco.mj_forward(model, data)
            # Follow the trunk smoothly (every state, so the path is the same whatever is drawn).
            pos = data.xpos[trunk]
            lookat = pos.copy() if lookat is None else lookat + 0.15 * (pos - lookat)
            if i not in wanted:
                continue
            cam.lookat[:] = lookat
            renderer.update_scene(data, cam)
            img = renderer.render().copy()
            if goal[i]:
                img[:4], img[-4:], img[:, :4], img[:, -4:] = GOAL_RGB, GOAL_RGB, GOAL_RGB, GOAL_RGB
            images[i] = img
    return images


def write_gif(folder: Path, images: list[np.ndarray], frame_s: float) -> Path:
    """``episode.gif`` of ``images``, each shown ``frame_s`` seconds."""
    from PIL import Image

    frames = [Image.fromarray(im).quantize(colors=128) for im in images]
    path = Path(folder) / "episode.gif"
    frames[0].save(path, save_all=True, append_images=frames[1:], duration=int(round(1000 * frame_s)), loop=0)
    return path


def write_filmstrip(a: RenderArgs, images: list[np.ndarray], times: np.ndarray) -> Path:
    """``filmstrip.png``: ``images`` side by side, titled with their ``times`` (s)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(images), figsize=(2.2 * len(images), 2.2 * a.height / a.width + 0.35), squeeze=False)
    for ax, im, t in zip(axes[0], images, times):
        ax.imshow(im)
        ax.set_title(f"t = {t:.1f} s", fontsize=9)
        ax.axis("off")
    fig.tight_layout(pad=0.3)
    path = Path(a.folder) / "filmstrip.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(a: RenderArgs) -> None:
    if not (Path(a.folder) / "trajectory.npz").exists():
        raise SystemExit(f"render: {a.folder} has no trajectory.npz; write it with selfright replay --out {a.folder}")
    if a.width < 16 or a.height < 16 or a.fps <= 0 or a.frames < 1:
        raise SystemExit("render: --width/--height must be >= 16, --fps > 0, --frames >= 1")
    rec = np.load(Path(a.folder) / "trajectory.npz")
    n, dt, t_s = len(rec["states"]), float(rec["control_dt_s"]), rec["t_s"]
    # The GIF: every state at most ``fps`` times a second, in real time. The filmstrip:
    # ``frames`` evenly spaced states, first and last included. One rendering pass for both.
    stride = max(1, int(round(1.0 / (a.fps * dt))))
    gif_idx = np.arange(0, n, stride)
    strip_idx = np.unique(np.linspace(0, n - 1, a.frames).round().astype(int))
    images = render_frames(a, np.union1d(gif_idx, strip_idx))
    gif = write_gif(a.folder, [images[i] for i in gif_idx], stride * dt)
    strip = write_filmstrip(a, [images[i] for i in strip_idx], t_s[strip_idx])
    for path in (gif, strip):
        print(f"wrote {path}")


if __name__ == "__main__":
    main(tyro.cli(RenderArgs))
