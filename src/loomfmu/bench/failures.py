"""Where methods fail: one study per mechanism, each a chart, CSV rows and a
one-line verdict computed from those rows.

* ``stiff`` (spindle): eigenvalues of df/dx at the start, the largest stable
  fixed step of explicit Euler and RK4 from theory (the ray of each
  eigenvalue leaves the method's stability region) against the measured one
  (bisection; RK4 is our FMU's, Euler a CasADi fixed-step loop on the same
  right-hand side, since the FMU has no Euler), and the cost of the adaptive
  explicit solver as the stiffness grows (blade damping beta).
* ``friction`` (backrest): fixed-step RK4 on the tanh-regularized model
  (chattering), the regularized model's cost as eps shrinks, and the
  event-driven model's accuracy at the same cost.
* ``delay`` (drive): the history interpolated linearly between steps against
  the solver's dense output, and fixed steps larger than the delay.
* ``breakpoints`` (heald frame): solvers that integrate straight through the
  dwell boundaries against the same solvers restarted there and our FMU,
  with the corrected (smooth) and the printed (jumping) motion law.

Every study reads only the prepared :class:`~loomfmu.bench.sweep.Case` of its
model and returns ``(rows, verdict)``; it writes its PNG into ``out``.
"""
from __future__ import annotations

import math
import time

import casadi as ca
import matplotlib
import numpy as np
from scipy.integrate import solve_ivp

from loomfmu.bench.runners import CasadiModel, Run, errors, scipy_run, timed
from loomfmu.bench.sweep import Case, Plan, point

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

#: a run counts as stable when its final-time error is below this (x range)
STABLE_ERROR = 1.0


def _fmt(v: float) -> str:
    return "–" if v is None or not np.isfinite(v) else f"{v:.2g}"


# -- stiff: the spindle --------------------------------------------------------------

def eigenvalues(cm: CasadiModel) -> np.ndarray:
    """Eigenvalues of df/dx at the start state (inputs and parameters of ``cm``)."""
    d = cm.dae
    J = ca.Function("J", [d.t, d.x, cm.P], [ca.jacobian(cm.problem["ode"], d.x)])
    return np.linalg.eigvals(np.asarray(J(0.0, cm.x0, cm.pnum)))


def _rk4_R(z):
    return 1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24


def stable_step_theory(lam: np.ndarray) -> dict[str, float]:
    """Largest h with h*lambda in the stability region for every eigenvalue
    (zero eigenvalues ignored): Euler |1 + z| <= 1, i.e. h <= -2 Re(l)/|l|^2;
    RK4 the first exit of the ray s*l/|l| from |R(z)| <= 1 (resolution 1e-4)."""
    lam = lam[np.abs(lam) > 1e-9 * np.max(np.abs(lam))]
    euler = np.where(lam.real < 0, -2 * lam.real / np.abs(lam) ** 2, 0.0)
    s = np.arange(1, 40001) * 1e-4  # |z| from 1e-4 to 4
    h_rk4 = []
    for lk in lam:
        out = np.abs(_rk4_R(s * lk / abs(lk))) > 1 + 1e-12
        h_rk4.append((s[np.argmax(out)] if out.any() else s[-1]) / abs(lk))
    return {"euler": float(euler.min()), "rk4": float(min(h_rk4))}


def _euler_final(cm: CasadiModel, h: float, stop: float, outputs) -> Run:
    """Explicit Euler with a fixed step on the CasADi right-hand side."""
    d = cm.dae
    n = max(1, int(round(stop / h)))
    h = stop / n
    tx = ca.vertcat(d.t, d.x)
    step = ca.Function("euler", [tx, cm.P], [ca.vertcat(d.t + h, d.x + h * cm.problem["ode"])])
    t0 = time.perf_counter()
    xs = np.asarray(step.mapaccum(n)(np.r_[0.0, cm.x0], cm.pnum))
    seconds = time.perf_counter() - t0
    xf = xs[1:, -1]
    ys = np.asarray(cm.out(stop, xf, np.zeros(d.w.numel()), cm.pnum)).ravel()
    idx = {name: i for i, name in enumerate(cm.out_names)}
    return Run(np.array([stop]), {k: np.array([ys[idx[k]]]) for k in outputs}, seconds)


