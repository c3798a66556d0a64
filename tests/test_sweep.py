"""loomfmu.sweep: studies on dask.distributed against the plain serial loop.

One two-worker LocalCluster run of a small rigid-frame study (9 cases, 3 of
them with a value the FMU refuses) is shared by the tests below; the serial
loop is fmpy.simulate_fmu with a fresh instance per case, the sweep reuses
one instance per worker with fmi2Reset.
"""
from __future__ import annotations

import csv
import http.server
import math
import re
import signal
import socket
import threading
import time

import psutil
import pytest

from loomfmu import build_fmu, load_model
from loomfmu.cli.dispatch import main as cli_main
from loomfmu.declare.solvers import SOLVERS
from loomfmu.machines import studies
from loomfmu.sweep import (
    Derived,
    Figure,
    Study,
    case_key,
    fmu_blob,
    grid,
    latin_hypercube,
    lists,
    parse_figure,
    run_serial,
    run_study,
    store,
)

FIGS = ["max_N_rem", "min_N_rem", "final_h"]


def _study(**kw):
    args = dict(cases=grid(omega=[40.0, 60.0, 80.0], k_z=[2.0, 5.0, 500.0]),
                figures=[Figure("max", "N_rem"), Figure("min", "N_rem"),
                         Figure("final", "h", after=0.1)],
                stop_time=0.2, output_interval=1e-3, rtol=1e-8, atol=1e-10, name="small")
    args.update(kw)
    return Study("heald_frame_rigid", **args)


@pytest.fixture(scope="module")
def blob(tmp_path_factory):
    path = build_fmu(load_model("heald_frame_rigid"), out_dir=tmp_path_factory.mktemp("sw"),
                     validate=False).path
    return fmu_blob(_study(), path)


