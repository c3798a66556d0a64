"""`pip install .` (non-editable) installs every subpackage: a wheel built
from the tree holds each package found under src/ and the models, and the
runtime sources. CI also runs the README's non-editable build command."""
from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # builds FMUs

ROOT = Path(__file__).resolve().parents[1]


def test_wheel_holds_every_package_models_and_runtime(tmp_path):
    res = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps",
                          "--no-build-isolation", "-q", "-w", str(tmp_path), str(ROOT)],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    wheel = next(tmp_path.glob("loomfmu-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    packages = [p.parent.relative_to(ROOT / "src").as_posix()
                for p in (ROOT / "src").rglob("__init__.py")]
    assert "loomfmu/drive" in packages and "loomfmu/heald" in packages
    for pkg in packages:
        assert f"{pkg}/__init__.py" in names, f"{pkg} missing from the wheel"
    for model in (ROOT / "models").glob("*.py"):
        assert f"loomfmu/models/{model.name}" in names
    tracked = subprocess.run(["git", "ls-files", "src/loomfmu"], cwd=ROOT, capture_output=True,
                             text=True).stdout.split()
    data = [f for f in tracked if not f.endswith(".py")] or [
        p.relative_to(ROOT).as_posix() for p in (ROOT / "src/loomfmu").rglob("*.[ch]")]
    assert any(f.endswith("lf_model.h") for f in data) and any(
        f.endswith("limit_driver.c") for f in data)
    for f in data:  # every file a command reads at run time: the C runtime, bench's driver
        assert f[len("src/"):] in names, f"{f} missing from the wheel (package data)"
    entry = next(n for n in names if n.endswith("entry_points.txt"))
    assert "loomfmu = loomfmu.cli:main" in zipfile.ZipFile(wheel).read(entry).decode()