def _rk4_grid(cm: CasadiModel, grid, n_sub: int, outputs) -> Run:
    """Classical RK4 with fixed step (grid spacing / n_sub) on the CasADi
    right-hand side, straight through every breakpoint; outputs on ``grid``
    (uniform)."""
    d = cm.dae
    h = float(grid[1] - grid[0]) / n_sub
    f = ca.Function("f", [d.t, d.x, cm.P], [cm.problem["ode"]])
    tx, P = ca.vertcat(d.t, d.x), cm.P
    t, x = tx[0], tx[1:]
    k1 = f(t, x, P)
    k2 = f(t + h / 2, x + h / 2 * k1, P)
    k3 = f(t + h / 2, x + h / 2 * k2, P)
    k4 = f(t + h, x + h * k3, P)
    step = ca.Function("rk4", [tx, P], [ca.vertcat(t + h, x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))])
    n = n_sub * (len(grid) - 1)
    t0 = time.perf_counter()
    xs = np.asarray(step.mapaccum(n)(np.r_[grid[0], cm.x0], cm.pnum))
    seconds = time.perf_counter() - t0
    xs = np.hstack([np.r_[grid[0], cm.x0][:, None], xs[:, n_sub - 1::n_sub]])[1:]
    ng = len(grid)
    ys = np.asarray(cm.out.map(ng)(np.asarray(grid)[None, :], xs, np.zeros((d.w.numel(), ng)),
                                   np.repeat(cm.pnum[:, None], ng, axis=1)))
    idx = {name: i for i, name in enumerate(cm.out_names)}
    return Run(np.asarray(grid), {k: ys[idx[k]] for k in outputs}, seconds, 4 * n)


def _largest_stable(is_stable, h_lo: float, h_hi: float, iters: int) -> float:
    """Bisection in log h between a stable h_lo and an unstable h_hi."""
    for _ in range(4):
        if is_stable(h_lo):
            break
        h_lo /= 4
    for _ in range(4):
        if not is_stable(h_hi):
            break
        h_hi *= 4
    for _ in range(iters):
        mid = math.sqrt(h_lo * h_hi)
        h_lo, h_hi = (mid, h_hi) if is_stable(mid) else (h_lo, mid)
    return h_lo


