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


@pytest.mark.parametrize("version", [2, 3])
def test_page_names_the_binaries_it_holds_and_how_to_rebuild_for_the_others(version):
    """The platform table: each binary of the FMU in its folder, the others
    to rebuild (macOS with clang; ARM Linux under FMI 2.0, which names no
    folder for it)."""
    model = load_model("two_mass_force")
    folders = ["linux64", "win64"] if version == 2 else ["x86_64-linux", "x86_64-windows",
                                                         "aarch64-linux"]
    ext = {"linux64": ".so", "win64": ".dll", "x86_64-linux": ".so",
           "x86_64-windows": ".dll", "aarch64-linux": ".so"}
    members = [f"binaries/{f}/two_mass_force{ext[f]}" for f in folders] + \
        ["sources/two_mass_force_casadi.c"]
    xml = None
    if version == 3:
        from loomfmu.export.dae import dae_form
        from loomfmu.export.fmi_xml import model_description
        xml = model_description(model, dae_form(model), "{0}", ["x.c"], fmi_version=3,
                                interface="cs")
    page = html.unescape(html_for(model, members=members, model_description_xml=xml))
    build = page[page.index('<section id="build">'):]
    build = build[:build.index("</section>")]
    for f in folders:
        assert f"binaries/{f}/two_mass_force{ext[f]}</code>" in build
    assert "wine" in build and "qemu-aarch64" in build
    assert "x86_64-w64-mingw32-gcc" in build and "-static-libgcc" in build
    assert "-ffp-contract=off" in build
    mac = "aarch64-darwin" if version == 3 else "darwin64"
    assert "-dynamiclib -I sources" in build and f"binaries/{mac}/two_mass_force.dylib" in build
    if version == 2:
        assert "FMI 2.0 names no folder for ARM" in build
        assert "none in FMI 2.0" in build
    else:
        assert "FMI 2.0 names no folder" not in build


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
