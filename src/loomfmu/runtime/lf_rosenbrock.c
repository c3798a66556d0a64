/* loomfmu runtime: the one step routine of the Rosenbrock methods (see
 * lf_rosenbrock.h; the methods: lf_rodas4.c, lf_wmethod.c). */
#include "lf_rosenbrock.h"
#include "lf_linalg.h"
#include "lf_math.h"

#include <math.h>

/* where row i of a packed lower triangle starts */
#define LF_RB_ROW(i) ((i) * ((i) - 1) / 2)

size_t lf_rb_work_size(const LfRosenbrock *m, size_t n) {
    return (size_t)m->nscal + (size_t)m->nvec * n + n * n + lf_shifted_doubles(n);
}

double *lf_rb_vec(LfSolver *s, const LfRosenbrock *m, int k) {
    return LF_PRIV(s) + m->nscal + (size_t)k * s->ode.n;
}

double *lf_rb_jac(LfSolver *s, const LfRosenbrock *m) {
    return LF_PRIV(s) + m->nscal + (size_t)m->nvec * s->ode.n;
}

double *lf_rb_lu(LfSolver *s, const LfRosenbrock *m) { return lf_rb_jac(s, m) + s->ode.n * s->ode.n; }

LfStatus lf_rb_jacobian(LfSolver *s, const LfRosenbrock *m) {
    const size_t n = s->ode.n;
    double *J = lf_rb_jac(s, m), *ft = lf_rb_vec(s, m, LF_RB_FT(m));
    LfStatus st;
    s->n_jac++;
    st = s->ode.jac(s->ode.ctx, s->t, s->x, J, ft);
    if (st == LF_OK || st == LF_WARNING) {
        if (lf_all_finite(J, n * n) && lf_all_finite(ft, n)) return LF_OK;
        lf_sv_set_msg(s, "%s: Jacobian or df/dt not finite at t=%.17g", m->name, s->t);
        return LF_DISCARD;
    }
    if (st == LF_DISCARD) {
        lf_sv_set_msg(s, "%s: Jacobian could not be evaluated at t=%.17g", m->name, s->t);
        return LF_DISCARD;
    }
    lf_sv_set_msg(s, "%s: Jacobian callback returned an error at t=%.17g", m->name, s->t);
    return st == LF_FATAL ? LF_FATAL : LF_ERROR;
}

/* out = base + w_0 t_0 + ... + w_{m-1} t_{m-1}, m = 1..6, summed left to
 * right term by term as the expressions this replaces (bit-identical
 * results); one loop per count of terms, weights in registers. */
static inline void rb_sum(double *out, const double *base, const double *w,
                          const double *const *t, int m, size_t n) {
    const double w0 = m > 0 ? w[0] : 0.0, w1 = m > 1 ? w[1] : 0.0, w2 = m > 2 ? w[2] : 0.0;
    const double w3 = m > 3 ? w[3] : 0.0, w4 = m > 4 ? w[4] : 0.0, w5 = m > 5 ? w[5] : 0.0;
    const double *t0 = t[0], *t1 = t[1], *t2 = t[2], *t3 = t[3], *t4 = t[4], *t5 = t[5];
    size_t r;
    switch (m) {
    case 1:
        for (r = 0; r < n; r++) out[r] = base[r] + w0 * t0[r];
        break;
    case 2:
        for (r = 0; r < n; r++) out[r] = base[r] + w0 * t0[r] + w1 * t1[r];
        break;
    case 3:
        for (r = 0; r < n; r++) out[r] = base[r] + w0 * t0[r] + w1 * t1[r] + w2 * t2[r];
        break;
    case 4:
        for (r = 0; r < n; r++)
            out[r] = base[r] + w0 * t0[r] + w1 * t1[r] + w2 * t2[r] + w3 * t3[r];
        break;
    case 5:
        for (r = 0; r < n; r++)
            out[r] = base[r] + w0 * t0[r] + w1 * t1[r] + w2 * t2[r] + w3 * t3[r] + w4 * t4[r];
        break;
    default: /* 6 (0 is never asked for) */
        for (r = 0; r < n; r++)
            out[r] = base[r] + w0 * t0[r] + w1 * t1[r] + w2 * t2[r] + w3 * t3[r] + w4 * t4[r] +
                     w5 * t5[r];
        break;
    }
}

