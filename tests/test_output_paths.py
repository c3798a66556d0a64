"""Every option of the ``loomfmu`` command that writes a file or a directory is
checked before any work: a file path that is a directory, a directory that is
a file, a directory that cannot be made (its parent is a file) or written in
is one line on standard error and exit code 2, never a traceback.

The paths are ones that fail for root too (tests may run as root, where a
chmod'ed directory is still writable)."""
from __future__ import annotations

from pathlib import Path

import pytest

from loomfmu.cli.dispatch import main
from loomfmu.declare.checks import check_output_options, check_writable


@pytest.fixture
def paths(tmp_path):
    afile = tmp_path / "afile"
    afile.write_text("keep me\n")
    adir = tmp_path / "adir"
    adir.mkdir()
    return afile, adir


def _exit_code(argv, capsys) -> tuple[int, str]:
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    return code, capsys.readouterr().err


#: (command, option, what the path is: "dir" an existing directory where a
#: file goes, "file" an existing file where a directory goes, "under" a path
#: under an existing file)
CASES = [
    (["simulate", "heald_frame_rigid"], "--csv", "dir"),
    (["simulate", "heald_frame_rigid"], "--csv", "under"),
    (["simulate", "heald_frame_rigid"], "--plot", "dir"),
    (["build", "heald_frame_rigid"], "--out-dir", "file"),
    (["inspect", "heald_frame_rigid"], "--out", "dir"),
    (["inspect", "--all"], "--out", "file"),
    (["docs"], "--out", "file"),
    (["docs"], "--out", "under"),
    (["scene", "run", "two_mass"], "--csv", "dir"),
    (["scene", "run", "two_mass"], "--fmu-dir", "file"),
    (["scene", "export", "two_mass"], "--out", "dir"),
    (["scene", "export", "two_mass"], "--out", "under"),
    (["scene", "fidelity", "two_mass", "--outputs", "disp.x2_out"], "--json", "dir"),
    (["scene", "fidelity", "two_mass", "--outputs", "disp.x2_out"], "--chart", "under"),
    (["sweep", "hinge"], "--out-dir", "file"),
    (["heald", "claims"], "--out", "dir"),
    (["heald", "fidelity"], "--out", "dir"),
    (["heald", "tension-input"], "--out", "under"),
    (["drive", "table"], "--out", "dir"),
    (["drive", "charts"], "--out-dir", "file"),
    (["drive", "tracking"], "--out", "dir"),
    (["rotor", "calibrate"], "--out", "file"),
    (["bench", "charts"], "--out", "file"),
    (["bench", "charts"], "--readme", "dir"),
    (["bench", "speed"], "--out", "dir"),
    (["bench", "friction"], "--out", "under"),
    (["bench", "limit"], "--out", "dir"),
    (["bench", "limit"], "--page", "dir"),
]

SAID = {"dir": "an existing directory, not a file", "file": "an existing file, not a directory",
        "under": "cannot be made"}


@pytest.mark.parametrize("command, option, kind", CASES,
                         ids=[" ".join(c[:2]) + " " + o + " " + k for c, o, k in CASES])
def test_an_output_that_cannot_be_written_is_one_line_and_exit_2(command, option, kind,
                                                                  paths, capsys):
    afile, adir = paths
    target = {"dir": adir, "file": afile, "under": afile / "sub" / "x.out"}[kind]
    code, err = _exit_code([*command, option, str(target)], capsys)
    assert code == 2, (code, err)
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert f"{option} '{target}': {SAID[kind]}" in err and "allowed" in err, err
    assert afile.read_text() == "keep me\n"   # nothing lost


def test_check_writable_names_the_argument_and_makes_nothing(paths, tmp_path):
    afile, adir = paths
    with pytest.raises(ValueError, match=r"^out = '.*adir': an existing directory, not a "
                                         r"file; allowed: a file path"):
        check_writable("out", adir)
    with pytest.raises(ValueError, match=r"^out = .*: an existing file, not a directory; "
                                         r"allowed: a directory"):
        check_writable("out", afile, folder=True)
    with pytest.raises(ValueError, match=r"cannot be made \('.*afile' is a file\)"):
        check_writable("out", afile / "a" / "b.csv")
    with pytest.raises(ValueError, match=r"^out = '/proc/x.csv': not writable"):
        check_writable("out", "/proc/x.csv")   # not writable even for root
    with pytest.raises(ValueError, match=r"^out = 3; allowed"):
        check_writable("out", 3)
    deep = tmp_path / "new" / "deeper" / "x.csv"
    assert check_writable("out", str(deep)) == deep and not deep.parent.parent.exists()
    assert check_writable("out", afile) == afile            # an existing file: overwritten


def test_check_output_options_makes_the_missing_directories(tmp_path):
    import argparse
    args = argparse.Namespace(csv=tmp_path / "a" / "x.csv", out_dir=tmp_path / "b" / "c",
                              plot=None)
    check_output_options(args, files=["csv", "plot"], folders=["out_dir"])
    assert (tmp_path / "a").is_dir() and (tmp_path / "b" / "c").is_dir()
    assert not Path(args.csv).exists()