@pytest.fixture(scope="module")
def swept(blob, tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep") / "small.csv"
    result = run_study(_study(), out=out, workers=2, blob=blob, progress=False)
    return result, out


@pytest.mark.slow
def test_two_workers_equal_the_serial_loop_bit_for_bit(swept, blob):
    result, out = swept
    serial = run_serial(_study(), blob=blob)  # fmpy.simulate_fmu, a fresh instance per case
    assert [r["status"] for r in result.rows] == [r["status"] for r in serial]
    ok = [(a, b) for a, b in zip(result.rows, serial) if a["status"] == "ok"]
    assert len(ok) == 6
    for a, b in ok:
        for f in FIGS:
            assert math.isfinite(a[f]) and a[f].hex() == b[f].hex(), (a["index"], f)
    # the workers reused their instance (fmi2Reset): 6 ok cases, at most 2 first cases
    # and 3 cases after a failed one (which drops its instance) start a new one
    assert sum(a["instance"] == "reset" for a, _ in ok) >= 1
    assert sum(a["instance"] == "new" for a in result.rows) <= 2 + 3
    assert {b["instance"] for b in serial} == {"plain"}
    # the table read back gives the same bits
    for a, b in zip(store.read_rows(out), serial):
        if b["status"] == "ok":
            assert [a[f].hex() for f in FIGS] == [b[f].hex() for f in FIGS]
    # the figures do depend on the case (a sweep that ignored the values would pass above)
    # (N_rem's extremes are the dwells' static loads: they follow k_z; h follows omega)
    assert len({(round(a["max_N_rem"], 9), round(a["final_h"], 12)) for a, _ in ok}) == 6
    # the cluster is closed: no worker process left behind (multiprocessing's own
    # resource tracker stays until this process ends)
    left = [p.cmdline() for p in psutil.Process().children(recursive=True)]
    assert [c for c in left if not any("resource_tracker" in a for a in c)] == []


@pytest.mark.slow
def test_failed_case_is_recorded_with_the_fmus_message(swept):
    result, out = swept
    assert result.executed == 9 and len(result.rows) == 9
    bad = [r for r in result.rows if r["k_z"] == 500.0]
    assert len(bad) == 3 and result.failed == bad
    for r in bad:
        assert r["status"] == "error"
        assert "k_z = 500 is outside its range [0.1, 50]" in r["message"], r["message"]
        assert "t = 0" in r["message"]
        assert all(math.isnan(r[f]) for f in FIGS)
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    assert sum(r["status"] == "error" for r in rows) == 3
    assert all("outside its range" in r["message"] for r in rows if r["status"] == "error")


@pytest.mark.slow
def test_resume_skips_finished_cases(swept, blob, tmp_path):
    result, out = swept
    lines = out.read_text().splitlines()
    part = tmp_path / "small.csv"
    part.write_text("\n".join(lines[:5]) + "\n")  # interrupted after 4 finished cases
    again = run_study(_study(), out=part, workers=1, blob=blob, progress=False, batch=2)
    assert (again.executed, again.skipped) == (5, 4)
    for a, b in zip(again.rows, result.rows):
        assert a["status"] == b["status"]
        if a["status"] == "ok":
            assert [a[f].hex() for f in FIGS] == [b[f].hex() for f in FIGS]
    kept = {r["key"]: r["worker"] for r in store.read_rows(part)}
    first = {r["key"]: r["worker"] for r in store.read_rows(out)}
    assert sum(kept[k] == first[k] for k in list(first)[:4]) == 4
    done = run_study(_study(), out=part, workers=1, blob=blob, progress=False, batch=4)
    assert (done.executed, done.skipped) == (0, 9)
    # a line cut short by a kill is run again; another study's table is not overwritten
    cut = tmp_path / "cut.csv"
    cut.write_text("\n".join(lines[:9]) + "\n" + lines[9][:30])
    assert store.read_rows(cut)[-1]["status"] in (None, "")  # cut in its case values
    again = run_study(_study(), out=cut, workers=1, blob=blob, progress=False)
    assert (again.executed, again.skipped) == (1, 8)
    with pytest.raises(ValueError, match=r"out = .*columns.*allowed: .*--fresh"):
        run_study(_study(figures=[Figure("max", "h")]), out=cut, blob=blob, progress=False)
    # a rebuild of the same model resumes (the FMU's members are hashed, not the zip)
    rebuilt = build_fmu(load_model("heald_frame_rigid"), out_dir=tmp_path / "re",
                        validate=False).path
    assert fmu_blob(_study(), rebuilt).sha256 == blob.sha256
    # another setting is another study: its keys differ, nothing is resumed
    fp1, fp2 = _study().fingerprint(blob.sha256), _study(rtol=1e-7).fingerprint(blob.sha256)
    assert fp1 != fp2
    assert case_key(fp1, {"omega": 40.0}) != case_key(fp2, {"omega": 40.0})


@pytest.mark.slow
def test_a_corrupt_row_is_named_by_file_and_line_and_its_case_run_again(swept, blob,
                                                                      tmp_path, capsys):
    result, out = swept
    lines = out.read_text().splitlines()
    cols = lines[0].split(",")
    status, first_fig = cols.index("status"), cols.index(FIGS[0])
    ok_line = next(i for i, r in enumerate(csv.reader(lines[1:]), 1) if r[status] == "ok"
                   and i > 2)
    lines[1] += ",surplus"                                  # one field too many
    fields = next(csv.reader([lines[2]]))
    fields[status] = "bogus"                                 # an unknown status
    lines[2] = ",".join(fields)
    fields = next(csv.reader([lines[ok_line]]))
    fields[first_fig] = "abc"                                # an ok row's figure
    lines[ok_line] = ",".join(fields)
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines) + "\n")
    again = run_study(_study(), out=bad, workers=1, blob=blob, progress=True)
    assert (again.executed, again.skipped) == (3, 6)
    assert len(again.notes) == 3, again.notes
    assert again.notes[0].startswith(f"{bad}:2: case 0 is run again: ")
    assert "fields, the header has" in again.notes[0]
    assert again.notes[1].startswith(f"{bad}:3: case 1 is run again: status 'bogus' is not "
                                     "one of ok, ")
    assert again.notes[2].startswith(f"{bad}:{ok_line + 1}: case {ok_line - 1} is run again: "
                                     f"figure {FIGS[0]} = 'abc' is not a number")
    err = capsys.readouterr().err
    assert all(f"sweep small: note: {n}" in err for n in again.notes) and "Traceback" not in err
    for a, b in zip(again.rows, result.rows):                # rerun: as before
        assert a["status"] == b["status"] and a["message"] == b["message"]
        if a["status"] == "ok":
            assert [a[f].hex() for f in FIGS] == [b[f].hex() for f in FIGS]
    assert run_study(_study(), out=bad, workers=1, blob=blob, progress=False).notes == []


@pytest.mark.slow
@pytest.mark.parametrize("reuse", [True, False])
def test_an_input_outside_its_range_is_a_warning_with_the_fmus_line_not_ok(blob, reuse):
    study = _study(cases=grid(omega=[60.0, 1000.0]))   # omega's range: [0, 500] rad/s
    rows = run_serial(study, blob=blob, reuse=reuse)
    assert [r["status"] for r in rows] == ["ok", "warning"]
    assert rows[0]["message"] == ""
    assert rows[1]["message"].startswith("log: [logStatusWarning] t = 0: input omega = 1000 "
                                         "is outside its range [0, 500]"), rows[1]["message"]
    assert math.isfinite(rows[1]["max_N_rem"])            # the figures are kept


