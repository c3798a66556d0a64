"""The runtime's own elementary functions (src/loomfmu/runtime/lf_math.c):
generated coefficients, accuracy against mpmath, C99's special values, the
same bits natively, under wine and under qemu-aarch64, and generated model
code that calls them.  tests/c/math_probe.c evaluates them."""
from __future__ import annotations

import importlib.util
import re
import struct
import subprocess
from pathlib import Path

import casadi as ca
import mpmath as mp
import numpy as np
import pytest

from loomfmu.export.codegen import MATH_FUNCTIONS, use_runtime_math
from loomfmu.export.runtime_files import RUNTIME_DIR
from loomfmu.fmu.platform_run import missing_tools, wine_env
from loomfmu.fmu.platforms import PLATFORMS

ROOT = Path(__file__).resolve().parent.parent
PROBE = ROOT / "tests" / "c" / "math_probe.c"
MATH_SOURCES = [str(RUNTIME_DIR / f) for f in ("lf_math.c", "lf_trig.c")]
FLAGS = ["-std=c99", "-O2", "-ffp-contract=off", "-Wall", "-Wextra", "-Werror"]

#: largest error in ulp allowed per function (lf_math.h; measured by
#: benchmarks/math_functions.py)
MAX_ULP = {"sin": 1, "cos": 1, "exp": 1, "log": 1, "atan": 1, "pow": 1.2, "hypot": 1,
           "expm1": 1.5, "log1p": 1.5, "tan": 2, "asin": 2, "acos": 2, "atan2": 2,
           "sinh": 2, "cosh": 2, "tanh": 2, "log10": 2, "asinh": 2, "acosh": 2.5, "atanh": 2}
MP = {"log": mp.log, "asin": mp.asin, "acos": mp.acos, "atan2": mp.atan2, "pow": mp.power}


def _probe(work: Path, platform: str = "linux64", libm: bool = False) -> Path:
    p = PLATFORMS[platform]
    exe = work / f"probe_{platform}{'_libm' if libm else ''}{'.exe' if p.windows else ''}"
    subprocess.run([p.cc, *FLAGS, *(["-DPROBE_LIBM"] if libm else []), f"-I{RUNTIME_DIR}",
                    str(PROBE), *MATH_SOURCES, "-o", str(exe),
                    *(["-static-libgcc"] if p.windows else ["-lm"])], check=True)
    return exe


def _run(exe: Path, n: int, platform: str = "linux64") -> list[tuple[str, str, str, str]]:
    """(function, bits of the arguments and of the result in hex) per call."""
    p = PLATFORMS[platform]
    out = subprocess.run([*p.emulator, str(exe), str(n)], capture_output=True, text=True,
                         check=True, env=wine_env() if p.windows else None, timeout=300).stdout
    rows = []
    for line in out.replace("\r", "").splitlines():
        rows.append(tuple(line.split()))
    return rows


def _double(hexbits: str) -> float:
    return struct.unpack(">d", bytes.fromhex(hexbits))[0]


@pytest.fixture(scope="module")
def native(tmp_path_factory):
    work = tmp_path_factory.mktemp("lf_math")
    return work, _run(_probe(work), 1000)


_spec = importlib.util.spec_from_file_location(
    "math_functions", ROOT / "benchmarks" / "math_functions.py")
gen = importlib.util.module_from_spec(_spec)  # the coefficients' generator and ulp measure
_spec.loader.exec_module(gen)


def test_the_coefficients_are_what_the_generator_writes():
    assert (RUNTIME_DIR / "lf_math_coeffs.h").read_text() == gen.header_text(), (
        "run python benchmarks/math_functions.py --coefficients")


