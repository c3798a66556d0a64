"""The runtime's own elementary functions (src/loomfmu/runtime/lf_math.c):
their coefficients, their accuracy and their speed against the C library.

    python benchmarks/math_functions.py --coefficients   # rewrite lf_math_coeffs.h
    python benchmarks/math_functions.py [--json docs/results/math_functions.json]
    python benchmarks/math_functions.py --table-from docs/results/math_functions.json

Every coefficient and constant of lf_math.c comes from here: polynomials
fitted with mpmath at 50 digits (least squares on Chebyshev points, in the
relative error) and constants rounded from mpmath's values, printed so that
any C99 compiler reads back the same double.  ``--coefficients`` writes the
header; tests/test_lf_math.py checks that the file in the tree is what this
script writes.

Without ``--coefficients``: compile a probe of lf_math.c and the C library
(gcc -O2 -ffp-contract=off), evaluate each function on 200 000 arguments
spread over the ranges below, and report the largest error in units in the
last place against mpmath (on a 4 000-argument subset, all arguments for the
elementary checks) and the nanoseconds per call of ours and the C library's.
"""
from __future__ import annotations

import argparse
import json
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mpmath as mp

ROOT = Path(__file__).resolve().parent.parent
RUNTIME = ROOT / "src" / "loomfmu" / "runtime"
MATH_SOURCES = [str(RUNTIME / f) for f in ("lf_math.c", "lf_trig.c")]
HEADER = RUNTIME / "lf_math_coeffs.h"

mp.mp.dps = 50


def _cheb_points(a, b, n):
    return [(a + b) / 2 + (b - a) / 2 * mp.cos(mp.pi * (k + mp.mpf(1) / 2) / n) for k in range(n)]


def fit(g, a, b, degree: int, n_points: int = 160) -> tuple[list[float], float]:
    """Coefficients c_0..c_degree (rounded to doubles) of a polynomial in z
    close to g(z) on [a, b] in the relative error, and that error's largest
    value over 2 000 points (with the rounded coefficients)."""
    a, b = mp.mpf(a), mp.mpf(b)
    zs = _cheb_points(a, b, n_points)
    rows = [[z ** j / g(z) for j in range(degree + 1)] for z in zs]
    rhs = [mp.mpf(1) for _ in zs]
    coef = mp.qr_solve(mp.matrix(rows), mp.matrix(rhs))[0]
    rounded = [float(c) for c in coef]
    worst = mp.mpf(0)
    for k in range(2001):
        z = a + (b - a) * k / 2000
        p = mp.mpf(0)
        for c in reversed(rounded):
            p = p * z + mp.mpf(c)
        worst = max(worst, abs(p / g(z) - 1))
    return rounded, float(worst)


def _split(x, bits: int) -> float:
    """x rounded toward zero to its leading ``bits`` significant bits."""
    x = mp.mpf(x)
    e = int(mp.floor(mp.log(abs(x), 2)))
    scale = mp.mpf(2) ** (bits - 1 - e)
    return float(mp.floor(x * scale) / scale)


def _hi_lo(x) -> tuple[float, float]:
    hi = float(mp.mpf(x))
    return hi, float(mp.mpf(x) - hi)


