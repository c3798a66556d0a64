"""The repository keeps its promises: CI runs the README's test command
verbatim, and the generated docs match the declarations."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from loomfmu.docs import model_markdown
from loomfmu.registry import MODELS, load_model

ROOT = Path(__file__).resolve().parents[1]


def readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text()
    quick = text.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    return [m.strip() for m in re.findall(r"^    (\S.*)$", quick, flags=re.M)]


def test_readme_quick_start_has_two_commands_and_ci_runs_the_test_one():
    cmds = readme_commands()
    assert len(cmds) == 2
    assert "build_fmu.py" in cmds[0] and "pytest" in cmds[1]
    ci_lines = [l.strip() for l in (ROOT / ".ci/run").read_text().splitlines()]
    assert cmds[1] in ci_lines


@pytest.mark.parametrize("name", sorted(MODELS))
def test_generated_model_docs_are_current(name):
    path = ROOT / "docs" / "models" / f"{name}.md"
    assert path.read_text() == model_markdown(load_model(name)), (
        f"{path} is stale: run python -m loomfmu.docs")
