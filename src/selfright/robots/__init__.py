"""Robot specs by name. Add a robot by writing a module like ``a1.py`` and registering it."""

from __future__ import annotations

from selfright.robots.a1 import A1
from selfright.robots.spec import RobotSpec

ROBOTS: dict[str, RobotSpec] = {A1.name: A1}


def get_robot(name: str) -> RobotSpec:
    """Robot spec by registry name; ``ValueError`` names the known ones."""
    if name not in ROBOTS:
        raise ValueError(f"unknown robot {name!r}; known: {', '.join(sorted(ROBOTS))}")
    return ROBOTS[name]


__all__ = ["ROBOTS", "RobotSpec", "get_robot"]
