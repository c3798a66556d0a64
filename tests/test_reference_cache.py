"""The scipy reference's on-disk cache: one computation serves every caller
that asks for the same reference, and nothing else."""
from __future__ import annotations

import numpy as np
import oracles
import pytest

from loomfmu import load_model
from loomfmu.verification import reference_cache
from loomfmu.verification.reference import reference


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", str(tmp_path / "objects"))
    return tmp_path / "references"


def _same(a, b):
    assert np.array_equal(a.t, b.t) and a.y.keys() == b.y.keys()
    for name in a.y:
        assert np.array_equal(a.y[name], b.y[name]), name
    assert (a.n_rhs, a.n_segments, a.switches, a.violation) == \
        (b.n_rhs, b.n_segments, b.switches, b.violation)


def test_a_second_call_is_served_bit_for_bit_from_the_cache(cache):
    model = load_model("backrest")  # events and mode switches
    first = reference(model, t_end=0.2, rtol=1e-8)
    again = reference(load_model("backrest"), t_end=0.2, rtol=1e-8)
    assert not first.cached and again.cached and first.switches
    _same(first, again)
    assert again.wall_seconds == first.wall_seconds  # the run that computed it
    assert len(list(cache.glob("ref-*.npz"))) == 1


def test_every_argument_and_the_declaration_are_in_the_key(cache):
    model = load_model("two_mass_force")
    base = reference(model, t_end=0.5, rtol=1e-8)
    t = base.t.copy()
    t[1] = np.nextafter(t[1], 1.0)  # one output time, one ulp later
    others = [reference(model, t_end=0.5, rtol=1e-9),
              reference(model, t_end=0.5, rtol=1e-8, atol=1e-11),
              reference(model, t_end=0.5, rtol=1e-8, method="Radau"),
              reference(model, t_end=0.4, rtol=1e-8),
              reference(model, t_end=0.5, t_eval=t, rtol=1e-8),
              reference(model, t_end=0.5, rtol=1e-8, values={"k1": 2 * model.var("k1").start}),
              reference(model, t_end=0.5, rtol=1e-8, input_steps=[(0.2, {"x2_in": 1e-3})])]
    assert not any(r.cached for r in others)
    changed = load_model("two_mass_force")
    changed.var("m1").start = 2 * changed.var("m1").start
    assert not reference(changed, t_end=0.5, rtol=1e-8).cached
    assert reference(model, t_end=0.5, rtol=1e-8).cached
    assert len(list(cache.glob("ref-*.npz"))) == 9


def test_input_functions_and_cache_false_are_never_cached(cache):
    model = load_model("two_mass_force")
    ramp = {"x2_in": lambda t: 1e-3 * t}
    assert not reference(model, t_end=0.3, input_functions=ramp).cached
    assert not reference(model, t_end=0.3, input_functions=ramp).cached
    assert not reference(model, t_end=0.3, cache=False).cached
    assert not reference(model, t_end=0.3, cache=False).cached
    assert not list(cache.glob("ref-*.npz"))
    with pytest.raises(ValueError, match="cache"):
        reference(model, t_end=0.3, cache="yes")


def test_a_damaged_entry_is_computed_again_and_overwritten(cache):
    model = load_model("heald_frame_rigid")
    first = reference(model)
    (entry,) = cache.glob("ref-*.npz")
    for damage in (b"", b"PK\x03\x04 not a zip", entry.read_bytes()[:200]):
        entry.write_bytes(damage)
        again = reference(model)
        assert not again.cached
        _same(first, again)
    assert reference(model).cached


def test_a_violation_is_cached_with_the_result_that_ends_before_it(cache):
    def spring():
        return oracles.spring("spring_taut", require="the spring went slack")

    first, again = reference(spring()), reference(spring())
    assert first.violation[0] == "taut" and again.cached
    assert again.violation == first.violation
    _same(first, again)


def test_no_cache_when_the_caches_are_off(monkeypatch, tmp_path):
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", "off")
    model = load_model("loom_shaft")
    assert not reference(model).cached and not reference(model).cached
    assert reference_cache.load("0" * 64) is None


def test_an_unwritable_cache_is_skipped(monkeypatch, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", str(blocker / "objects"))
    model = load_model("loom_shaft")
    assert not reference(model).cached and not reference(model).cached
