"""A damaged .ssp is named before an engine sees it: validate_ssd reports each
problem of the archive (not a zip, a missing or cut-short FMU, a source that
is not in it, a NaN parameter value, SSD that is not XML), and run_ssp raises
ValueError naming it instead of libcosim's "check if path is correct"."""
from __future__ import annotations

import re
import zipfile

import pytest

from loomfmu.machines.library import load_scene
from loomfmu.scene.ssp import export_ssp, validate_ssd

pytestmark = pytest.mark.slow  # builds the two-mass FMUs


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    out = tmp_path_factory.mktemp("ssp") / "two_mass.ssp"
    return export_ssp(load_scene("two_mass"), out)


def _copy(good, path, *, drop=(), replace=None, ssd=None):
    """A copy of ``good`` without the members ``drop``, with ``replace``
    (member -> bytes) and the SSD text changed by ``ssd``."""
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(path, "w") as dst:
        for name in src.namelist():
            if name in drop:
                continue
            data = (replace or {}).get(name, src.read(name))
            if name == "SystemStructure.ssd" and ssd is not None:
                data = ssd(data.decode()).encode()
            dst.writestr(name, data)
    return path


def _damaged(good, tmp_path):
    with zipfile.ZipFile(good) as z:
        fmu = z.read("resources/disp.fmu")
    not_zip = tmp_path / "not_zip.ssp"
    not_zip.write_bytes(b"hello, I am not an archive\n")
    return {
        "missing FMU": (_copy(good, tmp_path / "missing.ssp", drop={"resources/disp.fmu"}),
                        "component disp: its source 'resources/disp.fmu' is not in the archive"),
        "truncated FMU": (_copy(good, tmp_path / "cut.ssp",
                                replace={"resources/disp.fmu": fmu[:len(fmu) // 2]}),
                          "component disp: resources/disp.fmu is not an FMU, or is cut short"),
        "wrong source": (_copy(good, tmp_path / "source.ssp", ssd=lambda t: t.replace(
            'source="resources/force.fmu"', 'source="resources/forse.fmu"')),
            "component force: its source 'resources/forse.fmu' is not in the archive"),
        "NaN value": (_copy(good, tmp_path / "nan.ssp", ssd=lambda t: re.sub(
            r'<ssv:Real value="[^"]*"', '<ssv:Real value="NaN"', t, count=1)),
            "= 'NaN'; allowed: a finite number"),
        "broken XML": (_copy(good, tmp_path / "xml.ssp", ssd=lambda t: t[:len(t) // 2]),
                       "SystemStructure.ssd not well-formed XML"),
        "not a zip": (not_zip, "not a zip archive"),
    }


def test_a_good_ssp_validates(good):
    assert validate_ssd(good) == []
    assert validate_ssd(str(good)) == []


def test_validate_ssd_names_each_problem_of_a_damaged_ssp(good, tmp_path):
    for what, (path, said) in _damaged(good, tmp_path).items():
        problems = validate_ssd(path)
        assert len(problems) == 1 and said in problems[0], (what, problems)


def test_libcosim_is_not_handed_a_damaged_ssp(good, tmp_path):
    pytest.importorskip("libcosimpy")
    from loomfmu.scene.libcosim import run_ssp
    for what, (path, said) in _damaged(good, tmp_path).items():
        with pytest.raises(ValueError) as e:
            run_ssp(path, [("disp", "x2_out")], step=1e-3, stop=0.01)
        msg = str(e.value)
        assert msg.startswith(f"ssp = '{path}': ") and said in msg and "allowed" in msg, \
            (what, msg)
