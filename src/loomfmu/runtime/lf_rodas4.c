/* loomfmu runtime: rodas4, the Hairer-Wanner RODAS stiffly accurate
 * Rosenbrock method 4(3) with its 3rd-order dense output (contract:
 * lf_solver.h). */
#include "lf_solver_impl.h"
#include "lf_linalg.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* ------------------------------------------------------------------------ */
/* rodas4                                                                    */

/* Hairer & Wanner, Solving ODEs II, Sec. IV.7; coefficients of RODAS
 * (METH=1) in the W-transformed form used by rodas.f:
 *   (I/(h*gamma) - J) k_i = f(t + c_i h, x + sum_j a_ij k_j)
 *                           + sum_j (c_ij/h) k_j + h d_i df/dt
 * x_new = x + sum_j a_5j k_j + k5 + k6 (stiffly accurate), error = k6. */
#define RO_GAMMA 0.25
#define RO_C2 0.386
#define RO_C3 0.21
#define RO_C4 0.63
#define RO_D1 0.25
#define RO_D2 (-0.1043)
#define RO_D3 0.1035
#define RO_D4 (-0.3620000000000023e-01)
#define RO_A21 1.544
#define RO_A31 0.9466785280815826
#define RO_A32 0.2557011698983284
#define RO_A41 3.314825187068521
#define RO_A42 2.896124015972201
#define RO_A43 0.9986419139977817
#define RO_A51 1.221224509226641
#define RO_A52 6.019134481288629
#define RO_A53 12.53708332932087
#define RO_A54 (-0.6878860361058950)
#define RO_C21 (-5.6688)
#define RO_C31 (-2.430093356833875)
#define RO_C32 (-0.2063599157091915)
#define RO_C41 (-0.1073529058151375)
#define RO_C42 (-9.594562251023355)
#define RO_C43 (-20.47028614809616)
#define RO_C51 7.496443313967647
#define RO_C52 (-10.24680431464352)
#define RO_C53 (-33.99990352819905)
#define RO_C54 11.70890893206160
#define RO_C61 8.083246795921522
#define RO_C62 (-7.981132988064893)
#define RO_C63 (-31.52159432874371)
#define RO_C64 16.31930543123136
#define RO_C65 (-6.058818238834054)
/* dense output */
#define RO_D21 10.12623508344586
#define RO_D22 (-7.487995877610167)
#define RO_D23 (-34.80091861555747)
#define RO_D24 (-7.992771707568823)
#define RO_D25 1.025137723295662
#define RO_D31 (-0.6762803392801253)
#define RO_D32 6.087714651680015
#define RO_D33 16.43084320892478
#define RO_D34 24.76722511418386
#define RO_D35 (-6.594389125716872)

/* private data: 3 controller scalars (h_acc, err_acc, valid), then vectors
 * k1..k6, stage argument / new state, f at stage, f0 = f(t,x), df/dt,
 * dense cont3, cont4; then J (n*n) and the factored iteration matrix
 * (lf_shifted_factor: dense LU, or the Schur complement when J has
 * kinematic rows q' = v). */
enum { RO_HACC, RO_ERRACC, RO_HISTOK, RO_NSCAL };
enum { RO_K1, RO_K2, RO_K3, RO_K4, RO_K5, RO_K6, RO_Y, RO_DY, RO_F0, RO_FT, RO_CONT3, RO_CONT4, RO_NVEC };

static size_t ro_work_size(size_t n) {
    return RO_NSCAL + RO_NVEC * n + n * n + lf_shifted_doubles(n);
}

static double *ro_vec(LfSolver *s, int k) { return LF_PRIV(s) + RO_NSCAL + (size_t)k * s->ode.n; }
static double *ro_jac(LfSolver *s) { return LF_PRIV(s) + RO_NSCAL + RO_NVEC * s->ode.n; }
static double *ro_lu(LfSolver *s) { return ro_jac(s) + s->ode.n * s->ode.n; }

void lf_rodas4_clear_history(LfSolver *s) { LF_PRIV(s)[RO_HISTOK] = 0.0; }

/* f0 = f(t,x), J, df/dt at the accepted point */
static LfStatus ro_prepare(LfSolver *s) {
    const size_t n = s->ode.n;
    double *f0 = ro_vec(s, RO_F0), *ft = ro_vec(s, RO_FT), *J = ro_jac(s);
    LfStatus st = lf_sv_eval_rhs(s, s->t, s->x, f0);
    if (st != LF_OK) return lf_sv_start_failure(s, st);
    s->n_jac++;
    st = s->ode.jac(s->ode.ctx, s->t, s->x, J, ft);
    if (st == LF_OK || st == LF_WARNING) {
        if (lf_sv_all_finite(J, n * n) && lf_sv_all_finite(ft, n)) return LF_OK;
        lf_sv_set_msg(s, "rodas4: Jacobian or df/dt not finite at t=%.17g", s->t);
        return LF_DISCARD;
    }
    if (st == LF_DISCARD) {
        lf_sv_set_msg(s, "rodas4: Jacobian could not be evaluated at t=%.17g", s->t);
        return LF_DISCARD;
    }
    lf_sv_set_msg(s, "rodas4: Jacobian callback returned an error at t=%.17g", s->t);
    return st == LF_FATAL ? LF_FATAL : LF_ERROR;
}

