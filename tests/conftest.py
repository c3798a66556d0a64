"""Shared fixtures: FMUs are built once per test session into a temporary dir.

Every build of the suite is for x86-64 Linux only (``LOOMFMU_PLATFORMS``,
inherited by the ``loomfmu`` commands the tests run), unless a test asks for
other platforms with ``build_fmu(..., platforms=...)``: cross-compiling is
the subject of tests/test_platforms.py only, and would otherwise triple the
suite's compile time. Likewise the FMI-LS-REF reference result is left out of
the suite's builds (``LOOMFMU_LS_REF=off``; the first reference of a variant
can take a minute) except where tests/test_ls_ref.py asks for it.
"""
from __future__ import annotations

import gc
import os

import pytest
from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

from loomfmu import build_fmu, load_model
from loomfmu.verification.fmpy_logger import restore_fmpy_proxy

os.environ.setdefault("LOOMFMU_PLATFORMS", "linux64")
os.environ.setdefault("LOOMFMU_LS_REF", "off")


@pytest.fixture(scope="session")
def dist(tmp_path_factory):
    return tmp_path_factory.mktemp("dist")


@pytest.fixture(scope="session")
def heald_frame_fmu(dist):
    result = build_fmu(load_model("heald_frame"), out_dir=dist)
    return result


class Slave:
    """An FMU instance driven call by call, with its log captured."""

    def __init__(self, fmu_path, name="instance"):
        self.md = read_model_description(str(fmu_path))
        self.unzipdir = extract(str(fmu_path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.log: list[tuple[int, str, str]] = []

        def logger(env, instance, status, category, message):
            self.log.append((status, category.decode(), message.decode()))

        self._cb = fmi2CallbackFunctions()
        self._cb.logger = fmi2CallbackLoggerTYPE(logger)
        self._cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzipdir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier,
                             instanceName=name)
        self.fmu.instantiate(callbacks=self._cb)

    def set(self, **values):
        for name, value in values.items():
            if name == "solver":
                self.fmu.setInteger([self.vr[name]], [int(value)])
            else:
                self.fmu.setReal([self.vr[name]], [float(value)])

    def get(self, *names):
        return self.fmu.getReal([self.vr[n] for n in names])

    def start(self, t0=0.0, **values):
        self.fmu.setupExperiment(startTime=t0)
        self.set(**values)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()


@pytest.fixture(autouse=True)
def _fmpy_logger_proxy_restored():
    """Tests that call fmpy.simulate_fmu(..., logger=f) on an FMI 2 FMU leave
    FMPy's global logger proxy pointing at f's thunk, freed with the instance:
    a later FMU on FMPy's default callbacks that logs would call freed memory
    (see loomfmu.verification.fmpy_logger). Point it back at FMPy's printer after each test."""
    yield
    restore_fmpy_proxy()


@pytest.fixture(autouse=True, scope="module")
def _garbage_collected_per_module():
    """Collect the garbage after each test file: a file, pipe or socket a
    test leaves open then fails that file's last test (filterwarnings
    "error" turns the ResourceWarning into an error), not whichever test of
    another file the collector happens to run in."""
    yield
    gc.collect()


@pytest.fixture
def slave_factory():
    made = []

    def make(path, name="instance"):
        s = Slave(path, name)
        made.append(s)
        return s

    yield make
    for s in made:
        try:
            s.fmu.freeInstance()
        except Exception:
            pass


@pytest.fixture(scope="session")
def heald_frame_planar_fmu(dist):
    return build_fmu(load_model("heald_frame_planar"), out_dir=dist)


@pytest.fixture(scope="session")
def heald_frame_rigid_fmu(dist):
    return build_fmu(load_model("heald_frame_rigid"), out_dir=dist)


@pytest.fixture(scope="session")
def spindle_fmu(dist):
    return build_fmu(load_model("spindle"), out_dir=dist)


@pytest.fixture(scope="session")
def spindle_modal_fmu(dist):
    return build_fmu(load_model("spindle_modal"), out_dir=dist)


# -- the slow marker ---------------------------------------------------------
# Tests that build FMUs (gcc on generated C: seconds to minutes each) carry
# @pytest.mark.slow, so that `pytest -m "not slow"` is a quick loop.  The
# builder's compile step is watched: a test that is not marked slow and
# builds an FMU (itself or through a fixture it uses) fails, naming the marker.

_current_item = None


def pytest_runtest_setup(item):
    global _current_item
    _current_item = item


def pytest_runtest_teardown(item, nextitem):
    global _current_item
    _current_item = None


def _watch_builds():
    from loomfmu.fmu import builder, compile_cache

    compile_jobs = compile_cache.compile_jobs

    def watched(*args, **kwargs):
        item = _current_item
        if item is not None and item.get_closest_marker("slow") is None:
            pytest.fail(f"{item.nodeid} builds an FMU but is not marked slow: add "
                        "@pytest.mark.slow (or pytestmark = pytest.mark.slow to its module)",
                        pytrace=False)
        return compile_jobs(*args, **kwargs)

    # the builder's own reference and the module's (compile_objects calls it);
    # builds in a subprocess (`loomfmu build` run by a test) are not seen: such
    # tests carry the marker by hand (the command-line tests are slow as a module)
    builder.compile_jobs = compile_cache.compile_jobs = watched


_watch_builds()