@pytest.mark.slow
def test_invalid_case_is_refused_before_running(blob, tmp_path):
    study = Study("heald_frame_rigid", cases=lists(preset=[0, 999], omega=[60.0, 60.0]),
                  figures=[Figure("max", "N_rem")], stop_time=0.1, output_interval=1e-3,
                  prepare=studies.prepare_hinge)
    rows = run_serial(study, blob=blob, reuse=True)
    assert rows[0]["status"] == "ok" and rows[0]["max_N_rem"] > 0
    assert rows[1]["status"] == "invalid"
    assert rows[1]["message"].startswith("preset = 999; allowed: an integer in [0, 55]")


def _derived(t, y, case):
    return float(y["h"].max() - y["h"].min())


@pytest.mark.parametrize("make, names", [
    (lambda: Study("nope", cases=[{}], figures=[Figure("max", "h")], stop_time=1.0,
                   output_interval=0.1), "model"),
    (lambda: _study(cases=[]), "cases"),
    (lambda: _study(figures=[]), "figures"),
    (lambda: _study(stop_time=-1.0), "stop_time"),
    (lambda: _study(output_interval=0.5), "output_interval"),
    (lambda: _study(stop_time=0.05), "after"),  # final_h from 0.1 s on, past the stop
    (lambda: Figure("max", "h", label="a b"), "label"),
    (lambda: _study(figures=[Figure("max", "h"), Figure("max", "h")]), "figures"),
    (lambda: run_study(_study(), scheduler="tcp://127.0.0.1:1", connect_timeout=0),
     "connect_timeout"),
    (lambda: _study(solver="euler"), "solver"),
    (lambda: _study(rtol=0.0), "rtol"),
    (lambda: _study(name="a b"), "name"),
    (lambda: _study(prepare=lambda c, f: (c, None)), "prepare"),
    (lambda: Figure("median", "h"), "kind"),
    (lambda: Figure("max", "h", after=-1.0), "after"),
    (lambda: Derived("d", lambda t, y, c: 0.0, ("h",)), "function"),
    (lambda: parse_figure("N_rem"), "figure"),
    (lambda: grid(b1=[]), "b1"),
    (lambda: grid(b1="0.01"), "b1"),
    (lambda: lists(a=[1.0, 2.0], b=[1.0]), "axes"),
    (lambda: latin_hypercube({"a": (1.0, 0.0)}, n=3, seed=0), "bounds['a']"),
    (lambda: latin_hypercube({"a": (0.0, 1.0)}, n=0, seed=0), "n"),
    (lambda: latin_hypercube({"a": (0.0, 1.0)}, n=3, seed=-1), "seed"),
    (lambda: run_study(_study(), workers=0), "workers"),
    (lambda: run_study(_study(), workers=65), "workers"),
    (lambda: run_study(_study(), scheduler="localhost"), "scheduler"),
    (lambda: run_study(_study(), batch=0), "batch"),
    (lambda: run_study(_study(), out="."), "out = '.': an existing directory"),
    (lambda: run_study(_study(), out=__file__ + "/x.csv"), "out = "),
])
def test_bad_arguments_name_the_argument_and_the_allowed_range(make, names):
    with pytest.raises(ValueError) as e:
        make()
    assert str(e.value).startswith(names) and "allowed" in str(e.value), str(e.value)


@pytest.mark.slow
def test_names_are_checked_against_the_fmu(blob):
    with pytest.raises(ValueError, match=r"cases: unknown 'nope'.*allowed"):
        run_serial(_study(cases=grid(nope=[1.0])), blob=blob)
    with pytest.raises(ValueError, match=r"figures: unknown 'x2_out'.*allowed"):
        run_serial(_study(figures=[Figure("max", "x2_out")]), blob=blob)


@pytest.mark.slow
def test_derived_figure_and_latin_hypercube(blob):
    cases = latin_hypercube({"omega": (40.0, 80.0), "k_z": (2.0, 6.0)}, n=5, seed=3)
    assert cases == latin_hypercube({"omega": (40.0, 80.0), "k_z": (2.0, 6.0)}, n=5, seed=3)
    for name, (lo, hi) in (("omega", (40.0, 80.0)), ("k_z", (2.0, 6.0))):
        strata = sorted(int((c[name] - lo) / (hi - lo) * 5) for c in cases)
        assert strata == [0, 1, 2, 3, 4]  # one case per stratum of each axis
    study = _study(cases=cases[:2], figures=[Derived("stroke", _derived, ("h",))])
    rows = run_serial(study, blob=blob)
    # the frame's stroke over 0.2 s at these speeds: h runs through most of +-h_m
    assert all(r["status"] == "ok" and 0.0 < r["stroke"] <= 2 * 0.029 + 1e-12 for r in rows)


