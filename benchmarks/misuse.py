"""Misuse, bad values and corrupted FMU states against sanitizer builds of
the FMUs, and write docs/results/reliability.json.

    .venv/bin/python benchmarks/misuse.py                 # every model
    .venv/bin/python benchmarks/misuse.py backrest drive  # some
    .venv/bin/python benchmarks/misuse.py --baseline COMMIT backrest drive
                                      # the same cases against the facade and
                                      # serializer of COMMIT (printed)

For each model the FMU is built, its sources (``sources/`` of the .fmu) are
compiled together with the driver ``tests/c/misuse.c`` into one program with
``-fsanitize=address,undefined`` (LeakSanitizer included), and every misuse
case of the driver runs in its own process: a crash, an out-of-bounds access,
undefined behaviour or a leak ends that process and is counted as
"crashed", never taking the others down.  A case is "refused" when every
misuse call returned fmi2Error (or NULL) with a log line and the simulation
then continued bit for bit as an untouched one; "OK-with-wrong-answer" when a
misuse call returned OK/Warning and the results changed.

Random one-byte corruptions of a serialized FMU state run in forked
children of the driver, twice: as stored (the checksum must refuse every
one) and resealed (checksum recomputed after the corruption, so only the
field checks stand between the bytes and the solver: no crash is allowed,
while a state that is valid but different is accepted and continues as that
state, "accepted-and-changed").

tests/test_misuse.py runs the same driver on two models with a sample of
the corruptions; this script gives the full counts quoted in docs/results.md.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import time
import zipfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from fmpy import read_model_description

from loomfmu import build_fmu, load_model
from loomfmu.declare.model import Model
from loomfmu.fmu.builder import GENERATED_FLAGS, STRICT_FLAGS, fmi_headers_dir

ROOT = Path(__file__).resolve().parents[1]
DRIVER_SOURCE = ROOT / "tests" / "c" / "misuse.c"
SANITIZE = ("-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-g", "-O1")
#: exit code of AddressSanitizer/LeakSanitizer findings (UBSan aborts)
SANITIZER_EXIT = 86
SANITIZER_ENV = {
    "ASAN_OPTIONS": f"detect_leaks=1:exitcode={SANITIZER_EXIT}:abort_on_error=0",
    "UBSAN_OPTIONS": "halt_on_error=1:print_stacktrace=1",
}
CASE_LINE = re.compile(r"^case (\S+) kind (\S+) verdict (\S+) calls (\d+)$", re.M)
CORRUPT_LINE = re.compile(r"^corrupt bytes (\d+) tried (\d+) refused (\d+) identical (\d+) "
                          r"changed (\d+) refused_changed (\d+) silent (\d+) crashed (\d+)$", re.M)


@dataclass
class Driver:
    """The misuse program of one model and the communication step it uses."""
    model: str
    binary: Path
    h: float


@dataclass
class CaseResult:
    case: str
    verdict: str      # refused, clean, silent, accepted, ok-wrong, changed, crashed, hung
    returncode: int | None
    stderr: str


def _compile(cmd: list[str]) -> None:
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"command failed ({proc.returncode}): {' '.join(cmd)}\n"
                           f"{proc.stdout}{proc.stderr}")


#: the FMI facade and the state serializer (replaced by --baseline)
BASELINE_FILES = ("lf_fmi2.c", "lf_state.c", "lf_state.h")
#: files split out of lf_fmi2.c since (dropped from a --baseline build)
SPLIT_FROM_FACADE = ("lf_fmi2_state.c",)


def build_driver(model: Model, out_dir: Path, *, sanitize: bool = True, jobs: int = 2,
                 baseline: str | None = None) -> Driver:
    """Build ``model``'s FMU into ``out_dir`` and compile the misuse driver
    with the FMU's own sources (sanitizers on unless ``sanitize`` is False).
    ``baseline``: a git revision whose BASELINE_FILES replace the FMU's, to
    count what an earlier runtime did with the same cases."""
    out_dir = Path(out_dir)
    fmu = build_fmu(model, out_dir=out_dir, validate=False).path
    work = out_dir / f"{model.name}_misuse"
    src = work / "sources"
    with zipfile.ZipFile(fmu) as z:
        for name in z.namelist():
            if name.startswith("sources/"):
                z.extract(name, work)
    if baseline:  # the earlier facade holds the FMU-state functions itself
        for name in SPLIT_FROM_FACADE:
            (src / name).unlink(missing_ok=True)
    for name in BASELINE_FILES if baseline else ():
        (src / name).write_text(subprocess.run(
            ["git", "show", f"{baseline}:src/loomfmu/runtime/{name}"], cwd=ROOT,
            capture_output=True, text=True, check=True).stdout)
    generated = {p.name for p in src.glob("*_casadi.c")}
    extra = SANITIZE if sanitize else ("-O1",)
    include = ["-I", str(src), "-I", str(fmi_headers_dir())]
    objs, cmds = [], []
    for c_file in sorted(src.glob("*.c")) + [DRIVER_SOURCE]:
        flags = GENERATED_FLAGS if c_file.name in generated else STRICT_FLAGS
        obj = work / (c_file.stem + ".o")
        cmds.append(["gcc", *flags, *extra, *include, "-c", str(c_file), "-o", str(obj)])
        objs.append(str(obj))
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        list(pool.map(_compile, cmds))
    binary = work / "misuse"
    _compile(["gcc", *extra, "-o", str(binary), *objs, "-lm"])
    experiment = read_model_description(str(fmu)).defaultExperiment
    return Driver(model.name, binary, float(experiment.stopTime) / 100)


def _env() -> dict[str, str]:
    return {**os.environ, **SANITIZER_ENV}


def list_cases(driver: Driver) -> list[str]:
    out = subprocess.run([str(driver.binary), "list"], capture_output=True, text=True,
                         check=True, env=_env())
    return out.stdout.split()


def run_case(binary: Path | str, case: str, h: float, *, timeout: float = 120) -> CaseResult:
    """Run one case in its own process.  No case line, or an exit code other
    than 0/1 (signal, sanitizer report), is a crash."""
    try:
        proc = subprocess.run([str(binary), "case", case, repr(h)], capture_output=True,
                              text=True, timeout=timeout, env=_env())
    except subprocess.TimeoutExpired as e:
        return CaseResult(case, "hung", None, str(e.stderr or "")[-2000:])
    m = CASE_LINE.search(proc.stdout)
    if proc.returncode not in (0, 1) or not m:
        return CaseResult(case, "crashed", proc.returncode, proc.stderr[-4000:])
    return CaseResult(case, m.group(3), proc.returncode, proc.stderr[-2000:])


def run_corruptions(driver: Driver, *, seed: int, n: int, reseal: bool,
                    timeout: float = 1800) -> dict[str, int]:
    """``n`` random one-byte corruptions (forked children of one driver
    process); counts by outcome.  A crash of the driver itself is reported
    as all ``n`` crashed."""
    proc = subprocess.run([str(driver.binary), "corrupt", str(seed), str(n), repr(driver.h),
                           "1" if reseal else "0"], capture_output=True, text=True,
                          timeout=timeout, env=_env())
    m = CORRUPT_LINE.search(proc.stdout)
    if proc.returncode != 0 or not m:
        return {"bytes": 0, "tried": n, "refused": 0, "accepted_identical": 0,
                "accepted_changed": 0, "refused_but_changed": 0, "refused_silently": 0,
                "crashed": n, "stderr": proc.stderr[-2000:]}
    keys = ("bytes", "tried", "refused", "accepted_identical", "accepted_changed",
            "refused_but_changed", "refused_silently", "crashed")
    counts = dict(zip(keys, (int(g) for g in m.groups())))
    if counts["crashed"]:
        counts["stderr"] = proc.stderr[-2000:]
    return counts


def summarize_cases(results: list[CaseResult]) -> dict[str, int]:
    verdicts = [r.verdict for r in results]
    return {
        "tried": len(results),
        "refused": verdicts.count("refused"),
        "clean": verdicts.count("clean"),
        "crashed": verdicts.count("crashed") + verdicts.count("hung"),
        "ok_with_wrong_answer": verdicts.count("ok-wrong"),
        "accepted_same_answer": verdicts.count("accepted"),
        "refused_silently": verdicts.count("silent"),
        "refused_but_changed": verdicts.count("changed"),
    }


def measure(name: str, out_dir: Path, n_corrupt: int, seed: int,
            baseline: str | None = None) -> dict:
    t0 = time.perf_counter()
    driver = build_driver(load_model(name), out_dir, baseline=baseline)
    built = time.perf_counter() - t0
    results = [run_case(driver.binary, c, driver.h) for c in list_cases(driver)]
    # a baseline has no sealed layout to reseal
    modes = ("stored",) if baseline else ("stored", "resealed")
    corrupt = {mode: run_corruptions(driver, seed=seed, n=n_corrupt, reseal=mode == "resealed")
               for mode in modes}
    return {
        "communication_step": driver.h,
        "build_seconds": round(built, 1),
        "run_seconds": round(time.perf_counter() - t0 - built, 1),
        "cases": summarize_cases(results),
        "failures": [{"case": r.case, "verdict": r.verdict, "returncode": r.returncode,
                      "stderr": r.stderr[-600:]} for r in results
                     if r.verdict not in ("refused", "clean")],
        "corruptions": corrupt,
    }


def _total(per_model: dict, key: str, sub: str | None = None) -> dict[str, int]:
    out: dict[str, int] = {}
    for m in per_model.values():
        block = m[key][sub] if sub else m[key]
        for k, v in block.items():
            if isinstance(v, int) and k != "bytes":
                out[k] = out.get(k, 0) + v
    return out


def main(argv: list[str] | None = None) -> int:
    from loomfmu.registry import MODELS
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("models", nargs="*", help=f"models (default: all of {', '.join(MODELS)})")
    p.add_argument("--corruptions", type=int, default=2000,
                   help="random one-byte corruptions per model and mode (default 2000)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--out", default=None,
                   help="JSON report (default docs/results/reliability.json; none with --baseline)")
    p.add_argument("--work", default=None, help="build folder (default: a temporary one)")
    p.add_argument("--baseline", default=None, metavar="REV",
                   help="count with the FMI facade and state serializer of git revision REV "
                        "(cases that need the sealed state layout do not apply); "
                        "results are printed, and written only with --out")
    args = p.parse_args(argv)
    models = args.models or list(MODELS)
    unknown = [m for m in models if m not in MODELS]
    if unknown:
        p.error(f"unknown model(s) {unknown}; allowed: {', '.join(MODELS)}")
    if args.corruptions < 1:
        p.error(f"--corruptions = {args.corruptions}; allowed: >= 1")
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(args.work or tmp)
        per_model, failed = {}, []
        for name in models:
            print(f"{name}: building the sanitizer build and running the cases ...", flush=True)
            try:
                per_model[name] = measure(name, work, args.corruptions, args.seed,
                                          args.baseline)
            except (RuntimeError, subprocess.SubprocessError) as e:  # build failed
                print(f"  {name} not measured: {e}", flush=True)
                failed.append(name)
                continue
            c = per_model[name]["cases"]
            print(f"  cases {c['tried']}: refused {c['refused']}, clean {c['clean']}, crashed "
                  f"{c['crashed']}, OK-with-wrong-answer {c['ok_with_wrong_answer']} "
                  f"({per_model[name]['run_seconds']} s)", flush=True)
            for mode, k in per_model[name]["corruptions"].items():
                print(f"  one-byte corruptions ({mode}): tried {k['tried']}, refused "
                      f"{k['refused']}, accepted-and-identical {k['accepted_identical']}, "
                      f"accepted-and-changed {k['accepted_changed']}, crashed {k['crashed']}",
                      flush=True)
    report = {
        "command": " ".join(["python benchmarks/misuse.py",
                             *(argv if argv is not None else sys.argv[1:])]),
        "baseline": args.baseline,
        "sanitizers": " ".join(SANITIZE),
        "driver": "tests/c/misuse.c",
        "seed": args.seed,
        "corruptions_per_model_and_mode": args.corruptions,
        "total": {
            "cases": _total(per_model, "cases"),
            "corruptions_stored": _total(per_model, "corruptions", "stored"),
            **({} if args.baseline else
               {"corruptions_resealed": _total(per_model, "corruptions", "resealed")}),
        },
        "models": per_model,
        "not_measured": failed,
    }
    out = args.out or (None if args.baseline else str(ROOT / "docs" / "results" / "reliability.json"))
    t = report["total"]
    for key, block in t.items():
        print(f"total {key}: {block}")
    if out:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        Path(out).write_text(json.dumps(report, indent=1) + "\n")
        print(f"written {out}")
    bad = sum(block.get("crashed", 0) + block.get("ok_with_wrong_answer", 0)
              for block in t.values())
    return 1 if bad or failed else 0


if __name__ == "__main__":
    sys.exit(main())
