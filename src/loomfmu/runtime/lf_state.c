/* loomfmu shared runtime: the FMU state as a flat byte string.
 *
 * Everything that determines the continuation of a simulation is written:
 * the values, modes, the last solve of the unknowns, the event indicators'
 * signs, the solver (its struct fields and its whole work buffer, whose
 * layout is fixed by method and size) and the history of delayed values
 * (only the samples in use) and the pending breakpoints of the delays.
 * Pointers, the logger and the allocator are not part of the state: a
 * state can be set in another instance of the same FMU (checked by GUID
 * and sizes), also after a round trip through bytes.
 *
 * Bytes from outside are not trusted: a checksum over the whole blob, then
 * every field against its range, every count against its capacity, every
 * number for finiteness, and the values against the model and the
 * parameters the state carries (lf_state_check.c: outputs marked current
 * finite, each delay as its parameters give it), before anything is
 * changed.  A checksum only vouches that the bytes are as written, so the
 * deserialize functions run every one of these checks too
 * (lf_state_check_bytes), and setting a state runs them again
 * (lf_state_read). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lf_state.h"
#include "lf_base.h"
#include "lf_instance.h"
#include "lf_newton.h"
#include "lf_state_check.h"
#if defined(__has_include)
#if __has_include("lf_build.h")
#include "lf_build.h" /* LF_FMI_VERSION, written by the builder */
#endif
#endif
#ifndef LF_FMI_VERSION
#define LF_FMI_VERSION 2
#endif

#define RUNNING_OR_DONE (LF_ST_STEP_COMPLETE | LF_ST_STEP_FAILED | LF_ST_TERMINATED)

static unsigned long long fnv1a(const unsigned char *p, size_t n) {
    unsigned long long hash = LF_FNV_OFFSET;
    size_t i;
    for (i = 0; i < n; i++) {
        hash ^= p[i];
        hash *= LF_FNV_PRIME;
    }
    return hash;
}

static int method_index(const LfInstance *c) {
    size_t k;
    if (!c->run.solver_ready) return -1;
    for (k = 0; k < lf_n_methods; k++)
        if (lf_methods[k] == c->solver.method) return (int)k;
    return -1;
}

static size_t hist_doubles(const LfInstance *c) {
    size_t n = 0;
    int k;
    for (k = 0; k < LF_ND; k++) n += 3 * (size_t)c->dl.hist_count[k];
    return n;
}

static size_t fixed_bytes(void) { return LF_STATE_FIXED_BYTES; }

size_t lf_state_size(const LfInstance *c) {
    size_t work = c->run.solver_ready ? c->solver.work_len : 0;
    return fixed_bytes() + sizeof(double) * (work + hist_doubles(c) + (size_t)c->dl.n_bp);
}

static double *hist_at(const LfInstance *c, int k, long i) {
    return &c->dl.hist[((size_t)k * LF_HIST_CAP + (size_t)((c->dl.hist_start[k] + i) % LF_HIST_CAP)) * 3];
}

