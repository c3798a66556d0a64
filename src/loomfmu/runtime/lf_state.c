/* loomfmu shared runtime: the FMU state as a flat byte string.
 *
 * Everything that determines the continuation of a simulation is written:
 * the values, modes, the last solve of the unknowns, the event indicators'
 * signs, the solver (its struct fields and its whole work buffer, whose
 * layout is fixed by method and size) and the history of delayed values
 * (only the samples in use).  Pointers, the logger and the allocator are not
 * part of the state: a state can be set in another instance of the same FMU
 * (checked by GUID and sizes), also after a round trip through bytes. */
#include <string.h>

#include "lf_runtime.h"
#include "lf_state.h"

#define LF_STATE_MAGIC 0x4C465331u /* "LFS1" */

typedef struct {
    unsigned magic;
    unsigned n_real, nx, nq, nd, ne;
    size_t work_len;
    int method;
    char guid[40];
} Header;

/* The instance's plain-value fields, in one struct for one memcpy each way. */
typedef struct {
    double r[LF_NREAL];
    double q[LF_DIM(LF_NQ)];
    double w_cur[LF_DIM(LF_NW)];
    double e_old[LF_DIM(LF_NE)];
    double dval[LF_DIM(LF_ND)];
    double tau[LF_DIM(LF_ND)];
    double bp[LF_MAX_BP];
    long hist_count[LF_DIM(LF_ND)];
    int x_set[LF_DIM(LF_NX)];
    double t, t_start, last_successful_time;
    long max_steps, n_events, n_newton_fail;
    int solver_id, outputs_valid, inputs_changed, delay_interp, n_bp, solver_ready, state;
    /* solver fields (the work buffer follows separately) */
    double s_t, s_t_old, s_h;
    LfSolverOptions s_opt;
    int s_fsal_valid;
    long s_steps, s_rejected, s_rhs, s_jac, s_lu;
} Values;

static int method_index(const LfInstance *c) {
    size_t k;
    if (!c->solver_ready) return -1;
    for (k = 0; k < lf_n_methods; k++)
        if (lf_methods[k] == c->solver.method) return (int)k;
    return -1;
}

static size_t hist_doubles(const LfInstance *c) {
    size_t n = 0;
    int k;
    for (k = 0; k < LF_ND; k++) n += 3 * (size_t)c->hist_count[k];
    return n;
}

size_t lf_state_size(const LfInstance *c) {
    size_t work = c->solver_ready ? c->solver.work_len : 0;
    return sizeof(Header) + sizeof(Values) + sizeof(double) * (work + hist_doubles(c));
}

static double *hist_at(const LfInstance *c, int k, long i) {
    return &c->hist[((size_t)k * LF_HIST_CAP + (size_t)((c->hist_start[k] + i) % LF_HIST_CAP)) * 3];
}

void lf_state_write(const LfInstance *c, unsigned char *buf) {
    Header h;
    Values v;
    const LfSolver *s = &c->solver;
    int k;
    long i;
    memset(&h, 0, sizeof h);
    memset(&v, 0, sizeof v);
    h.magic = LF_STATE_MAGIC;
    h.n_real = LF_NREAL;
    h.nx = LF_NX;
    h.nq = LF_NQ;
    h.nd = LF_ND;
    h.ne = LF_NE;
    h.work_len = c->solver_ready ? s->work_len : 0;
    h.method = method_index(c);
    strncpy(h.guid, lf_model.guid, sizeof h.guid - 1);
    memcpy(v.r, c->r, sizeof v.r);
    memcpy(v.q, c->q, sizeof v.q);
    memcpy(v.w_cur, c->w_cur, sizeof v.w_cur);
    memcpy(v.e_old, c->e_old, sizeof v.e_old);
    memcpy(v.dval, c->dval, sizeof v.dval);
    memcpy(v.tau, c->tau, sizeof v.tau);
    memcpy(v.bp, c->bp, sizeof v.bp);
    memcpy(v.hist_count, c->hist_count, sizeof v.hist_count);
    memcpy(v.x_set, c->x_set, sizeof v.x_set);
    v.t = c->t;
    v.t_start = c->t_start;
    v.last_successful_time = c->last_successful_time;
    v.max_steps = c->max_steps;
    v.n_events = c->n_events;
    v.n_newton_fail = c->n_newton_fail;
    v.solver_id = c->solver_id;
    v.outputs_valid = c->outputs_valid;
    v.inputs_changed = c->inputs_changed;
    v.delay_interp = c->delay_interp;
    v.n_bp = c->n_bp;
    v.solver_ready = c->solver_ready;
    v.state = (int)c->state;
    if (c->solver_ready) {
        v.s_t = s->t;
        v.s_t_old = s->t_old;
        v.s_h = s->h;
        v.s_opt = s->opt;
        v.s_fsal_valid = s->fsal_valid;
        v.s_steps = s->n_steps;
        v.s_rejected = s->n_rejected;
        v.s_rhs = s->n_rhs;
        v.s_jac = s->n_jac;
        v.s_lu = s->n_lu;
    }
    memcpy(buf, &h, sizeof h);
    buf += sizeof h;
    memcpy(buf, &v, sizeof v);
    buf += sizeof v;
    if (c->solver_ready) {
        memcpy(buf, s->work, sizeof(double) * s->work_len);
        buf += sizeof(double) * s->work_len;
    }
    for (k = 0; k < LF_ND; k++)
        for (i = 0; i < c->hist_count[k]; i++) {
            memcpy(buf, hist_at(c, k, i), 3 * sizeof(double));
            buf += 3 * sizeof(double);
        }
}

