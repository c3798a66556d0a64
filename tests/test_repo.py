"""The repository keeps its promises: CI runs the README's two Quick start
commands verbatim, every relative link of the README and the docs leads to a
file, and the generated docs match the declarations."""
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


def test_readme_quick_start_has_two_commands_and_ci_runs_both():
    cmds = readme_commands()
    assert len(cmds) == 2, f"Quick start should hold two indented commands, found {cmds}"
    assert "build_fmu.py" in cmds[0] and "pytest" in cmds[1]
    ci_lines = [l.strip() for l in (ROOT / ".ci/run").read_text().splitlines()]
    for cmd in cmds:
        assert cmd in ci_lines, f"README command not run verbatim by .ci/run: {cmd}"


#: [text](target) and ![alt](target); the target ends at a space or ")"
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")


def relative_links(page: Path) -> list[str]:
    """The relative link targets of a Markdown page, without their #anchor;
    links inside code (fenced blocks, indented blocks, `spans`) are not links."""
    text = re.sub(r"^```.*?^```", "", page.read_text(), flags=re.M | re.S)
    text = re.sub(r"^(    |\t).*$", "", text, flags=re.M)
    text = re.sub(r"`[^`\n]*`", "", text)
    targets = [t.split("#", 1)[0] for t in LINK.findall(text)]
    return [t for t in targets if t and not re.match(r"^[a-z][a-z0-9+.-]*:", t, re.I)]


LINKED_PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


@pytest.mark.parametrize("page", LINKED_PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_lead_to_files(page):
    missing = [t for t in relative_links(page) if not (page.parent / t).exists()]
    assert not missing, f"{page.relative_to(ROOT)} links to missing files: {missing}"


def test_link_finder_sees_links_and_skips_code(tmp_path):
    page = tmp_path / "p.md"
    page.write_text("[a](x.md#s) ![b](img/c.png) [w](https://e.org) [h](#top)\n"
                    "`[d](code.md)`\n\n    [e](indented.md)\n\n```\n[f](fenced.md)\n```\n")
    assert relative_links(page) == ["x.md", "img/c.png"]


@pytest.mark.parametrize("name", sorted(MODELS))
def test_generated_model_docs_are_current(name):
    path = ROOT / "docs" / "reference" / "models" / f"{name}.md"
    assert path.read_text() == model_markdown(load_model(name)), (
        f"{path} is stale: run python -m loomfmu.docs")


def test_readme_derivation_example_prints_what_its_comments_show(capsys):
    """The Python example of 'Reading the derivation' runs and prints, line
    for line, the trailing comments under it (before: one comment line for
    numpy's three-line array)."""
    text = (ROOT / "README.md").read_text()
    section = text.split("## Reading the derivation", 1)[1].split("\n## ", 1)[0]
    block = re.search(r"^```python\n(.*?)^```", section, flags=re.M | re.S).group(1)
    lines = block.splitlines()
    n_code = max(i for i, l in enumerate(lines) if not l.startswith("#")) + 1
    shown = [l[2:] if l.startswith("# ") else l[1:] for l in lines[n_code:]]
    assert shown, "the example should show its output as comments"
    exec(compile("\n".join(lines[:n_code]), "README.md", "exec"), {})
    printed = capsys.readouterr().out.splitlines()
    assert printed == shown