def stiff(case: Case, plan: Plan, out, quick: bool):
    cm, sc, rows = case.casadi, case.scene, []
    lam = eigenvalues(cm)
    theory = stable_step_theory(lam)
    ref_final = {k: case.ref.y[k][-1] for k in sc.outputs}
    span = {k: float(np.ptp(case.ref.y[k])) or 1.0 for k in sc.outputs}

    def final_error(run: Run) -> float:
        return max(abs(float(run.y[k][-1]) - ref_final[k]) / span[k] for k in sc.outputs)

    def fmu_rk4(h):
        try:
            run = case.fmu.run(solver="rk4", rtol=1e-6, atol=1e-9, stop=case.stop,
                               interval=case.interval, outputs=sc.outputs,
                               values={**sc.values, "solver_h_fixed": h})
        except Exception:
            return False
        return final_error(run) < STABLE_ERROR

    def euler(h):
        return final_error(_euler_final(cm, h, case.stop, sc.outputs)) < STABLE_ERROR

    iters = 5 if quick else 8
    measured = {"rk4": _largest_stable(fmu_rk4, theory["rk4"] / 2, theory["rk4"] * 3, iters),
                "euler": _largest_stable(euler, theory["euler"] / 2, theory["euler"] * 3,
                                         iters)}
    for meth in ("euler", "rk4"):
        rows.append(point(case, "stiff", "theory", meth, None, h=theory[meth],
                          param="max|lambda|", value=float(np.max(np.abs(lam))),
                          note="largest stable fixed step from the eigenvalues at t = 0"))
        rows.append(point(case, "stiff", "fmu" if meth == "rk4" else "casadi-loop", meth,
                          None, h=measured[meth], param="max|lambda|",
                          value=float(np.max(np.abs(lam))),
                          note="largest stable fixed step, bisection (final error < range)"))
    # cost of the adaptive solvers as the stiffness grows
    betas = (2e-7, 2e-6, 2e-5) if quick else (2e-7, 6e-7, 2e-6, 6e-6, 2e-5)
    cost = {"dopri5": [], "rodas4": []}
    lam_max = []
    for beta in betas:
        values = {**sc.values, "beta": beta}
        cmb = CasadiModel(case.model, values)
        lam_max.append(float(np.max(np.abs(eigenvalues(cmb)))))
        ref = cmb.run(case.grid, plugin="cvodes", rtol=1e-11, atol=1e-11 * sc.atol_scale,
                      outputs=sc.outputs)
        for solver in cost:
            run = timed(lambda s=solver: case.fmu.run(
                solver=s, rtol=1e-6, atol=1e-6 * sc.atol_scale, stop=case.stop,
                interval=case.interval, outputs=sc.outputs, values=values), plan.repeats)
            e_final, e_max = errors(run, ref, sc.outputs)
            cost[solver].append(run.seconds)
            rows.append({**point(case, "stiff", "fmu", solver, None, rtol=1e-6, param="beta",
                                 value=beta, note=f"max|lambda| = {lam_max[-1]:.3g} 1/s"),
                         "seconds": run.seconds, "err_final": e_final, "err_max": e_max})
    # chart
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.5))
    th = np.linspace(0, 2 * np.pi, 400)
    ax[0].plot(-1 + np.cos(th), np.sin(th), "k--", lw=1, label="Euler |1+z| = 1")
    xx, yy = np.meshgrid(np.linspace(-3.2, 0.6, 400), np.linspace(-3.2, 3.2, 400))
    ax[0].contour(xx, yy, np.abs(_rk4_R(xx + 1j * yy)), [1.0], colors="C0")
    ax[0].plot([], [], "C0", label="RK4 |R(z)| = 1")
    z = measured["rk4"] * lam
    ax[0].plot(z.real, z.imag, "C3.", label=f"h λ, h = {measured['rk4']:.3g} s (measured RK4)")
    ax[0].set(xlabel="Re z", ylabel="Im z", title=f"{case.name}: stability regions",
              aspect="equal")
    ax[0].legend(fontsize=7, loc="lower left")
    for solver, c in (("dopri5", "C1"), ("rodas4", "C2")):
        ax[1].loglog(lam_max, cost[solver], "o-", color=c, label=f"FMU {solver}, rtol 1e-6")
    ax[1].set(xlabel="max |λ| of df/dx (1/s), blade damping β varied",
              ylabel="CPU time (s)", title="adaptive explicit vs implicit as stiffness grows")
    ax[1].grid(True, which="both", alpha=0.3)
    ax[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / f"{case.name}_stiff.png", dpi=110)
    plt.close(fig)
    growth = cost["dopri5"][-1] / cost["dopri5"][0]
    verdict = (f"{case.name}: max|λ| = {np.max(np.abs(lam)):.3g} 1/s; largest stable fixed "
               f"step: RK4 {_fmt(measured['rk4'])} s measured vs {_fmt(theory['rk4'])} s "
               f"theory, Euler {_fmt(measured['euler'])} s vs {_fmt(theory['euler'])} s; "
               f"as max|λ| grows {lam_max[-1] / lam_max[0]:.0f}x, dopri5's cost grows "
               f"{growth:.0f}x, rodas4's {cost['rodas4'][-1] / cost['rodas4'][0]:.1f}x")
    return rows, verdict


# -- friction: the backrest ------------------------------------------------------------

