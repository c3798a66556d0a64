/* A minimal FMI importer, compiled for every platform an FMU carries a
 * binary for, to run that binary where it was built for (natively, under
 * wine, under qemu-aarch64) and compare the outputs bit for bit with the
 * native run (loomfmu.fmu.platform_run).
 *
 *     platform_driver JOBFILE
 *
 * JOBFILE: one run per line, fields separated by spaces:
 *
 *     LIB FMI(2|3) IFACE(cs|me) TOKEN RESOURCES START STOP STEP SUBSTEPS NX NZ OUT.csv
 *         NSET (i|r VR VALUE)... NVR VR...
 *
 * LIB the shared library (dlopen / LoadLibrary), TOKEN the GUID or
 * instantiation token, RESOURCES the resource location (FMI 2.0: a file URI;
 * FMI 3.0: a path), START STOP STEP the experiment and its output interval,
 * SUBSTEPS explicit Euler steps per output interval (model exchange), NX NZ
 * the number of states and event indicators (model exchange), NSET start
 * values to set before initialization (i: an Integer/Int32, r: a
 * Real/Float64, by value reference), VR the value references of the Float64
 * outputs to record.  Output times: START + i STEP
 * and STOP.  Co-simulation: one doStep per output interval with the FMU's embedded solver.  Model exchange:
 * explicit Euler at STEP / SUBSTEPS, events handled at the end of the step
 * where an indicator changed sign, a time event fell or the FMU asked
 * (completedIntegratorStep).
 *
 * OUT.csv: a header "time,vr<VR>,..." and one row per output time, each
 * double written as the 16 hex digits of its IEEE 754 bits (exact, and
 * independent of the C library's printf).  Prints "RUN <i> OK" or
 * "RUN <i> FAILED <what> t=<time>" per line; exits 1 if any run failed.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2FunctionTypes.h"
#include "fmi3FunctionTypes.h"

typedef void (*AnyFn)(void);

#ifdef _WIN32
#include <windows.h>
typedef HMODULE Lib;
static Lib lib_open(const char *path) { return LoadLibraryA(path); }
static AnyFn lib_fn(Lib h, const char *name) { return (AnyFn)GetProcAddress(h, name); }
static void lib_close(Lib h) { FreeLibrary(h); }
#else
#include <dlfcn.h>
typedef void *Lib;
static Lib lib_open(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
/* memcpy: ISO C has no cast between object and function pointers */
static AnyFn lib_fn(Lib h, const char *name) {
    void *p = dlsym(h, name);
    AnyFn f;
    memcpy(&f, &p, sizeof f);
    return f;
}
static void lib_close(Lib h) { dlclose(h); }
#endif

#define MAX_VR 256
#define MAX_SET 16
#define MAX_X 512

static int missing = 0;

/* a function of the library; a missing one is noted (the run fails) */
static AnyFn sym(Lib h, const char *name) {
    AnyFn f = lib_fn(h, name);
    if (f == NULL) {
        fprintf(stderr, "missing function %s\n", name);
        missing = 1;
    }
    return f;
}

static void put_double(FILE *f, double v) {
    unsigned char b[8];
    unsigned long hi = 0, lo = 0;
    int i;
    memcpy(b, &v, 8);  /* little-endian on every target here */
    for (i = 7; i >= 4; i--) hi = (hi << 8) | b[i];
    for (i = 3; i >= 0; i--) lo = (lo << 8) | b[i];
    fprintf(f, "%08lx%08lx", hi, lo);
}

static void put_row(FILE *f, double t, const double *y, size_t n) {
    size_t i;
    put_double(f, t);
    for (i = 0; i < n; i++) {
        fputc(',', f);
        put_double(f, y[i]);
    }
    fputc('\n', f);
}

typedef struct {
    char lib[1024], token[256], res[1024], out[1024], iface[8];
    int fmi;
    double start, stop, step;
    int substeps;
    size_t nx, nz, nvr, nset;
    unsigned int vr[MAX_VR];
    char set_kind[MAX_SET];
    unsigned int set_vr[MAX_SET];
    double set_value[MAX_SET];
} Job;

static char failure[256];

