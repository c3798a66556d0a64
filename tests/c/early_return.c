/* Driver for the step loop's early return (lf_step.h), compiled with the
 * sources of one built FMU (tests/test_early_return.py): it calls the
 * runtime directly, as an FMI 3.0 facade would, so the step loop is tested
 * apart from any facade.
 *
 * Usage: early_return <mode> <t_end> <h> [name=value ...]
 *   mode  plain        stop_at_events = 0 (events handled inside the step)
 *         early        stop_at_events = 1; lf_handle_pending_event after
 *                      each early return, then on to the same grid point
 *         lazy         stop_at_events = 1; the pending event is never handled
 *                      by the driver (the next lf_do_step does it)
 *         state        like early, but at each early return the FMU state is
 *                      written, read into a fresh instance, which goes on
 *                      (the old one is freed): the pending event survives
 *         settle       like plain; after each input set during the run
 *                      (@T:name=value) lf_settle_inputs, then the point
 *                      printed as "settled <t> <every Real> <modes>"
 *   name=value   a Real by name (lf_model.real_names), or solver=<id>
 *   @T:name=value  the same, set at the first communication point >= T
 * Output (stdout): per grid point "t <t> <every Real, %.17g>"; per early
 * return "early <t> <indicator> <values_changed>"; at the end
 * "steps <accepted> <rejected> <rhs> <events> <known breaks crossed>".  Log lines go to stderr.
 * Exit status 0, or 1 with the reason on stderr. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lf_state.h"
#include "lf_step.h"

static void logger(void *env, const char *instance, LfStatus status, const char *category,
                   const char *message) {
    (void)env;
    (void)instance;
    fprintf(stderr, "[%d %s] %s\n", (int)status, category, message);
}

static void *cb_calloc(size_t n, size_t size) { return calloc(n, size); }
static void cb_free(void *p) { free(p); }

static int fail(const char *what, double t) {
    fprintf(stderr, "driver: %s at t = %.17g\n", what, t);
    return 1;
}

static LfInstance *make(void) {
    LfAllocator alloc;
    LfInstance *c;
    int k;
    alloc.calloc = cb_calloc;
    alloc.free = cb_free;
    c = lf_instantiate("early_return", logger, NULL, alloc);
    if (!c) return NULL;
    for (k = 0; k < LF_N_LOG; k++) c->unsaved.log_on[k] = k == LF_LOG_EVENTS || k != LF_LOG_SOLVER;
    c->run.state = LF_ST_INIT;
    return c;
}

static int set_value(LfInstance *c, const char *arg) {
    const char *eq = strchr(arg, '=');
    unsigned vr;
    double v;
    if (!eq) return 0;
    v = atof(eq + 1);
    if (strncmp(arg, "solver=", 7) == 0) return lf_set_solver(c, (int)v) == LF_OK;
    for (vr = 0; vr < LF_NREAL; vr++)
        if (strlen(lf_model.real_names[vr]) == (size_t)(eq - arg) &&
            strncmp(lf_model.real_names[vr], arg, (size_t)(eq - arg)) == 0)
            return lf_set_real(c, vr, v) == LF_OK;
    return 0;
}

static void print_point(const LfInstance *c) {
    unsigned vr;
    printf("t %.17g", c->run.t);
    for (vr = 0; vr < LF_NREAL; vr++) printf(" %.17g", c->val.r[vr]);
    printf("\n");
}

/* The instance made again from its FMU state (written, read into a fresh
 * instance; the old one freed). */
static LfInstance *through_state(LfInstance *c) {
    size_t n = lf_state_size(c);
    unsigned char *buf = (unsigned char *)malloc(n);
    LfInstance *d = make();
    if (!buf || !d) return NULL;
    d->unsaved.stop_at_events = c->unsaved.stop_at_events; /* configuration, not state */
    lf_state_write(c, buf);
    if (lf_state_read(d, buf, n) != LF_OK) {
        free(buf);
        lf_free(d);
        return NULL;
    }
    free(buf);
    lf_free(c);
    return d;
}

static unsigned long long fnv1a(const unsigned char *p, size_t n) {
    unsigned long long hash = LF_FNV_OFFSET;
    size_t i;
    for (i = 0; i < n; i++) {
        hash ^= p[i];
        hash *= LF_FNV_PRIME;
    }
    return hash;
}

/* The FMU state with one field of the pending event corrupted (checksum
 * sealed again, so that only the field checks stand): each must be refused
 * by a fresh instance.  Prints "refused <n of 6>". */
