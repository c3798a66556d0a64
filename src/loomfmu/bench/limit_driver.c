/* The C-level benchmark of `loomfmu bench limit` (loomfmu.bench.limit): one
 * FMU's verification run driven through its FMI 2.0 functions, without
 * Python.  Compiled with gcc from the FMU's own sources/ plus this file into
 * one static program (the FMU's runtime symbols carry its prefix through
 * lf_prefix.h; its FMI functions are the plain fmi2* ones).
 *
 * Usage: limit_driver <stop s> <comm step s> <rtol> <atol> <solver name>
 *                     <repeats> <best of> [<real variable>=<value> ...]
 *
 * Runs `repeats` times: instantiate, setupExperiment(rtol, 0, stop), set the
 * solver and solver_atol (and the given start values) before initialization,
 * step to stop at the communication step (as FMPy does: t_k = k * step),
 * reading the outputs after every step.  After the last run, before freeing
 * the instance (fmi2Component is the LfInstance), reads the solver's
 * counters and times one call of the right-hand side the solver integrates
 * (lf_ode_of(c).rhs: `wsol`, or `res` + Newton for implicit models) and of
 * its Jacobian at the run's final state, and of the outputs (what every
 * fmi2DoStep ends with), each in a tight loop, the best batch of `best of`.
 *
 * Prints one JSON object on stdout; errors go to stderr, exit status 1
 * (a failed FMI call, non-finite results) or 2 (bad arguments).
 */
#define _POSIX_C_SOURCE 199309L

#include "fmi2Functions.h"
#include "lf_delay.h"
#include "lf_instance.h"
#include "lf_newton.h"
#include "lf_outputs.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define MAX_REPEATS 64
#define MAX_STARTS 32
/* a timing batch lasts at least this long (s) */
#define MIN_BATCH_S 2e-3

typedef struct {
    double stop, step, rtol, atol;
    int solver_id, repeats, best_of;
    int n_start;
    unsigned start_vr[MAX_STARTS];
    double start_value[MAX_STARTS];
} Args;

typedef struct {
    double cpu, wall;
} Clock;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    (void)env;
    if (status >= fmi2Discard) fprintf(stderr, "[%s] %s: %s\n", category, name, message);
}