def test_accuracy_against_mpmath(native):
    """On 1 000 arguments per function spread over its domain (huge ones
    for sin and cos): the largest error in ulp against mpmath at 40 digits."""
    _, rows = native
    worst: dict[str, float] = {}
    seen: dict[str, int] = {}
    with mp.workdps(40):
        for name, ahex, bhex, r in rows:
            a, b = _double(ahex), _double(bhex)
            seen[name] = seen.get(name, 0) + 1
            if seen[name] <= 20 * (20 if name in ("atan2", "pow", "hypot") else 1):
                continue  # the special arguments come first
            fn = MP[name] if name in MP else getattr(mp, name)
            exact = fn(mp.mpf(a), mp.mpf(b)) if name in ("atan2", "pow", "hypot") else fn(
                mp.mpf(a))
            if isinstance(exact, mp.mpc) or not mp.isfinite(exact) or abs(exact) > 1.7e308 \
                    or (exact != 0 and abs(exact) < 2.3e-308):
                continue
            worst[name] = max(worst.get(name, 0.0), gen.ulps(_double(r), exact))
    assert set(worst) == set(MAX_ULP)
    over = {k: round(v, 3) for k, v in worst.items() if v > MAX_ULP[k]}
    assert not over, over
    assert min(worst.values()) > 0.3  # the measurement sees rounding at all


def test_special_values_are_the_c_librarys(native):
    """±0, subnormals, ±1, ±max, ±Inf, NaN and overflowing arguments (each
    pair of them for atan2, pow and hypot): the C library's result bit for
    bit, NaN for NaN; results that are neither 0, infinite nor NaN within
    2 ulp (the C library rounds some correctly where ours is 1 ulp off)."""
    work, ours = native
    libm = _run(_probe(work, libm=True), 0)
    special = {row[:3] for row in libm}
    ours = [row for row in ours if row[:3] in special]
    assert len(ours) == len(libm) > 1000
    bad = []
    for (name, a, b, r), (_, _, _, want) in zip(ours, libm):
        x, y = _double(r), _double(want)
        if np.isnan(y) or np.isnan(x):
            ok = np.isnan(x) and np.isnan(y)
        elif not np.isfinite(y) or y == 0 or not np.isfinite(x) or x == 0:
            ok = r == want
        else:
            ok = (x > 0) == (y > 0) and abs(int(r, 16) - int(want, 16)) <= 2
        if not ok:
            bad.append((name, _double(a), _double(b), x, y))
    assert not bad, bad[:10]


@pytest.mark.parametrize("platform", ["win64", "aarch64"])
def test_the_same_bits_on_every_platform(native, platform):
    """Every function on 1 000 arguments each and the special ones: the bits
    of the native run under wine and under qemu-aarch64 (the C libraries'
    own functions differ: benchmarks/platforms.py --libm)."""
    why = missing_tools(platform)
    if why:
        pytest.skip(f"{platform}: {why}")
    work, rows = native
    other = _run(_probe(work, platform), 1000, platform)
    assert len(other) == len(rows)
    differ = [(a, b[3]) for a, b in zip(rows, other) if a != b]
    assert not differ, differ[:10]