@pytest.mark.slow
def test_cli_sweep_run(blob, tmp_path, capsys):
    fmu = tmp_path / blob.name
    fmu.write_bytes(blob.data)
    code = cli_main(["sweep", "run", "heald_frame_rigid", "--grid", "omega=40,60",
                     "--figure", "max:N_rem", "--stop", "0.1", "--fmu", str(fmu),
                     "--workers", "1", "--out-dir", str(tmp_path)])
    assert code == 0
    rows = store.read_rows(tmp_path / "heald_frame_rigid.csv")
    assert [r["omega"] for r in rows] == [40.0, 60.0] and all(r["status"] == "ok" for r in rows)
    assert "2 cases, 2 run now" in capsys.readouterr().out
    code = cli_main(["sweep", "run", "heald_frame_rigid", "--grid", "omega=40,abc",
                     "--figure", "max:N_rem", "--stop", "0.1"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("loomfmu sweep: error: --grid omega: 'abc'; allowed")


def _nan_figure(t, y, case):
    return float("nan") if case["omega"] > 50 else 1.0


def _solver_items(blob) -> dict[str, int]:
    """The FMU's own ``solver`` enumeration: item name -> value."""
    import io

    import fmpy
    md = fmpy.read_model_description(io.BytesIO(blob.data), validate=False)
    var = next(v for v in md.modelVariables if v.name == "solver")
    return {item.name: int(item.value) for item in var.declaredType.items}


@pytest.mark.parametrize("solver", [s for s in SOLVERS if s != "dopri5"])
@pytest.mark.slow
def test_every_solver_of_the_fmu_runs_and_agrees_with_dopri5(blob, solver):
    """Each solver the FMU offers runs a case in the worker, the FMU's
    ``solver`` set to its own enumeration item of that name, with finite
    figures that agree with dopri5's (ros34pw2 was missing from the
    worker's own solver table: KeyError in every dask task)."""
    assert set(_solver_items(blob)) == set(SOLVERS)
    figures = [Figure("max", "N_rem"), Figure("min", "N_rem"), Figure("final", "h", after=0.1),
               Figure("final", "solver")]
    cases = grid(omega=[40.0, 60.0])
    ref = run_serial(_study(cases=cases, figures=figures), blob=blob)
    rows = run_serial(_study(cases=cases, figures=figures, solver=solver), blob=blob)
    assert [r["status"] for r in rows + ref] == ["ok"] * 4, [r["message"] for r in rows + ref]
    assert [r["final_solver"] for r in rows] == [_solver_items(blob)[solver]] * 2
    for a, b in zip(rows, ref):
        for f in FIGS:
            assert math.isfinite(a[f]), (solver, f, a[f])
            assert a[f] == pytest.approx(b[f], rel=1e-6, abs=1e-9), (solver, f, a[f], b[f])


@pytest.mark.slow
def test_a_nan_figure_is_a_failed_case_not_ok(blob):
    study = _study(cases=grid(omega=[40.0, 60.0]), figures=[Derived("odd", _nan_figure, ("h",))])
    rows = run_serial(study, blob=blob)
    assert [r["status"] for r in rows] == ["ok", "failed"]
    assert rows[1]["message"] == "figure: odd = nan at stop time 0.2 s"


def test_smallest_b1_interpolates_between_grid_points():
    # max |x2| = c b1^-3 exactly: log-log interpolation gives the exact crossing
    rows = [{"status": "ok", "width_cm": 180, "k_z": 5.0, "d1": 0.0014, "b1": b,
             "max_abs_x2_out": 1e-9 * b ** -3} for b in (0.005, 0.01, 0.02, 0.04)]
    rows.append({**rows[0], "status": "error", "b1": 0.03, "max_abs_x2_out": float("nan")})
    (got,) = studies.smallest_b1(rows, gap=0.004)
    assert got["b1_min"] == pytest.approx((1e-9 / 0.004) ** (1 / 3), rel=1e-12)
    (edge,) = studies.smallest_b1(rows[:1], gap=1.0)
    assert edge["b1_min"] is None and "already" in edge["note"]
    (none,) = studies.smallest_b1(rows, gap=1e-12)
    assert none["b1_min"] is None and "no b1" in none["note"]


def test_sweep_help():
    with pytest.raises(SystemExit) as e:
        cli_main(["sweep", "--help"])
    assert e.value.code == 0



def test_trend_case_starts_on_the_periodic_orbit_with_the_studys_parameter():
    fixed = {"n_rpm": 16000.0, "ecc": 5e-6, "base": {"k_f": 2.0e6, "a_s": 6e-4, "k_u": 1.0e7}}
    values, stop = studies.prepare_trend({"trend": 1, "x": 3.0}, fixed)  # upper support x 3
    assert values["k_u"] == 3.0e7 and "k_f" not in values
    assert values["Omega"] == pytest.approx(16000.0 * 2 * math.pi / 60, rel=1e-15)  # rad/s
    assert (values["e_b"], values["e_w"]) == (5e-6, 5e-6)
    assert stop == pytest.approx(3 * 60 / 16000.0, rel=1e-15)
    assert any(v != 0.0 for k, v in values.items() if k.endswith(".x"))  # off-centre start
    with pytest.raises(ValueError, match=r"trend = 4; allowed: an integer in \[0, 3\]"):
        studies.prepare_trend({"trend": 4, "x": 1.0}, fixed)


@pytest.mark.slow
def test_figures_differing_in_after_are_named_apart(blob):
    study = _study(cases=grid(omega=[60.0]), figures=[Figure("mean", "h"),
                                                      Figure("mean", "h", after=0.15)])
    assert [f.name for f in study.figures] == ["mean_h_from_0s", "mean_h_from_0p15s"]
    (row,) = run_serial(study, blob=blob)
    assert row["status"] == "ok" and row["mean_h_from_0s"] != row["mean_h_from_0p15s"]
    # each column holds its own figure: the same figures run alone, under their plain name
    for after, name in ((0.0, "mean_h_from_0s"), (0.15, "mean_h_from_0p15s")):
        (alone,) = run_serial(_study(cases=grid(omega=[60.0]),
                                     figures=[Figure("mean", "h", after=after)]), blob=blob)
        assert alone["mean_h"].hex() == row[name].hex()


@pytest.mark.slow
def test_an_fmu_of_another_model_is_named_as_such(blob, tmp_path):
    import io
    import zipfile
    src, out = zipfile.ZipFile(io.BytesIO(blob.data)), io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:  # the same FMU, declared as another model
        for name in src.namelist():
            data = src.read(name)
            if name == "modelDescription.xml":
                data = data.replace(b'modelName="heald_frame_rigid"', b'modelName="backrest"')
            z.writestr(name, data)
    other = tmp_path / "backrest.fmu"
    other.write_bytes(out.getvalue())
    with pytest.raises(ValueError, match=r"fmu = 'backrest.fmu': a build of model 'backrest', "
                                         r"not of the study's model 'heald_frame_rigid'"):
        run_serial(_study(), fmu=other)


@pytest.fixture
def not_dask():
    """Addresses where no dask scheduler answers: an HTTP server, a server
    that sends garbage, a closed port (all on this host, free ports)."""
    web = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _QuietHandler)
    junk = socket.create_server(("127.0.0.1", 0))

    def babble():
        while True:
            try:
                conn, _ = junk.accept()
            except OSError:
                return
            conn.sendall(b"\xff" * 64)  # a frame count of 2**64 - 1
            conn.close()
    threads = [threading.Thread(target=web.serve_forever, daemon=True),
               threading.Thread(target=babble, daemon=True)]
    for t in threads:
        t.start()
    with socket.create_server(("127.0.0.1", 0)) as s:
        closed = s.getsockname()[1]
    yield {"http": f"tcp://127.0.0.1:{web.server_address[1]}",
           "garbage": f"tcp://127.0.0.1:{junk.getsockname()[1]}",
           "closed": f"tcp://127.0.0.1:{closed}"}
    web.shutdown()
    web.server_close()
    junk.close()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def _alarm(seconds):
    def fail(*_):
        raise TimeoutError(f"still waiting after {seconds} s")
    signal.signal(signal.SIGALRM, fail)
    signal.alarm(seconds)


@pytest.mark.slow
def test_a_scheduler_address_without_a_dask_scheduler_is_refused_in_bounded_time(
        not_dask, blob, tmp_path, capsys):
    try:
        for what, address in not_dask.items():
            _alarm(30)  # before the fix the HTTP server held the client for ever
            t0 = time.perf_counter()
            with pytest.raises(ValueError) as e:
                run_study(_study(), out=tmp_path / "x.csv", blob=blob, scheduler=address,
                          connect_timeout=1.5, progress=False)
            took = time.perf_counter() - t0
            assert str(e.value).startswith(f"scheduler = '{address}': "), (what, str(e.value))
            assert "allowed: the address of a running dask scheduler" in str(e.value)
            if what == "garbage":
                assert "answered with bytes that are not dask's protocol" in str(e.value)
            assert took < 1.5 + 2.0, (what, took)
            assert not (tmp_path / "x.csv").exists()  # refused before anything ran
        _alarm(30)
        fmu = tmp_path / blob.name
        fmu.write_bytes(blob.data)
        code = cli_main(["sweep", "run", "heald_frame_rigid", "--grid", "omega=40",
                         "--figure", "max:N_rem", "--stop", "0.1", "--fmu", str(fmu),
                         "--out-dir", str(tmp_path), "--scheduler", not_dask["http"],
                         "--connect-timeout", "1"])
    finally:
        signal.alarm(0)
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"loomfmu sweep: error: scheduler = '{not_dask['http']}': no dask "
                          "scheduler answered within 1 s"), err