static Clock now(void) {
    struct timespec cpu, wall;
    Clock c;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &cpu);
    clock_gettime(CLOCK_MONOTONIC, &wall);
    c.cpu = (double)cpu.tv_sec + 1e-9 * (double)cpu.tv_nsec;
    c.wall = (double)wall.tv_sec + 1e-9 * (double)wall.tv_nsec;
    return c;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n) {
    qsort(v, (size_t)n, sizeof v[0], cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static int real_vr(const char *name, unsigned *vr) {
    unsigned k;
    for (k = 0; k < lf_model.n_real; k++) {
        if (strcmp(lf_model.real_names[k], name) == 0) {
            *vr = k;
            return 1;
        }
    }
    return 0;
}

static int parse_number(const char *text, const char *what, double lo, double *out) {
    char *end;
    double v = strtod(text, &end);
    if (end == text || *end != '\0' || !isfinite(v) || !(v > lo)) {
        fprintf(stderr, "%s = %s; allowed: a finite number > %g\n", what, text, lo);
        return 0;
    }
    *out = v;
    return 1;
}

static int parse_args(int argc, char **argv, Args *a) {
    int k;
    double reps, best;
    if (argc < 8) {
        fprintf(stderr, "usage: %s <stop> <step> <rtol> <atol> <solver> <repeats> <best of> "
                "[name=value ...]\n", argv[0]);
        return 0;
    }
    if (!parse_number(argv[1], "stop", 0.0, &a->stop) ||
        !parse_number(argv[2], "step", 0.0, &a->step) ||
        !parse_number(argv[3], "rtol", 0.0, &a->rtol) ||
        !parse_number(argv[4], "atol", 0.0, &a->atol) ||
        !parse_number(argv[6], "repeats", 0.0, &reps) ||
        !parse_number(argv[7], "best of", 0.0, &best))
        return 0;
    if (reps > MAX_REPEATS || best > MAX_REPEATS || reps != floor(reps) || best != floor(best)) {
        fprintf(stderr, "repeats = %s, best of = %s; allowed: integers 1 ... %d\n", argv[6],
                argv[7], MAX_REPEATS);
        return 0;
    }
    a->repeats = (int)reps;
    a->best_of = (int)best;
    a->solver_id = 0;
    for (k = 0; k < LF_N_SOLVERS; k++)
        if (strcmp(lf_model.solver_names[k], argv[5]) == 0) a->solver_id = k + 1;
    if (!a->solver_id) {
        fprintf(stderr, "solver = %s; allowed: one of this FMU's solvers\n", argv[5]);
        return 0;
    }
    a->n_start = argc - 8;
    if (a->n_start > MAX_STARTS) {
        fprintf(stderr, "%d start values; allowed: at most %d\n", a->n_start, MAX_STARTS);
        return 0;
    }
    for (k = 0; k < a->n_start; k++) {
        char name[256], *eq = strchr(argv[8 + k], '=');
        size_t len = eq ? (size_t)(eq - argv[8 + k]) : 0;
        if (!eq || len == 0 || len >= sizeof name) {
            fprintf(stderr, "start value %s; allowed: <real variable>=<value>\n", argv[8 + k]);
            return 0;
        }
        memcpy(name, argv[8 + k], len);
        name[len] = '\0';
        if (!real_vr(name, &a->start_vr[k])) {
            fprintf(stderr, "start value %s: no Real variable %s in this FMU\n", argv[8 + k],
                    name);
            return 0;
        }
        if (!parse_number(eq + 1, name, -INFINITY, &a->start_value[k])) return 0;
    }
    return 1;
}

/* Instantiate and initialize as FMPy's simulate_fmu does. */
static fmi2Component start(const Args *a, const fmi2CallbackFunctions *cb) {
    fmi2Integer sid = a->solver_id;
    fmi2ValueReference vr_solver = LF_VR_SOLVER, vr_atol;
    fmi2Component comp = fmi2Instantiate("limit", fmi2CoSimulation, lf_model.guid, "", cb,
                                         fmi2False, fmi2False);
    if (!comp) return NULL;
    if (!real_vr("solver_atol", &vr_atol) ||
        fmi2SetupExperiment(comp, fmi2True, a->rtol, 0.0, fmi2True, a->stop) != fmi2OK ||
        fmi2SetInteger(comp, &vr_solver, 1, &sid) != fmi2OK ||
        fmi2SetReal(comp, &vr_atol, 1, &a->atol) != fmi2OK ||
        (a->n_start > 0 &&
         fmi2SetReal(comp, a->start_vr, (size_t)a->n_start, a->start_value) != fmi2OK) ||
        fmi2EnterInitializationMode(comp) != fmi2OK ||
        fmi2ExitInitializationMode(comp) != fmi2OK) {
        fprintf(stderr, "initialization failed\n");
        fmi2FreeInstance(comp);
        return NULL;
    }
    return comp;
}

/* Step to a->stop; 1 on success with every output finite. */
static int run(const Args *a, fmi2Component comp) {
    fmi2ValueReference vr_y[LF_DIM(LF_NY)];
    double y[LF_DIM(LF_NY)], t = 0.0;
    long k, n = (long)floor(a->stop / a->step + 0.5);
    int i;
    for (i = 0; i < LF_NY; i++) vr_y[i] = (fmi2ValueReference)(LF_VR_Y0 + i);
    for (k = 0; k < n; k++) {
        double t_next = (k + 1 == n) ? a->stop : (double)(k + 1) * a->step;
        if (fmi2DoStep(comp, t, t_next - t, fmi2True) != fmi2OK) {
            fprintf(stderr, "fmi2DoStep failed at t = %.17g\n", t);
            return 0;
        }
        t = t_next;
        if (LF_NY > 0 && fmi2GetReal(comp, vr_y, LF_NY, y) != fmi2OK) return 0;
        for (i = 0; i < LF_NY; i++) {
            if (!isfinite(y[i])) {
                fprintf(stderr, "output %d is %g at t = %.17g\n", i, y[i], t);
                return 0;
            }
        }
    }
    return 1;
}

/* The outputs at the end of the run, by name (as JSON). */
static void print_outputs(fmi2Component comp) {
    int i;
    printf(" \"y_end\": {");
    for (i = 0; i < LF_NY; i++) {
        fmi2ValueReference vr = (fmi2ValueReference)(LF_VR_Y0 + i);
        double y = NAN;
        fmi2GetReal(comp, &vr, 1, &y);
        printf("%s\"%s\": %.17g", i ? ", " : "", lf_model.real_names[LF_VR_Y0 + i], y);
    }
    printf("},\n");
}

/* Seconds per call of the ODE's right-hand side (jac = 0) or Jacobian
 * (jac = 1) at (t, x): the best of `best_of` batches, each at least
 * MIN_BATCH_S long; < 0 if a call fails. */
static double time_call(LfOde ode, double t, const double *x, int jac, int best_of) {
    static double dx[LF_DIM(LF_NX)], J[LF_DIM(LF_NX * LF_NX)];
    double best = INFINITY;
    long calls = 1, i;
    int b;
    for (b = 0; b < best_of; b++) {
        Clock t0, t1;
        for (;;) {
            t0 = now();
            for (i = 0; i < calls; i++) {
                LfStatus st = jac ? ode.jac(ode.ctx, t, x, J, dx) : ode.rhs(ode.ctx, t, x, dx);
                if (st != LF_OK) return -1.0;
            }
            t1 = now();
            if (t1.cpu - t0.cpu >= MIN_BATCH_S) break;
            calls *= 2;
        }
        if ((t1.cpu - t0.cpu) / (double)calls < best) best = (t1.cpu - t0.cpu) / (double)calls;
    }
    return best;
}

/* Seconds per evaluation of the outputs at the instance's current point
 * (lf_update_outputs, as after every fmi2DoStep: the unknowns w and the
 * generated output function; not the outputs a history sample kept at the
 * same point, lf_hist_outputs), best of `best_of` batches; < 0 on failure. */
static double time_outputs(LfInstance *c, int best_of) {
    double best = INFINITY;
    long calls = 1, i;
    int b;
    for (b = 0; b < best_of; b++) {
        Clock t0, t1;
        for (;;) {
            t0 = now();
            for (i = 0; i < calls; i++) {
                c->run.outputs_valid = 0;
                c->unsaved.ho_valid = 0; /* the whole evaluation, not the kept outputs */
                if (lf_update_outputs(c) != LF_OK) return -1.0;
            }
            t1 = now();
            if (t1.cpu - t0.cpu >= MIN_BATCH_S) break;
            calls *= 2;
        }
        if ((t1.cpu - t0.cpu) / (double)calls < best) best = (t1.cpu - t0.cpu) / (double)calls;
    }
    return best;
}

/* Seconds per history sample (lf_hist_sample: the unknowns w and the
 * generated history function, g and dg/dt of every delayed expression) at
 * (t, x), best of `best_of` batches; 0 for a model that keeps no history (no
 * delay, or every delay 0); < 0 on failure.  One per accepted step is part of
 * a delay model's limit. */
static double time_hist(LfInstance *c, double t, const double *x, int best_of) {
    double g[LF_DIM(2 * LF_ND)], best = INFINITY;
    long calls = 1, i;
    int b, k, kept = 0;
    for (k = 0; k < LF_ND; k++) kept |= c->dl.tau[k] > 0;
    if (!kept) return 0.0;
    for (b = 0; b < best_of; b++) {
        Clock t0, t1;
        for (;;) {
            t0 = now();
            for (i = 0; i < calls; i++)
                if (lf_hist_sample(c, t, x, g) != LF_OK) return -1.0;
            t1 = now();
            if (t1.cpu - t0.cpu >= MIN_BATCH_S) break;
            calls *= 2;
        }
        if ((t1.cpu - t0.cpu) / (double)calls < best) best = (t1.cpu - t0.cpu) / (double)calls;
    }
    return best;
}

int main(int argc, char **argv) {
    Args a;
    fmi2CallbackFunctions cb;
    double cpu[MAX_REPEATS], wall[MAX_REPEATS], x[LF_DIM(LF_NX)], t_rhs, t_jac, t_out, t_hist, t;
    LfInstance *c = NULL;
    LfOde ode;
    int r;
    if (!parse_args(argc, argv, &a)) return 2;
    cb.logger = logger;
    cb.allocateMemory = calloc;
    cb.freeMemory = free;
    cb.stepFinished = NULL;
    cb.componentEnvironment = NULL;
    for (r = 0; r < a.repeats; r++) {
        Clock t0 = now(), t1;
        fmi2Component comp = start(&a, &cb);
        if (!comp) return 1;
        if (!run(&a, comp)) return 1;
        t1 = now();
        cpu[r] = t1.cpu - t0.cpu;
        wall[r] = t1.wall - t0.wall;
        if (r + 1 < a.repeats) {
            fmi2Terminate(comp);
            fmi2FreeInstance(comp);
            continue;
        }
        c = (LfInstance *)comp;
        printf("{\"model\": \"%s\", \"solver\": \"%s\", \"nx\": %d, \"nw\": %d, "
               "\"implicit\": %d, \"stop\": %.17g, \"step\": %.17g, \"rtol\": %.17g, "
               "\"atol\": %.17g, \"repeats\": %d,\n",
               lf_model.identifier, lf_model.solver_names[a.solver_id - 1], LF_NX, LF_NW,
               LF_IMPLICIT, a.stop, a.step, a.rtol, a.atol, a.repeats);
        printf(" \"steps\": %ld, \"rejected\": %ld, \"rhs\": %ld, \"jac\": %ld, \"lu\": %ld, "
               "\"events\": %ld, \"newton_failures\": %ld,\n",
               c->solver.n_steps, c->solver.n_rejected, c->solver.n_rhs, c->solver.n_jac,
               c->solver.n_lu, c->stats.n_events, c->stats.n_newton_fail);
        print_outputs(comp);
        /* the right-hand side and Jacobian at the run's last accepted point */
        t = c->solver.t;
        memcpy(x, c->solver.x, sizeof(double) * LF_NX);
        ode = lf_ode_of(c);
        t_rhs = time_call(ode, t, x, 0, a.best_of);
        t_jac = time_call(ode, t, x, 1, a.best_of);
        t_out = time_outputs(c, a.best_of);
        t_hist = time_hist(c, t, x, a.best_of);
        if (t_rhs < 0 || t_jac < 0 || t_out < 0 || t_hist < 0) {
            fprintf(stderr, "right-hand side, Jacobian or outputs failed at t = %.17g\n", t);
            return 1;
        }
        printf(" \"rhs_s\": %.6e, \"jac_s\": %.6e, \"out_s\": %.6e, \"hist_s\": %.6e, "
               "\"t_end\": %.17g,\n", t_rhs, t_jac, t_out, t_hist, t);
        fmi2Terminate(comp);
        fmi2FreeInstance(comp);
    }
    printf(" \"cpu_s\": %.6e, \"wall_s\": %.6e, \"cpu_runs\": [", median(cpu, a.repeats),
           median(wall, a.repeats));
    for (r = 0; r < a.repeats; r++) printf("%s%.6e", r ? ", " : "", cpu[r]);
    printf("]}\n");
    return 0;
}
