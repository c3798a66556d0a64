"""Binaries for x86-64 Linux, x86-64 Windows and aarch64 Linux in one FMU,
tested where they run: our driver (src/loomfmu/fmu/platform_driver.c),
compiled for each platform, runs each FMU's default experiment natively,
under wine and under qemu-aarch64, and the outputs are compared with the
native run, bit for bit. Small models only (two_mass_force in both FMI
versions and both interfaces, heald_frame_rigid with its events and
trigonometry in FMI 3.0): the rest of the suite builds for linux64 only
(``LOOMFMU_PLATFORMS`` in conftest.py); benchmarks/platforms.py runs every
model. A platform whose compiler or emulator is missing is skipped, naming
the Debian package (.ci/run installs them)."""
from __future__ import annotations

import re
import shutil
import zipfile

import pytest

from loomfmu import build_fmu, load_model
from loomfmu.fmu import platforms as plat
from loomfmu.fmu.builder import exported_symbols, fmi_headers_dir, imported_dlls
from loomfmu.fmu.platform_run import compare, missing_tools, run_on

CROSS = ("win64", "aarch64")


def _available(names):
    return [n for n in names if plat.installed(n)]


# ------------------------------------------------------------- no build
@pytest.mark.parametrize("value, needle", [
    ("win32", "unknown platform 'win32'; allowed: linux64, win64, aarch64"),
    ("", "names no platform"),
    ([], "names no platform"),
    (5, "allowed: a list or a comma-separated string"),
    (["linux64", 3], "allowed: a list or a comma-separated string"),
])
def test_bad_platforms_are_refused_naming_the_argument(value, needle):
    with pytest.raises(ValueError, match="platforms") as exc:
        build_fmu(load_model("two_mass_force"), fmi_version=3, platforms=value)
    assert needle in str(exc.value)


def test_fmi2_has_no_aarch64_folder():
    with pytest.raises(ValueError, match=r"platforms: 'aarch64-linux' has no binaries folder "
                                         r"in FMI 2.0; allowed with fmi_version=2: linux64"):
        build_fmu(load_model("two_mass_force"), platforms="linux64,aarch64-linux")


def test_fmi3_folder_names_are_accepted_in_table_order():
    assert plat.parse("aarch64-linux, x86_64-windows,linux64", 3) == (
        "linux64", "win64", "aarch64")
    assert plat.parse(["win64", "x86_64-windows"], 2) == ("win64",)


def test_the_environment_variable_is_checked_by_name(monkeypatch):
    monkeypatch.setenv(plat.ENV, "linux64,amd64")
    with pytest.raises(ValueError, match="LOOMFMU_PLATFORMS: unknown platform 'amd64'"):
        build_fmu(load_model("two_mass_force"))
    monkeypatch.setenv(plat.ENV, "win64")
    assert plat.select(None, 2) == (("win64",), ())
    assert plat.select("linux64", 2) == (("linux64",), ())  # the argument wins


def test_default_skips_platforms_without_compiler_in_one_line(monkeypatch, tmp_path, capsys):
    """A machine with only gcc: the default builds linux64 and names what it
    skipped with the Debian package of each, once."""
    (tmp_path / "gcc").symlink_to(shutil.which("gcc"))
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.delenv(plat.ENV, raising=False)
    plat.installed.cache_clear()
    try:
        assert plat.select(None, 3) == (("linux64",), ("win64", "aarch64"))
        assert plat.select(None, 2) == (("linux64",), ("win64",))  # no aarch64 in FMI 2.0
        plat.note_skipped(("win64", "aarch64"))
        plat.note_skipped(("win64", "aarch64"))
    finally:
        plat.installed.cache_clear()
    err = capsys.readouterr().err
    assert err == ("loomfmu: platforms skipped (no compiler): win64 (Debian: apt-get install "
                   "gcc-mingw-w64-x86-64), aarch64 (Debian: apt-get install "
                   "gcc-aarch64-linux-gnu)\n")


# ------------------------------------------------------------ the builds
@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """two_mass_force as FMI 2.0 and FMI 3.0 `both`, heald_frame_rigid as
    FMI 3.0 `both`, each for every platform with a compiler here, into a
    fresh object cache; then the FMI 3.0 two_mass_force again (from it)."""
    out = tmp_path_factory.mktemp("platforms")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("LOOMFMU_BUILD_CACHE", str(out / "cache"))
        two = load_model("two_mass_force")
        res = {
            (2, "two_mass_force"): build_fmu(two, out_dir=out / "a", fmi_version=2,
                                             interface="both",
                                             platforms=_available(["linux64", "win64"])),
            (3, "two_mass_force"): build_fmu(two, out_dir=out / "a", fmi_version=3,
                                             interface="both",
                                             platforms=_available(plat.PLATFORMS)),
            (3, "heald_frame_rigid"): build_fmu(load_model("heald_frame_rigid"),
                                                out_dir=out / "a", fmi_version=3,
                                                interface="both",
                                                platforms=_available(plat.PLATFORMS)),
        }
        again = build_fmu(two, out_dir=out / "b", fmi_version=3, interface="both",
                          platforms=_available(plat.PLATFORMS))
    return res, again


def _need(name):
    why = missing_tools(name)
    if why:
        pytest.skip(f"{name}: {why}")