static void write_values(const LfInstance *c, LfStateValues *v) {
    const LfSolver *s = &c->solver;
    memset(v, 0, sizeof *v);
    memcpy(v->r, c->val.r, sizeof v->r);
    memcpy(v->q, c->val.q, sizeof v->q);
    memcpy(v->w_cur, c->val.w_cur, sizeof v->w_cur);
    memcpy(v->e_old, c->ev.e_old, sizeof v->e_old);
    memcpy(v->dval, c->dl.dval, sizeof v->dval);
    memcpy(v->tau, c->dl.tau, sizeof v->tau);
    memcpy(v->hist_count, c->dl.hist_count, sizeof v->hist_count);
    memcpy(v->x_set, c->val.x_set, sizeof v->x_set);
    memcpy(v->u_d1, c->in.u_d1, sizeof v->u_d1);
    memcpy(v->u_d2, c->in.u_d2, sizeof v->u_d2);
    memcpy(v->u_t0, c->in.u_t0, sizeof v->u_t0);
    memcpy(v->seen_u, c->in.seen_u, sizeof v->seen_u);
    memcpy(v->seen_d1, c->in.seen_d1, sizeof v->seen_d1);
    memcpy(v->seen_d2, c->in.seen_d2, sizeof v->seen_d2);
    v->seen_t = c->in.seen_t;
    v->wants_terminate = c->run.wants_terminate;
    v->solver_index = c->run.solver_index;
    v->event_pending = c->run.solver_ready && c->ev.pending;
    v->event_index = v->event_pending ? c->ev.index : -1;
    if (v->event_pending) {
        v->t_event = c->ev.t_event;
        v->ev_t_ok = c->ev.t_ok;
        memcpy(v->ev_x_ok, c->ev.x_ok, sizeof v->ev_x_ok);
        memcpy(v->ev_q_ok, c->ev.q_ok, sizeof v->ev_q_ok);
    }
    v->kb_ready = c->run.solver_ready && c->kb.ready;
    v->kb_index = v->kb_ready ? c->kb.index : -1;
    if (v->kb_ready) {
        v->kb_clear = c->kb.clear;
        v->kb_dt = c->kb.dt;
        memcpy(v->kb_xdot, c->kb.xdot, sizeof v->kb_xdot);
        memcpy(v->kb_e, c->kb.e, sizeof v->kb_e);
    }
    if (v->kb_index >= 0) {
        v->kb_t_land = c->kb.t_land;
        v->kb_t_right = c->kb.t_right;
    }
    v->t = c->run.t;
    v->t_start = c->run.t_start;
    v->t_stop = c->run.t_stop;
    v->rtol_importer = c->run.rtol_importer;
    v->last_successful_time = c->run.last_successful_time;
    v->max_steps = c->run.max_steps;
    v->n_events = c->stats.n_events;
    v->n_newton_fail = c->stats.n_newton_fail;
    v->solver_id = c->run.solver_id;
    v->outputs_valid = c->run.outputs_valid;
    v->inputs_changed = c->run.inputs_changed;
    v->delay_interp = c->dl.delay_interp;
    v->n_bp = c->dl.n_bp;
    v->solver_ready = c->run.solver_ready;
    v->state = (int)c->run.state;
    if (!c->run.solver_ready) return;
    v->s_t = s->t;
    v->s_t_old = s->t_old;
    v->s_h = s->h;
    v->s_opt = s->opt;
    v->s_fsal_valid = s->fsal_valid;
    v->s_steps = s->n_steps;
    v->s_rejected = s->n_rejected;
    v->s_rhs = s->n_rhs;
    v->s_jac = s->n_jac;
    v->s_lu = s->n_lu;
}

void lf_state_write(const LfInstance *c, unsigned char *buf) {
    LfStateHeader h;
    LfStateValues v;
    unsigned char *p = buf;
    unsigned long long sum;
    int k;
    long i;
    memset(&h, 0, sizeof h);
    h.magic = LF_STATE_MAGIC;
    h.fmi_version = LF_FMI_VERSION;
    h.n_real = LF_NREAL;
    h.nx = LF_NX;
    h.nq = LF_NQ;
    h.nd = LF_ND;
    h.ne = LF_NE;
    h.nw = LF_NW;
    h.size = lf_state_size(c);
    h.work_len = c->run.solver_ready ? c->solver.work_len : 0;
    h.method = method_index(c);
    strncpy(h.guid, lf_model.guid, sizeof h.guid - 1);
    write_values(c, &v);
    memcpy(p, &h, sizeof h);
    p += sizeof h;
    memcpy(p, &v, sizeof v);
    p += sizeof v;
    if (c->run.solver_ready) {
        memcpy(p, c->solver.work, sizeof(double) * c->solver.work_len);
        p += sizeof(double) * c->solver.work_len;
    }
    for (k = 0; k < LF_ND; k++)
        for (i = 0; i < c->dl.hist_count[k]; i++) {
            memcpy(p, hist_at(c, k, i), 3 * sizeof(double));
            p += 3 * sizeof(double);
        }
    memcpy(p, c->dl.bp, sizeof(double) * (size_t)c->dl.n_bp);
    p += sizeof(double) * (size_t)c->dl.n_bp;
    sum = fnv1a(buf, (size_t)(p - buf));
    memcpy(p, &sum, sizeof sum);
}