/* row a_i = (a_{i-1}, 1): argument i = argument i-1 + k_{i-1} */
static int rb_extends(const double *a, const double *prev, int i) {
    int j;
    for (j = 0; j < i - 1; j++)
        if (a[j] != prev[j]) return 0;
    return a[i - 1] == 1.0;
}

/* The stages k_1..k_s of a step h from (t, x) to t_new with the factors in
 * place; y ends as the last stage's argument. */
/* the error estimate: out = e_0 k_0 + ... + e_{s-1} k_{s-1}, left to right */
static void rb_error(double *out, const double *e, double *const *k, int ns, size_t n) {
    size_t r;
    int j;
    if (ns == 4) {
        const double e0 = e[0], e1 = e[1], e2 = e[2], e3 = e[3];
        const double *k0 = k[0], *k1 = k[1], *k2 = k[2], *k3 = k[3];
        for (r = 0; r < n; r++) out[r] = e0 * k0[r] + e1 * k1[r] + e2 * k2[r] + e3 * k3[r];
        return;
    }
    for (r = 0; r < n; r++) {
        double v = e[0] * k[0][r];
        for (j = 1; j < ns; j++) v += e[j] * k[j][r];
        out[r] = v;
    }
}

static LfStatus rb_stages(LfSolver *s, const LfRosenbrock *m, double *const *k, double h,
                          double t_new) {
    const size_t n = s->ode.n;
    const int ns = m->stages;
    double *y = lf_rb_vec(s, m, LF_RB_Y(m)), *dy = lf_rb_vec(s, m, LF_RB_DY(m));
    const double *f0 = lf_rb_vec(s, m, LF_RB_F0(m)), *ft = lf_rb_vec(s, m, LF_RB_FT(m));
    const double *J = lf_rb_jac(s, m);
    double *E = lf_rb_lu(s, m);
    const double t = s->t;
    /* the terms: k_1..k_{i-1}, then df/dt; unused ones point at x */
    const double *term[LF_RB_MAX_STAGES + 1];
    double w[LF_RB_MAX_STAGES + 1];
    size_t r;
    int i, j;
    LfStatus st;

    for (j = 0; j <= LF_RB_MAX_STAGES; j++) term[j] = s->x;
    for (i = 0; i < ns; i++) {
        const double *f = f0;
        int nt = i;
        if (i > 0) {
            if (i > 1 && rb_extends(m->a + LF_RB_ROW(i), m->a + LF_RB_ROW(i - 1), i)) {
                /* the previous argument plus k_{i-1} (rodas4's stage 6): the
                 * same doubles summed in the same order, fewer terms */
                for (r = 0; r < n; r++) y[r] += k[i - 1][r];
            } else {
                rb_sum(y, s->x, m->a + LF_RB_ROW(i), term, i, n);
            }
            st = lf_sv_eval_rhs(s, m->alpha[i] == 1.0 ? t_new : t + m->alpha[i] * h, y, dy);
            if (st != LF_OK) return st;
            f = dy;
        }
        for (j = 0; j < i; j++) w[j] = m->c[LF_RB_ROW(i) + j] / h;
        if (m->d[i] != 0.0) {
            term[i] = ft;
            w[nt++] = h * m->d[i];
        }
        if (nt > 0)
            rb_sum(k[i], f, w, term, nt, n);
        else
            lf_sv_copy_vec(k[i], f, n);
        term[i] = k[i];
        lf_shifted_solve(E, J, n, k[i]);
    }
    return LF_OK;
}

/* Hairer's controller: h / fac with 1/5 <= 1/fac <= 6 */
static double rb_clamp(double fac) {
    if (fac > 5.0) fac = 5.0;
    if (fac < 1.0 / 6.0) fac = 1.0 / 6.0;
    return fac;
}

