"""The sources of two loomfmu FMUs can live in one program: apart from the
fmi2 functions (which the importer renames with FMI2_FUNCTION_PREFIX, when its
FMI headers support it -- FMPy's do not), no global symbol of one FMU's
sources is also defined by the other's: the runtime's own symbols carry the
model identifier."""
from __future__ import annotations

import subprocess
import zipfile

from loomfmu import build_fmu, load_model
from loomfmu.builder import fmi_headers_dir


def _global_symbols(fmu, workdir):
    ident = fmu.stem
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
    return {s for s in symbols if not s.startswith("fmi2")}


def test_two_fmus_sources_share_no_symbol(tmp_path, heald_frame_fmu):
    other = build_fmu(load_model("backrest"), out_dir=tmp_path / "dist", validate=False)
    a = _global_symbols(heald_frame_fmu.path, tmp_path)
    b = _global_symbols(other.path, tmp_path)
    assert a and b
    assert not (a & b), sorted(a & b)[:10]
    assert all(s.startswith("heald_frame_") for s in a)