def friction(case: Case, plan: Plan, out, quick: bool, reg: Case | None = None):
    """``case``: the event-driven backrest; ``reg``: the regularized one (its FMU)."""
    if reg is None:
        return [], f"{case.name}: friction study skipped (backrest_regularized not run)"
    sc, rows = case.scene, []
    names = sc.outputs
    # study reference: the event-driven FMU at rtol 1e-10 (it matches the scipy
    # reference to ~1e-8 of the range, tests/test_backrest.py)
    k_static = (1.3, 1.0)
    interval = None  # the 1 ms grid: at h = 1 ms every sample is one step

    def ev_ref(ks, interval=None):
        return case.fmu.run(solver="dopri5", rtol=1e-10, atol=1e-13, stop=case.stop,
                            interval=interval, outputs=names, values={"k_static": ks})

    # (a) chattering of fixed-step RK4 on the tanh law, eps = 1e-3
    eps_chat = 1e-3
    ref_fine = ev_ref(1.0, interval)
    steps = (5e-5, 2e-4, 1e-3) if quick else (2e-5, 5e-5, 1e-4, 2e-4, 5e-4, 1e-3)
    chat, traces = {"regularized": [], "event-driven": []}, {}

    def sign_changes(run):
        w = run.y["omega2_out"]
        return int(np.sum(np.sign(w[1:]) * np.sign(w[:-1]) < 0))

    n_ref = sign_changes(ref_fine)
    for h in steps:
        for label, fmu, vals in (("regularized", reg.fmu, {"eps": eps_chat}),
                                 ("event-driven", case.fmu, {})):
            run = fmu.run(solver="rk4", rtol=1e-6, atol=1e-9, stop=case.stop,
                          interval=interval, outputs=names,
                          values={**vals, "k_static": 1.0, "solver_h_fixed": h})
            e_final, e_max = errors(run, ref_fine, names)
            chat[label].append((h, e_max, sign_changes(run)))
            traces[label, h] = run
            rows.append({**point(case, "friction-chatter", "fmu", f"rk4 {label}", None, h=h,
                                 param="sign changes of omega2", value=sign_changes(run),
                                 note=f"k_static 1.0, eps {eps_chat:g}; reference has "
                                 f"{n_ref} sign changes"),
                         "seconds": run.seconds, "err_final": e_final, "err_max": e_max})
    # (b) regularized cost as eps shrinks, (c) event-driven at the same tolerance
    eps_values = (1e-1, 1e-2, 1e-3) if quick else (1e-1, 1e-2, 1e-3, 1e-4)
    eps_pts = {}
    for ks in k_static:
        ref = ev_ref(ks)
        for solver in ("dopri5", "rodas4"):
            for label, fmu, vals_list in (("event-driven", case.fmu, [{}]),
                                          ("regularized", reg.fmu,
                                           [{"eps": e} for e in eps_values])):
                for vals in vals_list:
                    try:
                        run = timed(lambda: fmu.run(
                            solver=solver, rtol=1e-8, atol=1e-11, stop=case.stop,
                            interval=None, outputs=names, values={**vals, "k_static": ks}),
                            plan.repeats)
                    except Exception as exc:
                        rows.append(point(case, "friction-eps", "fmu", f"{solver} {label}",
                                          None, rtol=1e-8, param="eps",
                                          value=vals.get("eps", math.nan), status="failed",
                                          note=str(exc)[:100]))
                        continue
                    e_final, e_max = errors(run, ref, names)
                    eps_pts.setdefault((ks, solver, label), []).append(
                        (vals.get("eps", math.nan), run.seconds, e_max))
                    rows.append({**point(case, "friction-eps", "fmu", f"{solver} {label}",
                                         None, rtol=1e-8, param="eps",
                                         value=vals.get("eps", math.nan),
                                         note=f"k_static {ks}"),
                                 "seconds": run.seconds, "err_final": e_final,
                                 "err_max": e_max})
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.5))
    win = (ref_fine.t > 0.2) & (ref_fine.t < 0.5)
    ax[0].plot(ref_fine.t[win], ref_fine.y["omega2_out"][win], "k", lw=2, label="reference")
    for i, h in enumerate((steps[0], steps[-1])):
        run = traces["regularized", h]
        ax[0].plot(run.t[win], run.y["omega2_out"][win], color=f"C{i}", lw=0.8,
                   label=f"regularized, RK4 h = {h:g} s")
    ax[0].set(xlabel="t (s)", ylabel="omega2 (rad/s)", title="fixed-step RK4 on tanh friction")
    ax[0].legend(fontsize=7)
    for label, c in (("regularized", "C3"), ("event-driven", "C2")):
        hs, es, ns = zip(*chat[label])
        ax[1].loglog(hs, es, "o-", color=c, label=f"RK4, {label}")
        for h, e, n in chat[label]:
            ax[1].annotate(str(n), (h, e), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax[1].set(xlabel="fixed step h (s)", ylabel="max error / range",
              title=f"error (labels: sign changes of omega2; reference {n_ref})")
    ax[1].grid(True, which="both", alpha=0.3)
    ax[1].legend(fontsize=7)
    for (ks, solver, label), pts in eps_pts.items():
        _, secs, errs = zip(*pts)
        style = "o-" if label == "regularized" else "*"
        ax[2].loglog(secs, errs, style, ms=10 if label != "regularized" else 5,
                     label=f"{solver} {label}, k_static {ks}")
        if label == "regularized":
            for e, s, er in pts:
                ax[2].annotate(f"ε={e:g}", (s, er), fontsize=6, xytext=(3, 3),
                               textcoords="offset points")
    ax[2].set(xlabel="CPU time (s)", ylabel="max error / range",
              title="regularized (ε shrinks) vs event-driven, rtol 1e-8")
    ax[2].grid(True, which="both", alpha=0.3)
    ax[2].legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(out / f"{case.name}_friction.png", dpi=110)
    plt.close(fig)
    reg1 = eps_pts.get((1.0, "dopri5", "regularized"), [])
    ev1 = eps_pts.get((1.0, "dopri5", "event-driven"), [])
    reg13 = eps_pts.get((1.3, "dopri5", "regularized"), [])
    big = chat["regularized"][-1]
    verdict = (f"{case.name}: fixed-step RK4 on the tanh law (ε {eps_chat:g}) at h = "
               f"{big[0]:g} s crosses zero {big[2]} times against {n_ref} in the reference "
               f"(error {_fmt(big[1])}; event-driven RK4 {_fmt(chat['event-driven'][-1][1])}); "
               + (f"with k_static = 1.0, dopri5's cost grows {reg1[-1][1] / reg1[0][1]:.0f}x "
                  f"from ε {reg1[0][0]:g} to {reg1[-1][0]:g} while its error falls "
                  f"{_fmt(reg1[0][2])} → {_fmt(reg1[-1][2])}; event-driven: "
                  f"{_fmt(ev1[0][2])} in {ev1[0][1] * 1e3:.0f} ms; " if reg1 and ev1 else "")
               + (f"with k_static = 1.3 the regularized error stalls at {_fmt(reg13[-1][2])}"
                  if reg13 else ""))
    return rows, verdict


# -- delay: the drive -------------------------------------------------------------------

def delay(case: Case, plan: Plan, out, quick: bool):
    sc, rows = case.scene, []
    fast = {**sc.values, "f_rad": 0.02}  # the cam turns every ~0.2 s: u varies within steps
    ref = scipy_run(case.model, case.grid, method="DOP853", rtol=plan.ref_rtol,
                    atol=plan.ref_rtol * sc.atol_scale, values=fast)
    rtols = (1e-4, 1e-6, 1e-8) if quick else tuple(10.0 ** -k for k in range(3, 11))
    wp = {}
    for interp, label in ((1, "dense (Hermite)"), (2, "linear")):
        for solver in ("dopri5", "rodas4"):
            for rtol in rtols:
                run = timed(lambda: case.fmu.run(
                    solver=solver, rtol=rtol, atol=rtol * sc.atol_scale, stop=case.stop,
                    interval=case.interval, outputs=sc.outputs,
                    values={**fast, "delay_interpolation": interp}), plan.repeats)
                e_final, e_max = errors(run, ref, sc.outputs)
                wp.setdefault((solver, label), []).append((rtol, run.seconds, e_max))
                rows.append({**point(case, "delay-history", "fmu", f"{solver} {label}", None,
                                     rtol=rtol, param="delay_interpolation", value=interp,
                                     note="f_rad 0.02"),
                             "seconds": run.seconds, "err_final": e_final, "err_max": e_max})
    # fixed steps against a short delay: tau = 0.02 s, communication step 0.1 s
    short = {**fast, "tau": 0.02}
    stop, interval = min(case.stop, 5.0), 0.1
    grid = case.fmu.run(solver="dopri5", rtol=1e-6, atol=1e-6, stop=stop, interval=interval,
                        outputs=sc.outputs[:1], values=short).t
    ref_s = scipy_run(case.model, grid, method="DOP853", rtol=plan.ref_rtol,
                      atol=plan.ref_rtol * sc.atol_scale, values=short)
    ratios = (0.25, 1.0, 2.0, 4.0) if quick else (0.125, 0.25, 0.5, 1.0, 1.5, 2.0, 4.0)
    fixed = {}
    for interp, label in ((1, "dense (Hermite)"), (2, "linear")):
        for r in ratios:
            h = r * short["tau"]
            try:
                run = case.fmu.run(solver="rk4", rtol=1e-6, atol=1e-6, stop=stop,
                                   interval=interval, outputs=sc.outputs,
                                   values={**short, "solver_h_fixed": h,
                                           "delay_interpolation": interp})
                e_final, e_max = errors(run, ref_s, sc.outputs)
                status = "ok"
            except Exception as exc:
                run, e_final, e_max, status = None, math.nan, math.nan, f"failed: {exc}"[:100]
            fixed.setdefault(label, []).append((r, e_max))
            rows.append({**point(case, "delay-step", "fmu", f"rk4 {label}", None, h=h,
                                 param="h/tau", value=r, status="ok" if run else "failed",
                                 note="tau 0.02 s, f_rad 0.02" + ("" if run else status)),
                         "seconds": run.seconds if run else math.nan,
                         "err_final": e_final, "err_max": e_max})
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.5))
    for (solver, label), pts in wp.items():
        _, secs, errs = zip(*pts)
        ax[0].loglog(secs, errs, "o-" if label.startswith("dense") else "s--",
                     label=f"FMU {solver}, history {label}")
    ax[0].set(xlabel="CPU time (s)", ylabel="max error / range",
              title=f"{case.name}: delayed signal from the history (rtol sweep)")
    ax[0].grid(True, which="both", alpha=0.3)
    ax[0].legend(fontsize=7)
    for label, pts in fixed.items():
        rs, es = zip(*pts)
        ax[1].loglog(rs, es, "o-", label=f"FMU rk4, history {label}")
    ax[1].axvline(1.0, color="k", lw=0.8, ls=":")
    ax[1].set(xlabel="requested fixed step h / tau  (tau = 0.02 s)", ylabel="max error / range",
              title="fixed steps around the delay")
    ax[1].grid(True, which="both", alpha=0.3)
    # the span is about a decade and a half: labelled at the requested steps
    # (matplotlib's own minor labels there run into each other)
    ax[1].set_xticks(sorted({r for pts in fixed.values() for r, _ in pts}))
    ax[1].xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax[1].xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / f"{case.name}_delay.png", dpi=110)
    plt.close(fig)
    d_best = min(e for _, _, e in wp["dopri5", "dense (Hermite)"])
    l_best = min(e for _, _, e in wp["dopri5", "linear"])
    dense_fixed = dict(fixed["dense (Hermite)"])
    big = max(dense_fixed)
    at_tau = dense_fixed.get(1.0, math.nan)
    capped = abs(dense_fixed[big] - at_tau) <= 1e-3 * at_tau
    verdict = (f"{case.name}: with the history linear between steps dopri5's error stops at "
               f"{_fmt(l_best)} while the dense history reaches {_fmt(d_best)} (tightest "
               f"rtol {rtols[-1]:g}); a fixed RK4 step of {big:g}x the delay gives "
               f"{_fmt(dense_fixed[big])} against {_fmt(at_tau)} at h = tau"
               + (": the FMU cuts steps at the delay" if capped else ""))
    return rows, verdict


