/* loomfmu runtime: ros34pw2, the Rosenbrock-W method ROS34PW2 of Rang and
 * Angermann (order 3, embedded order 2, 4 stages, stiffly accurate,
 * L-stable), reusing the Jacobian and its factorization across steps
 * (contract: lf_solver.h).
 *
 * Source of the tableau: J. Rang, L. Angermann, "New Rosenbrock W-methods of
 * order 3 for partial differential algebraic equations of index 1", BIT
 * Numer. Math. 45 (2005) 761-787, Table ROS34PW2 (gamma = 0.435866521508459;
 * alpha_21 = 0.87173304301691801, alpha_31 = 0.84457060015369423,
 * alpha_32 = -0.11299064236484185, alpha_43 = 1; gamma_21 =
 * -0.87173304301691801, gamma_31 = -0.90338057013044082, gamma_32 =
 * 0.054180672388095326, gamma_41 = 0.24212380706095346, gamma_42 =
 * -1.2232505839045147, gamma_43 = 0.54526025533510214; b = (gamma_41,
 * gamma_42, 1.5452602553351020, gamma); b^ = (0.37810903145819369,
 * -0.096042292212423178, 0.5, 0.2179332607542295)).  Below in Hairer's
 * transformed form (as rodas4): with u_i = sum_j gamma_ij k_j,
 *   (I/(h*gamma) - W) u_i = f(t + alpha_i h, x + sum_j a_ij u_j)
 *                           + sum_j (c_ij/h) u_j + h gamma_i df/dt,
 *   a = A Gamma^-1, c = -Gamma^-1 off the diagonal, x_new = x + sum m_j u_j,
 * computed from the table above (the order-3 conditions then hold to 2e-16).
 *
 * A W-method keeps its order for ANY matrix W, not only W = df/dx (tested:
 * order 3 with W != J, where rodas4 falls to order 1).  That allows the
 * reuse: J0 (and df/dt) evaluated at an earlier point and the factors of
 * E = I/(h0*gamma) - J0 serve every step of size h0 (W = J0, only older):
 *  - a proposed step with WM_SNAP_LO <= h/h0 <= WM_SNAP_HI is taken as h0
 *    (the controller's wish to grow a little is declined, as in RADAU5);
 *  - the steps left to t_bound are made equal (wm_even_split), so that a
 *    communication interval, and the next one of the same length, needs no
 *    remainder step of another size;
 *  - J0 and the factors survive restarts (input changes: the old W stays a
 *    good approximation); the factors are renewed when h leaves that band,
 *    after WM_MAX_AGE accepted steps, and when a step with an older J0 is
 *    rejected; J0 itself is re-evaluated for a new factorization only when
 *    it is WM_JAC_AGE or more accepted steps old (or after a rejection or
 *    WM_MAX_AGE): a new h alone needs new factors, not a new J.  On the
 *    spindle run-up (ros34pw2, input derivatives, rtol 1e-6) this cut the
 *    Jacobians from 21 393 to 5 939 with the steps and factorizations
 *    unchanged (79 949 steps, 21 717 LU).
 * Measured on the spindle run-up: a shifted W = J0 + (1/h - 1/h0)/gamma I
 * for h < h0 (also a W-method) costs more rejections than it saves
 * factorizations (the error estimate of the stiff, lightly damped modes
 * is sensitive to it), so the band below h0 is empty by default.  The
 * embedded 2nd-order W-method guards the accuracy whatever W is.  Dense
 * output: cubic Hermite from x and f at both ends (f at the new point is
 * the next step's f0).
 */
#include "lf_solver_impl.h"
#include "lf_linalg.h"

#include <math.h>

#define WM_GAMMA 0.435866521508459
#define WM_A21 2.0
#define WM_A31 1.4192173174557647
#define WM_A32 (-0.25923221167296971)
#define WM_A41 4.1847604823191607
#define WM_A42 (-0.28519201735549591)
#define WM_A43 2.2942803602790417
#define WM_C21 (-4.5885607205580835)
#define WM_C31 (-4.1847604823191607)
#define WM_C32 0.28519201735549591
#define WM_C41 (-6.3681792001283578)
#define WM_C42 (-6.7956209444668362)
#define WM_C43 2.8700986043310561
#define WM_ALPHA2 0.87173304301691801
#define WM_ALPHA3 0.73157995778885238
/* gamma_i = sum_j gamma_ij (df/dt terms); gamma_4 = 0 */
#define WM_D1 0.435866521508459
#define WM_D2 (-0.435866521508459)
#define WM_D3 (-0.41333337623388649)
/* x_new = x + a41 u1 + a42 u2 + a43 u3 + u4 (stiffly accurate: the stage-4
 * argument plus u4); error = sum e_j u_j (m - m^) */