@pytest.mark.slow
def test_a_running_scheduler_is_accepted_a_worker_is_not(blob, tmp_path):
    from dask.distributed import LocalCluster
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cluster:
        res = run_study(_study(cases=grid(omega=[40.0, 60.0])), blob=blob, progress=False,
                        scheduler=cluster.scheduler_address, connect_timeout=5)
        (worker,) = [w.address for w in cluster.workers.values()]
        with pytest.raises(ValueError, match=r"the peer is not a dask scheduler \(it answered "
                                             r"as 'Worker'\)"):
            run_study(_study(), blob=blob, scheduler=worker, connect_timeout=5)
    assert res.workers == -1 and [r["status"] for r in res.rows] == ["ok", "ok"]


@pytest.mark.slow
def test_cli_out_dir_is_checked_before_running(blob, tmp_path, capsys):
    fmu = tmp_path / blob.name
    fmu.write_bytes(blob.data)
    afile = tmp_path / "afile"
    afile.write_text("")
    taken = tmp_path / "taken"
    (taken / "heald_frame_rigid.csv").mkdir(parents=True)
    for out_dir, said in ((afile, "an existing file, not a directory"),
                          (afile / "sub", "cannot be made"),
                          (taken, "heald_frame_rigid.csv in it is a directory")):
        code = cli_main(["sweep", "run", "heald_frame_rigid", "--grid", "omega=40",
                         "--figure", "max:N_rem", "--stop", "0.1", "--fmu", str(fmu),
                         "--out-dir", str(out_dir)])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
        assert err.startswith(f"loomfmu sweep: error: --out-dir '{out_dir}': {said}"), err
        assert "allowed" in err