# -- breakpoints: the heald frame's motion law -------------------------------------------

def _plain_scipy(cm: CasadiModel, grid, *, method: str, rtol: float, atol: float,
                 restart: bool, outputs) -> Run:
    """solve_ivp on the symbolic right-hand side, straight through the event
    indicators' zeros or (restart) stopped and restarted at each of them."""
    d = cm.dae
    f = ca.Function("f", [d.t, d.x, cm.P], [cm.problem["ode"]])
    e = ca.Function("e", [d.t, d.x, cm.P], [ca.substitute(d.e, d.w, d.wsol)])
    p = cm.pnum
    n_rhs = [0]

    def rhs(t, x):
        n_rhs[0] += 1
        return np.asarray(f(t, x, p)).ravel()

    events = []
    for k in range(d.e.numel()) if restart else ():
        def ev(t, x, k=k):
            return float(e(t, x, p)[k])
        ev.terminal = True
        events.append(ev)
    t0, x, t_end = float(grid[0]), cm.x0.copy(), float(grid[-1])
    xs = np.empty((len(grid), len(x)))
    wall = time.perf_counter()
    while True:
        sol = solve_ivp(rhs, (t0, t_end), x, method=method, rtol=rtol, atol=atol,
                        events=events or None, dense_output=True)
        t1 = sol.t[-1]
        sel = (grid >= t0) & (grid <= t1)
        xs[sel] = sol.sol(grid[sel]).T
        if t1 >= t_end or sol.status != 1:
            break
        # past the root (as loomfmu.verification.reference does), then watch the events again
        gap = 1e-10 * max(1.0, abs(t1))
        x = solve_ivp(rhs, (t1, t1 + gap), sol.y[:, -1], method=method, rtol=rtol,
                      atol=atol).y[:, -1]
        t0 = t1 + gap
    wall = time.perf_counter() - wall
    ys = np.asarray(cm.out.map(len(grid))(grid[None, :], xs.T, np.zeros((d.w.numel(), len(grid))),
                                          np.repeat(p[:, None], len(grid), axis=1)))
    idx = {n: i for i, n in enumerate(cm.out_names)}
    return Run(grid, {k: ys[idx[k]] for k in outputs}, wall, n_rhs[0])