#define WM_E1 0.27774994764796811
#define WM_E2 (-1.403239895175999)
#define WM_E3 1.7726301276675507
#define WM_E4 0.5

/* reuse policy (see above); the factors serve a step h with
 * WM_RATIO_LO <= h/h0 <= 1 + 1e-9 (below 1: W = J0 + (1/h - 1/h0)/gamma I) */
#ifndef WM_SNAP_HI
#define WM_SNAP_HI 1.5
#endif
#ifndef WM_SNAP_LO
#define WM_SNAP_LO 1.0
#endif
#ifndef WM_RATIO_LO
#define WM_RATIO_LO (1.0 - 1e-9)
#endif
#ifndef WM_MAX_AGE
#define WM_MAX_AGE 50
#endif
#ifndef WM_JAC_AGE
#define WM_JAC_AGE 10
#endif

/* private data: scalars, vectors u1..u4, stage argument / new state, f at a
 * stage, f0 = f(t, x), f(t_old, x_old), df/dt (with J0), then J0 (n*n) and
 * the factored iteration matrix (lf_shifted_*). */
enum { WM_HACC, WM_ERRACC, WM_HISTOK, WM_JOK, WM_H0, WM_AGE, WM_NSCAL };
enum { WM_U1, WM_U2, WM_U3, WM_U4, WM_Y, WM_DY, WM_F0, WM_FOLD, WM_FT, WM_NVEC };

static size_t wm_work_size(size_t n) {
    return WM_NSCAL + WM_NVEC * n + n * n + lf_shifted_doubles(n);
}

static double *wm_vec(LfSolver *s, int k) { return LF_PRIV(s) + WM_NSCAL + (size_t)k * s->ode.n; }
static double *wm_jac(LfSolver *s) { return LF_PRIV(s) + WM_NSCAL + WM_NVEC * s->ode.n; }
static double *wm_lu(LfSolver *s) { return wm_jac(s) + s->ode.n * s->ode.n; }

/* after a restart: forget the controller history, keep J0 and its factors */
void lf_ros34pw2_restart(LfSolver *s) { LF_PRIV(s)[WM_HISTOK] = 0.0; }

/* J0, df/dt at the current point */
static LfStatus wm_jacobian(LfSolver *s) {
    const size_t n = s->ode.n;
    double *J = wm_jac(s), *ft = wm_vec(s, WM_FT);
    LfStatus st;
    s->n_jac++;
    st = s->ode.jac(s->ode.ctx, s->t, s->x, J, ft);
    if (st == LF_OK || st == LF_WARNING) {
        if (lf_sv_all_finite(J, n * n) && lf_sv_all_finite(ft, n)) {
            LF_PRIV(s)[WM_AGE] = 0.0;
            return LF_OK;
        }
        lf_sv_set_msg(s, "ros34pw2: Jacobian or df/dt not finite at t=%.17g", s->t);
        return LF_DISCARD;
    }
    if (st == LF_DISCARD) {
        lf_sv_set_msg(s, "ros34pw2: Jacobian could not be evaluated at t=%.17g", s->t);
        return LF_DISCARD;
    }
    lf_sv_set_msg(s, "ros34pw2: Jacobian callback returned an error at t=%.17g", s->t);
    return st == LF_FATAL ? LF_FATAL : LF_ERROR;
}

/* Make the factors usable for step h: refresh J (if older than this point)
 * and refactor when there are none, h left the ratio band, or `renew`.
 * Returns LF_OK, a failure of the Jacobian, or -1 for a singular matrix. */
static int wm_matrix(LfSolver *s, double h, int renew) {
    double *p = LF_PRIV(s), r = p[WM_JOK] != 0.0 ? h / p[WM_H0] : 0.0;
    LfStatus st;
    if (!renew && r >= WM_RATIO_LO && r <= 1.0 + 1e-9) return LF_OK;
    if (p[WM_JOK] == 0.0 || (p[WM_AGE] > 0.0 && (renew || p[WM_AGE] >= WM_JAC_AGE))) {
        p[WM_JOK] = 0.0;
        st = wm_jacobian(s);
        if (st != LF_OK) return (int)st;
    }
    s->n_lu++;
    p[WM_JOK] = 0.0;
    if (lf_shifted_factor(wm_lu(s), wm_jac(s), s->ode.n, 1.0 / (h * WM_GAMMA)) != 0) return -1;
    p[WM_JOK] = 1.0;
    p[WM_H0] = h;
    return LF_OK;
}