#: the serial run of the bench test below, in a subprocess with one BLAS thread
#: as dask's nannies give their workers (OMP/MKL/OPENBLAS_NUM_THREADS=1)
_BENCH_SERIAL = """
import sys
from pathlib import Path
from loomfmu.bench.cli import charts
from loomfmu.bench.sweep import Plan
plan = Plan((1e-3, 1e-6), (1e-3, 1e-6), (1e-4,), (4.0,), 1, 1e9, 1e-10)
only = {("fmu", "dopri5"), ("fmu", "rk4"), ("scipy", "RK45"), ("scipy", "Radau")}
charts(["drive"], out=Path(sys.argv[1]), quick=True, readme=None, failures_on=False,
       cmd="test", plan=plan, only=only)
"""


@pytest.mark.slow
def test_bench_charts_on_dask_equal_the_serial_run_but_for_the_times(tmp_path):
    """``loomfmu bench charts --dask``: one task per (model, method) sweep on a
    two-worker LocalCluster; every row but its seconds equals the serial
    run's (with the workers' single-threaded BLAS: Radau's LU factorizations
    round otherwise), in the same order, and the chart and tables are
    written."""
    import json
    import os
    import subprocess
    import sys

    from loomfmu.bench.cli import charts
    from loomfmu.bench.sweep import Plan
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "OPENBLAS_NUM_THREADS": "1"}
    serial = subprocess.Popen([sys.executable, "-c", _BENCH_SERIAL, str(tmp_path / "serial")],
                              env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    plan = Plan((1e-3, 1e-6), (1e-3, 1e-6), (1e-4,), (4.0,), 1, 1e9, 1e-10)
    only = {("fmu", "dopri5"), ("fmu", "rk4"), ("scipy", "RK45"), ("scipy", "Radau")}
    par = charts(["drive"], out=tmp_path / "dask", quick=True, readme=None, failures_on=False,
                 cmd="test", plan=plan, only=only, dask={"workers": 2, "progress": False})
    err = serial.communicate(timeout=120)[1]  # closes the pipe (else a ResourceWarning later)
    assert serial.returncode == 0, err.decode()[-2000:]

    def rows(folder):  # every column but the seconds, as written
        with open(tmp_path / folder / "points.csv") as fh:
            return [{k: v for k, v in r.items() if k != "seconds"} for r in csv.DictReader(fh)]
    assert len(rows("serial")) == 2 + 1 + 2 + 2
    assert rows("dask") == rows("serial")
    assert all(math.isfinite(r["err_max"]) and r["status"] == "ok" for r in par["rows"])
    assert {(t["family"], t["method"]) for t in par["tasks"]} == only
    # a short task's thread CPU time can round to 0 (clock granularity): the
    # times are recorded, non-negative, and the tasks together took time
    assert all(t["cpu_s"] >= 0 and t["wall_s"] >= 0 for t in par["tasks"])
    assert sum(t["wall_s"] for t in par["tasks"]) > 0
    for f in ("drive_wp.png", "points.csv", "summary.md", "speed_table.json"):
        assert (tmp_path / "dask" / f).stat().st_size > 0
    table = json.loads((tmp_path / "dask" / "speed_table.json").read_text())
    assert len(table["dask_tasks"]) == len(only)


def test_the_worker_logs_fmi2_and_fmi3_messages_and_reports_the_first_failure():
    """FMPy calls an FMI 3 logger with 4 arguments (an FMI 2 one with 5): both
    land in the row's log; the row's message names the first Discard or worse
    (FMPy may call the FMU again after a Discard; the last line is then only
    the refusal of that call)."""
    from types import SimpleNamespace

    from loomfmu.sweep.worker import _message, _Slot
    slot = SimpleNamespace(log=[])
    _Slot.logger(slot, None, b"inst", 2, b"logStatusDiscard", b"max steps spent")
    _Slot.logger(slot, b"inst", 3, b"logStatusError", b"doStep in state StepFailed")
    assert slot.log == [(2, "[logStatusDiscard] max steps spent"),
                        (3, "[logStatusError] doStep in state StepFailed")]
    msg = _message(slot.log, RuntimeError("doStep failed"))
    assert msg.startswith("doStep failed; log: [logStatusDiscard] max steps spent ... ")
    assert _message([(0, "[ok] fine")], RuntimeError("x")) == "x; log: [ok] fine"


@pytest.mark.slow
def test_slots_of_ended_threads_are_closed(blob):
    """Batches run on one thread pool after another keep no more FMU
    instances (and extracted copies) than there are live threads: a slot
    whose thread has ended is closed, its directory removed."""
    import concurrent.futures
    import os

    from loomfmu.sweep import worker

    setup = _study().setup()
    items = [(0, "a", {"omega": 40.0, "k_z": 5.0})]
    dirs = set()
    for _ in range(4):
        with concurrent.futures.ThreadPoolExecutor(2) as pool:
            rows = list(pool.map(lambda _: worker.run_batch(blob, setup, items)[0], range(2)))
        assert all(r["status"] == "ok" for r in rows), rows
        dirs.update(s.dir for s in worker._SLOTS.values())
        assert len(worker._SLOTS) <= threading.active_count() + 2, len(worker._SLOTS)
    worker.run_batch(blob, setup, items)  # the pools' threads have ended
    alive = {t.ident for t in threading.enumerate()}
    assert all(k[1] in alive for k in worker._SLOTS), list(worker._SLOTS)
    kept = {s.dir for s in worker._SLOTS.values()}
    assert all(not os.path.isdir(d) for d in dirs - kept), sorted(dirs - kept)
    assert all(os.path.isdir(d) for d in kept)


@pytest.mark.slow
def test_slots_of_threads_threading_does_not_know_stay_in_their_hands(blob):
    """Threads started by _thread (or natively) are not in
    threading.enumerate(): their slots must not be taken for ended ones and
    closed while they run (a segfault or 'Cannot find shared library')."""
    import _thread

    from loomfmu.sweep import worker

    setup = _study().setup()
    items = [(0, "a", {"omega": 40.0, "k_z": 5.0})] * 12
    lock = threading.Lock()
    results, done = [], []

    def job(k):
        try:
            rows = worker.run_batch(blob, setup, items)
            with lock:
                results.extend(r for r in rows if r["status"] != "ok")
        except BaseException as exc:  # noqa: BLE001 (reported below)
            with lock:
                results.append(repr(exc))
        finally:
            with lock:
                done.append(k)

    for k in range(4):
        _thread.start_new_thread(job, (k,))
    deadline = time.monotonic() + 120
    while len(done) < 4 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert len(done) == 4 and not results, results[:3]


@pytest.mark.slow
def test_sigint_keeps_the_rows_and_says_how_to_resume_in_one_line(blob, tmp_path):
    """^C during `loomfmu sweep` (SIGINT to its process group, workers
    included): exit 130, one line on standard error (no traceback) naming the
    rows kept, and the results file keeps them."""
    import os
    import subprocess
    import sys
    fmu = tmp_path / blob.name
    fmu.write_bytes(blob.data)
    out_dir = tmp_path / "out"
    omegas = ",".join(str(40.0 + 0.1 * i) for i in range(200))
    proc = subprocess.Popen(
        [sys.executable, "-m", "loomfmu", "sweep", "run", "heald_frame_rigid", "--grid",
         f"omega={omegas}", "--figure", "max:N_rem", "--stop", "1", "--fmu", str(fmu),
         "--workers", "2", "--out-dir", str(out_dir)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "LOOMFMU_PROGRESS": "off"}, start_new_session=True)
    csv_path = out_dir / "heald_frame_rigid.csv"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        if csv_path.exists() and len(csv_path.read_text().splitlines()) >= 4:
            break
        time.sleep(0.05)
    assert proc.poll() is None, proc.communicate()
    os.killpg(proc.pid, signal.SIGINT)   # as ^C in a terminal: the workers get it too
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, (proc.returncode, stdout, stderr)
    assert "Traceback" not in stderr and stderr.count("\n") == 1, stderr
    kept = store.read_rows(csv_path)
    assert 3 <= len(kept) < 200 and all(r["status"] == "ok" for r in kept)
    assert stderr.startswith(f"loomfmu sweep: interrupted: {len(kept)} finished case(s) kept "
                             f"in {csv_path}; run the same command again to resume"), stderr


def _dying_prepare(marker):
    """A prepare (pickled by value: its module is __main__) whose worker dies
    the first time it sees omega = 60."""
    ns = {"__name__": "__main__"}
    exec(f"""
import os
def prepare(case, fixed):
    if case["omega"] == 60.0 and not os.path.exists({str(marker)!r}):
        open({str(marker)!r}, "w").close()
        os._exit(1)
    return {{**fixed, **case}}, None
""", ns)
    return ns["prepare"]


@pytest.mark.slow
# the worker killed on purpose leaves dask's pipe to it for the garbage collector
@pytest.mark.filterwarnings("ignore::ResourceWarning")
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_a_case_whose_worker_is_lost_is_run_again_and_said(blob, tmp_path, capsys):
    marker = tmp_path / "died"
    study = _study(cases=grid(omega=[40.0, 60.0, 80.0]), prepare=_dying_prepare(marker))
    res = run_study(study, workers=2, blob=blob, progress=True)
    assert marker.exists()
    assert [r["status"] for r in res.rows] == ["ok", "ok", "ok"]
    serial = run_serial(_study(cases=grid(omega=[40.0, 60.0, 80.0])), blob=blob)
    assert [r["max_N_rem"] for r in res.rows] == [r["max_N_rem"] for r in serial]
    assert len(res.notes) == 1 and re.match(
        r"case\(s\) 1 ran again after the worker running them was lost \(1 time\(s\)\)",
        res.notes[0]), \
        res.notes
    assert f"sweep small: note: {res.notes[0]}" in capsys.readouterr().err


def test_the_cancel_race_of_distributed_is_not_logged_after_an_interrupt():
    """^C while distributed's sync() has not yet made its future: its cancel
    callback raises NameError on the event loop, which tornado would log with
    a traceback after the interrupt was handled; that record (only) is
    dropped."""
    import logging

    from loomfmu.sweep.run import _CancelRace, _quiet_cancel_race
    _quiet_cancel_race()
    _quiet_cancel_race()   # once only
    log = logging.getLogger("tornado.application")
    assert sum(isinstance(f, _CancelRace) for f in log.filters) == 1

    def record(exc):
        try:
            raise exc
        except Exception:
            import sys
            return logging.LogRecord("tornado.application", logging.ERROR, __file__, 1,
                                     "Exception in callback", None, sys.exc_info())
    race = NameError("cannot access free variable 'future' where it is not associated "
                     "with a value in enclosing scope")
    assert not log.filter(record(race))
    assert log.filter(record(NameError("name 'other' is not defined")))
    assert log.filter(record(RuntimeError("future")))
