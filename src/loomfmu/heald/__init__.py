"""Analysis around the heald-frame models (seeds 000 and 002).

* :mod:`loomfmu.mechanics.heald_presets` (re-exported here): seed 002's
  tables 1-2 as named parameter sets (``preset_values("STB-180 Elitex")``);
* :mod:`.hinge`: the seed's kinetostatic hinge load over the eight phases;
* :mod:`.claims`: natural frequencies, the seed's claims, the fidelity
  comparison and the slat-section design function;
* the derivation's named quantities: ``models/heald_derivation.py``;
* :mod:`.tension_input`: the warp tension as an input (build option
  ``warp_tension="input"``): lockstep with the geometry tension, the
  defaults shared with the backrest, frames in opposition;

    loomfmu heald claims     # docs/guides/heald_claims.md
    loomfmu heald fidelity   # docs/guides/heald_fidelity.md
    loomfmu heald design --gap 0.004
    loomfmu heald tension-input   # docs/guides/heald_tension_input.md

May import: every layer below the mechanism packages; not another
mechanism's package.
"""
from loomfmu.heald.hinge import PHASES, hinge_load_kinetostatic, hinge_load_phases
from loomfmu.mechanics.heald_presets import MAKERS, WIDTHS_CM, YARNS, preset_names, preset_values

__all__ = ["PHASES", "hinge_load_kinetostatic", "hinge_load_phases", "MAKERS",
           "WIDTHS_CM", "YARNS", "preset_names", "preset_values"]
