"""The builder's object cache: reused only for the same preprocessed text,
flags and compiler; a corrupted entry is compiled again; no cache, no harm."""
from __future__ import annotations

import zipfile

import pytest
from fmpy import simulate_fmu

from loomfmu import build_fmu, load_model
from loomfmu.fmu.compile_cache import _key, cache_dir, compile_objects, prune


def _binary(fmu):
    with zipfile.ZipFile(fmu) as z:
        return z.read("binaries/linux64/two_mass_force.so")


@pytest.mark.slow
def test_second_build_reuses_every_object_and_links_the_same_binary(tmp_path, monkeypatch):
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", str(tmp_path / "cache"))
    model = load_model("two_mass_force")
    first = build_fmu(model, out_dir=tmp_path / "a", validate=False)
    assert first.compile_stats.reused == 0 and first.compile_stats.compiled > 20
    second = build_fmu(model, out_dir=tmp_path / "b", validate=False)
    assert second.compile_stats.compiled == 0
    assert second.compile_stats.reused == first.compile_stats.compiled
    assert _binary(first.path) == _binary(second.path)
    # another variant of the same model: the generated code is reused, the
    # runtime (which reads the variant's lf_build.h) is compiled again
    me = build_fmu(model, out_dir=tmp_path / "c", interface="me", validate=False)
    assert me.compile_stats.reused >= 1 and me.compile_stats.compiled >= 1
    res = simulate_fmu(str(second.path), stop_time=0.01)
    assert len(res) > 1


