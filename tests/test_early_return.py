"""Early return at events (lf_step.h; FMI 3.0 co-simulation's
earlyReturnAllowed / event mode): the step loop ends a step at the first
event it locates, and lf_handle_pending_event performs the event later.

The driver tests/c/early_return.c calls the runtime of a built FMU directly
(as a facade would) and prints every Real at each communication point, so
the step loop is tested apart from any facade: runs with early returns
(event handled by the driver, by the next step, or after a trip through the
FMU state) must follow the run without them."""
from __future__ import annotations

import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

from loomfmu import build_fmu, load_model

pytestmark = [pytest.mark.slow, pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not available")]

DRIVER = Path(__file__).parent / "c" / "early_return.c"
STRICT = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic"]


def _driver(model, out: Path) -> Path:
    """The driver linked with the sources of the FMU of `model` (a name or
    a Model; runtime files with strict warnings, CasADi's code without
    -Werror)."""
    model = load_model(model) if isinstance(model, str) else model
    fmu = build_fmu(model, out_dir=out / "fmu", validate=False).path
    src = out / "src"
    with zipfile.ZipFile(fmu) as z:
        z.extractall(src, [n for n in z.namelist() if n.startswith("sources/")])
    src = src / "sources"
    runtime = [str(p) for p in sorted(src.glob("lf_*.c")) if not p.name.startswith("lf_fmi")]
    generated = [p for p in src.glob("*.c") if not p.name.startswith("lf_")]
    objs = []
    for p in generated:
        obj = out / (p.stem + ".o")
        cmd = ["gcc", "-std=c99", "-O2", "-c", str(p), "-o", str(obj)]
        subprocess.run(cmd, check=True, capture_output=True)
        objs.append(str(obj))
    exe = out / "early_return"
    cmd = ["gcc", *STRICT, f"-I{src}", str(DRIVER), *runtime, *objs, "-lm", "-o", str(exe)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return exe


class Run:
    def __init__(self, exe: Path, mode: str, t_end: float, h: float, *values: str):
        proc = subprocess.run([str(exe), mode, repr(t_end), repr(h), *values],
                              capture_output=True, text=True, timeout=120)
        assert proc.returncode == 0, proc.stderr[-2000:]
        lines = proc.stdout.splitlines()
        self.points = np.array([l.split()[1:] for l in lines if l.startswith("t ")], float)
        self.early = [(float(l.split()[1]), int(l.split()[2]), int(l.split()[3]))
                      for l in lines if l.startswith("early ")]
        self.steps = [int(v) for v in lines[-1].split()[1:]]
        self.events = [float(t) for t in
                       re.findall(r"t = (\S+): event \S+, solver restarted", proc.stderr)]
        self.log = proc.stderr
        self.settled = [[float(v) for v in l.split()[1:]] for l in lines
                        if l.startswith("settled ")]


@pytest.fixture(scope="module")
def backrest_driver(tmp_path_factory):
    return _driver("backrest", tmp_path_factory.mktemp("early_backrest"))


@pytest.fixture(scope="module")
def drive_driver(tmp_path_factory):
    return _driver("drive", tmp_path_factory.mktemp("early_drive"))


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.nanmax(np.abs(a - b) / np.maximum(1.0, np.abs(b))))


@pytest.mark.parametrize("solver", [1, 2, 3, 4])
@pytest.mark.parametrize("mode", ["early", "lazy", "state"])
def test_backrest_early_returns_follow_the_in_step_trajectory(backrest_driver, solver, mode):
    """Backrest stick-slip (16 switches in 1 s): with early return every
    switch ends a step at its event time, and the run then follows the one
    whose events are handled inside the steps: same switch times, same
    steps, the same values at every communication point to rounding (the
    step after an early return ends at t_event + (t_next - t_event), which
    can miss t_next by an ulp)."""
    ref = Run(backrest_driver, "plain", 1.0, 0.01, f"solver={solver}")
    run = Run(backrest_driver, mode, 1.0, 0.01, f"solver={solver}")
    assert len(ref.events) > 10 and ref.steps[3] == len(ref.events)
    assert len(run.early) == len(ref.events)
    assert [t for t, _, _ in run.early] == pytest.approx(ref.events, abs=1e-10)
    assert run.events == pytest.approx(ref.events, abs=1e-10)
    # every early return ended inside its communication step, before its end
    grid = np.round(np.array([t for t, _, _ in run.early]) / 0.01)
    assert all(abs(t - g * 0.01) > 1e-12 for (t, _, _), g in zip(run.early, grid))
    if mode != "lazy":  # the driver handled them: a mode changed at each
        assert all(changed == 1 for _, _, changed in run.early)
    assert run.steps == ref.steps
    assert run.points.shape == ref.points.shape
    assert _rel(run.points, ref.points) < 1e-8


def test_early_return_without_events_changes_nothing(drive_driver):
    """The drive (delays, no events): with stop_at_events set the run is
    bit for bit the run without it."""
    ref = Run(drive_driver, "plain", 0.3, 0.01)
    run = Run(drive_driver, "early", 0.3, 0.01)
    assert ref.steps[0] > 0 and run.early == [] and ref.events == []
    assert run.steps == ref.steps
    assert np.array_equal(run.points, ref.points, equal_nan=True)


def test_corrupt_pending_event_in_the_fmu_state_is_refused(backrest_driver):
    """An FMU state written at an early return, with one field of its
    pending event corrupted and the checksum sealed again (indicator out of
    range, none while pending, flag 2, t_event off the state's time, the
    point before it not finite): every one is refused."""
    proc = subprocess.run([str(backrest_driver), "corrupt", "0.2", "0.01"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    counts = re.findall(r"refused (\d+) of 6", proc.stdout)
    assert len(counts) >= 3 and all(c == "6" for c in counts), proc.stdout
    assert "FMU state refused: event_index" in proc.stderr
    assert "FMU state refused: t_event" in proc.stderr


def test_inputs_set_between_steps_settle_the_modes_at_once(backrest_driver):
    """An input set between steps (backrest letoff 0 -> 2 mm at t = 0.01,
    both pivots stuck) makes stuck joints break away; lf_settle_inputs
    chooses the modes at once, as the next step's start does, so that the
    outputs and modes read before the next step are those of the new input
    (they were those of the old one).  The mode changes are those the run
    without it logs at the next step's start, and the trajectory is the
    same (to rounding: Newton starts from another point)."""
    args = ("@0.01:letoff=0.002",)
    ref = Run(backrest_driver, "plain", 0.2, 0.01, *args)
    run = Run(backrest_driver, "settle", 0.2, 0.01, *args)
    changes = re.findall(r"t = 0\.01: mode (\S+): (\S+) -> (\S+)", ref.log)
    assert len(changes) >= 1 and changes == re.findall(r"t = 0\.01: mode (\S+): (\S+) -> (\S+)",
                                                      run.log)
    assert len(run.settled) == 1
    modes = run.settled[0][-2:]  # the backrest's two modes, O1 and O2, after the Reals
    final = {name: float(new) for name, _, new in changes}
    assert [final.get("mode_O1", 0.0), final.get("mode_O2", 0.0)] == modes
    assert run.events == pytest.approx(ref.events, abs=1e-10)
    assert run.points.shape == ref.points.shape and _rel(run.points, ref.points) < 1e-9
