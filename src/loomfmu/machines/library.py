"""The scenes loomfmu ships, by name: ``loomfmu scene list|run|export NAME``."""
from __future__ import annotations

from collections.abc import Callable

from loomfmu.scene.declare import Scene


def _two_mass() -> Scene:
    from loomfmu.machines.two_mass import scene
    return scene()


def _spinning() -> Scene:
    from loomfmu.machines.spinning import scene
    return scene()


def _loom() -> Scene:
    from loomfmu.machines.loom import scene
    return scene()


#: scene name -> (factory, one-line description)
SCENES: dict[str, tuple[Callable[[], Scene], str]] = {
    "two_mass": (_two_mass, "two masses coupled by a spring-damper, split into two FMUs "
                            "(force-displacement coupling): the benchmark with an exact "
                            "co-simulation map"),
    "spinning": (_spinning, "spinning position: the spindle drive with its layer cam "
                            "(compensated) feeding the spindle rotor (full FE model), which "
                            "starts on its periodic unbalance solution; one layer cycle"),
    "loom": (_loom, "loom: main shaft, two heald frames in opposition (plain weave) "
                    "stretching the warp, the backrest taking it up and returning the "
                    "tension to the frames"),
}


def load_scene(name: str) -> Scene:
    if not isinstance(name, str) or name not in SCENES:
        raise ValueError(f"scene = {name!r:.60}; allowed: {', '.join(sorted(SCENES))}")
    return SCENES[name][0]()
