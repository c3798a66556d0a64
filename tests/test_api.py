"""The public API: ``loomfmu.__all__`` and the package docstring's example."""
from __future__ import annotations

import doctest
import subprocess
import sys

import pytest

import loomfmu


def test_all_names_resolve():
    for name in loomfmu.__all__:
        assert getattr(loomfmu, name) is not None, name
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        loomfmu.nope  # noqa: B018


def test_import_is_light():
    """``import loomfmu`` loads neither SymPy nor scipy (the lazy names do)."""
    code = ("import sys, loomfmu; print('sympy' in sys.modules, 'scipy.integrate' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"], out


@pytest.mark.slow
def test_package_docstring_example_runs():
    result = doctest.testmod(loomfmu, verbose=False, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 8 and result.failed == 0, result