static void logger2(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                 fmi2String category, fmi2String message, ...) {
    (void)env;
    if (status >= fmi2Warning)
        fprintf(stderr, "[%s %d %s] %s\n", name, (int)status, category, message);
}

static void logger3(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                 fmi3String message) {
    (void)env;
    if (status >= fmi3Warning) fprintf(stderr, "[%d %s] %s\n", (int)status, category, message);
}

#define FAIL(what, t) do { sprintf(failure, "%s t=%.17g", what, (double)(t)); goto done; } while (0)
#define CHECK2(call, what, t) do { if ((call) > fmi2Warning) FAIL(what, t); } while (0)
#define CHECK3(call, what, t) do { if ((call) > fmi3Warning) FAIL(what, t); } while (0)

/* output times: START + i STEP, the last one STOP (a shorter last interval
 * when STOP is not on the grid) */
static long n_out(const Job *j) { return (long)ceil((j->stop - j->start) / j->step - 1e-9); }

static double out_time(const Job *j, long i) {
    return i >= n_out(j) ? j->stop : j->start + (double)i * j->step;
}

/* sign change of an event indicator between two points */
static int crossed(const double *z0, const double *z1, size_t nz) {
    size_t i;
    for (i = 0; i < nz; i++)
        if ((z0[i] > 0 && z1[i] <= 0) || (z0[i] < 0 && z1[i] >= 0)) return 1;
    return 0;
}