def kernels() -> dict[str, tuple[list[float], float, str]]:
    """Name: (coefficients, relative error of the fit, what they approximate)."""
    out = {}
    half_ln2 = mp.log(2) / 2

    def e_exp(r):  # (exp(r) - 1 - r) / r^2
        return (mp.exp(r) - 1 - r) / r ** 2 if r != 0 else mp.mpf(1) / 2
    out["EXP"] = (*fit(e_exp, -half_ln2, half_ln2, 10),
                  "(exp(r) - 1 - r) / r^2 in r, |r| <= ln(2)/2")

    smax = (mp.sqrt(2) - 1) / (mp.sqrt(2) + 1)

    def e_log(z):  # (2 atanh(s) / s - 2) / z, z = s^2
        s = mp.sqrt(z)
        return (2 * mp.atanh(s) / s - 2) / z if z != 0 else mp.mpf(2) / 3
    out["LOG"] = (*fit(e_log, 0, smax ** 2, 7),
                  "(2 atanh(s)/s - 2) / s^2 in z = s^2, s = f/(2+f), 1+f in [sqrt(1/2), sqrt(2))")

    q = (mp.pi / 4) ** 2

    def e_sin(z):
        r = mp.sqrt(z)
        return (mp.sin(r) - r) / r ** 3 if z != 0 else -mp.mpf(1) / 6
    out["SIN"] = (*fit(e_sin, 0, q, 6), "(sin(r) - r) / r^3 in z = r^2, |r| <= pi/4")

    def e_cos(z):
        r = mp.sqrt(z)
        return (mp.cos(r) - 1 + z / 2) / z ** 2 if z != 0 else mp.mpf(1) / 24
    out["COS"] = (*fit(e_cos, 0, q, 6), "(cos(r) - 1 + r^2/2) / r^4 in z = r^2, |r| <= pi/4")

    def e_atan(z):
        t = mp.sqrt(z)
        return (mp.atan(t) - t) / t ** 3 if z != 0 else -mp.mpf(1) / 3
    out["ATAN"] = (*fit(e_atan, 0, (mp.mpf(7) / 16) ** 2, 11),
                   "(atan(t) - t) / t^3 in z = t^2, |t| <= 7/16")
    return out


def constants() -> dict[str, tuple[float, str]]:
    ln2 = mp.log(2)
    pio2 = mp.pi / 2
    c = {}
    c["LN2_HI"] = (_split(ln2, 32), "ln 2 to 32 bits: k * LN2_HI is exact for |k| < 2^21")
    c["LN2_LO"] = (float(ln2 - mp.mpf(c["LN2_HI"][0])), "ln 2 - LN2_HI")
    c["INV_LN2"] = (float(1 / ln2), "1 / ln 2")
    c["INV_LN10_HI"] = (_split(1 / mp.log(10), 32), "1 / ln 10 to 32 bits")
    c["INV_LN10_LO"] = (float(1 / mp.log(10) - mp.mpf(c["INV_LN10_HI"][0])),
                        "1 / ln 10 - INV_LN10_HI")
    c["TWO_OVER_PI"] = (float(2 / mp.pi), "2 / pi")
    rest = pio2
    for k in (1, 2, 3):  # pi/2 = PIO2_1 + PIO2_2 + PIO2_3 + PIO2_3T, 33 bits each
        part = _split(rest, 33)
        c[f"PIO2_{k}"] = (part, f"bits {33 * (k - 1) + 1}..{33 * k} of pi/2: n * PIO2_{k} "
                          "is exact for |n| < 2^20")
        rest -= mp.mpf(part)
        c[f"PIO2_{k}T"] = (float(rest), "pi/2 - " + " - ".join(f"PIO2_{j}" for j in range(1, k + 1)))
    for name, value in (("TWO_THIRDS", mp.mpf(2) / 3), ("ATAN_HALF", mp.atan(mp.mpf(1) / 2)),
                        ("PIO4", mp.pi / 4),
                        ("ATAN_3HALF", mp.atan(mp.mpf(3) / 2)), ("PIO2", pio2),
                        ("PI", mp.pi)):
        hi, lo = _hi_lo(value)
        c[f"{name}_HI"] = (hi, f"{name.lower()} rounded")
        c[f"{name}_LO"] = (lo, f"{name.lower()} - {name}_HI")
    return c


def two_over_pi_words(n_words: int = 38) -> list[int]:
    """The bits of 2/pi after the binary point, 32 to a word, most significant
    first (the argument reduction of huge arguments needs up to bit 1 163)."""
    with mp.workdps(400):
        frac = 2 / mp.pi
        words = []
        for _ in range(n_words):
            frac *= 2 ** 32
            w = int(mp.floor(frac))
            words.append(w)
            frac -= w
    return words


