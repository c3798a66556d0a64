/* loomfmu runtime: rodas4, the Hairer-Wanner RODAS stiffly accurate
 * Rosenbrock method 4(3) with its 3rd-order dense output (contract:
 * lf_solver.h). */
#include "lf_rosenbrock.h"

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

/* the tableau (lower triangles row by row, lf_rosenbrock.h); stage 6 takes the stage-5
 * argument plus k5, x_new is stage 6's argument plus k6, the error k6 */
static const double ro_a[15] = {RO_A21, RO_A31, RO_A32, RO_A41, RO_A42, RO_A43,
    RO_A51, RO_A52, RO_A53, RO_A54, RO_A51, RO_A52, RO_A53, RO_A54, 1.0};
static const double ro_c[15] = {RO_C21, RO_C31, RO_C32, RO_C41, RO_C42, RO_C43,
    RO_C51, RO_C52, RO_C53, RO_C54, RO_C61, RO_C62, RO_C63, RO_C64, RO_C65};
static const double ro_alpha[6] = {0.0, RO_C2, RO_C3, RO_C4, 1.0, 1.0};
static const double ro_d[6] = {RO_D1, RO_D2, RO_D3, RO_D4, 0.0, 0.0};

/* private data (lf_rosenbrock.h): the controller scalars; k1..k6, the
 * common vectors, then the dense output's cont3, cont4 */
#define RO_CONT3 (6 + 4)
#define RO_CONT4 (6 + 5)

static LfStatus ro_accept(LfSolver *s, double *const *k, const double *y, double t_new);

static const LfRosenbrock ro_method = {
    "rodas4", 6, LF_RB_NSCAL, 6 + 6, RO_GAMMA, ro_a, ro_c, ro_alpha, ro_d, NULL,
    4.0, 0.25, 1, NULL, NULL, NULL, ro_accept};

static size_t ro_work_size(size_t n) { return lf_rb_work_size(&ro_method, n); }

void lf_rodas4_clear_history(LfSolver *s) { LF_PRIV(s)[LF_RB_HISTOK] = 0.0; }

/* the dense output's coefficients from the stages of the accepted step */
static LfStatus ro_accept(LfSolver *s, double *const *k, const double *y, double t_new) {
    const size_t n = s->ode.n;
    double *cont3 = lf_rb_vec(s, &ro_method, RO_CONT3), *cont4 = lf_rb_vec(s, &ro_method, RO_CONT4);
    size_t i;
    (void)y;
    (void)t_new;
    for (i = 0; i < n; i++) {
        cont3[i] = RO_D21 * k[0][i] + RO_D22 * k[1][i] + RO_D23 * k[2][i] + RO_D24 * k[3][i] +
                   RO_D25 * k[4][i];
        cont4[i] = RO_D31 * k[0][i] + RO_D32 * k[1][i] + RO_D33 * k[2][i] + RO_D34 * k[3][i] +
                   RO_D35 * k[4][i];
    }
    return LF_OK;
}

static LfStatus ro_step(LfSolver *s, double t_bound) { return lf_rb_step(s, &ro_method, t_bound); }

static void ro_dense(const LfSolver *s, double tq, double *out) {
    const size_t n = s->ode.n;
    const double *w = LF_CPRIV(s) + LF_RB_NSCAL;
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