static int run2(Lib h, const Job *j, FILE *out) {
    fmi2InstantiateTYPE *inst = (fmi2InstantiateTYPE *)sym(h, "fmi2Instantiate");
    fmi2FreeInstanceTYPE *free_ = (fmi2FreeInstanceTYPE *)sym(h, "fmi2FreeInstance");
    fmi2SetupExperimentTYPE *setup = (fmi2SetupExperimentTYPE *)sym(h, "fmi2SetupExperiment");
    fmi2EnterInitializationModeTYPE *enter =
        (fmi2EnterInitializationModeTYPE *)sym(h, "fmi2EnterInitializationMode");
    fmi2ExitInitializationModeTYPE *exit_ =
        (fmi2ExitInitializationModeTYPE *)sym(h, "fmi2ExitInitializationMode");
    fmi2GetRealTYPE *get = (fmi2GetRealTYPE *)sym(h, "fmi2GetReal");
    fmi2TerminateTYPE *term = (fmi2TerminateTYPE *)sym(h, "fmi2Terminate");
    fmi2CallbackFunctions cb;
    fmi2Component c = NULL;
    double y[MAX_VR], x[MAX_X], dx[MAX_X], z0[MAX_X], z1[MAX_X], t = j->start;
    long i, n = n_out(j);
    int me = strcmp(j->iface, "me") == 0, k;
    if (missing) return 0;
    cb.logger = logger2;
    cb.allocateMemory = calloc;
    cb.freeMemory = free;
    cb.stepFinished = NULL;
    cb.componentEnvironment = NULL;
    c = inst("driver", me ? fmi2ModelExchange : fmi2CoSimulation, j->token, j->res, &cb,
             fmi2False, fmi2False);
    if (c == NULL) FAIL("fmi2Instantiate", t);
    {
        fmi2SetIntegerTYPE *seti = (fmi2SetIntegerTYPE *)sym(h, "fmi2SetInteger");
        fmi2SetRealTYPE *setr = (fmi2SetRealTYPE *)sym(h, "fmi2SetReal");
        size_t q;
        if (missing) FAIL("functions", t);
        for (q = 0; q < j->nset; q++) {
            fmi2Integer iv = (fmi2Integer)j->set_value[q];
            if (j->set_kind[q] == 'i')
                CHECK2(seti(c, &j->set_vr[q], 1, &iv), "fmi2SetInteger", t);
            else
                CHECK2(setr(c, &j->set_vr[q], 1, &j->set_value[q]), "fmi2SetReal", t);
        }
    }
    CHECK2(setup(c, fmi2False, 0.0, j->start, fmi2True, j->stop), "fmi2SetupExperiment", t);
    CHECK2(enter(c), "fmi2EnterInitializationMode", t);
    CHECK2(exit_(c), "fmi2ExitInitializationMode", t);
    if (!me) {
        fmi2DoStepTYPE *step = (fmi2DoStepTYPE *)sym(h, "fmi2DoStep");
        if (missing) FAIL("functions", t);
        CHECK2(get(c, j->vr, j->nvr, y), "fmi2GetReal", t);
        put_row(out, t, y, j->nvr);
        for (i = 1; i <= n; i++) {
            double t0 = out_time(j, i - 1);
            t = out_time(j, i);
            CHECK2(step(c, t0, t - t0, fmi2True), "fmi2DoStep", t0);
            CHECK2(get(c, j->vr, j->nvr, y), "fmi2GetReal", t);
            put_row(out, t, y, j->nvr);
        }
    } else {
        fmi2NewDiscreteStatesTYPE *nds = (fmi2NewDiscreteStatesTYPE *)sym(h, "fmi2NewDiscreteStates");
        fmi2EnterContinuousTimeModeTYPE *ctm =
            (fmi2EnterContinuousTimeModeTYPE *)sym(h, "fmi2EnterContinuousTimeMode");
        fmi2EnterEventModeTYPE *evm = (fmi2EnterEventModeTYPE *)sym(h, "fmi2EnterEventMode");
        fmi2GetContinuousStatesTYPE *getx =
            (fmi2GetContinuousStatesTYPE *)sym(h, "fmi2GetContinuousStates");
        fmi2SetContinuousStatesTYPE *setx =
            (fmi2SetContinuousStatesTYPE *)sym(h, "fmi2SetContinuousStates");
        fmi2GetDerivativesTYPE *der = (fmi2GetDerivativesTYPE *)sym(h, "fmi2GetDerivatives");
        fmi2GetEventIndicatorsTYPE *ind =
            (fmi2GetEventIndicatorsTYPE *)sym(h, "fmi2GetEventIndicators");
        fmi2SetTimeTYPE *settime = (fmi2SetTimeTYPE *)sym(h, "fmi2SetTime");
        fmi2CompletedIntegratorStepTYPE *done_ =
            (fmi2CompletedIntegratorStepTYPE *)sym(h, "fmi2CompletedIntegratorStep");
        fmi2EventInfo ev;
        size_t q;
        if (missing) FAIL("functions", t);
        if (j->nx > MAX_X || j->nz > MAX_X) FAIL("too many states", t);
        memset(&ev, 0, sizeof ev);
        ev.newDiscreteStatesNeeded = fmi2True;
        while (ev.newDiscreteStatesNeeded) CHECK2(nds(c, &ev), "fmi2NewDiscreteStates", t);
        CHECK2(ctm(c), "fmi2EnterContinuousTimeMode", t);
        CHECK2(getx(c, x, j->nx), "fmi2GetContinuousStates", t);
        CHECK2(ind(c, z0, j->nz), "fmi2GetEventIndicators", t);
        CHECK2(get(c, j->vr, j->nvr, y), "fmi2GetReal", t);
        put_row(out, t, y, j->nvr);
        for (i = 1; i <= n; i++) {
            double t0 = out_time(j, i - 1), h_ = (out_time(j, i) - t0) / j->substeps;
            for (k = 1; k <= j->substeps; k++) {
                fmi2Boolean event = fmi2False, stop = fmi2False;
                double t_prev = t;
                CHECK2(der(c, dx, j->nx), "fmi2GetDerivatives", t);
                t = k == j->substeps ? out_time(j, i) : t0 + k * h_;
                for (q = 0; q < j->nx; q++) x[q] += (t - t_prev) * dx[q];
                CHECK2(settime(c, t), "fmi2SetTime", t);
                CHECK2(setx(c, x, j->nx), "fmi2SetContinuousStates", t);
                CHECK2(done_(c, fmi2True, &event, &stop), "fmi2CompletedIntegratorStep", t);
                CHECK2(ind(c, z1, j->nz), "fmi2GetEventIndicators", t);
                if (event || crossed(z0, z1, j->nz) ||
                    (ev.nextEventTimeDefined && t >= ev.nextEventTime)) {
                    CHECK2(evm(c), "fmi2EnterEventMode", t);
                    ev.newDiscreteStatesNeeded = fmi2True;
                    while (ev.newDiscreteStatesNeeded)
                        CHECK2(nds(c, &ev), "fmi2NewDiscreteStates", t);
                    CHECK2(ctm(c), "fmi2EnterContinuousTimeMode", t);
                    if (ev.valuesOfContinuousStatesChanged)
                        CHECK2(getx(c, x, j->nx), "fmi2GetContinuousStates", t);
                    CHECK2(ind(c, z1, j->nz), "fmi2GetEventIndicators", t);
                }
                memcpy(z0, z1, j->nz * sizeof *z0);
            }
            CHECK2(get(c, j->vr, j->nvr, y), "fmi2GetReal", t);
            put_row(out, t, y, j->nvr);
        }
    }
    CHECK2(term(c), "fmi2Terminate", t);
done:
    if (c != NULL) free_(c);
    return failure[0] == 0;
}