def header_text() -> str:
    lines = ["/* Coefficients and constants of lf_math.c.  Generated by",
             " * `python benchmarks/math_functions.py --coefficients` (mpmath, 50 digits):",
             " * do not edit.  Each polynomial is fitted in the relative error; the",
             " * comment gives what it approximates and the fit's largest relative",
             " * error with the rounded coefficients (the rounding of the arithmetic",
             " * comes on top). */", "#ifndef LF_MATH_COEFFS_H", "#define LF_MATH_COEFFS_H", ""]
    for name, (value, what) in constants().items():
        lines.append(f"#define LF_M_{name} {value!r} /* {what} */")
    lines.append("")
    words = two_over_pi_words()
    lines.append(f"/* 2/pi: bits 1..{32 * len(words)} after the binary point, 32 to a word */")
    lines.append(f"#define LF_M_TWO_OVER_PI_WORDS {len(words)}")
    lines.append("#define LF_M_TWO_OVER_PI_BITS \\")
    for k in range(0, len(words), 6):
        chunk = ", ".join(f"0x{w:08x}UL" for w in words[k:k + 6])
        lines.append(f"    {chunk}" + (", \\" if k + 6 < len(words) else ""))
    lines.append("")
    for name, (coef, err, what) in kernels().items():
        lines.append(f"/* {what}: relative error {err:.1e} */")
        for j, cj in enumerate(coef):
            lines.append(f"#define LF_M_{name}{j} {cj!r}")
        lines.append("")
    lines += ["#endif", ""]
    return "\n".join(lines)


# ---------------------------------------------------------------- measuring
FUNCTIONS = {  # name: (arity, argument generator over u, v in [0, 1), mpmath function)
    "sin": (1, lambda u, v: (u - 0.5) * 40, mp.sin),
    "sin_large": (1, lambda u, v: (u - 0.5) * 2e6, mp.sin),
    "cos": (1, lambda u, v: (u - 0.5) * 40, mp.cos),
    "tan": (1, lambda u, v: (u - 0.5) * 6, mp.tan),
    "exp": (1, lambda u, v: (u - 0.5) * 1400, mp.exp),
    "exp_small": (1, lambda u, v: (u - 0.5) * 4, mp.exp),
    "expm1": (1, lambda u, v: (u - 0.5) * 4, mp.expm1),
    "log": (1, lambda u, v: 10 ** ((u - 0.5) * 40), mp.log),
    "log_near1": (1, lambda u, v: 0.5 + u, mp.log),
    "log1p": (1, lambda u, v: (u - 0.1) * 2, mp.log1p),
    "log10": (1, lambda u, v: 10 ** ((u - 0.5) * 40), mp.log10),
    "pow": (2, lambda u, v: (4 * u, (v - 0.5) * 20), mp.power),
    "pow_wide": (2, lambda u, v: (10 ** ((u - 0.5) * 20), (v - 0.5) * 30), mp.power),
    "pow_large": (2, lambda u, v: (0.5 + 1.5 * u, (v - 0.5) * 1400 / _ln(0.5 + 1.5 * u)),
                  mp.power),
    "tanh": (1, lambda u, v: (u - 0.5) * 10, mp.tanh),
    "sinh": (1, lambda u, v: (u - 0.5) * 10, mp.sinh),
    "cosh": (1, lambda u, v: (u - 0.5) * 10, mp.cosh),
    "atan": (1, lambda u, v: (u - 0.5) * 10, mp.atan),
    "atan2": (2, lambda u, v: ((u - 0.5) * 4, (v - 0.5) * 4), mp.atan2),
    "asin": (1, lambda u, v: 2 * u - 1, mp.asin),
    "acos": (1, lambda u, v: 2 * u - 1, mp.acos),
    "hypot": (2, lambda u, v: ((u - 0.5) * 1e3, (v - 0.5) * 1e3), mp.hypot),
    "asinh": (1, lambda u, v: (u - 0.5) * 10, mp.asinh),
    "acosh": (1, lambda u, v: 1 + u * 10, mp.acosh),
    "atanh": (1, lambda u, v: 2 * u - 1, mp.atanh),
}
C_NAME = {"log": "ln"}