/* ---- checks: each logs the first problem it finds and returns 0 -------- */

#define REQUIRE(cond, what, value, expected)                                      \
    do {                                                                          \
        if (!(cond)) return lf_state_refuse(c, what, (double)(value), expected);  \
    } while (0)

static int is_flag(int v) { return v == 0 || v == 1; }

/* Integrity: size, checksum, this FMU, sizes of its arrays. */
static int check_header(LfInstance *c, const unsigned char *buf, size_t n, LfStateHeader *h) {
    unsigned long long sum;
    char guid[LF_STATE_GUID_LEN];
    REQUIRE(n >= fixed_bytes(), "size of the state (bytes)", n, "at least the fixed part");
    memcpy(&sum, buf + n - sizeof sum, sizeof sum);
    if (sum != fnv1a(buf, n - sizeof sum)) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "t = %.17g: FMU state refused: its checksum does not match its %lu bytes "
               "(corrupted or truncated); the instance keeps its state", c->run.t,
               (unsigned long)n);
        return 0;
    }
    memcpy(h, buf, sizeof *h);
    REQUIRE(h->magic == LF_STATE_MAGIC, "format tag", h->magic,
            "a loomfmu state of this version (LFS6)");
    REQUIRE(h->fmi_version == LF_FMI_VERSION, "FMI version of the state", h->fmi_version,
            LF_FMI_VERSION == 3 ? "3 (a state of this model's FMI 3.0 build)"
                                : "2 (a state of this model's FMI 2.0 build)");
    memset(guid, 0, sizeof guid);
    strncpy(guid, lf_model.guid, sizeof guid - 1);
    if (memcmp(guid, h->guid, sizeof guid) != 0) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "t = %.17g: FMU state refused: it is a state of another FMU (GUID differs "
               "from %s); the instance keeps its state", c->run.t, lf_model.guid);
        return 0;
    }
    REQUIRE(h->n_real == LF_NREAL, "number of Reals", h->n_real, "this FMU's");
    REQUIRE(h->nx == LF_NX && h->nq == LF_NQ && h->nd == LF_ND && h->ne == LF_NE &&
                h->nw == LF_NW,
            "number of states", h->nx, "this FMU's sizes of states, modes, delays, events");
    REQUIRE(h->size == n, "size of the state (bytes)", n, "the size it was written with");
    return 1;
}

static int check_times(LfInstance *c, const LfStateValues *v) {
    REQUIRE(isfinite(v->t_start), "t_start", v->t_start, "finite");
    REQUIRE(isfinite(v->t) && v->t >= v->t_start, "t", v->t, "finite, >= t_start");
    REQUIRE(isfinite(v->last_successful_time) && v->last_successful_time >= v->t_start &&
                v->last_successful_time <= v->t,
            "last_successful_time", v->last_successful_time, "finite, in [t_start, t]");
    REQUIRE(v->t_stop == INFINITY || (isfinite(v->t_stop) && v->t_stop >= v->t_start),
            "t_stop", v->t_stop, "finite and >= t_start, or none");
    REQUIRE(v->rtol_importer == 0 || (v->rtol_importer >= lf_model.real_min[LF_SET_RTOL] &&
                                      v->rtol_importer <= lf_model.real_max[LF_SET_RTOL]),
            "importer tolerance", v->rtol_importer, "0 (none) or within solver_rtol's range");
    return 1;
}