@pytest.mark.slow
def test_binaries_sit_in_the_folders_each_fmi_version_names(built):
    res, _ = built
    folders = {2: {"linux64": "linux64/two_mass_force.so", "win64": "win64/two_mass_force.dll"},
               3: {"linux64": "x86_64-linux/two_mass_force.so",
                   "win64": "x86_64-windows/two_mass_force.dll",
                   "aarch64": "aarch64-linux/two_mass_force.so"}}
    for v in (2, 3):
        r = res[v, "two_mass_force"]
        with zipfile.ZipFile(r.path) as z:
            binaries = sorted(n for n in z.namelist() if n.startswith("binaries/"))
        assert binaries == sorted(f"binaries/{folders[v][p]}" for p in r.platforms)
        assert not r.problems
    for name in CROSS:
        if name not in res[3, "two_mass_force"].platforms:
            pytest.skip(f"{name}: {missing_tools(name)}")


def _declared(version: int) -> set[str]:
    text = (fmi_headers_dir() / f"fmi{version}Functions.h").read_text()
    return set(re.findall(rf"FMI{version}_Export\s+\w+TYPE\s+(fmi{version}\w+);", text))


@pytest.mark.slow
def test_the_generated_code_calls_the_runtimes_elementary_functions(built):
    """heald_frame_rigid's sin and cos are the runtime's (lf_math.c), the
    same bits on every platform, not the C library's."""
    res, _ = built
    with zipfile.ZipFile(res[3, "heald_frame_rigid"].path) as z:
        src = z.read("sources/heald_frame_rigid_casadi.c").decode()
    assert "lf_sin(" in src and "lf_cos(" in src
    assert not re.search(r"(?<![\w.])(sin|cos|exp|log|pow|tanh)\(", src)


@pytest.mark.slow
def test_every_binary_exports_the_fmi_functions_and_nothing_else(built, tmp_path):
    """The same export table on every platform: only names the standard's
    header declares (nm -D for ELF, objdump -p's export table for the DLL)."""
    res, _ = built
    for (v, model), r in res.items():
        with zipfile.ZipFile(r.path) as z:
            z.extractall(tmp_path / r.path.stem)
        tables = {}
        for name in r.platforms:
            p = plat.PLATFORMS[name]
            lib = tmp_path / r.path.stem / "binaries" / p.folder(v) / f"{model}{p.suffix}"
            tables[name] = set(exported_symbols(lib, p))
        declared = _declared(v)
        for name, table in tables.items():
            assert table and table <= declared, (model, name, sorted(table - declared))
            assert table == tables["linux64"], (model, name)


@pytest.mark.slow
def test_the_windows_dll_needs_no_dll_beside_it(built, tmp_path):
    _need("win64")
    res, _ = built
    p = plat.PLATFORMS["win64"]
    with zipfile.ZipFile(res[3, "two_mass_force"].path) as z:
        lib = z.extract("binaries/x86_64-windows/two_mass_force.dll", tmp_path)
    dlls = {d.lower() for d in imported_dlls(lib, p)}
    assert dlls and dlls <= {"kernel32.dll", "msvcrt.dll"}, dlls


@pytest.mark.slow
def test_the_object_cache_serves_every_platform(built):
    res, again = built
    first = res[3, "two_mass_force"]
    assert again.platforms == first.platforms
    assert again.compile_stats.compiled == 0
    assert again.compile_stats.reused == first.compile_stats.compiled + \
        first.compile_stats.reused


#: the embedded solvers run: dopri5 (the default) and the fixed-step rk4
RK4 = {"solver_index": 3}


def _runs(res, fmi_versions):
    return [(res[key].path, *run) for key in sorted(res) if key[0] in fmi_versions
            for run in (("cs",), ("cs", RK4), ("me",))]


@pytest.fixture(scope="module")
def native_runs(built):
    res, _ = built
    runs = _runs(res, (2, 3))
    out = run_on("linux64", runs)
    assert all(r.ok for r in out), [r.message for r in out]
    by_run = dict(zip(map(_key, runs), out))
    for run in runs:  # the start value took: rk4 is not dopri5
        if len(run) == 3:
            dopri5 = by_run[_key(run[:2])]
            assert not compare(dopri5, by_run[_key(run)])["identical"], run
    return by_run


def _key(run):
    return (run[0], run[1], tuple(sorted(run[2].items())) if len(run) > 2 else ())


@pytest.mark.slow
@pytest.mark.parametrize("name", CROSS)
def test_cross_binaries_give_the_native_numbers(built, native_runs, name):
    """One driver process per platform (wine starts once) runs FMI 2.0 CS
    (dopri5 and rk4) and ME (win64 only: FMI 2.0 has no aarch64 folder) and
    FMI 3.0 CS (dopri5, rk4) and ME of each FMU: every output at every
    output time equals the native run's bits (the same operations in the
    same order, no fused multiply-add: -ffp-contract=off, and the runtime's
    own sin, cos, exp, ... (lf_math.c) in place of the C library's, which
    differ between glibc and wine's msvcrt)."""
    _need(name)
    res, _ = built
    runs = _runs(res, (2, 3) if name == "win64" else (3,))
    out = run_on(name, runs)
    for run, r in zip(runs, out):
        assert r.ok, (run, r.message)
        assert len(r.time) > 100
        c = compare(native_runs[_key(run)], r)
        assert c["identical"], (run, c)