def _ln(x):
    """log x for the pow_large arguments, 1 where it is 0 (y then stays finite)."""
    import numpy as np
    lx = np.log(x)
    return np.where(lx == 0, 1.0, lx)


def _probe_source(names) -> str:
    cases = []
    for k, name in enumerate(names):
        base = name.split("_")[0]
        arity = FUNCTIONS[name][0]
        ours, theirs = f"lf_{C_NAME.get(base, base)}", base
        args = "a[i]" if arity == 1 else "a[i], b[i]"
        cases.append(f"    case {k}: for (i = 0; i < n; i++) r[i] = ours ? {ours}({args}) : "
                     f"{theirs}({args}); break;")
    return "\n".join([
        '#include <math.h>', '#include <stdio.h>', '#include <stdlib.h>', '#include <time.h>',
        '#include "lf_math.h"',
        "int main(int argc, char **argv) {",
        "    int f = atoi(argv[1]), ours = atoi(argv[2]), reps = atoi(argv[3]);",
        "    long n, i; int k; double *a, *b, *r; clock_t t0; FILE *in = fopen(argv[4], \"rb\");",
        "    if (!in || fread(&n, sizeof n, 1, in) != 1) return 1;",
        "    a = malloc(n * 8); b = malloc(n * 8); r = malloc(n * 8);",
        "    if (fread(a, 8, n, in) != (size_t)n || fread(b, 8, n, in) != (size_t)n) return 1;",
        "    t0 = clock();",
        "    for (k = 0; k < reps; k++) switch (f) {", *cases, "    default: return 1; }",
        "    fprintf(stderr, \"%.6e\\n\", (double)(clock() - t0) / CLOCKS_PER_SEC / reps / n);",
        "    fwrite(r, 8, n, stdout);", "    return 0;", "}", ""])


def ulps(x: float, exact) -> float:
    """|x - exact| in units of the last place of the double nearest to exact."""
    e = float(exact)
    if e == 0 or not mp.isfinite(exact):
        return 0.0 if x == e else float("inf")
    b = struct.unpack("<q", struct.pack("<d", abs(e)))[0]
    ulp = struct.unpack("<d", struct.pack("<q", b + 1))[0] - abs(e)
    return float(abs(mp.mpf(x) - exact) / ulp)


def measure(n: int = 200_000, n_exact: int = 4_000) -> dict:
    import numpy as np
    names = list(FUNCTIONS)
    rng = np.random.default_rng(20261129)
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "probe.c").write_text(_probe_source(names))
        subprocess.run(["gcc", "-std=c99", "-O2", "-ffp-contract=off", f"-I{RUNTIME}",
                        str(tmp / "probe.c"), *MATH_SOURCES, "-lm",
                        "-o", str(tmp / "probe")], check=True)
        for k, name in enumerate(names):
            arity, gen, exact_fn = FUNCTIONS[name]
            u, v = rng.random(n), rng.random(n)
            args = gen(u, v)
            a, b = (args, np.zeros(n)) if arity == 1 else args
            a, b = np.asarray(a, float), np.asarray(b, float)
            (tmp / "in.bin").write_bytes(np.int64(n).tobytes() + a.tobytes() + b.tobytes())
            res, ns = {}, {}
            for ours in (1, 0):
                p = subprocess.run([str(tmp / "probe"), str(k), str(ours), "5",
                                    str(tmp / "in.bin")], capture_output=True, check=True)
                res[ours] = np.frombuffer(p.stdout, dtype=float)
                ns[ours] = float(p.stderr) * 1e9
            worst = {0: 0.0, 1: 0.0}
            idx = rng.choice(n, n_exact, replace=False)
            for i in idx:
                ex = exact_fn(mp.mpf(a[i])) if arity == 1 else exact_fn(mp.mpf(a[i]), mp.mpf(b[i]))
                if not mp.isfinite(ex) or abs(ex) > 1.7e308 or (ex != 0 and abs(ex) < 2.3e-308):
                    continue
                for ours in (1, 0):
                    worst[ours] = max(worst[ours], ulps(res[ours][i], ex))
            out[name] = {"max_ulp_ours": round(worst[1], 3), "max_ulp_libm": round(worst[0], 3),
                         "ns_ours": round(ns[1], 2), "ns_libm": round(ns[0], 2),
                         "differing_from_libm": int(np.sum(res[1] != res[0]))}
    return out


