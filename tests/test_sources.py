"""The sources of two loomfmu FMUs can live in one program: apart from the
fmi2 functions (which the importer renames with FMI2_FUNCTION_PREFIX, when its
FMI headers support it -- FMPy's do not), no global symbol of one FMU's
sources is also defined by the other's: the runtime's own symbols carry the
model identifier.  The same holds for FMI 3.0 sources (fmi3 functions)."""
from __future__ import annotations

import subprocess
import zipfile

import pytest

from loomfmu import build_fmu, load_model
from loomfmu.fmu.builder import fmi_headers_dir

pytestmark = pytest.mark.slow  # builds FMUs


def _global_symbols(fmu, workdir):
    return _global_symbols_of(fmu, fmu.stem, workdir)


def _global_symbols_of(fmu, ident, workdir):
    with zipfile.ZipFile(fmu) as z:
        for name in z.namelist():
            if name.startswith("sources/"):
                z.extract(name, workdir / ident)
    src = workdir / ident / "sources"
    symbols = set()
    for c_file in sorted(src.glob("*.c")):
        obj = workdir / f"{ident}_{c_file.stem}.o"
        subprocess.run(["gcc", "-std=c99", "-O0", "-fPIC", "-c", "-I", str(src),
                        "-I", str(fmi_headers_dir()), str(c_file), "-o", str(obj)],
                       check=True, capture_output=True)
        out = subprocess.run(["nm", "-g", "--defined-only", str(obj)], check=True,
                             capture_output=True, text=True).stdout
        symbols |= {ln.split()[2] for ln in out.splitlines() if len(ln.split()) == 3}
    return {s for s in symbols if not s.startswith(("fmi2", "fmi3"))}


def test_two_fmus_sources_share_no_symbol(tmp_path, heald_frame_fmu):
    other = build_fmu(load_model("backrest"), out_dir=tmp_path / "dist", validate=False)
    a = _global_symbols(heald_frame_fmu.path, tmp_path)
    b = _global_symbols(other.path, tmp_path)
    assert a and b
    assert not (a & b), sorted(a & b)[:10]
    assert all(s.startswith("heald_frame_") for s in a)


def test_two_fmi3_fmus_sources_share_no_symbol(tmp_path):
    """FMI 3.0 model exchange and co-simulation sources of two models: only
    the fmi3 functions are common, every runtime symbol carries its model's
    identifier (the FMI 3 facade files included)."""
    a = build_fmu(load_model("loom_shaft"), out_dir=tmp_path / "a", fmi_version=3,
                  interface="me", validate=False)
    b = build_fmu(load_model("heald_frame_rigid"), out_dir=tmp_path / "b", fmi_version=3,
                  interface="cs", validate=False)
    sa = _global_symbols_of(a.path, "loom_shaft", tmp_path)
    sb = _global_symbols_of(b.path, "heald_frame_rigid", tmp_path)
    assert any(s.startswith("loom_shaft_lf_fmi3") for s in sa)
    assert any(s.startswith("heald_frame_rigid_lf_fmi3") for s in sb)
    assert not (sa & sb), sorted(sa & sb)[:10]
    assert all(s.startswith("loom_shaft_") for s in sa)
    assert all(s.startswith("heald_frame_rigid_") for s in sb)