static int check_flags(LfInstance *c, const LfStateValues *v) {
    int i, st = v->state, running = (st & RUNNING_OR_DONE) != 0;
    REQUIRE(st == LF_ST_INSTANTIATED || st == LF_ST_INIT || st == LF_ST_STEP_COMPLETE ||
                st == LF_ST_STEP_FAILED || st == LF_ST_TERMINATED,
            "interface state", st, "one of instantiated, initialization, stepping, terminated");
    REQUIRE(is_flag(v->solver_ready) && v->solver_ready == running, "solver_ready",
            v->solver_ready, "1 after initialization, 0 before");
    REQUIRE(v->solver_id >= 1 && v->solver_id <= (int)lf_n_methods, "solver", v->solver_id,
            "a solver of this FMU");
    REQUIRE(is_flag(v->outputs_valid), "outputs_valid", v->outputs_valid, "0 or 1");
    REQUIRE(is_flag(v->inputs_changed), "inputs_changed", v->inputs_changed, "0 or 1");
    REQUIRE(is_flag(v->wants_terminate), "wants_terminate", v->wants_terminate, "0 or 1");
    REQUIRE(v->solver_index >= 0 && v->solver_index <= (int)lf_n_methods, "solver_index",
            v->solver_index, "0 or a solver of this FMU");
    REQUIRE(v->delay_interp == LF_DELAY_HERMITE || v->delay_interp == LF_DELAY_LINEAR,
            "delay_interpolation", v->delay_interp, "1 (hermite) or 2 (linear)");
    REQUIRE(v->max_steps > 0, "max_steps", v->max_steps, "> 0");
    REQUIRE(v->n_events >= 0 && v->n_newton_fail >= 0, "event/Newton counters", v->n_events,
            ">= 0");
    for (i = 0; i < LF_DIM(LF_NX); i++)
        REQUIRE(is_flag(v->x_set[i]), "x_set", v->x_set[i], "0 or 1");
    return 1;
}

static int all_finite(const double *x, size_t n) {
    size_t i;
    for (i = 0; i < n; i++)
        if (!isfinite(x[i])) return 0;
    return 1;
}

static int check_modes_delays(LfInstance *c, const LfStateValues *v) {
    char what[160];
    int k, j;
    for (k = 0; k < LF_NQ; k++) {
        int found = 0;
        for (j = lf_model.mode_value_offset[k]; j < lf_model.mode_value_offset[k + 1]; j++)
            if (v->q[k] == lf_model.mode_values[j]) found = 1;
        REQUIRE(found, lf_model.mode_names[k], v->q[k], "one of the mode's values");
    }
    REQUIRE(all_finite(v->w_cur, LF_DIM(LF_NW)), "unknowns w (Newton start)", NAN, "finite");
    REQUIRE(all_finite(v->e_old, LF_DIM(LF_NE)), "event indicators", NAN, "finite");
    REQUIRE(all_finite(v->dval, LF_DIM(LF_ND)), "delayed values", NAN, "finite");
    REQUIRE(all_finite(v->u_d1, LF_DIM(LF_NU)) && all_finite(v->u_d2, LF_DIM(LF_NU)) &&
                all_finite(v->u_t0, LF_DIM(LF_NU)) && all_finite(v->seen_u, LF_DIM(LF_NU)) &&
                all_finite(v->seen_d1, LF_DIM(LF_NU)) && all_finite(v->seen_d2, LF_DIM(LF_NU)) &&
                isfinite(v->seen_t),
            "input derivatives", NAN, "finite");
    REQUIRE(v->n_bp >= 0 && v->n_bp <= LF_BP_CAP, "number of delay breakpoints", v->n_bp,
            "0 ... this FMU's capacity (8192 with delays, 0 without)");
    for (k = 0; k < LF_DIM(LF_ND); k++) {
        double tau_max = k < LF_ND ? lf_model.delay_max[k] : 0.0;
        long cap = k < LF_ND ? LF_HIST_CAP : 0;
        snprintf(what, sizeof what, "delay %s", k < LF_ND ? lf_model.delay_names[k] : "(none)");
        REQUIRE(v->tau[k] >= 0 && v->tau[k] <= tau_max, what, v->tau[k],
                "0 ... the FMU's longest delay");
        snprintf(what, sizeof what, "history samples of delay %s",
                 k < LF_ND ? lf_model.delay_names[k] : "(none)");
        REQUIRE(v->hist_count[k] >= 0 && v->hist_count[k] <= cap, what, v->hist_count[k],
                "0 ... 65536 (0 without delays)");
    }
    return 1;
}