def table(data: dict) -> str:
    """The measurement as a markdown table."""
    rows = ["| function | arguments | largest error, ours (ulp) | glibc's (ulp) | ns per call, "
            "ours | glibc's |", "|---|---|---|---|---|---|"]
    ranges = {"sin": "(-20, 20)", "sin_large": "(-1e6, 1e6)", "cos": "(-20, 20)",
              "tan": "(-3, 3)", "exp": "(-700, 700)", "exp_small": "(-2, 2)",
              "expm1": "(-2, 2)", "log": "1e-20 ... 1e20", "log_near1": "(0.5, 1.5)",
              "log1p": "(-0.2, 1.8)", "log10": "1e-20 ... 1e20", "pow": "x in (0, 4), y in (-10, 10)",
              "pow_wide": "x 1e-10 ... 1e10, y in (-15, 15)",
              "pow_large": "x in (0.5, 2), y log x in (-700, 700)", "tanh": "(-5, 5)",
              "sinh": "(-5, 5)", "cosh": "(-5, 5)", "atan": "(-5, 5)", "atan2": "(-2, 2)^2",
              "asin": "(-1, 1)", "acos": "(-1, 1)", "hypot": "(-500, 500)^2",
              "asinh": "(-5, 5)", "acosh": "(1, 11)", "atanh": "(-1, 1)"}
    for name, r in data["functions"].items():
        rows.append(f"| {name.split('_')[0]} | {ranges.get(name, '')} | {r['max_ulp_ours']:.2f} | "
                    f"{r['max_ulp_libm']:.2f} | {r['ns_ours']:.0f} | {r['ns_libm']:.0f} |")
    return "\n".join(rows) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--coefficients", action="store_true", help=f"rewrite {HEADER.name}")
    ap.add_argument("--json", type=Path, help="write the measurement there")
    ap.add_argument("--table-from", type=Path, help="print the table of a measurement")
    args = ap.parse_args(argv)
    if args.table_from:
        print(table(json.loads(args.table_from.read_text())), end="")
        return 0
    if args.coefficients:
        HEADER.write_text(header_text())
        print(f"wrote {HEADER.relative_to(ROOT)}")
        return 0
    t0 = time.time()
    data = measure()
    print(f"{'function':12} {'ulp ours':>9} {'ulp libm':>9} {'ns ours':>8} {'ns libm':>8} "
          f"{'differ':>7}")
    for name, row in data.items():
        print(f"{name:12} {row['max_ulp_ours']:9.3f} {row['max_ulp_libm']:9.3f} "
              f"{row['ns_ours']:8.1f} {row['ns_libm']:8.1f} {row['differing_from_libm']:7d}")
    if args.json:
        import importlib.metadata
        args.json.write_text(json.dumps({
            "command": "python benchmarks/math_functions.py --json " + str(args.json),
            "loomfmu": importlib.metadata.version("loomfmu"),
            "wall_s": round(time.time() - t0, 1), "functions": data}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
