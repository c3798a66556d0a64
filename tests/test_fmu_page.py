"""The FMU's page (documentation/index.html) says first what an importer
needs: what the model is, its interface, where it is valid and what it
leaves out; then how to rebuild the binary from sources/ elsewhere; solver
settings and verification after.  Built from the declaration alone (no FMU
is compiled here)."""
from __future__ import annotations

import html
import re

import pytest

from loomfmu import load_model
from loomfmu.fidelity import level
from loomfmu.fmu.documentation import html_for

MEMBERS = ["modelDescription.xml", "sources/backrest_casadi.c", "sources/model_decl.c",
           "sources/lf_fmi2.c", "sources/lf_build.h", "sources/model_decl.h",
           "binaries/linux64/backrest.so", "documentation/index.html"]


def _sections(page: str) -> list[str]:
    return re.findall(r'<section id="([^"]+)">', page)


def test_validity_and_what_the_model_leaves_out_come_before_solver_and_verification():
    model = load_model("backrest")
    page = html.unescape(html_for(model, members=MEMBERS))
    ids = _sections(page)
    assert ids.index("validity") < ids.index("solver") < ids.index("verification")
    assert ids.index("interfaces") < ids.index("validity")
    for text in level("backrest").leaves_out + (level("backrest").suffices,):
        assert text.rstrip(".") in page
    for c in model.validity:
        assert c.name in page and c.message in page


def test_page_says_how_to_rebuild_from_the_sources_with_gcc_clang_and_msvc():
    page = html.unescape(html_for(load_model("backrest"), members=MEMBERS))
    build = page[page.index('<section id="build">'):]
    build = build[:build.index("</section>")]
    for cc in ("gcc ", "clang ", "cl "):
        assert cc in build
    for f in ("sources/backrest_casadi.c", "sources/model_decl.c", "sources/lf_fmi2.c"):
        assert f in build
    pre = build[build.index("<pre"):]
    assert "sources/lf_build.h" not in pre
    assert "-I sources" in build and "/I sources" in build
    assert "-lm" in build


def test_page_describes_only_the_build_options_this_fmu_has():
    page = html_for(load_model("spindle_modal"))
    assert "static_correction=True" not in page, page[page.index("static_correction=True")
                                                      - 300:][:400]
    assert "mode-acceleration" not in page
    page = html_for(load_model("spindle_modal", static_correction=True))
    assert "mode-acceleration" in page


@pytest.mark.slow  # a whole derivation report: seconds
def test_backrest_frame_is_drawn_in_the_report_and_on_the_page():
    """The seed's figure is missing: the frame reconstructed from the signs of
    (3)-(13) is drawn (lever, roller, warp branches, the angles and points)."""
    from loomfmu.inspection.report import report
    model = load_model("backrest")
    for page in (html_for(model), report(model, "html")):
        svg = page[page.index("<figure><svg"):]
        svg = svg[:svg.index("</svg>")]
        for mark in ("O<tspan", ">A<", "\u03b1", "\u03b8", "\u03b3", "\u03c6", "x<", "y<"):
            assert mark in svg, mark
        assert "reconstructed from the signs of (3)-(13)" in page