def breakpoints(case: Case, plan: Plan, out, quick: bool):
    sc, rows = case.scene, []
    laws = {"k_H 9/7 (corrected, smooth)": 9 / 7, "k_H 1.2 (printed, H' H'' jump)": 1.2}
    rtols = (1e-4, 1e-7, 1e-10) if quick else tuple(10.0 ** -k for k in range(3, 11))
    # stop short of the scene's end: it lies on a revolution boundary, where the
    # printed law's H jumps, and the final value would depend on the side taken
    stop = 0.95 * case.stop
    grid = case.grid[case.grid <= stop + 1e-12]
    stop = float(grid[-1])
    curves, fixed = {}, {}
    subs = (10, 40) if quick else (10, 20, 40, 80)
    for law, k_H in laws.items():
        vals = {**sc.values, "k_H": k_H}
        ref = scipy_run(case.model, grid, method="DOP853", rtol=plan.ref_rtol / 10,
                        atol=plan.ref_rtol / 10 * sc.atol_scale, values=vals)
        cm = CasadiModel(case.model, vals)
        methods = {
            "FMU dopri5 (stops at breakpoints)": lambda r: case.fmu.run(
                solver="dopri5", rtol=r, atol=r * sc.atol_scale, stop=stop,
                interval=case.interval, outputs=sc.outputs, values=vals),
            "scipy DOP853 through": lambda r: _plain_scipy(
                cm, grid, method="DOP853", rtol=r, atol=r * sc.atol_scale,
                restart=False, outputs=sc.outputs),
            "scipy DOP853 restarted": lambda r: _plain_scipy(
                cm, grid, method="DOP853", rtol=r, atol=r * sc.atol_scale,
                restart=True, outputs=sc.outputs),
            "CasADi cvodes through": lambda r: cm.run(
                grid, plugin="cvodes", rtol=r, atol=r * sc.atol_scale,
                outputs=sc.outputs),
        }
        for label, fn in methods.items():
            for rtol in rtols:
                run = timed(lambda: fn(rtol), plan.repeats)
                e_final, e_max = errors(run, ref, sc.outputs)
                curves.setdefault(law, {}).setdefault(label, []).append(
                    (rtol, run.seconds, e_max))
                rows.append({**point(case, "breakpoints", label.split()[0].lower(), label,
                                     None, rtol=rtol, param="k_H", value=k_H),
                             "seconds": run.seconds, "err_final": e_final, "err_max": e_max,
                             "n_rhs": "" if run.n_rhs is None else run.n_rhs})
        dt = float(grid[1] - grid[0])
        for n_sub in subs:
            h = dt / n_sub
            for label, fn in (("FMU rk4 (stops at breakpoints)", lambda: case.fmu.run(
                    solver="rk4", rtol=1e-6, atol=1e-9, stop=stop, interval=case.interval,
                    outputs=sc.outputs, values={**vals, "solver_h_fixed": h})),
                    ("RK4 through (CasADi loop)", lambda: _rk4_grid(cm, grid, n_sub,
                                                                   sc.outputs))):
                run = fn()
                e_final, e_max = errors(run, ref, sc.outputs)
                fixed.setdefault(law, {}).setdefault(label, []).append((h, e_max))
                rows.append({**point(case, "breakpoints", label.split()[0].lower(), label,
                                     None, h=h, param="k_H", value=k_H),
                             "seconds": run.seconds, "err_final": e_final, "err_max": e_max})
    fig, ax = plt.subplots(2, 2, figsize=(12, 8.5))
    for a, (law, by_method) in zip(ax[0], curves.items()):
        for label, pts in by_method.items():
            rt, _, es = zip(*pts)
            a.loglog(rt, es, "o-", label=label)
        a.set(xlabel="rtol", ylabel="max error / range", title=f"{case.name}: {law}")
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=7)
    for a, (law, by_method) in zip(ax[1], fixed.items()):
        for label, pts in by_method.items():
            hs, es = zip(*pts)
            a.loglog(hs, es, "o-", label=label)
        a.set(xlabel="fixed step h (s)", ylabel="max error / range", title=law)
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / f"{case.name}_breakpoints.png", dpi=110)
    plt.close(fig)
    printed = curves[list(laws)[1]]
    loose = {k: v[0][2] for k, v in printed.items()}

    def order(pts):
        (h0, e0), (h1, e1) = sorted(pts)[:2]
        return math.log(e1 / e0) / math.log(h1 / h0) if e0 > 0 and e1 > 0 else math.nan

    rk = fixed[list(laws)[1]]
    verdict = (f"{case.name}, printed law (H' and H'' jump at the dwells): fixed-step RK4 "
               f"straight through converges at order "
               f"{order(rk['RK4 through (CasADi loop)']):.1f}, our FMU's RK4, which stops "
               f"there, at {order(rk['FMU rk4 (stops at breakpoints)']):.1f}; adaptive "
               f"solvers pay less: at rtol {rtols[0]:g} DOP853 through "
               f"{_fmt(loose['scipy DOP853 through'])}, restarted "
               f"{_fmt(loose['scipy DOP853 restarted'])}, CasADi cvodes through "
               f"{_fmt(loose['CasADi cvodes through'])}, our FMU dopri5 "
               f"{_fmt(loose['FMU dopri5 (stops at breakpoints)'])}")
    return rows, verdict


#: scene name -> study (the study gets the scene's Case; ``friction`` also the
#: regularized backrest's)
STUDIES = {"spindle": stiff, "backrest": friction, "drive": delay, "heald_frame": breakpoints}
