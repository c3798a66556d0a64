/* The spindle run-up driven through the FMU's FMI 2.0 functions, without
 * Python (built by benchmarks/spindle_runup.py --counters from the FMU's own
 * sources/ plus this file).  Reads the solver's counters from the instance
 * (fmi2Component is the LfInstance) after the run.
 *
 * Usage: spindle_runup_driver <solver id> <rtol> <atol> <comm step> <interp 0|1>
 *            <ramp s> <hold s> <top rpm> <ecc m> <repeats>
 *            <vr solver> <vr solver_atol> <vr Omega> <vr e_b> <vr e_w> <vr r_top> <guid>
 * Prints "key value" lines: cpu_s (median of the repeats), steps, rejected,
 * rhs, jac, lu, r_top_max, r_top_end.
 */
#define _POSIX_C_SOURCE 199309L
#include "fmi2Functions.h"
#include "lf_instance.h"
#include "lf_newton.h"
#ifdef LF_PROBE_SCHUR
#include "lf_linalg.h"
#endif

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <math.h>

/* the spindle FMU's input Omega is rad/s; the scene is written in rpm */
#define RAD_S_PER_RPM (2.0 * 3.14159265358979323846 / 60.0)

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    (void)env;
    (void)name;
    if (status >= fmi2Discard) fprintf(stderr, "[%s] %s\n", category, message);
}