static void corrupt_pending(LfInstance *c) {
    size_t n = lf_state_size(c), off = sizeof(LfStateHeader);
    unsigned char *buf = (unsigned char *)malloc(n);
    int which, refused = 0;
    for (which = 0; which < 6 && buf; which++) {
        LfStateValues v;
        LfInstance *d = make();
        unsigned long long sum;
        lf_state_write(c, buf);
        memcpy(&v, buf + off, sizeof v);
        if (which == 0) v.event_index = LF_NE;
        if (which == 1) v.event_index = -1;
        if (which == 2) v.event_pending = 2;
        if (which == 3) v.t_event = v.t + 1e-3;
        if (which == 4) v.ev_t_ok = NAN;
        if (which == 5) v.ev_x_ok[0] = INFINITY;
        memcpy(buf + off, &v, sizeof v);
        sum = fnv1a(buf, n - sizeof sum);
        memcpy(buf + n - sizeof sum, &sum, sizeof sum);
        if (d && lf_state_read(d, buf, n) == LF_ERROR) refused++;
        if (d) lf_free(d);
    }
    free(buf);
    printf("refused %d of 6\n", refused);
}

int main(int argc, char **argv) {
    LfInstance *c;
    const char *mode;
    double t_end, h, t;
    long i, n;
    int a;
    if (argc < 4) return fail("usage: early_return <mode> <t_end> <h> [name=value ...]", 0);
    mode = argv[1];
    t_end = atof(argv[2]);
    h = atof(argv[3]);
    c = make();
    if (!c) return fail("lf_instantiate failed", 0);
    for (a = 4; a < argc; a++)
        if (argv[a][0] != '@' && !set_value(c, argv[a])) return fail(argv[a], 0);
    c->unsaved.stop_at_events = strcmp(mode, "plain") != 0 && strcmp(mode, "quiet") != 0;
    if (lf_initialize(c) != LF_OK) return fail("lf_initialize failed", 0);
    c->run.state = LF_ST_STEP_COMPLETE;
    if (strcmp(mode, "quiet") != 0) print_point(c);
    n = (long)floor(t_end / h + 0.5);
    for (i = 1, t = c->run.t; i <= n; i++) {
        double t_next = i * h;
        for (a = 4; a < argc; a++) { /* inputs set during the run */
            const char *colon = strchr(argv[a], ':');
            int k;
            if (argv[a][0] != '@' || !colon || atof(argv[a] + 1) > c->run.t + 1e-12 ||
                atof(argv[a] + 1) <= c->run.t - h + 1e-12)
                continue;
            if (!set_value(c, colon + 1)) return fail(argv[a], c->run.t);
            if (strcmp(mode, "settle") != 0) continue;
            if (lf_settle_inputs(c) != LF_OK || lf_update_outputs(c) != LF_OK)
                return fail("lf_settle_inputs failed", c->run.t);
            printf("settled %.17g", c->run.t);
            for (k = 0; k < (int)LF_NREAL; k++) printf(" %.17g", c->val.r[k]);
            for (k = 0; k < LF_NQ; k++) printf(" %g", c->val.q[k]);
            printf("\n");
        }
        while (t_next - c->run.t > 1e-13 * fmax(1.0, fabs(t_next))) {
            int changed = -1;
            LfStatus st = lf_do_step(c, c->run.t, t_next - c->run.t);
            if (st != LF_OK) return fail("lf_do_step failed", c->run.t);
            if (!c->ev.pending) {
                if (fabs(c->run.t - t_next) > 1e-13 * fmax(1.0, fabs(t_next)))
                    return fail("step ended early with no event pending", c->run.t);
                continue;
            }
            if (!c->unsaved.stop_at_events || c->run.t != c->ev.t_event || c->run.t >= t_next || c->run.t < t)
                return fail("early return outside the step, or not at t_event", c->run.t);
            if (strcmp(mode, "corrupt") == 0) corrupt_pending(c);
            if (strcmp(mode, "state") == 0) {
                c = through_state(c);
                if (!c) return fail("FMU state with a pending event refused", t);
            }
            printf("early %.17g %d", c->run.t, c->ev.index);
            if (strcmp(mode, "lazy") != 0) {
                if (lf_handle_pending_event(c, &changed) != LF_OK)
                    return fail("lf_handle_pending_event failed", c->run.t);
                if (c->ev.pending) return fail("event still pending after handling", c->run.t);
            }
            printf(" %d\n", changed);
        }
        t = c->run.t;
        if (strcmp(mode, "quiet") != 0 || i == n) print_point(c);
    }
    printf("steps %ld %ld %ld %ld %ld\n", c->solver.n_steps, c->solver.n_rejected,
           c->solver.n_rhs, c->stats.n_events, c->unsaved.n_known_breaks);
    lf_free(c);
    return 0;
}