@pytest.mark.slow
def test_corrupted_entries_are_compiled_again(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", str(cache))
    model = load_model("two_mass_force")
    first = build_fmu(model, out_dir=tmp_path / "a", validate=False)
    entries = sorted(cache.glob("*.o"))
    assert len(entries) == first.compile_stats.compiled
    entries[0].write_bytes(entries[0].read_bytes()[:-100])   # truncated
    blob = bytearray(entries[1].read_bytes())
    blob[40] ^= 0xFF                                          # one byte altered
    entries[1].write_bytes(bytes(blob))
    entries[2].write_bytes(b"")                               # emptied
    again = build_fmu(model, out_dir=tmp_path / "b", validate=False)
    assert again.compile_stats.compiled == 3
    assert _binary(first.path) == _binary(again.path)
    assert len(simulate_fmu(str(again.path), stop_time=0.01)) > 1


@pytest.mark.parametrize("value", ["off", "0", "OFF", " "])
def test_cache_off(tmp_path, monkeypatch, value):
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", value)
    assert cache_dir() is None


@pytest.mark.slow
def test_unwritable_cache_is_no_cache(tmp_path, monkeypatch):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", str(blocker / "cache"))
    result = build_fmu(load_model("two_mass_force"), out_dir=tmp_path / "a", validate=False)
    assert result.compile_stats.reused == 0 and result.compile_stats.compiled > 20
    assert len(simulate_fmu(str(result.path), stop_time=0.01)) > 1


def test_key_follows_headers_macros_and_flags_not_paths(tmp_path):
    for d in ("x", "y"):
        (tmp_path / d).mkdir()
        (tmp_path / d / "h.h").write_text("#define K 1.0\n")
        (tmp_path / d / "f.c").write_text('#include "h.h"\ndouble f(void) { return K; }\n')
    flags = ("-O2",)
    kx = _key("gcc", flags, ["-I", str(tmp_path / "x")], tmp_path / "x" / "f.c")
    ky = _key("gcc", flags, ["-I", str(tmp_path / "y")], tmp_path / "y" / "f.c")
    assert kx == ky                     # same text in another folder: same object
    assert _key("gcc", ("-O1",), ["-I", str(tmp_path / "x")], tmp_path / "x" / "f.c") != kx
    (tmp_path / "y" / "h.h").write_text("#define K 2.0\n")
    assert _key("gcc", flags, ["-I", str(tmp_path / "y")], tmp_path / "y" / "f.c") != kx


@pytest.mark.slow
def test_compile_error_is_reported_and_not_cached(tmp_path, monkeypatch):
    from loomfmu.fmu.builder import BuildError
    cache = tmp_path / "cache"
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", str(cache))
    (tmp_path / "bad.c").write_text("int f(void) { return undefined_name; }\n")
    (tmp_path / "good.c").write_text("int g(void) { return 1; }\n")
    out = tmp_path / "obj"
    out.mkdir()
    with pytest.raises(BuildError, match="undefined_name"):
        compile_objects([(tmp_path / "bad.c", ("-O2",)), (tmp_path / "good.c", ("-O2",))],
                        [], out)
    assert len(list(cache.glob("*.o"))) <= 1   # at most the good one


def test_prune_keeps_the_most_recently_used(tmp_path):
    import os
    for i in range(5):
        p = tmp_path / f"{i}.o"
        p.write_bytes(b"x" * 1000)
        os.utime(p, (1000 + i, 1000 + i))
    prune(tmp_path, max_bytes=2500)
    assert sorted(p.name for p in tmp_path.glob("*.o")) == ["3.o", "4.o"]


@pytest.mark.slow
def test_a_poisoned_entry_is_compiled_again_when_the_objects_do_not_link(tmp_path,
                                                                          monkeypatch):
    """An entry replaced by another file's valid object (its SHA-256 right): the
    link fails, the builder compiles everything again, overwrites the entries
    and links the same binary as before."""
    cache = tmp_path / "cache"
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", str(cache))
    model = load_model("two_mass_force")
    first = build_fmu(model, out_dir=tmp_path / "a", validate=False)
    entries = sorted(cache.glob("*.o"), key=lambda p: p.stat().st_size)
    entries[-1].write_bytes(entries[0].read_bytes())   # the biggest holds the smallest
    again = build_fmu(model, out_dir=tmp_path / "b", validate=False)
    assert again.compile_stats.compiled == first.compile_stats.compiled
    assert _binary(first.path) == _binary(again.path)
    third = build_fmu(model, out_dir=tmp_path / "c", validate=False)   # healed
    assert third.compile_stats.compiled == 0 and _binary(third.path) == _binary(first.path)


@pytest.mark.slow
def test_a_read_only_cache_is_still_read(tmp_path, monkeypatch):
    import loomfmu.fmu.compile_cache as cc
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", str(tmp_path / "cache"))
    model = load_model("two_mass_force")
    build_fmu(model, out_dir=tmp_path / "a", validate=False)

    def refuse(*a, **k):
        raise OSError(30, "Read-only file system")
    import os
    import types
    monkeypatch.setattr(cc, "os", types.SimpleNamespace(**{**vars(os), "utime": refuse}))
    monkeypatch.setattr(cc, "tempfile", types.SimpleNamespace(mkstemp=refuse))
    again = build_fmu(model, out_dir=tmp_path / "b", validate=False)
    assert again.compile_stats.compiled == 0


@pytest.mark.slow
def test_a_failed_write_leaves_no_partial_file(tmp_path, monkeypatch):
    import loomfmu.fmu.compile_cache as cc
    cache = tmp_path / "cache"
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", str(cache))

    def disk_full(*a, **k):
        raise OSError(28, "No space left on device")
    import os
    import types
    # the cache module's os only (the builder's packaging uses os.replace too)
    monkeypatch.setattr(cc, "os", types.SimpleNamespace(**{**vars(os), "replace": disk_full}))
    result = build_fmu(load_model("two_mass_force"), out_dir=tmp_path / "a", validate=False)
    assert result.compile_stats.compiled > 20
    assert list(cache.glob("*")) == []
    assert len(simulate_fmu(str(result.path), stop_time=0.01)) > 1


@pytest.mark.slow
def test_a_missing_compiler_is_a_build_error_naming_it(tmp_path):
    from loomfmu.fmu.builder import BuildError
    (tmp_path / "f.c").write_text("int f(void) { return 1; }\n")
    with pytest.raises(BuildError, match="'no_such_cc_xyz' cannot be run.*on PATH"):
        compile_objects([(tmp_path / "f.c", ("-O2",))], [], tmp_path, cc="no_such_cc_xyz")


def test_cache_dir_expands_the_home_folder(monkeypatch):
    from pathlib import Path
    monkeypatch.setenv("LOOMFMU_BUILD_CACHE", "~/lf_objects")
    assert cache_dir() == Path.home() / "lf_objects"