LfStatus lf_rb_step(LfSolver *s, const LfRosenbrock *m, double t_bound) {
    const size_t n = s->ode.n;
    const int ns = m->stages;
    double *k[LF_RB_MAX_STAGES];
    double *y = lf_rb_vec(s, m, LF_RB_Y(m)), *dy = lf_rb_vec(s, m, LF_RB_DY(m));
    double *f0 = lf_rb_vec(s, m, LF_RB_F0(m)), *hist = LF_PRIV(s), *x = s->x;
    const double t = s->t, hmax = s->opt.h_max;
    double h;
    int rejected = 0, cause = CAUSE_NONE, attempts = 0, nsing = 0, renew = 0, mst, j;
    size_t i;
    LfStatus st;

    for (j = 0; j < LF_RB_MAX_STAGES; j++) k[j] = j < ns ? lf_rb_vec(s, m, j) : x;
    if (!(t_bound > t)) return lf_sv_bad_bound(s, t_bound);
    if (!s->fsal_valid) {
        st = lf_sv_eval_rhs(s, t, x, f0);
        if (st != LF_OK) return lf_sv_start_failure(s, st);
        if (m->fresh_jacobian) {
            st = lf_rb_jacobian(s, m);
            if (st != LF_OK) return st;
        }
        s->fsal_valid = 1;
    }
    if (m->renew && m->renew(s, 0)) renew = 1;
    h = s->h;
    if (!(h > 0.0)) h = lf_sv_initial_step(s, f0, y, dy, m->order, fmin(hmax, t_bound - t));
    if (h > hmax) h = hmax;

    for (;;) {
        double h_prop = h, t_new, hmin, err, fac, hnew;
        const double *errv = k[ns - 1];
        int last;
        if (++attempts > LF_MAX_ATTEMPTS) return lf_sv_give_up(s, h, 0.0, cause, 1);
        if (m->propose) h = m->propose(s, h, t_bound, rejected, renew);
        if (lf_sv_plan_step(s, t_bound, &h, &t_new, &last, &hmin)) return lf_sv_give_up(s, h, hmin, cause, 0);

        /* iteration matrix I/(h*gamma) - J, factorized */
        if (m->matrix) {
            mst = m->matrix(s, h, renew);
            renew = 0;
        } else {
            s->n_lu++;
            mst = lf_shifted_factor(lf_rb_lu(s, m), lf_rb_jac(s, m), n, 1.0 / (h * m->gamma)) != 0
                      ? -1 : LF_OK;
        }
        if (mst < 0) {
            if (++nsing >= 5) {
                lf_sv_set_msg(s, "%s: singular iteration matrix I/(h*gamma) - J at t=%.17g "
                              "(h=%.3g, 5 step reductions)", m->name, t, h);
                return LF_DISCARD;
            }
            h *= 0.5;
            rejected = 1;
            cause = CAUSE_SINGULAR;
            s->n_rejected++;
            continue;
        }
        if (mst != LF_OK) return (LfStatus)mst;

        st = rb_stages(s, m, k, h, t_new);
        if (st != LF_OK) goto failed;
        /* new solution (stiffly accurate) and the embedded error */
        for (i = 0; i < n; i++) y[i] += k[ns - 1][i];
        if (m->e) {
            rb_error(dy, m->e, k, ns, n);
            errv = dy;
        }
        err = lf_sv_err_norm(s, errv, x, y);
        if (!isfinite(err) || !lf_all_finite(y, n)) {
            st = LF_DISCARD;
            goto failed;
        }
        fac = rb_clamp(lf_pow(err, m->expo) / 0.9);
        hnew = h / fac;
        if (err <= 1.0) {
            if (m->accept) {
                st = m->accept(s, k, y, t_new);
                if (st != LF_OK) goto failed;
            }
            if (hist[LF_RB_HISTOK] != 0.0) {
                /* predictive controller of Gustafsson */
                double facgus = rb_clamp((hist[LF_RB_HACC] / h) *
                                         lf_pow(err * err / hist[LF_RB_ERRACC], m->expo) / 0.9);
                fac = fmax(fac, facgus);
                hnew = h / fac;
            }
            hist[LF_RB_HACC] = h;
            hist[LF_RB_ERRACC] = fmax(1e-2, err);
            hist[LF_RB_HISTOK] = 1.0;
            lf_sv_copy_vec(s->x_old, x, n);
            lf_sv_copy_vec(x, y, n);
            s->t_old = t;
            s->t = t_new;
            if (rejected && hnew > h) hnew = h;
            if (last && !rejected && h_prop > hnew) hnew = h_prop;
            s->h = fmin(hnew, hmax);
            if (m->fresh_jacobian) s->fsal_valid = 0; /* f0, J, df/dt anew at the new point */
            s->n_steps++;
            return LF_OK;
        }
        h = hnew;
        rejected = 1;
        cause = CAUSE_ERRTEST;
        s->n_rejected++;
        if (m->renew && m->renew(s, 1)) renew = 1;
        continue;
    failed:
        if (st != LF_DISCARD) return lf_sv_callback_error(s, st, t + h);
        h *= 0.25;
        rejected = 1;
        cause = CAUSE_NONFINITE;
        s->n_rejected++;
        if (m->renew && m->renew(s, 1)) renew = 1;
    }
}
