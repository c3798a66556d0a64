/* loomfmu runtime: dopri5, explicit Dormand-Prince 5(4) with FSAL and
 * Hairer's 4th-order dense output (contract: lf_solver.h). */
#include "lf_solver_impl.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* ------------------------------------------------------------------------ */
/* dopri5                                                                    */

/* Dormand & Prince (1980) 5(4) tableau, Hairer-Norsett-Wanner DOPRI5 */
#define DP_C2 (1.0 / 5.0)
#define DP_C3 (3.0 / 10.0)
#define DP_C4 (4.0 / 5.0)
#define DP_C5 (8.0 / 9.0)
#define DP_A21 (1.0 / 5.0)
#define DP_A31 (3.0 / 40.0)
#define DP_A32 (9.0 / 40.0)
#define DP_A41 (44.0 / 45.0)
#define DP_A42 (-56.0 / 15.0)
#define DP_A43 (32.0 / 9.0)
#define DP_A51 (19372.0 / 6561.0)
#define DP_A52 (-25360.0 / 2187.0)
#define DP_A53 (64448.0 / 6561.0)
#define DP_A54 (-212.0 / 729.0)
#define DP_A61 (9017.0 / 3168.0)
#define DP_A62 (-355.0 / 33.0)
#define DP_A63 (46732.0 / 5247.0)
#define DP_A64 (49.0 / 176.0)
#define DP_A65 (-5103.0 / 18656.0)
#define DP_A71 (35.0 / 384.0)
#define DP_A73 (500.0 / 1113.0)
#define DP_A74 (125.0 / 192.0)
#define DP_A75 (-2187.0 / 6784.0)
#define DP_A76 (11.0 / 84.0)
/* error coefficients: 5th-order minus 4th-order weights */
#define DP_E1 (71.0 / 57600.0)
#define DP_E3 (-71.0 / 16695.0)
#define DP_E4 (71.0 / 1920.0)
#define DP_E5 (-17253.0 / 339200.0)
#define DP_E6 (22.0 / 525.0)
#define DP_E7 (-1.0 / 40.0)
/* dense output (Hairer's CONTD5) */
#define DP_D1 (-12715105075.0 / 11282082432.0)
#define DP_D3 (87487479700.0 / 32700410799.0)
#define DP_D4 (-10690763975.0 / 1880347072.0)
#define DP_D5 (701980252875.0 / 199316789632.0)
#define DP_D6 (-1453857185.0 / 822651844.0)
#define DP_D7 (69997945.0 / 29380423.0)

/* private vectors: stages k1..k7, stage argument, new state, dense r3..r5 */
enum { DP_K1, DP_K2, DP_K3, DP_K4, DP_K5, DP_K6, DP_K7, DP_Y, DP_YNEW, DP_R3, DP_R4, DP_R5, DP_NVEC };

static size_t dp_work_size(size_t n) { return DP_NVEC * n; }

