"""Does a rough policy do better on the tiles it trained on than on fresh ones of the same roughness?

The ``rough`` context trains on ``EpisodeConfig.rough_variants`` (8) fixed tiles, one noise
draw per extent (``selfright.train.contexts``). A policy that sees a height scan could learn
those few tiles rather than rough ground. This script runs ``selfright evaluate --grid rough``
with each cell's tile swapped for a training tile (``--tiles train``: the training variant whose
extent is nearest the cell's level, built with the training seed exactly as training built it)
or for a fresh draw of the same extent (``--tiles fresh``: variant ``1000 + seed``, never trained
on). The falls are the benchmark's for the cell and ``--seed``, so the two runs are paired.

    python scripts/train_tiles.py --policy rough-dc-teacher --tiles train --out /tmp/tt/train
    python scripts/train_tiles.py --policy rough-dc-teacher --tiles fresh --seed 0 --out /tmp/tt/f0
    python scripts/seed_table.py /tmp/tt/train            # then compare the rates
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np
import tyro

from selfright import cli
from selfright.env.world import World, build_world
from selfright.evaluate.runner import context_config
from selfright.terrain import Cell
from selfright.train.config import EpisodeConfig
from selfright.train.contexts import training_cells


@dataclass(frozen=True)
class Args:
    policy: str = "rough"
    """Any name ``selfright evaluate --policy`` takes."""
    tiles: Literal["train", "fresh"] = "train"
    """train = the training run's own tiles; fresh = new draws of the same extents."""
    out: Path = Path("results/train_tiles")
    """Results directory (as ``selfright evaluate --out``)."""
    seed: int = 0
    """Falls (and, with --tiles fresh, the tile variant 1000 + seed)."""
    train_seed: int = 0
    """The training run's ``--seed`` (its tiles depend on it)."""
    rough_variants: int = 8
    """The training run's ``--train.episode.rough-variants`` (its tiles depend on it)."""
    rough_min_extent_m: float = 0.0
    """The training run's ``--train.episode.rough-min-extent-m`` (its tiles depend on it)."""
    episodes: int = 64
    """Episodes per cell."""
    threads: int = 1
    """Physics threads."""


def main(a: Args) -> None:
    ev = cli.Evaluate(policy=a.policy, grid="rough", episodes=a.episodes, seed=a.seed, threads=a.threads,
                      out=a.out, plots=False, progress=False)
    cfg = ev.bench_config()
    ctx = context_config(cfg)
    train = training_cells("rough", cfg, EpisodeConfig(rough_variants=a.rough_variants, rough_min_extent_m=a.rough_min_extent_m))
    extents = np.array([c.roughness_extent_m for c in train])

    def swapped(cell: Cell) -> World:
        k = int(np.argmin(np.abs(extents - cell.roughness_extent_m)))
        tile_variant = k if a.tiles == "train" else 1000 + a.seed
        world = build_world(train[k], cfg, ctx, a.train_seed, variant=tile_variant)
        print(f"level {cell.roughness_level} ({cell.roughness_extent_m:.3f} m) -> training extent "
              f"{train[k].roughness_extent_m:.3f} m, {a.tiles} tile", file=sys.stderr)
        return replace(world, cell=cell)  # the benchmark's cell (its falls and row labels), the swapped tile

    label = f"{a.tiles} tiles of a rough run with {a.rough_variants} variants, training seed {a.train_seed}"
    cli.run_evaluate(ev, world_for=swapped, worlds_label=label)


if __name__ == "__main__":
    main(tyro.cli(Args))