def test_generated_code_calls_the_runtime_functions(tmp_path):
    """Every C library function CasADi emits for an elementary operation is
    replaced, the file compiles with the runtime's header, and gives the
    runtime's values."""
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    ops = [ca.sin(x), ca.cos(x), ca.tan(x), ca.asin(x / 4), ca.acos(x / 4), ca.atan(x),
           ca.atan2(x, y), ca.sinh(x), ca.cosh(x), ca.tanh(x), ca.exp(x), ca.log(x),
           ca.log10(x), x ** y, ca.expm1(x), ca.log1p(x), ca.hypot(x, y), ca.asinh(x),
           ca.acosh(x + 1), ca.atanh(x / 4), ca.sqrt(x), ca.floor(x)]
    f = ca.Function("probe_f", [x, y], [ca.vertcat(*ops)])
    cg = ca.CodeGenerator("probe_f.c", {"with_header": True, "casadi_real": "double"})
    cg.add(f)
    cg.generate(str(tmp_path) + "/")
    raw = (tmp_path / "probe_f.c").read_text()
    apart, src = use_runtime_math(raw, pair=False), use_runtime_math(raw)
    left = re.findall(r"(?<![\w.])(" + "|".join(MATH_FUNCTIONS) + r")\(", src)
    assert not left, left
    for ours in set(MATH_FUNCTIONS.values()) - {"lf_log10"}:  # CasADi writes log(x)/log(10)
        assert ours + "(" in apart, ours
    (tmp_path / "probe_f.c").write_text(src)
    (tmp_path / "lf_prefix.h").write_text("")
    (tmp_path / "main.c").write_text(
        '#include <stdio.h>\n#include "probe_f.h"\n'
        "int main(void) { double a[2] = {0.75, 1.5}, r[22]; const double *arg[2] = {a, a + 1};\n"
        "double *res[1] = {r}; long long iw[64]; double w[256]; int i;\n"
        "probe_f(arg, res, iw, w, 0);\n"
        'for (i = 0; i < 22; i++) printf("%.17g\\n", r[i]); return 0; }\n')
    exe = tmp_path / "probe_f"
    subprocess.run(["gcc", *FLAGS[:3], f"-I{tmp_path}", f"-I{RUNTIME_DIR}",
                    str(tmp_path / "main.c"), str(tmp_path / "probe_f.c"),
                    *MATH_SOURCES, "-lm", "-o", str(exe)], check=True)
    got = [float(v) for v in subprocess.run([str(exe)], capture_output=True, text=True,
                                            check=True).stdout.split()]
    want = f(0.75, 1.5).full().ravel()  # CasADi's own evaluation: the C library's
    assert np.allclose(got, want, rtol=4e-16, atol=0)


def test_sin_and_cos_of_one_value_share_one_reduction(tmp_path):
    """CasADi writes cos(j x) and sin(j x) apart, each of its own copy of
    j x: the generated code computes each pair with one lf_sincos, and gives
    the bits of the separate calls."""
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    ops = [c * ca.cos(j * x) + s * ca.sin(j * x) for j, (c, s) in
           enumerate([(0.3, -1.2), (2.0, 0.7), (-0.4, 0.1), (1.1, 1.3)], 1)]
    ops += [ca.sin(x + y) * ca.cos(x + y), ca.cos(y), ca.sin(x * y), ca.cos(x) ** 2]
    f = ca.Function("pair_f", [x, y], [ca.vertcat(*ops)])
    cg = ca.CodeGenerator("pair_f.c", {"with_header": True, "casadi_real": "double"})
    cg.add(f)
    cg.generate(str(tmp_path) + "/")
    raw = (tmp_path / "pair_f.c").read_text()
    (tmp_path / "lf_prefix.h").write_text("")
    (tmp_path / "main.c").write_text(
        '#include <stdio.h>\n#include <string.h>\n#include "pair_f.h"\n'
        "int main(void) { double a[2], r[8]; const double *arg[2] = {a, a + 1};\n"
        "double *res[1] = {r}; long long iw[64]; double w[256]; int i, k;\n"
        "for (k = 0; k < 200; k++) { a[0] = -40.0 + 0.4 * k; a[1] = 1e3 - 17.0 * k;\n"
        "probe: pair_f(arg, res, iw, w, 0);\n"
        "for (i = 0; i < 8; i++) { unsigned long long u; memcpy(&u, r + i, 8);\n"
        'printf("%llx\\n", u); } } return 0; }\n'.replace("probe: ", ""))
    outs = []
    for pair in (True, False):
        src = use_runtime_math(raw, pair=pair)
        assert (src.count("lf_sincos(") == 5) == pair  # j x for j = 1..4, and x + y
        (tmp_path / "pair_f.c").write_text(src)
        exe = tmp_path / f"pair_{pair}"
        subprocess.run(["gcc", *FLAGS[:3], f"-I{tmp_path}", f"-I{RUNTIME_DIR}",
                        str(tmp_path / "main.c"), str(tmp_path / "pair_f.c"), *MATH_SOURCES,
                        "-lm", "-o", str(exe)], check=True)
        outs.append(subprocess.run([str(exe)], capture_output=True, text=True,
                                   check=True).stdout)
    assert outs[0] == outs[1] and len(outs[0].split()) == 1600