/* the job's start values, before initialization */
static int set3(Lib h, fmi3Instance c, const Job *j) {
    fmi3SetInt32TYPE *seti = (fmi3SetInt32TYPE *)sym(h, "fmi3SetInt32");
    fmi3SetFloat64TYPE *setr = (fmi3SetFloat64TYPE *)sym(h, "fmi3SetFloat64");
    size_t q;
    if (missing) return 0;
    for (q = 0; q < j->nset; q++) {
        fmi3Int32 iv = (fmi3Int32)j->set_value[q];
        fmi3Status st = j->set_kind[q] == 'i' ? seti(c, &j->set_vr[q], 1, &iv, 1)
                                              : setr(c, &j->set_vr[q], 1, &j->set_value[q], 1);
        if (st > fmi3Warning) return 0;
    }
    return 1;
}

static int run3(Lib h, const Job *j, FILE *out) {
    fmi3FreeInstanceTYPE *free_ = (fmi3FreeInstanceTYPE *)sym(h, "fmi3FreeInstance");
    fmi3EnterInitializationModeTYPE *enter =
        (fmi3EnterInitializationModeTYPE *)sym(h, "fmi3EnterInitializationMode");
    fmi3ExitInitializationModeTYPE *exit_ =
        (fmi3ExitInitializationModeTYPE *)sym(h, "fmi3ExitInitializationMode");
    fmi3GetFloat64TYPE *get = (fmi3GetFloat64TYPE *)sym(h, "fmi3GetFloat64");
    fmi3TerminateTYPE *term = (fmi3TerminateTYPE *)sym(h, "fmi3Terminate");
    fmi3Instance c = NULL;
    double y[MAX_VR], x[MAX_X], dx[MAX_X], z0[MAX_X], z1[MAX_X], t = j->start;
    long i, n = n_out(j);
    int me = strcmp(j->iface, "me") == 0, k;
    if (missing) return 0;
    if (!me) {
        fmi3InstantiateCoSimulationTYPE *inst =
            (fmi3InstantiateCoSimulationTYPE *)sym(h, "fmi3InstantiateCoSimulation");
        fmi3DoStepTYPE *step = (fmi3DoStepTYPE *)sym(h, "fmi3DoStep");
        fmi3Boolean need = fmi3False, stop = fmi3False, early = fmi3False;
        double last = 0.0;
        if (missing) FAIL("functions", t);
        c = inst("driver", j->token, j->res, fmi3False, fmi3False, fmi3False, fmi3False,
                 NULL, 0, NULL, logger3, NULL);
        if (c == NULL) FAIL("fmi3InstantiateCoSimulation", t);
        if (!set3(h, c, j)) FAIL("fmi3SetInt32/fmi3SetFloat64", t);
        CHECK3(enter(c, fmi3False, 0.0, j->start, fmi3True, j->stop),
               "fmi3EnterInitializationMode", t);
        CHECK3(exit_(c), "fmi3ExitInitializationMode", t);
        CHECK3(get(c, j->vr, j->nvr, y, j->nvr), "fmi3GetFloat64", t);
        put_row(out, t, y, j->nvr);
        for (i = 1; i <= n; i++) {
            double t0 = out_time(j, i - 1);
            t = out_time(j, i);
            CHECK3(step(c, t0, t - t0, fmi3True, &need, &stop, &early, &last), "fmi3DoStep", t0);
            CHECK3(get(c, j->vr, j->nvr, y, j->nvr), "fmi3GetFloat64", t);
            put_row(out, t, y, j->nvr);
        }
    } else {
        fmi3InstantiateModelExchangeTYPE *inst =
            (fmi3InstantiateModelExchangeTYPE *)sym(h, "fmi3InstantiateModelExchange");
        fmi3UpdateDiscreteStatesTYPE *upd =
            (fmi3UpdateDiscreteStatesTYPE *)sym(h, "fmi3UpdateDiscreteStates");
        fmi3EnterContinuousTimeModeTYPE *ctm =
            (fmi3EnterContinuousTimeModeTYPE *)sym(h, "fmi3EnterContinuousTimeMode");
        fmi3EnterEventModeTYPE *evm = (fmi3EnterEventModeTYPE *)sym(h, "fmi3EnterEventMode");
        fmi3GetContinuousStatesTYPE *getx =
            (fmi3GetContinuousStatesTYPE *)sym(h, "fmi3GetContinuousStates");
        fmi3SetContinuousStatesTYPE *setx =
            (fmi3SetContinuousStatesTYPE *)sym(h, "fmi3SetContinuousStates");
        fmi3GetContinuousStateDerivativesTYPE *der =
            (fmi3GetContinuousStateDerivativesTYPE *)sym(h, "fmi3GetContinuousStateDerivatives");
        fmi3GetEventIndicatorsTYPE *ind =
            (fmi3GetEventIndicatorsTYPE *)sym(h, "fmi3GetEventIndicators");
        fmi3SetTimeTYPE *settime = (fmi3SetTimeTYPE *)sym(h, "fmi3SetTime");
        fmi3CompletedIntegratorStepTYPE *done_ =
            (fmi3CompletedIntegratorStepTYPE *)sym(h, "fmi3CompletedIntegratorStep");
        fmi3Boolean again = fmi3True, stop = fmi3False, nominals = fmi3False,
            changed = fmi3False, timed = fmi3False;
        double next = 0.0;
        size_t q;
        if (missing) FAIL("functions", t);
        if (j->nx > MAX_X || j->nz > MAX_X) FAIL("too many states", t);
        c = inst("driver", j->token, j->res, fmi3False, fmi3False, NULL, logger3);
        if (c == NULL) FAIL("fmi3InstantiateModelExchange", t);
        if (!set3(h, c, j)) FAIL("fmi3SetInt32/fmi3SetFloat64", t);
        CHECK3(enter(c, fmi3False, 0.0, j->start, fmi3True, j->stop),
               "fmi3EnterInitializationMode", t);
        CHECK3(exit_(c), "fmi3ExitInitializationMode", t);
        while (again)
            CHECK3(upd(c, &again, &stop, &nominals, &changed, &timed, &next),
                   "fmi3UpdateDiscreteStates", t);
        CHECK3(ctm(c), "fmi3EnterContinuousTimeMode", t);
        CHECK3(getx(c, x, j->nx), "fmi3GetContinuousStates", t);
        CHECK3(ind(c, z0, j->nz), "fmi3GetEventIndicators", t);
        CHECK3(get(c, j->vr, j->nvr, y, j->nvr), "fmi3GetFloat64", t);
        put_row(out, t, y, j->nvr);
        for (i = 1; i <= n; i++) {
            double t0 = out_time(j, i - 1), h_ = (out_time(j, i) - t0) / j->substeps;
            for (k = 1; k <= j->substeps; k++) {
                fmi3Boolean event = fmi3False;
                double t_prev = t;
                CHECK3(der(c, dx, j->nx), "fmi3GetContinuousStateDerivatives", t);
                t = k == j->substeps ? out_time(j, i) : t0 + k * h_;
                for (q = 0; q < j->nx; q++) x[q] += (t - t_prev) * dx[q];
                CHECK3(settime(c, t), "fmi3SetTime", t);
                CHECK3(setx(c, x, j->nx), "fmi3SetContinuousStates", t);
                CHECK3(done_(c, fmi3True, &event, &stop), "fmi3CompletedIntegratorStep", t);
                CHECK3(ind(c, z1, j->nz), "fmi3GetEventIndicators", t);
                if (event || crossed(z0, z1, j->nz) || (timed && t >= next)) {
                    CHECK3(evm(c), "fmi3EnterEventMode", t);
                    again = fmi3True;
                    while (again)
                        CHECK3(upd(c, &again, &stop, &nominals, &changed, &timed, &next),
                               "fmi3UpdateDiscreteStates", t);
                    CHECK3(ctm(c), "fmi3EnterContinuousTimeMode", t);
                    if (changed) CHECK3(getx(c, x, j->nx), "fmi3GetContinuousStates", t);
                    CHECK3(ind(c, z1, j->nz), "fmi3GetEventIndicators", t);
                }
                memcpy(z0, z1, j->nz * sizeof *z0);
            }
            CHECK3(get(c, j->vr, j->nvr, y, j->nvr), "fmi3GetFloat64", t);
            put_row(out, t, y, j->nvr);
        }
    }
    CHECK3(term(c), "fmi3Terminate", t);
done:
    if (c != NULL) free_(c);
    return failure[0] == 0;
}