static LfStatus dp_step(LfSolver *s, double t_bound) {
    const size_t n = s->ode.n;
    double *w = LF_PRIV(s);
    double *k1 = w + DP_K1 * n, *k2 = w + DP_K2 * n, *k3 = w + DP_K3 * n, *k4 = w + DP_K4 * n;
    double *k5 = w + DP_K5 * n, *k6 = w + DP_K6 * n, *k7 = w + DP_K7 * n;
    double *y = w + DP_Y * n, *ynew = w + DP_YNEW * n;
    double *x = s->x;
    const double t = s->t, hmax = s->opt.h_max;
    double h;
    int rejected = 0, cause = CAUSE_NONE, attempts = 0;
    size_t i;
    LfStatus st;

    if (!(t_bound > t)) return lf_sv_bad_bound(s, t_bound);
    if (!s->fsal_valid) {
        st = lf_sv_eval_rhs(s, t, x, k1);
        if (st != LF_OK) return lf_sv_start_failure(s, st);
        s->fsal_valid = 1;
    }
    h = s->h;
    if (!(h > 0.0)) h = lf_sv_initial_step(s, k1, k2, k3, 5.0, fmin(hmax, t_bound - t));
    if (h > hmax) h = hmax;

    for (;;) {
        double h_prop = h, t_new, hmin, err, fac;
        int last;
        if (++attempts > LF_MAX_ATTEMPTS) return lf_sv_give_up(s, h, 0.0, cause, 1);
        if (lf_sv_plan_step(s, t_bound, &h, &t_new, &last, &hmin)) return lf_sv_give_up(s, h, hmin, cause, 0);

        for (i = 0; i < n; i++) y[i] = x[i] + h * DP_A21 * k1[i];
        st = lf_sv_eval_rhs(s, t + DP_C2 * h, y, k2);
        if (st != LF_OK) goto failed;
        for (i = 0; i < n; i++) y[i] = x[i] + h * (DP_A31 * k1[i] + DP_A32 * k2[i]);
        st = lf_sv_eval_rhs(s, t + DP_C3 * h, y, k3);
        if (st != LF_OK) goto failed;
        for (i = 0; i < n; i++)
            y[i] = x[i] + h * (DP_A41 * k1[i] + DP_A42 * k2[i] + DP_A43 * k3[i]);
        st = lf_sv_eval_rhs(s, t + DP_C4 * h, y, k4);
        if (st != LF_OK) goto failed;
        for (i = 0; i < n; i++)
            y[i] = x[i] + h * (DP_A51 * k1[i] + DP_A52 * k2[i] + DP_A53 * k3[i] + DP_A54 * k4[i]);
        st = lf_sv_eval_rhs(s, t + DP_C5 * h, y, k5);
        if (st != LF_OK) goto failed;
        for (i = 0; i < n; i++)
            y[i] = x[i] + h * (DP_A61 * k1[i] + DP_A62 * k2[i] + DP_A63 * k3[i] +
                               DP_A64 * k4[i] + DP_A65 * k5[i]);
        st = lf_sv_eval_rhs(s, t_new, y, k6);
        if (st != LF_OK) goto failed;
        for (i = 0; i < n; i++)
            ynew[i] = x[i] + h * (DP_A71 * k1[i] + DP_A73 * k3[i] + DP_A74 * k4[i] +
                                  DP_A75 * k5[i] + DP_A76 * k6[i]);
        st = lf_sv_eval_rhs(s, t_new, ynew, k7);
        if (st != LF_OK) goto failed;

        for (i = 0; i < n; i++)
            y[i] = h * (DP_E1 * k1[i] + DP_E3 * k3[i] + DP_E4 * k4[i] + DP_E5 * k5[i] +
                        DP_E6 * k6[i] + DP_E7 * k7[i]);
        err = lf_sv_err_norm(s, y, x, ynew);
        if (!isfinite(err)) {
            st = LF_DISCARD;
            goto failed;
        }
        if (err <= 1.0) {
            double hnew, *r3 = w + DP_R3 * n, *r4 = w + DP_R4 * n, *r5 = w + DP_R5 * n;
            fac = err > 0.0 ? 0.9 * pow(err, -0.2) : 10.0;
            if (fac > 10.0) fac = 10.0;
            if (fac < 0.2) fac = 0.2;
            if (rejected && fac > 1.0) fac = 1.0;
            hnew = h * fac;
            if (!s->dense_unused) {
                for (i = 0; i < n; i++) {
                    double dy = ynew[i] - x[i];
                    r3[i] = h * k1[i] - dy;
                    r4[i] = dy - h * k7[i] - r3[i];
                    r5[i] = h * (DP_D1 * k1[i] + DP_D3 * k3[i] + DP_D4 * k4[i] +
                                 DP_D5 * k5[i] + DP_D6 * k6[i] + DP_D7 * k7[i]);
                }
            }
            for (i = 0; i < n; i++) { /* (a loop: n is small, a memmove call is not) */
                s->x_old[i] = x[i];
                x[i] = ynew[i];
                k1[i] = k7[i]; /* FSAL */
            }
            s->t_old = t;
            s->t = t_new;
            /* a step shortened to hit t_bound says little about the next one */
            if (last && !rejected && h_prop > hnew) hnew = h_prop;
            s->h = fmin(hnew, hmax);
            s->n_steps++;
            return LF_OK;
        }
        fac = 0.9 * pow(err, -0.2);
        if (fac < 0.2) fac = 0.2;
        h *= fac;
        rejected = 1;
        cause = CAUSE_ERRTEST;
        s->n_rejected++;
        continue;
    failed:
        if (st != LF_DISCARD) return lf_sv_callback_error(s, st, t + h);
        h *= 0.25;
        rejected = 1;
        cause = CAUSE_NONFINITE;
        s->n_rejected++;
    }
}

/* (not after steps taken with s->dense_unused set) */
static void dp_dense(const LfSolver *s, double tq, double *out) {
    const size_t n = s->ode.n;
    const double *w = LF_CPRIV(s);
    const double *r3 = w + DP_R3 * n, *r4 = w + DP_R4 * n, *r5 = w + DP_R5 * n;
    const double *x0 = s->x_old, *x1 = s->x;
    double h = s->t - s->t_old, th, th1;
    size_t i;
    if (!(h > 0.0)) {
        lf_sv_copy_vec(out, x1, n);
        return;
    }
    th = (tq - s->t_old) / h;
    th1 = 1.0 - th;
    for (i = 0; i < n; i++) {
        double dy = x1[i] - x0[i];
        out[i] = x0[i] + th * (dy + th1 * (r3[i] + th * (r4[i] + th1 * r5[i])));
    }
}

const LfMethod lf_dopri5 = {"dopri5", 1, 0, dp_work_size, dp_step, dp_dense};