static int is_mode_value(int k, double q) {
    int j;
    for (j = lf_model.mode_value_offset[k]; j < lf_model.mode_value_offset[k + 1]; j++)
        if (q == lf_model.mode_values[j]) return 1;
    return 0;
}

/* The pending event of an early return: at the state's time, after a
 * solver started, its indicator one of this FMU's, the point before it
 * (time, states, modes) finite and valid; none pending: all zero. */
static int check_pending_event(LfInstance *c, const LfStateValues *v) {
    int k;
    REQUIRE(is_flag(v->event_pending), "event_pending", v->event_pending, "0 or 1");
    if (!v->event_pending) {
        REQUIRE(v->event_index == -1 && v->t_event == 0 && v->ev_t_ok == 0, "event_index",
                v->event_index, "-1 (no event pending)");
        return 1;
    }
    REQUIRE(v->solver_ready, "event_pending", v->event_pending, "0 before initialization");
    REQUIRE(v->event_index >= 0 && v->event_index < LF_NE, "event_index", v->event_index,
            "an event indicator of this FMU");
    REQUIRE(v->t_event == v->t, "t_event", v->t_event, "the state's time t");
    REQUIRE(isfinite(v->ev_t_ok) && v->ev_t_ok <= v->t_event && v->ev_t_ok >= v->t_start,
            "time before the event", v->ev_t_ok, "finite, in [t_start, t_event]");
    REQUIRE(all_finite(v->ev_x_ok, LF_DIM(LF_NX)), "states before the event", NAN, "finite");
    for (k = 0; k < LF_NQ; k++)
        REQUIRE(is_mode_value(k, v->ev_q_ok[k]), lf_model.mode_names[k], v->ev_q_ok[k],
                "one of the mode's values (before the event)");
    return 1;
}

/* The known-break prediction: none (all zero), or rates, scan and values
 * finite where they are used, the break ahead of the scan's start. */
static int check_known_breaks(LfInstance *c, const LfStateValues *v) {
    int k;
    REQUIRE(is_flag(v->kb_ready), "kb_ready", v->kb_ready, "0 or 1");
    REQUIRE(v->kb_index >= -1 && v->kb_index < LF_NE && (v->kb_ready || v->kb_index == -1),
            "kb_index", v->kb_index, "-1, or an event indicator of this FMU when kb_ready");
    if (!v->kb_ready) {
        REQUIRE(v->kb_clear == 0 && v->kb_dt == 0, "kb_clear", v->kb_clear,
                "0 when no prediction is kept");
        return 1;
    }
    REQUIRE(v->solver_ready, "kb_ready", v->kb_ready, "0 before initialization");
    REQUIRE(all_finite(v->kb_xdot, LF_DIM(LF_NX)), "clock rates", NAN, "finite");
    REQUIRE(isfinite(v->kb_clear) && v->kb_clear >= v->t_start, "kb_clear", v->kb_clear,
            "finite, >= t_start");
    REQUIRE(isfinite(v->kb_dt) && v->kb_dt > 0, "kb_dt", v->kb_dt, "finite, > 0");
    for (k = 0; k < LF_NE; k++)
        REQUIRE(lf_model.event_time_only[k] == 0 || isfinite(v->kb_e[k]),
                "predicted indicator", v->kb_e[k], "finite");
    if (v->kb_index >= 0)
        REQUIRE(isfinite(v->kb_t_land) && isfinite(v->kb_t_right) &&
                    v->kb_t_land < v->kb_t_right,
                "kb_t_land", v->kb_t_land, "finite, before kb_t_right");
    else
        REQUIRE(v->kb_t_land == 0 && v->kb_t_right == 0, "kb_t_land", v->kb_t_land,
                "0 when no break is ahead");
    return 1;
}