static int read_job(FILE *f, Job *j) {
    size_t i;
    unsigned long nx, nz, nset, nvr;
    if (fscanf(f, "%1023s %d %7s %255s %1023s %lf %lf %lf %d %lu %lu %1023s %lu", j->lib, &j->fmi,
               j->iface, j->token, j->res, &j->start, &j->stop, &j->step, &j->substeps,
               &nx, &nz, j->out, &nset) != 13)
        return 0;
    j->nx = nx;
    j->nz = nz;
    j->nset = nset;
    if (j->nset > MAX_SET) return -1;
    for (i = 0; i < j->nset; i++) {
        char kind[2];
        if (fscanf(f, "%1s %u %lf", kind, &j->set_vr[i], &j->set_value[i]) != 3) return -1;
        j->set_kind[i] = kind[0];
    }
    if (fscanf(f, "%lu", &nvr) != 1) return -1;
    j->nvr = nvr;
    if (j->nvr > MAX_VR || j->step <= 0 || j->substeps < 1) return -1;
    for (i = 0; i < j->nvr; i++)
        if (fscanf(f, "%u", &j->vr[i]) != 1) return -1;
    return 1;
}

int main(int argc, char **argv) {
    FILE *jobs;
    Job j;
    int n = 0, bad = 0, r;
    if (argc != 2) {
        fprintf(stderr, "usage: %s JOBFILE\n", argv[0]);
        return 2;
    }
    jobs = fopen(argv[1], "r");
    if (jobs == NULL) {
        fprintf(stderr, "cannot read %s\n", argv[1]);
        return 2;
    }
    memset(&j, 0, sizeof j);
    while ((r = read_job(jobs, &j)) != 0) {
        Lib h;
        FILE *out;
        size_t i;
        int ok = 0;
        n++;
        failure[0] = 0;
        missing = 0;
        if (r < 0) {
            printf("RUN %d FAILED bad job line\n", n);
            bad = 1;
            break;
        }
        h = lib_open(j.lib);
        if (h == NULL) {
            printf("RUN %d FAILED cannot load %s\n", n, j.lib);
            bad = 1;
            continue;
        }
        out = fopen(j.out, "w");
        if (out == NULL) {
            printf("RUN %d FAILED cannot write %s\n", n, j.out);
            lib_close(h);
            bad = 1;
            continue;
        }
        fputs("time", out);
        for (i = 0; i < j.nvr; i++) fprintf(out, ",vr%u", j.vr[i]);
        fputc('\n', out);
        ok = j.fmi == 2 ? run2(h, &j, out) : run3(h, &j, out);
        fclose(out);
        lib_close(h);
        if (ok) {
            printf("RUN %d OK\n", n);
        } else {
            printf("RUN %d FAILED %s\n", n, missing ? "missing FMI functions" : failure);
            bad = 1;
        }
        fflush(stdout);
    }
    fclose(jobs);
    return bad;
}
