"""Check replayed successes against the goal set's height with MuJoCo alone: for each replay folder
(``selfright replay --out DIR``), load ``scene.xml``, set every recorded physics state of
``trajectory.npz`` (time, qpos, qvel) and measure the trunk origin's height above the mean of the
four feet's lowest points (foot sphere centre minus radius) along gravity (world z), over the last
``hold_s`` of the record. No selfright code computes the height here.

    for e in 0 1 2; do selfright replay --policy flat --grid flat --seed 1000 --episode $e --no-video --out replays/flat_$e; done
    python scripts/check_replays.py replays/flat_* [--bar-m 0.32]

Prints one line per replay and exits 1 if a success dips under the bar during its hold.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import mujoco
import numpy as np

FEET = ("FR_foot", "FL_foot", "RR_foot", "RL_foot")
"""The A1 MJCF's foot spheres (src/selfright/robots/a1.py)."""


def hold_heights(folder: Path) -> tuple[dict, np.ndarray]:
    """The replay's ``replay.json`` and the trunk's height over its feet (m) at each recorded
    state of its last ``hold_s``."""
    meta = json.loads((folder / "replay.json").read_text())
    rec = np.load(folder / "trajectory.npz")
    model = mujoco.MjModel.from_xml_path(str(folder / "scene.xml"))
    data = mujoco.MjData(model)
    feet = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name) for name in FEET]
    trunk = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "trunk")
    hold = int(round(meta["hold_s"] / float(rec["control_dt_s"])))
    heights = []
    for state in rec["states"][-hold:]:
        data.qpos[:] = state[1 : 1 + model.nq]  # mjSTATE_PHYSICS: time, qpos, qvel
        mujoco.mj_kinematics(model, data)
        lowest = [data.geom_xpos[g][2] - model.geom_size[g][0] for g in feet]
        heights.append(data.xpos[trunk][2] - float(np.mean(lowest)))
    return meta, np.asarray(heights)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("folders", type=Path, nargs="+", help="replay folders (selfright replay --out)")
    p.add_argument("--bar-m", type=float, default=0.32, help="the goal set's height bar (m), 0.8 x the A1's 0.4 m legs")
    a = p.parse_args(argv)
    bad = 0
    for folder in a.folders:
        meta, h = hold_heights(folder)
        verdict = "-" if not meta["success"] else ("ok" if h.min() >= a.bar_m else "UNDER THE BAR")
        bad += verdict == "UNDER THE BAR"
        print(f"{folder}: success={meta['success']} lowest over the last {meta['hold_s']:g} s "
              f"{h.min():.4f} m, highest {h.max():.4f} m  {verdict}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