static int check_solver(LfInstance *c, const LfStateHeader *h, const LfStateValues *v,
                        const double *work) {
    const LfSolverOptions *o = &v->s_opt;
    size_t len, i;
    if (!v->solver_ready) {
        REQUIRE(h->method == -1 && h->work_len == 0, "solver method", h->method,
                "none before initialization");
        return 1;
    }
    REQUIRE(h->method >= 0 && h->method < (int)lf_n_methods && h->method == v->solver_id - 1,
            "solver method", h->method, "the solver the instance was set up with");
    len = 2 * (size_t)LF_NX + lf_methods[h->method]->work_size(LF_NX);
    REQUIRE(h->work_len == len, "solver work length", (double)h->work_len,
            "the method's length for this FMU");
    REQUIRE(isfinite(v->s_t) && fabs(v->s_t - v->t) <= 1e-9 * fmax(1.0, fabs(v->t)),
            "solver time", v->s_t, "the instance's time");
    REQUIRE(isfinite(v->s_t_old) && v->s_t_old <= v->s_t, "solver previous time", v->s_t_old,
            "finite, <= solver time");
    REQUIRE(isfinite(v->s_h) && v->s_h >= 0, "solver step size", v->s_h, "finite, >= 0");
    REQUIRE(isfinite(o->rtol) && o->rtol > 0 && isfinite(o->atol) && o->atol > 0,
            "solver tolerance", o->rtol, "finite, > 0");
    REQUIRE(o->h_max > 0 && isfinite(o->h_fixed) && o->h_fixed > 0, "solver step limit",
            o->h_max, "> 0");
    REQUIRE(is_flag(v->s_fsal_valid), "solver flag", v->s_fsal_valid, "0 or 1");
    REQUIRE(v->s_steps >= 0 && v->s_rejected >= 0 && v->s_rhs >= 0 && v->s_jac >= 0 &&
                v->s_lu >= 0,
            "solver counters", v->s_steps, ">= 0");
    /* the states at t and t_old: finite, and at t those of the instance */
    REQUIRE(all_finite(work, 2 * (size_t)LF_NX), "solver states", NAN, "finite");
    for (i = 0; i < (size_t)LF_NX; i++)
        REQUIRE(work[i] == v->r[LF_VR_X0 + i], lf_model.real_names[LF_VR_X0 + i], work[i],
                "the solver's state at t");
    return 1;
}

/* ---- restore ------------------------------------------------------------- */

/* A solver of the state's method and size, made before the old one is given
 * up, so that a failure leaves the instance as it was. */
static int prepare_solver(LfInstance *c, const LfStateHeader *h, const LfStateValues *v,
                          LfSolver *fresh) {
    const LfMethod *m = lf_methods[h->method];
    if (c->run.solver_ready && c->solver.method == m && c->solver.work_len == h->work_len) {
        *fresh = c->solver;
        return 1;
    }
    if (lf_solver_init(fresh, m, lf_ode_of(c), v->s_opt, v->s_t, &v->r[LF_VR_X0],
                       &c->unsaved.alloc) != LF_OK || fresh->work_len != h->work_len) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR,
               "t = %.17g: FMU state refused: cannot make its solver (%s); the instance "
               "keeps its state", c->run.t, fresh->message);
        if (fresh->work) lf_solver_free(fresh, &c->unsaved.alloc);
        return 0;
    }
    if (c->run.solver_ready) lf_solver_free(&c->solver, &c->unsaved.alloc);
    return 1;
}

