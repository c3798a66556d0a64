"""Check an FMU against the reference result it carries, with FMPy and numpy only.

    python benchmarks/ls_ref_fmpy_check.py FMU [FMU ...]

No loomfmu code: what any user of the FMU can do. For each FMU it reads
``extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml`` (FMI-LS-REF), the
CSV of role ``result`` and the tolerance annotated there, runs the default
experiment with ``fmpy.simulate_fmu`` in each interface the FMU has (the
DefaultExperiment's stop time and tolerance; its stepSize as the output
interval) and compares every output at the CSV's times: the largest
|y_FMU - y_ref| relative to the output's range in the CSV.

Prints one JSON object per line: {"fmu", "interface", "tolerance", "worst",
"worst_output", "ok", "outputs": {name: deviation}} or {"fmu", "error"}.
Exit 0 if every run is within its tolerance, 1 otherwise.
"""
from __future__ import annotations

import csv
import io
import json
import posixpath
import sys
import xml.etree.ElementTree as ET
import zipfile

import fmpy
import numpy as np

LS_DIR = "extra/org.fmi-standard.fmi-ls-ref"
NS = "{http://fmi-standard.org/fmi-ls-manifest}"
INTERFACES = {"cs": ("coSimulation", "CoSimulation"), "me": ("modelExchange", "ModelExchange")}


def reference(path: str):
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read(f"{LS_DIR}/fmi-ls-manifest.xml"))
        assert root.tag == "fmiReferences", root.tag
        assert root.get(f"{NS}fmi-ls-name") == "org.fmi-standard.fmi-ls-ref"
        rel = next(r for r in root.findall("Related")
                   if r.get("role") == "result" and r.get("type") == "text/csv")
        member = posixpath.normpath(posixpath.join(LS_DIR, rel.get("source")))
        rows = list(csv.reader(io.StringIO(z.read(member).decode())))
    tolerance = {t.get("interface"): float(t.get("maxDeviationRelativeToRange"))
                 for t in rel.iter("Tolerance")}
    data = np.array([[float(c) for c in r] for r in rows[1:] if r])
    assert np.all(np.isfinite(data)), "the reference has a value that is not finite"
    return tolerance, data[:, 0], {n: data[:, k] for k, n in enumerate(rows[0]) if k}


def check(path: str) -> list[dict]:
    tolerance, t_ref, ref = reference(path)
    md = fmpy.read_model_description(path)
    step = float(md.defaultExperiment.stepSize)
    out = []
    for key, (attr, fmi_type) in INTERFACES.items():
        if getattr(md, attr) is None:
            continue
        res = fmpy.simulate_fmu(path, fmi_type=fmi_type, output=list(ref),
                                output_interval=step)
        t = res["time"]
        idx = np.searchsorted(t, t_ref, side="right") - 1  # after an event at that time
        assert np.all(np.abs(t[idx] - t_ref) <= 1e-9 * np.maximum(1, np.abs(t_ref)))
        dev = {}
        for name, r in ref.items():
            span = np.ptp(r) or np.max(np.abs(r)) or 1.0
            dev[name] = float(np.max(np.abs(res[name][idx] - r)) / span)
        worst = max(dev, key=dev.get)
        tol = tolerance[fmi_type]
        out.append({"fmu": path, "interface": key, "tolerance": tol, "worst": dev[worst],
                    "worst_output": worst, "ok": bool(dev[worst] <= tol), "outputs": dev})
    return out


def main(paths: list[str]) -> int:
    ok = True
    for path in paths:
        try:
            rows = check(path)
        except Exception as e:  # noqa: BLE001 (report and go on with the next FMU)
            rows = [{"fmu": path, "error": f"{type(e).__name__}: {e}"}]
        for row in rows:
            ok &= row.get("ok", False)
            print(json.dumps(row), flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
