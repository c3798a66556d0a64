"""The scenes loomfmu ships, by name: ``loomfmu scene list|run|export NAME``."""
from __future__ import annotations

from collections.abc import Callable

from .declare import Scene


def _two_mass() -> Scene:
    from .two_mass import scene
    return scene()


#: scene name -> (factory, one-line description)
SCENES: dict[str, tuple[Callable[[], Scene], str]] = {
    "two_mass": (_two_mass, "two masses coupled by a spring-damper, split into two FMUs "
                            "(force-displacement coupling): the benchmark with an exact "
                            "co-simulation map"),
}


def load_scene(name: str) -> Scene:
    if not isinstance(name, str) or name not in SCENES:
        raise ValueError(f"scene = {name!r:.60}; allowed: {', '.join(sorted(SCENES))}")
    return SCENES[name][0]()