static void apply_solver(LfSolver *s, const LfStateValues *v, const double *work) {
    memcpy(s->work, work, sizeof(double) * s->work_len);
    s->t = v->s_t;
    s->t_old = v->s_t_old;
    s->h = v->s_h;
    s->opt = v->s_opt;
    s->fsal_valid = v->s_fsal_valid;
    s->n_steps = v->s_steps;
    s->n_rejected = v->s_rejected;
    s->n_rhs = v->s_rhs;
    s->n_jac = v->s_jac;
    s->n_lu = v->s_lu;
    s->message[0] = '\0';
    s->dense_unused = LF_DENSE_UNUSED;
    s->rhs_finite = 1;
}

static void apply_values(LfInstance *c, const LfStateValues *v, const double *hist) {
    int k;
    long i;
    memcpy(c->val.r, v->r, sizeof v->r);
    c->unsaved.k_stale = 1; /* k is a function of the parameters just restored (parameter folding) */
    memcpy(c->val.q, v->q, sizeof v->q);
    memcpy(c->val.w_cur, v->w_cur, sizeof v->w_cur);
    memcpy(c->ev.e_old, v->e_old, sizeof v->e_old);
    memcpy(c->dl.dval, v->dval, sizeof v->dval);
    memcpy(c->dl.tau, v->tau, sizeof v->tau);
    memcpy(c->val.x_set, v->x_set, sizeof v->x_set);
    memcpy(c->in.u_d1, v->u_d1, sizeof v->u_d1);
    memcpy(c->in.u_d2, v->u_d2, sizeof v->u_d2);
    memcpy(c->in.u_t0, v->u_t0, sizeof v->u_t0);
    memcpy(c->in.seen_u, v->seen_u, sizeof v->seen_u);
    memcpy(c->in.seen_d1, v->seen_d1, sizeof v->seen_d1);
    memcpy(c->in.seen_d2, v->seen_d2, sizeof v->seen_d2);
    c->in.seen_t = v->seen_t;
    c->run.wants_terminate = v->wants_terminate;
    c->run.solver_index = v->solver_index;
    c->ev.pending = v->event_pending;
    c->ev.index = v->event_index;
    c->ev.t_event = v->t_event;
    c->ev.t_ok = v->ev_t_ok;
    memcpy(c->ev.x_ok, v->ev_x_ok, sizeof v->ev_x_ok);
    memcpy(c->ev.q_ok, v->ev_q_ok, sizeof v->ev_q_ok);
    c->unsaved.u_poly = 0;
    for (k = 0; k < LF_NU; k++)
        if (c->in.u_d1[k] != 0 || c->in.u_d2[k] != 0) c->unsaved.u_poly = 1;
    c->run.t = v->t;
    c->run.t_start = v->t_start;
    c->run.t_stop = v->t_stop;
    c->run.rtol_importer = v->rtol_importer;
    c->run.last_successful_time = v->last_successful_time;
    c->run.max_steps = v->max_steps;
    c->stats.n_events = v->n_events;
    c->stats.n_newton_fail = v->n_newton_fail;
    c->run.solver_id = v->solver_id;
    /* the outputs were saved with the other Reals: valid if they were, so a
     * read after the restore returns them instead of solving again (an
     * implicit model's Newton from the restored w_cur moves w by rounding,
     * and the continuation with it) */
    c->run.outputs_valid = v->outputs_valid;
    c->unsaved.ho_valid = 0; /* the outputs a history sample kept (a cache, not state) */
    c->run.inputs_changed = v->inputs_changed;
    c->dl.delay_interp = v->delay_interp;
    c->dl.n_bp = v->n_bp;
    c->unsaved.t_bp_step = INFINITY;
    c->kb.ready = v->kb_ready;
    c->kb.index = v->kb_index;
    c->kb.t_land = v->kb_t_land;
    c->kb.t_right = v->kb_t_right;
    c->kb.clear = v->kb_clear;
    c->kb.dt = v->kb_dt;
    memcpy(c->kb.xdot, v->kb_xdot, sizeof v->kb_xdot);
    memcpy(c->kb.e, v->kb_e, sizeof v->kb_e);
    c->unsaved.kb_sure = -INFINITY; /* not part of the state: vouch again from a new scan */
    c->run.state = (LfState)v->state;
    for (k = 0; k < LF_ND; k++) {
        c->dl.hist_start[k] = 0;
        c->dl.hist_count[k] = v->hist_count[k];
        for (i = 0; i < v->hist_count[k]; i++, hist += 3) memcpy(hist_at(c, k, i), hist, 3 * sizeof(double));
    }
    memcpy(c->dl.bp, hist, sizeof(double) * (size_t)v->n_bp); /* after the history */
}