static double cpu_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    fmi2CallbackFunctions cb;
    int solver, interp, repeats, rep;
    double rtol, atol, h, ramp, hold, top, ecc, times[64], rmax = 0.0, rend = 0.0;
    fmi2ValueReference vr_solver, vr_atol, vr_rpm, vr_eb, vr_ew, vr_rtop;
    LfInstance *c = NULL;
    long nsteps;
    if (argc != 18) {
        fprintf(stderr, "usage: see source\n");
        return 2;
    }
    solver = atoi(argv[1]);
    rtol = atof(argv[2]);
    atol = atof(argv[3]);
    h = atof(argv[4]);
    interp = atoi(argv[5]);
    ramp = atof(argv[6]);
    hold = atof(argv[7]);
    top = atof(argv[8]);
    ecc = atof(argv[9]);
    repeats = atoi(argv[10]);
    if (repeats < 1 || repeats > 64) return 2;
    vr_solver = (fmi2ValueReference)strtol(argv[11], NULL, 10);
    vr_atol = (fmi2ValueReference)strtol(argv[12], NULL, 10);
    vr_rpm = (fmi2ValueReference)strtol(argv[13], NULL, 10);
    vr_eb = (fmi2ValueReference)strtol(argv[14], NULL, 10);
    vr_ew = (fmi2ValueReference)strtol(argv[15], NULL, 10);
    vr_rtop = (fmi2ValueReference)strtol(argv[16], NULL, 10);
    nsteps = (long)((ramp + hold) / h + 0.5);
    cb.logger = logger;
    cb.allocateMemory = calloc;
    cb.freeMemory = free;
    cb.stepFinished = NULL;
    cb.componentEnvironment = NULL;
    for (rep = 0; rep < repeats; rep++) {
        double t0 = cpu_now(), zero = 0.0;
        fmi2ValueReference vrs[4];
        fmi2Integer sid = solver, one = 1;
        long i;
        fmi2Component comp = fmi2Instantiate("runup", fmi2CoSimulation, argv[17], "", &cb, fmi2False,
                                             fmi2False);
        if (!comp) return 1;
        c = (LfInstance *)comp;
        fmi2SetupExperiment(comp, fmi2True, rtol, 0.0, fmi2False, 0.0);
        fmi2SetInteger(comp, &vr_solver, 1, &sid);
        vrs[0] = vr_atol;
        vrs[1] = vr_eb;
        vrs[2] = vr_ew;
        vrs[3] = vr_rpm;
        {
            double v[4];
            v[0] = atol;
            v[1] = ecc;
            v[2] = ecc;
            v[3] = zero;
            fmi2SetReal(comp, vrs, 4, v);
        }
        fmi2EnterInitializationMode(comp);
        fmi2ExitInitializationMode(comp);
        rmax = 0.0;
        for (i = 0; i < nsteps; i++) {
            double t = (double)i * h, rpm, omega, slope, r;
            if (t < ramp - 1e-12) {
                rpm = top * t / ramp;
                slope = top / ramp;
            } else {
                rpm = top;
                slope = 0.0;
            }
            omega = rpm * RAD_S_PER_RPM; /* the input Omega is rad/s */
            slope *= RAD_S_PER_RPM;
            fmi2SetReal(comp, &vr_rpm, 1, &omega);
            if (interp && slope != 0.0) fmi2SetRealInputDerivatives(comp, &vr_rpm, 1, &one, &slope);
            if (fmi2DoStep(comp, t, h, fmi2True) != fmi2OK) {
                fprintf(stderr, "doStep failed at t=%g\n", t);
                return 1;
            }
            fmi2GetReal(comp, &vr_rtop, 1, &r);
            if (r > rmax) rmax = r;
            rend = r;
        }
        times[rep] = cpu_now() - t0;
        if (rep == repeats - 1) {
            printf("steps %ld\nrejected %ld\nrhs %ld\njac %ld\nlu %ld\n", c->solver.n_steps,
                   c->solver.n_rejected, c->solver.n_rhs, c->solver.n_jac, c->solver.n_lu);
#ifdef LF_PROBE_SCHUR
            {   /* kinematic rows the Newton matrix eliminates at the end state */
                LfOde ode = lf_ode_of(c);
                size_t n = ode.n;
                double *J = (double *)calloc(n * n + n + lf_shifted_doubles(n), sizeof(double));
                double *ws = J ? J + n * n + n : NULL, *b = (double *)calloc(2 * n, sizeof(double));
                if (J && b && ode.jac(ode.ctx, c->solver.t, c->solver.x, J, J + n * n) == LF_OK &&
                    lf_shifted_factor(ws, J, n, 1e4) == 0) {
                    /* cost of each part at the end state, best of 5 rounds */
                    double best[6] = {1e300, 1e300, 1e300, 1e300, 1e300, 1e300};
                    int round, k, reps[6] = {2000, 200, 200, 2000, 100, 2000};
                    double *E = (double *)calloc(n * n, sizeof(double));
                    size_t *piv = (size_t *)calloc(n, sizeof(size_t)), i;
                    printf("states %lu\neliminated %lu\n", (unsigned long)n,
                           (unsigned long)lf_shifted_eliminated(ws));
                    for (round = 0; round < 5; round++) {
                        double t0;
                        t0 = cpu_now();
                        for (k = 0; k < reps[0]; k++) ode.rhs(ode.ctx, c->solver.t, c->solver.x, b);
                        best[0] = fmin(best[0], (cpu_now() - t0) / reps[0]);
                        t0 = cpu_now();
                        for (k = 0; k < reps[1]; k++) ode.jac(ode.ctx, c->solver.t, c->solver.x, J, b);
                        best[1] = fmin(best[1], (cpu_now() - t0) / reps[1]);
                        t0 = cpu_now();
                        for (k = 0; k < reps[2]; k++) lf_shifted_factor(ws, J, n, 1e4 + k);
                        best[2] = fmin(best[2], (cpu_now() - t0) / reps[2]);
                        t0 = cpu_now();
                        for (k = 0; k < reps[3]; k++) {
                            b[k % n] = 1.0;
                            lf_shifted_solve(ws, J, n, b);
                        }
                        best[3] = fmin(best[3], (cpu_now() - t0) / reps[3]);
                        /* the dense path: LU of the whole alpha*I - J */
                        t0 = cpu_now();
                        for (k = 0; k < reps[4] && E && piv; k++) {
                            for (i = 0; i < n * n; i++) E[i] = -J[i];
                            for (i = 0; i < n; i++) E[i + i * n] += 1e4 + k;
                            lf_lu_factor(E, n, piv);
                        }
                        best[4] = fmin(best[4], (cpu_now() - t0) / reps[4]);
                        t0 = cpu_now();
                        for (k = 0; k < reps[5] && E && piv; k++) {
                            b[k % n] = 1.0;
                            lf_lu_solve(E, n, piv, b);
                        }
                        best[5] = fmin(best[5], (cpu_now() - t0) / reps[5]);
                    }
                    free(E);
                    free(piv);
                    printf("rhs_us %.3f\njac_us %.3f\nfactor_us %.3f\nsolve_us %.3f\n"
                           "dense_factor_us %.3f\ndense_solve_us %.3f\n",
                           1e6 * best[0], 1e6 * best[1], 1e6 * best[2], 1e6 * best[3],
                           1e6 * best[4], 1e6 * best[5]);
                }
                free(b);
                free(J);
            }
#endif
        }
        fmi2Terminate(comp);
        fmi2FreeInstance(comp);
    }
    qsort(times, (size_t)repeats, sizeof times[0], cmp_double);
    printf("cpu_s %.6f\n", times[repeats / 2]);
    printf("r_top_max %.17g\nr_top_end %.17g\n", rmax, rend);
    return 0;
}