static LfStatus ro_step(LfSolver *s, double t_bound) {
    const size_t n = s->ode.n;
    double *k1 = ro_vec(s, RO_K1), *k2 = ro_vec(s, RO_K2), *k3 = ro_vec(s, RO_K3);
    double *k4 = ro_vec(s, RO_K4), *k5 = ro_vec(s, RO_K5), *k6 = ro_vec(s, RO_K6);
    double *y = ro_vec(s, RO_Y), *dy = ro_vec(s, RO_DY), *f0 = ro_vec(s, RO_F0);
    double *ft = ro_vec(s, RO_FT), *J = ro_jac(s), *E = ro_lu(s), *hist = LF_PRIV(s);
    double *x = s->x;
    const double t = s->t, hmax = s->opt.h_max;
    double h;
    int rejected = 0, cause = CAUSE_NONE, attempts = 0, nsing = 0;
    size_t i;
    LfStatus st;

    if (!(t_bound > t)) return lf_sv_bad_bound(s, t_bound);
    if (!s->fsal_valid) {
        st = ro_prepare(s);
        if (st != LF_OK) return st;
        s->fsal_valid = 1;
    }
    h = s->h;
    if (!(h > 0.0)) h = lf_sv_initial_step(s, f0, y, dy, 4.0, fmin(hmax, t_bound - t));
    if (h > hmax) h = hmax;

    for (;;) {
        double h_prop = h, t_new, hmin, err, fac, hnew, fac_lu, hd, c1, c2, c3, c4, c5;
        int last;
        if (++attempts > LF_MAX_ATTEMPTS) return lf_sv_give_up(s, h, 0.0, cause, 1);
        if (lf_sv_plan_step(s, t_bound, &h, &t_new, &last, &hmin)) return lf_sv_give_up(s, h, hmin, cause, 0);

        /* iteration matrix I/(h*gamma) - J, factorized */
        fac_lu = 1.0 / (h * RO_GAMMA);
        s->n_lu++;
        if (lf_shifted_factor(E, J, n, fac_lu) != 0) {
            if (++nsing >= 5) {
                lf_sv_set_msg(s, "rodas4: singular iteration matrix I/(h*gamma) - J at t=%.17g "
                           "(h=%.3g, 5 step reductions)", t, h);
                return LF_DISCARD;
            }
            h *= 0.5;
            rejected = 1;
            cause = CAUSE_SINGULAR;
            s->n_rejected++;
            continue;
        }

        /* stage 1 */
        hd = h * RO_D1;
        for (i = 0; i < n; i++) k1[i] = f0[i] + hd * ft[i];
        lf_shifted_solve(E, J, n, k1);
        /* stage 2 */
        for (i = 0; i < n; i++) y[i] = x[i] + RO_A21 * k1[i];
        st = lf_sv_eval_rhs(s, t + RO_C2 * h, y, dy);
        if (st != LF_OK) goto failed;
        hd = h * RO_D2;
        c1 = RO_C21 / h;
        for (i = 0; i < n; i++) k2[i] = dy[i] + c1 * k1[i] + hd * ft[i];
        lf_shifted_solve(E, J, n, k2);
        /* stage 3 */
        for (i = 0; i < n; i++) y[i] = x[i] + RO_A31 * k1[i] + RO_A32 * k2[i];
        st = lf_sv_eval_rhs(s, t + RO_C3 * h, y, dy);
        if (st != LF_OK) goto failed;
        hd = h * RO_D3;
        c1 = RO_C31 / h;
        c2 = RO_C32 / h;
        for (i = 0; i < n; i++) k3[i] = dy[i] + c1 * k1[i] + c2 * k2[i] + hd * ft[i];
        lf_shifted_solve(E, J, n, k3);
        /* stage 4 */
        for (i = 0; i < n; i++) y[i] = x[i] + RO_A41 * k1[i] + RO_A42 * k2[i] + RO_A43 * k3[i];
        st = lf_sv_eval_rhs(s, t + RO_C4 * h, y, dy);
        if (st != LF_OK) goto failed;
        hd = h * RO_D4;
        c1 = RO_C41 / h;
        c2 = RO_C42 / h;
        c3 = RO_C43 / h;
        for (i = 0; i < n; i++) k4[i] = dy[i] + c1 * k1[i] + c2 * k2[i] + c3 * k3[i] + hd * ft[i];
        lf_shifted_solve(E, J, n, k4);
        /* stage 5 (c5 = 1, d5 = 0) */
        for (i = 0; i < n; i++)
            y[i] = x[i] + RO_A51 * k1[i] + RO_A52 * k2[i] + RO_A53 * k3[i] + RO_A54 * k4[i];
        st = lf_sv_eval_rhs(s, t_new, y, dy);
        if (st != LF_OK) goto failed;
        c1 = RO_C51 / h;
        c2 = RO_C52 / h;
        c3 = RO_C53 / h;
        c4 = RO_C54 / h;
        for (i = 0; i < n; i++) k5[i] = dy[i] + c1 * k1[i] + c2 * k2[i] + c3 * k3[i] + c4 * k4[i];
        lf_shifted_solve(E, J, n, k5);
        /* embedded 3rd-order solution, stage 6 */
        for (i = 0; i < n; i++) y[i] += k5[i];
        st = lf_sv_eval_rhs(s, t_new, y, dy);
        if (st != LF_OK) goto failed;
        c1 = RO_C61 / h;
        c2 = RO_C62 / h;
        c3 = RO_C63 / h;
        c4 = RO_C64 / h;
        c5 = RO_C65 / h;
        for (i = 0; i < n; i++)
            k6[i] = dy[i] + c1 * k1[i] + c2 * k2[i] + c3 * k3[i] + c4 * k4[i] + c5 * k5[i];
        lf_shifted_solve(E, J, n, k6);
        /* new solution (4th order) */
        for (i = 0; i < n; i++) y[i] += k6[i];

        err = lf_sv_err_norm(s, k6, x, y);
        if (!isfinite(err) || !lf_sv_all_finite(y, n)) {
            st = LF_DISCARD;
            goto failed;
        }
        /* Hairer's RODAS controller: 1/5 <= hnew/h <= 6 */
        fac = pow(err, 0.25) / 0.9;
        if (fac > 5.0) fac = 5.0;
        if (fac < 1.0 / 6.0) fac = 1.0 / 6.0;
        hnew = h / fac;
        if (err <= 1.0) {
            double *cont3 = ro_vec(s, RO_CONT3), *cont4 = ro_vec(s, RO_CONT4);
            if (hist[RO_HISTOK] != 0.0) {
                /* predictive controller of Gustafsson */
                double facgus = (hist[RO_HACC] / h) * pow(err * err / hist[RO_ERRACC], 0.25) / 0.9;
                if (facgus > 5.0) facgus = 5.0;
                if (facgus < 1.0 / 6.0) facgus = 1.0 / 6.0;
                fac = fmax(fac, facgus);
                hnew = h / fac;
            }
            hist[RO_HACC] = h;
            hist[RO_ERRACC] = fmax(1e-2, err);
            hist[RO_HISTOK] = 1.0;
            for (i = 0; i < n; i++) {
                cont3[i] = RO_D21 * k1[i] + RO_D22 * k2[i] + RO_D23 * k3[i] + RO_D24 * k4[i] +
                           RO_D25 * k5[i];
                cont4[i] = RO_D31 * k1[i] + RO_D32 * k2[i] + RO_D33 * k3[i] + RO_D34 * k4[i] +
                           RO_D35 * k5[i];
            }
            lf_sv_copy_vec(s->x_old, x, n);
            lf_sv_copy_vec(x, y, n);
            s->t_old = t;
            s->t = t_new;
            if (rejected && hnew > h) hnew = h;
            if (last && !rejected && h_prop > hnew) hnew = h_prop;
            s->h = fmin(hnew, hmax);
            s->fsal_valid = 0; /* f0, J, df/dt are recomputed at the new point */
            s->n_steps++;
            return LF_OK;
        }
        h = hnew;
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

static void ro_dense(const LfSolver *s, double tq, double *out) {
    const size_t n = s->ode.n;
    const double *w = LF_CPRIV(s) + RO_NSCAL;
    const double *cont3 = w + RO_CONT3 * n, *cont4 = w + RO_CONT4 * n;
    const double *x0 = s->x_old, *x1 = s->x;
    double h = s->t - s->t_old, th, th1;
    size_t i;
    if (!(h > 0.0)) {
        lf_sv_copy_vec(out, x1, n);
        return;
    }
    th = (tq - s->t_old) / h;
    th1 = 1.0 - th;
    for (i = 0; i < n; i++) out[i] = x0[i] * th1 + th * (x1[i] + th1 * (cont3[i] + th * cont4[i]));
}

const LfMethod lf_rodas4 = {"rodas4", 1, 1, ro_work_size, ro_step, ro_dense};
