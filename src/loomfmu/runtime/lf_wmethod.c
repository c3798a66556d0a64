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
#include "lf_rosenbrock.h"
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

/* the tableau (lower triangles row by row, lf_rosenbrock.h) */
static const double wm_a[6] = {WM_A21, WM_A31, WM_A32, WM_A41, WM_A42, WM_A43};
static const double wm_c[6] = {WM_C21, WM_C31, WM_C32, WM_C41, WM_C42, WM_C43};
static const double wm_alpha[4] = {0.0, WM_ALPHA2, WM_ALPHA3, 1.0};
static const double wm_d[4] = {WM_D1, WM_D2, WM_D3, 0.0};
static const double wm_e[4] = {WM_E1, WM_E2, WM_E3, WM_E4};

/* private data (lf_rosenbrock.h): the controller scalars, then J0's state
 * (J0 and factors usable, h0 of the factors, accepted steps since J0);
 * u1..u4, the common vectors (df/dt goes with J0), then f(t_old, x_old) */
enum { WM_JOK = LF_RB_NSCAL, WM_H0, WM_AGE, WM_NSCAL };
#define WM_FOLD (4 + 4)

static int wm_renew(const LfSolver *s, int rejected);
static double wm_propose(LfSolver *s, double h, double t_bound, int rejected, int renew);
static int wm_matrix(LfSolver *s, double h, int renew);
static LfStatus wm_accept(LfSolver *s, double *const *k, const double *y, double t_new);

static const LfRosenbrock wm_method = {
    "ros34pw2", 4, WM_NSCAL, 4 + 5, WM_GAMMA, wm_a, wm_c, wm_alpha, wm_d, wm_e,
    3.0, 1.0 / 3.0, 0, wm_renew, wm_propose, wm_matrix, wm_accept};

static size_t wm_work_size(size_t n) { return lf_rb_work_size(&wm_method, n); }

/* after a restart: forget the controller history, keep J0 and its factors */
void lf_ros34pw2_restart(LfSolver *s) { LF_PRIV(s)[LF_RB_HISTOK] = 0.0; }

/* J0, df/dt at the current point */
static LfStatus wm_jacobian(LfSolver *s) {
    LfStatus st = lf_rb_jacobian(s, &wm_method);
    if (st == LF_OK) LF_PRIV(s)[WM_AGE] = 0.0;
    return st;
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
    if (lf_shifted_factor(lf_rb_lu(s, &wm_method), lf_rb_jac(s, &wm_method), s->ode.n,
                          1.0 / (h * WM_GAMMA)) != 0)
        return -1;
    p[WM_JOK] = 1.0;
    p[WM_H0] = h;
    return LF_OK;
}

/* renew the factors: at a step's start when J0 served WM_MAX_AGE steps;
 * after a rejection when J0 is older than this point (it may be what
 * failed) */
static int wm_renew(const LfSolver *s, int rejected) {
    const double age = LF_CPRIV(s)[WM_AGE];
    return rejected ? age > 0.0 : age >= WM_MAX_AGE;
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

/* h snapped to the factors' h0 within the band, then split evenly */
static double wm_propose(LfSolver *s, double h, double t_bound, int rejected, int renew) {
    const double *p = LF_CPRIV(s);
    if (!renew && !rejected && p[WM_JOK] != 0.0 && h >= WM_SNAP_LO * p[WM_H0] &&
        h <= WM_SNAP_HI * p[WM_H0])
        h = p[WM_H0];
    return wm_even_split(h, t_bound - s->t);
}

/* f at the new point: the dense output's end slope and the next step's f0 */
static LfStatus wm_accept(LfSolver *s, double *const *k, const double *y, double t_new) {
    const size_t n = s->ode.n;
    double *dy = lf_rb_vec(s, &wm_method, LF_RB_DY(&wm_method));
    double *f0 = lf_rb_vec(s, &wm_method, LF_RB_F0(&wm_method));
    LfStatus st;
    (void)k;
    st = lf_sv_eval_rhs(s, t_new, y, dy);
    if (st != LF_OK) return st;
    LF_PRIV(s)[WM_AGE] += 1.0;
    lf_sv_copy_vec(lf_rb_vec(s, &wm_method, WM_FOLD), f0, n);
    lf_sv_copy_vec(f0, dy, n);
    return LF_OK;
}

static LfStatus wm_step(LfSolver *s, double t_bound) { return lf_rb_step(s, &wm_method, t_bound); }

static void wm_dense(const LfSolver *s, double tq, double *out) {
    const size_t n = s->ode.n;
    const double *w = LF_CPRIV(s) + WM_NSCAL;
    const double *f1 = w + LF_RB_F0(&wm_method) * n, *f0 = w + WM_FOLD * n;
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