/* Every check, nothing changed: the header, then each field, the values
 * against the model and its parameters (lf_state_check.c).  The solver
 * work, history and breakpoints are copied out (the bytes need not be
 * aligned) into *doubles, for the caller to free.  0, logged, if the bytes
 * are not a state this FMU can take. */
static int check_state(LfInstance *c, const unsigned char *buf, size_t n, LfStateHeader *h,
                       LfStateValues *v, double **doubles) {
    size_t need, hist_len = 0;
    double *work;
    int k;
    if (!check_header(c, buf, n, h)) return 0;
    memcpy(v, buf + sizeof *h, sizeof *v);
    if (!check_times(c, v) || !check_flags(c, v) || !check_modes_delays(c, v) ||
        !check_pending_event(c, v) || !check_known_breaks(c, v))
        return 0;
    for (k = 0; k < LF_ND; k++) hist_len += 3 * (size_t)v->hist_count[k];
    hist_len += (size_t)v->n_bp; /* the breakpoints follow the history */
    need = h->work_len <= n / sizeof(double)
               ? fixed_bytes() + sizeof(double) * ((size_t)h->work_len + hist_len) : 0;
    REQUIRE(n == need, "size of the state (bytes)", n,
            "header + values + work + history + breakpoints");
    work = (double *)c->unsaved.alloc.calloc((size_t)h->work_len + hist_len + 1, sizeof(double));
    if (!work) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: FMU state: out of memory", c->run.t);
        return 0;
    }
    memcpy(work, buf + sizeof *h + sizeof *v, sizeof(double) * ((size_t)h->work_len + hist_len));
    if (!lf_state_check_reals(c, v->r, v->solver_ready, v->outputs_valid) ||
        !check_solver(c, h, v, work) ||
        !lf_state_check_history(c, v->hist_count, v->n_bp, work + h->work_len) ||
        !lf_state_check_delays(c, v->r, v->tau, &v->s_opt, v->solver_ready)) {
        c->unsaved.alloc.free(work);
        return 0;
    }
    *doubles = work;
    return 1;
}

LfStatus lf_state_check_bytes(LfInstance *c, const unsigned char *buf, size_t n) {
    LfStateHeader h;
    LfStateValues v;
    double *doubles;
    if (!check_state(c, buf, n, &h, &v, &doubles)) return LF_ERROR;
    c->unsaved.alloc.free(doubles);
    return LF_OK;
}

LfStatus lf_state_read(LfInstance *c, const unsigned char *buf, size_t n) {
    LfStateHeader h;
    LfStateValues v;
    LfSolver fresh;
    double *work;
    if (!check_state(c, buf, n, &h, &v, &work)) return LF_ERROR;
    if (v.solver_ready && !prepare_solver(c, &h, &v, &fresh)) {
        c->unsaved.alloc.free(work);
        return LF_ERROR;
    }
    /* from here on nothing fails: the instance takes the state */
    if (v.solver_ready) {
        c->solver = fresh;
        apply_solver(&c->solver, &v, work);
    } else if (c->run.solver_ready) {
        lf_solver_free(&c->solver, &c->unsaved.alloc);
    }
    c->run.solver_ready = v.solver_ready;
    apply_values(c, &v, work + h.work_len);
    c->unsaved.alloc.free(work);
    return LF_OK;
}