LfStatus lf_state_read(LfInstance *c, const unsigned char *buf, size_t n) {
    Header h;
    Values v;
    LfSolver *s = &c->solver;
    size_t need;
    int k;
    long i;
    if (n < sizeof h + sizeof v) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "FMU state: %lu bytes, expected at least %lu",
               (unsigned long)n, (unsigned long)(sizeof h + sizeof v));
        return LF_ERROR;
    }
    memcpy(&h, buf, sizeof h);
    memcpy(&v, buf + sizeof h, sizeof v);
    if (h.magic != LF_STATE_MAGIC || strncmp(h.guid, lf_model.guid, sizeof h.guid - 1) != 0 ||
        h.n_real != LF_NREAL || h.nx != LF_NX || h.nq != LF_NQ || h.nd != LF_ND ||
        h.ne != LF_NE) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "FMU state: not a state of this FMU (GUID or sizes differ)");
        return LF_ERROR;
    }
    need = sizeof h + sizeof v + sizeof(double) * h.work_len;
    for (k = 0; k < LF_ND; k++) {
        if (v.hist_count[k] < 0 || v.hist_count[k] > LF_HIST_CAP) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "FMU state: corrupt history size");
            return LF_ERROR;
        }
        need += 3 * sizeof(double) * (size_t)v.hist_count[k];
    }
    if (n != need || (v.solver_ready && (h.method < 0 || h.method >= (int)lf_n_methods))) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "FMU state: %lu bytes, expected %lu",
               (unsigned long)n, (unsigned long)need);
        return LF_ERROR;
    }
    if (v.solver_ready) { /* a solver of the state's method and size */
        if (c->solver_ready &&
            (c->solver.method != lf_methods[h.method] || c->solver.work_len != h.work_len)) {
            lf_solver_free(&c->solver, &c->alloc);
            c->solver_ready = 0;
        }
        if (!c->solver_ready) {
            LfOde ode = lf_ode_of(c);
            if (lf_solver_init(s, lf_methods[h.method], ode, v.s_opt, v.s_t,
                               &v.r[LF_VR_X0], &c->alloc) != LF_OK ||
                s->work_len != h.work_len) {
                /* the old solver is gone: this instance cannot step any more */
                lf_log(c, LF_ERROR, LF_LOG_ERROR, "FMU state: cannot restore the solver");
                c->state = LF_ST_ERROR;
                return LF_ERROR;
            }
            c->solver_ready = 1;
        }
        memcpy(s->work, buf + sizeof h + sizeof v, sizeof(double) * h.work_len);
        s->t = v.s_t;
        s->t_old = v.s_t_old;
        s->h = v.s_h;
        s->opt = v.s_opt;
        s->fsal_valid = v.s_fsal_valid;
        s->n_steps = v.s_steps;
        s->n_rejected = v.s_rejected;
        s->n_rhs = v.s_rhs;
        s->n_jac = v.s_jac;
        s->n_lu = v.s_lu;
        s->message[0] = '\0';
    } else if (c->solver_ready) {
        lf_solver_free(&c->solver, &c->alloc);
        c->solver_ready = 0;
    }
    memcpy(c->r, v.r, sizeof v.r);
    memcpy(c->q, v.q, sizeof v.q);
    memcpy(c->w_cur, v.w_cur, sizeof v.w_cur);
    memcpy(c->e_old, v.e_old, sizeof v.e_old);
    memcpy(c->dval, v.dval, sizeof v.dval);
    memcpy(c->tau, v.tau, sizeof v.tau);
    memcpy(c->bp, v.bp, sizeof v.bp);
    memcpy(c->x_set, v.x_set, sizeof v.x_set);
    c->t = v.t;
    c->t_start = v.t_start;
    c->last_successful_time = v.last_successful_time;
    c->max_steps = v.max_steps;
    c->n_events = v.n_events;
    c->n_newton_fail = v.n_newton_fail;
    c->solver_id = v.solver_id;
    c->outputs_valid = 0;
    c->inputs_changed = v.inputs_changed;
    c->delay_interp = v.delay_interp;
    c->n_bp = v.n_bp;
    c->state = (LfState)v.state;
    buf += sizeof h + sizeof v + sizeof(double) * h.work_len; /* the history follows */
    for (k = 0; k < LF_ND; k++) {
        c->hist_start[k] = 0;
        c->hist_count[k] = v.hist_count[k];
        for (i = 0; i < v.hist_count[k]; i++) {
            memcpy(hist_at(c, k, i), buf, 3 * sizeof(double));
            buf += 3 * sizeof(double);
        }
    }
    return LF_OK;
}