/* The k = ceil(rem/h) steps left to t_bound made equal (rem/k <= h): as
 * many steps as k-1 steps of h and a remainder, but one step size, and the
 * same one in the next communication interval of the same length, so that
 * one factorization serves them all. */
static double wm_even_split(double h, double rem) {
    double k;
    if (!(h > 0.0) || !(rem > h)) return h;
    k = ceil(rem / h * (1.0 - 1e-12));
    return k > 1e6 ? h : rem / k;
}

static LfStatus wm_step(LfSolver *s, double t_bound) {
    const size_t n = s->ode.n;
    double *u1 = wm_vec(s, WM_U1), *u2 = wm_vec(s, WM_U2), *u3 = wm_vec(s, WM_U3);
    double *u4 = wm_vec(s, WM_U4), *y = wm_vec(s, WM_Y), *dy = wm_vec(s, WM_DY);
    double *f0 = wm_vec(s, WM_F0), *ft = wm_vec(s, WM_FT), *J = wm_jac(s), *E = wm_lu(s);
    double *p = LF_PRIV(s), *x = s->x;
    const double t = s->t, hmax = s->opt.h_max;
    double h;
    int rejected = 0, cause = CAUSE_NONE, attempts = 0, nsing = 0, renew = 0, mst;
    size_t i;
    LfStatus st;

    if (!(t_bound > t)) return lf_sv_bad_bound(s, t_bound);
    if (!s->fsal_valid) {
        st = lf_sv_eval_rhs(s, t, x, f0);
        if (st != LF_OK) return lf_sv_start_failure(s, st);
        s->fsal_valid = 1;
    }
    if (p[WM_AGE] >= WM_MAX_AGE) renew = 1;
    h = s->h;
    if (!(h > 0.0)) h = lf_sv_initial_step(s, f0, y, dy, 3.0, fmin(hmax, t_bound - t));
    if (h > hmax) h = hmax;

    for (;;) {
        double h_prop = h, t_new, hmin, err, fac, hnew, hd, c1, c2, c3;
        int last;
        if (++attempts > LF_MAX_ATTEMPTS) return lf_sv_give_up(s, h, 0.0, cause, 1);
        if (!renew && !rejected && p[WM_JOK] != 0.0 && h >= WM_SNAP_LO * p[WM_H0] &&
            h <= WM_SNAP_HI * p[WM_H0])
            h = p[WM_H0];
        h = wm_even_split(h, t_bound - t);
        if (lf_sv_plan_step(s, t_bound, &h, &t_new, &last, &hmin)) return lf_sv_give_up(s, h, hmin, cause, 0);

        mst = wm_matrix(s, h, renew);
        renew = 0;
        if (mst < 0) {
            if (++nsing >= 5) {
                lf_sv_set_msg(s, "ros34pw2: singular iteration matrix I/(h*gamma) - J at t=%.17g "
                              "(h=%.3g, 5 step reductions)", t, h);
                return LF_DISCARD;
            }
            h *= 0.5;
            rejected = 1;
            cause = CAUSE_SINGULAR;
            s->n_rejected++;
            continue;
        }
        if (mst != LF_OK) return (LfStatus)mst;

        /* stage 1 */
        hd = h * WM_D1;
        for (i = 0; i < n; i++) u1[i] = f0[i] + hd * ft[i];
        lf_shifted_solve(E, J, n, u1);
        /* stage 2 */
        for (i = 0; i < n; i++) y[i] = x[i] + WM_A21 * u1[i];
        st = lf_sv_eval_rhs(s, t + WM_ALPHA2 * h, y, dy);
        if (st != LF_OK) goto failed;
        hd = h * WM_D2;
        c1 = WM_C21 / h;
        for (i = 0; i < n; i++) u2[i] = dy[i] + c1 * u1[i] + hd * ft[i];
        lf_shifted_solve(E, J, n, u2);
        /* stage 3 */
        for (i = 0; i < n; i++) y[i] = x[i] + WM_A31 * u1[i] + WM_A32 * u2[i];
        st = lf_sv_eval_rhs(s, t + WM_ALPHA3 * h, y, dy);
        if (st != LF_OK) goto failed;
        hd = h * WM_D3;
        c1 = WM_C31 / h;
        c2 = WM_C32 / h;
        for (i = 0; i < n; i++) u3[i] = dy[i] + c1 * u1[i] + c2 * u2[i] + hd * ft[i];
        lf_shifted_solve(E, J, n, u3);
        /* stage 4 (alpha_4 = 1, gamma_4 = 0) */
        for (i = 0; i < n; i++) y[i] = x[i] + WM_A41 * u1[i] + WM_A42 * u2[i] + WM_A43 * u3[i];
        st = lf_sv_eval_rhs(s, t_new, y, dy);
        if (st != LF_OK) goto failed;
        c1 = WM_C41 / h;
        c2 = WM_C42 / h;
        c3 = WM_C43 / h;
        for (i = 0; i < n; i++) u4[i] = dy[i] + c1 * u1[i] + c2 * u2[i] + c3 * u3[i];
        lf_shifted_solve(E, J, n, u4);
        /* new solution (stiffly accurate) and the embedded error */
        for (i = 0; i < n; i++) {
            y[i] += u4[i];
            dy[i] = WM_E1 * u1[i] + WM_E2 * u2[i] + WM_E3 * u3[i] + WM_E4 * u4[i];
        }
        err = lf_sv_err_norm(s, dy, x, y);
        if (!isfinite(err) || !lf_sv_all_finite(y, n)) {
            st = LF_DISCARD;
            goto failed;
        }
        fac = pow(err, 1.0 / 3.0) / 0.9;
        if (fac > 5.0) fac = 5.0;
        if (fac < 1.0 / 6.0) fac = 1.0 / 6.0;
        hnew = h / fac;
        if (err <= 1.0) {
            /* f at the new point: the dense output's end slope and the next
             * step's f0 */
            st = lf_sv_eval_rhs(s, t_new, y, dy);
            if (st != LF_OK) goto failed;
            if (p[WM_HISTOK] != 0.0) {
                /* predictive controller of Gustafsson */
                double facgus = (p[WM_HACC] / h) * pow(err * err / p[WM_ERRACC], 1.0 / 3.0) / 0.9;
                if (facgus > 5.0) facgus = 5.0;
                if (facgus < 1.0 / 6.0) facgus = 1.0 / 6.0;
                fac = fmax(fac, facgus);
                hnew = h / fac;
            }
            p[WM_HACC] = h;
            p[WM_ERRACC] = fmax(1e-2, err);
            p[WM_HISTOK] = 1.0;
            p[WM_AGE] += 1.0;
            lf_sv_copy_vec(wm_vec(s, WM_FOLD), f0, n);
            lf_sv_copy_vec(f0, dy, n);
            lf_sv_copy_vec(s->x_old, x, n);
            lf_sv_copy_vec(x, y, n);
            s->t_old = t;
            s->t = t_new;
            if (rejected && hnew > h) hnew = h;
            if (last && !rejected && h_prop > hnew) hnew = h_prop;
            s->h = fmin(hnew, hmax);
            s->n_steps++;
            return LF_OK;
        }
        h = hnew;
        rejected = 1;
        cause = CAUSE_ERRTEST;
        s->n_rejected++;
        /* a W older than this point may be what failed: renew it */
        if (p[WM_AGE] > 0.0) renew = 1;
        continue;
    failed:
        if (st != LF_DISCARD) return lf_sv_callback_error(s, st, t + h);
        h *= 0.25;
        rejected = 1;
        cause = CAUSE_NONFINITE;
        s->n_rejected++;
        if (p[WM_AGE] > 0.0) renew = 1;
    }
}

static void wm_dense(const LfSolver *s, double tq, double *out) {
    const size_t n = s->ode.n;
    const double *w = LF_CPRIV(s) + WM_NSCAL;
    const double *f1 = w + WM_F0 * n, *f0 = w + WM_FOLD * n;
    const double *x0 = s->x_old, *x1 = s->x;
    double h = s->t - s->t_old, th, th2, th3, h00, h10, h01, h11;
    size_t i;
    if (!(h > 0.0) || !s->fsal_valid) {
        lf_sv_copy_vec(out, x1, n);
        return;
    }
    th = (tq - s->t_old) / h;
    th2 = th * th;
    th3 = th2 * th;
    h00 = 2.0 * th3 - 3.0 * th2 + 1.0;
    h10 = (th3 - 2.0 * th2 + th) * h;
    h01 = 3.0 * th2 - 2.0 * th3;
    h11 = (th3 - th2) * h;
    for (i = 0; i < n; i++) out[i] = h00 * x0[i] + h10 * f0[i] + h01 * x1[i] + h11 * f1[i];
}

const LfMethod lf_ros34pw2 = {"ros34pw2", 1, 1, wm_work_size, wm_step, wm_dense};
