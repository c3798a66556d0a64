/* Misuse driver for a loomfmu FMU: compiled together with the FMU's own
 * sources (sources/ of the .fmu), usually with -fsanitize=address,undefined,
 * so that a crash, an out-of-bounds access, undefined behaviour or a leak
 * ends the process with a non-zero code.  tests/test_misuse.py and
 * benchmarks/misuse.py run one case per process.
 *
 * Usage:
 *   misuse list                      names of the cases that apply to this model
 *   misuse case NAME H               run one case; H = communication step
 *   misuse corrupt SEED N H RESEAL   N random one-byte corruptions of a
 *                                    serialized state, each in a forked child;
 *                                    RESEAL = 1: the checksum is recomputed after
 *                                    the corruption (tests the field checks alone)
 *
 * Every case runs a reference simulation (fresh instance, K0 + M steps of H,
 * all Reals read after each step) and repeats it with the misuse inserted.
 * A case line: "case NAME kind KIND verdict VERDICT", where for kind
 * "refuse" the verdict is
 *   refused   every misuse call returned fmi2Error (or NULL) with a log line,
 *             and the simulation continued bit for bit as the reference;
 *   silent    refused without a log line;
 *   accepted  a misuse call returned fmi2OK/fmi2Warning, results unchanged;
 *   ok-wrong  a misuse call returned fmi2OK/fmi2Warning and results changed;
 *   changed   refused, but the results changed afterwards;
 * and for kind "clean" (legal calls whose only risk is a crash or a leak,
 * e.g. FMU states never freed) the verdict is "clean" or "changed".
 * Exit code 0 iff the verdict is "refused" or "clean".
 *
 * corrupt prints "corrupt tried N refused R identical I changed C
 * refused_changed X crashed Z"; refused means refused with a log line and
 * the instance continued from where it was. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "fmi2Functions.h"
#include "lf_model.h"
#include "lf_state.h"

#define K0 20     /* steps before the misuse */
#define AHEAD 3   /* steps the instance moves on before a state is set */
#define M 10      /* steps compared after the misuse */
#define NSTEPS (K0 + AHEAD + M)

/* ---- logging --------------------------------------------------------- */

static int n_bad_logs;        /* lines with status >= warning since mark() */
static char last_log[1200];
static int verbose;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    (void)env;
    if (status >= fmi2Warning) n_bad_logs++;
    snprintf(last_log, sizeof last_log, "[%s] %s", category, message);
    if (verbose) fprintf(stderr, "log %s %d %s: %s\n", name, (int)status, category, message);
}

static fmi2CallbackFunctions cbs = {logger, calloc, free, NULL, NULL};

/* ---- simulation helpers ---------------------------------------------- */

static double H;
static double ref[NSTEPS + 1][LF_NREAL];
static fmi2ValueReference all_vr[LF_NREAL];

static fmi2Component inst(const char *name) {
    fmi2Component c = fmi2Instantiate(name, fmi2CoSimulation, lf_model.guid, "", &cbs, 0, 0);
    if (!c) {
        fprintf(stderr, "cannot instantiate %s: %s\n", name, last_log);
        exit(2);
    }
    return c;
}

static void start(fmi2Component c) {
    if (fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0) > fmi2Warning ||
        fmi2EnterInitializationMode(c) > fmi2Warning ||
        fmi2ExitInitializationMode(c) > fmi2Warning) {
        fprintf(stderr, "cannot initialize: %s\n", last_log);
        exit(2);
    }
}

/* Step from step `from` to `to`, comparing every Real with the reference;
 * returns the number of steps that differ (a failed step counts). */
static int advance(fmi2Component c, int from, int to) {
    double v[LF_NREAL];
    int k, bad = 0;
    for (k = from; k < to; k++) {
        if (fmi2DoStep(c, k * H, H, fmi2True) != fmi2OK ||
            fmi2GetReal(c, all_vr, LF_NREAL, v) != fmi2OK ||
            memcmp(v, ref[k + 1], sizeof v) != 0)
            bad++;
    }
    return bad;
}

static void make_reference(void) {
    fmi2Component c;
    int k;
    for (k = 0; k < LF_NREAL; k++) all_vr[k] = (fmi2ValueReference)k;
    c = inst("reference");
    start(c);
    fmi2GetReal(c, all_vr, LF_NREAL, ref[0]);
    for (k = 0; k < NSTEPS; k++)
        if (fmi2DoStep(c, k * H, H, fmi2True) != fmi2OK ||
            fmi2GetReal(c, all_vr, LF_NREAL, ref[k + 1]) != fmi2OK) {
            fprintf(stderr, "reference run failed at step %d: %s\n", k, last_log);
            exit(2);
        }
    fmi2FreeInstance(c);
}

/* An instance K0 steps in, checked against the reference on the way. */
static fmi2Component ready(const char *name) {
    fmi2Component c = inst(name);
    start(c);
    if (advance(c, 0, K0)) {
        fprintf(stderr, "run before the misuse differs from the reference\n");
        exit(2);
    }
    return c;
}

/* ---- outcome of a case ------------------------------------------------- */

static int n_calls, n_accepted, n_silent, n_changed;
static int mark_logs;

static void mark(void) { mark_logs = n_bad_logs; }

/* a misuse call's status: refused (>= fmi2Error) with a log line if `logs` */
static void refused(fmi2Status st, int logs) {
    n_calls++;
    if (st <= fmi2Warning) n_accepted++;
    else if (logs && n_bad_logs == mark_logs) n_silent++;
    mark();
}

static void refused_null(fmi2Component c, int logs) {
    n_calls++;
    if (c) {
        n_accepted++;
        fmi2FreeInstance(c);
    } else if (logs && n_bad_logs == mark_logs) {
        n_silent++;
    }
    mark();
}

/* after the misuse: the simulation goes on as the reference, then ends */
static void follow(fmi2Component c, int from) {
    n_changed += advance(c, from, from + M) != 0;
    fmi2FreeInstance(c);
}

/* the model still works (for cases that end their instance) */
static void fresh_run(void) {
    fmi2Component c = ready("fresh");
    follow(c, K0);
}

/* ---- item 3: NULL arrays, implausible sizes, partial sets ---------------- */

static void null_arrays(int which) {
    fmi2Component c = ready("instance");
    fmi2ValueReference vr[1] = {0};
    fmi2Real r[1] = {0};
    fmi2Integer i[1] = {0};
    fmi2Boolean b[1] = {0};
    fmi2String s[1] = {""};
    fmi2Status st = fmi2OK;
    int nul_vr = which % 2 == 0;
    const fmi2ValueReference *v = nul_vr ? NULL : vr;
    mark();
    switch (which / 2) {
    case 0: st = fmi2GetReal(c, v, 1, nul_vr ? r : NULL); break;
    case 1: st = fmi2SetReal(c, v, 1, nul_vr ? r : NULL); break;
    case 2: st = fmi2GetInteger(c, v, 1, nul_vr ? i : NULL); break;
    case 3: st = fmi2SetInteger(c, v, 1, nul_vr ? i : NULL); break;
    case 4: st = fmi2GetBoolean(c, v, 1, nul_vr ? b : NULL); break;
    case 5: st = fmi2SetBoolean(c, v, 1, nul_vr ? b : NULL); break;
    case 6: st = fmi2GetString(c, v, 1, nul_vr ? s : NULL); break;
    default: st = fmi2SetString(c, v, 1, nul_vr ? s : NULL); break;
    }
    refused(st, 1);
    follow(c, K0);
}

/* input and output derivatives: NULL arrays, sizes no array can have, a
 * value reference that is not an input/output, orders outside 1..2 (1),
 * non-finite values, one bad entry after a good one (nothing set) */
static void derivatives(int which) {
    fmi2Component c = ready("instance");
    fmi2ValueReference vr[2] = {LF_VR_U0, LF_VR_U0};
    fmi2Integer order[2] = {1, 1};
    fmi2Real r[2] = {1.0, 1.0};
    fmi2Status st;
    mark();
    switch (which) {
    case 0: st = fmi2SetRealInputDerivatives(c, NULL, 1, order, r); break;
    case 1: st = fmi2SetRealInputDerivatives(c, vr, 1, NULL, r); break;
    case 2: st = fmi2SetRealInputDerivatives(c, vr, 1, order, NULL); break;
    case 3: st = fmi2SetRealInputDerivatives(c, vr, SIZE_MAX, order, r); break;
    case 4: vr[0] = LF_VR_X0; st = fmi2SetRealInputDerivatives(c, vr, 1, order, r); break;
    case 5: order[0] = 0; st = fmi2SetRealInputDerivatives(c, vr, 1, order, r); break;
    case 6: order[0] = 3; st = fmi2SetRealInputDerivatives(c, vr, 1, order, r); break;
    case 7: r[0] = NAN; st = fmi2SetRealInputDerivatives(c, vr, 1, order, r); break;
    case 8: r[1] = INFINITY; st = fmi2SetRealInputDerivatives(c, vr, 2, order, r); break;
    case 9: vr[0] = LF_VR_Y0; st = fmi2GetRealOutputDerivatives(c, NULL, 1, order, r); break;
    case 10: vr[0] = LF_VR_Y0; st = fmi2GetRealOutputDerivatives(c, vr, 1, NULL, r); break;
    case 11: vr[0] = LF_VR_Y0; st = fmi2GetRealOutputDerivatives(c, vr, 1, order, NULL); break;
    case 12: vr[0] = LF_VR_Y0; st = fmi2GetRealOutputDerivatives(c, vr, SIZE_MAX, order, r); break;
    case 13: order[0] = 2; vr[0] = LF_VR_Y0; st = fmi2GetRealOutputDerivatives(c, vr, 1, order, r); break;
    default: st = fmi2GetRealOutputDerivatives(c, vr, 1, order, r); break; /* an input */
    }
    refused(st, 1);
    follow(c, K0);
}

/* nvr far beyond the 2-element arrays: refused before either is read (the
 * sanitizer build catches any read past them) */
static void huge_nvr(int which) {
    fmi2Component c = ready("instance");
    fmi2ValueReference vr[2] = {0, 0};
    fmi2Real r[2] = {0, 0};
    fmi2Integer i[2] = {1, 1};
    fmi2Boolean b[2] = {0, 0};
    size_t n = which % 2 ? SIZE_MAX : (size_t)1 << 30;
    mark();
    switch (which / 2) {
    case 0: refused(fmi2GetReal(c, vr, n, r), 1); break;
    case 1: refused(fmi2SetReal(c, vr, n, r), 1); break;
    case 2: refused(fmi2GetInteger(c, vr, n, i), 1); break;
    case 3: refused(fmi2SetInteger(c, vr, n, i), 1); break;
    default: refused(fmi2GetBoolean(c, vr, n, b), 1); break;
    }
    follow(c, K0);
}

/* a set call with one bad element changes nothing (also not the good ones) */
static void partial_set(int which) {
    fmi2Component c;
    fmi2ValueReference vr[2] = {LF_VR_U0, LF_NREAL + 5};
    fmi2Real r[2] = {0.5 * ref[K0][LF_VR_U0] + 0.25, 1.0};
    fmi2ValueReference ivr[2] = {LF_VR_SOLVER, LF_VR_SOLVER};
    fmi2Integer iv[2] = {2, 99};
    if (which == 2) { /* before initialization: solver 2 must not stick */
        c = inst("instance");
        mark();
        refused(fmi2SetInteger(c, ivr, 2, iv), 1);
        start(c);
        n_changed += advance(c, 0, K0) != 0;
        follow(c, K0);
        return;
    }
    c = ready("instance");
    if (which == 1) vr[1] = LF_VR_P0; /* a parameter cannot be set after initialization */
    mark();
    refused(fmi2SetReal(c, vr, 2, r), 1);
    follow(c, K0);
}

/* ---- item 3: life cycle, status, logging --------------------------------- */

static void after_free(int which) {
    fmi2Component c = ready("instance"), other;
    fmi2Real r[1];
    fmi2ValueReference vr[1] = {0};
    fmi2FreeInstance(c);
    mark();
    switch (which) {
    case 0: fmi2FreeInstance(c); refused(fmi2Error, 0); break; /* returns void */
    case 1: refused(fmi2DoStep(c, K0 * H, H, fmi2True), 0); break;
    case 2: refused(fmi2GetReal(c, vr, 1, r), 0); break;
    default: /* documented limit: if the address is reused, the call is that
              * instance's (legal there); only no crash and no leak are checked */
        other = inst("other");
        refused(fmi2GetReal(c, vr, 1, r), 0);
        fmi2FreeInstance(other);
        break;
    }
    fresh_run();
}

static void null_instance(int which) {
    fmi2ValueReference vr[1] = {0};
    fmi2Real r[1];
    fmi2FMUstate s = NULL;
    fmi2Status st;
    (void)which;
    mark();
    refused(fmi2SetupExperiment(NULL, 0, 0, 0, 0, 0), 0);
    refused(fmi2DoStep(NULL, 0, H, fmi2True), 0);
    refused(fmi2GetReal(NULL, vr, 1, r), 0);
    refused(fmi2SetReal(NULL, vr, 1, r), 0);
    refused(fmi2GetFMUstate(NULL, &s), 0);
    refused(fmi2GetStatus(NULL, fmi2DoStepStatus, &st), 0);
    refused(fmi2SetDebugLogging(NULL, 1, 0, NULL), 0);
    fmi2FreeInstance(NULL);
    fresh_run();
}

static void status_null(int which) {
    fmi2Component c = ready("instance");
    mark();
    switch (which) {
    case 0: refused(fmi2GetStatus(c, fmi2DoStepStatus, NULL), 1); break;
    case 1: refused(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, NULL), 1); break;
    case 2: refused(fmi2GetIntegerStatus(c, fmi2DoStepStatus, NULL), 1); break;
    case 3: refused(fmi2GetBooleanStatus(c, fmi2Terminated, NULL), 1); break;
    default: refused(fmi2GetStringStatus(c, fmi2PendingStatus, NULL), 1); break;
    }
    follow(c, K0);
}

static void debug_logging(int which) {
    fmi2Component c = ready("instance");
    fmi2String cats[2] = {"logEvents", NULL};
    mark();
    if (which == 0) refused(fmi2SetDebugLogging(c, 1, 1, NULL), 1);
    else if (which == 1) refused(fmi2SetDebugLogging(c, 1, 2, cats), 1);
    else refused(fmi2SetDebugLogging(c, 1, SIZE_MAX, cats), 1);
    follow(c, K0);
}

static void instantiate(int which) {
    fmi2CallbackFunctions no_logger = cbs;
    no_logger.logger = NULL;
    mark();
    switch (which) {
    case 0: refused_null(fmi2Instantiate(NULL, fmi2CoSimulation, lf_model.guid, "", &cbs, 0, 0), 1); break;
    case 1: refused_null(fmi2Instantiate("", fmi2CoSimulation, lf_model.guid, "", &cbs, 0, 0), 1); break;
    case 2: refused_null(fmi2Instantiate("x", fmi2CoSimulation, lf_model.guid, "", NULL, 0, 0), 0); break;
    case 3: refused_null(fmi2Instantiate("x", fmi2CoSimulation, lf_model.guid, "", &no_logger, 0, 0), 0); break;
    case 4: refused_null(fmi2Instantiate("x", fmi2CoSimulation, NULL, "", &cbs, 0, 0), 1); break;
    case 5: refused_null(fmi2Instantiate("x", fmi2CoSimulation, "{not-this-fmu}", "", &cbs, 0, 0), 1); break;
    default: refused_null(fmi2Instantiate("x", fmi2ModelExchange, lf_model.guid, "", &cbs, 0, 0), 1); break;
    }
    fresh_run();
}

/* ---- item 3: FMU state calls ---------------------------------------------- */

static void state_calls(int which) {
    fmi2Component c = ready("instance"), other = NULL;
    fmi2FMUstate s = NULL, s2 = NULL, foreign = (fmi2FMUstate)&which, copy;
    fmi2Byte buf[16] = {0};
    size_t n = 0;
    if (fmi2GetFMUstate(c, &s) != fmi2OK || fmi2SerializedFMUstateSize(c, s, &n) != fmi2OK) exit(2);
    mark();
    switch (which) {
    case 0: refused(fmi2GetFMUstate(c, NULL), 1); break;
    case 1: refused(fmi2GetFMUstate(c, &foreign), 1); break;
    case 2: refused(fmi2SetFMUstate(c, NULL), 1); break;
    case 3: refused(fmi2SetFMUstate(c, foreign), 1); break;
    case 4: refused(fmi2FreeFMUstate(c, &foreign), 1); break;
    case 5: /* freed twice through a copy of the pointer */
        copy = s;
        if (fmi2FreeFMUstate(c, &s) != fmi2OK) n_accepted++;
        mark();
        refused(fmi2FreeFMUstate(c, &copy), 1);
        break;
    case 6: refused(fmi2SerializedFMUstateSize(c, s, NULL), 1); break;
    case 7: refused(fmi2SerializeFMUstate(c, s, NULL, n), 1); break;
    case 8: refused(fmi2SerializeFMUstate(c, s, buf, sizeof buf), 1); break;
    case 9: refused(fmi2DeSerializeFMUstate(c, NULL, n, &s2), 1); break;
    case 10: refused(fmi2DeSerializeFMUstate(c, buf, sizeof buf, NULL), 1); break;
    case 11: refused(fmi2SerializedFMUstateSize(c, foreign, &n), 1); break;
    default: /* another instance's state is not this instance's */
        other = ready("other");
        if (fmi2GetFMUstate(other, &s2) != fmi2OK) exit(2);
        mark();
        refused(fmi2SetFMUstate(c, s2), 1);
        fmi2FreeInstance(other);
        s2 = NULL;
        break;
    }
    fmi2FreeFMUstate(c, &s);
    follow(c, K0);
}

/* legal: states never freed by the importer are freed with the instance */
static void state_leak(int which) {
    fmi2Component c = ready("instance");
    fmi2FMUstate s = NULL, s2 = NULL, s3 = NULL;
    fmi2Byte *bytes;
    size_t n = 0;
    (void)which;
    fmi2GetFMUstate(c, &s);
    fmi2GetFMUstate(c, &s2);
    fmi2SerializedFMUstateSize(c, s, &n);
    bytes = (fmi2Byte *)malloc(n);
    fmi2SerializeFMUstate(c, s, bytes, n);
    fmi2DeSerializeFMUstate(c, bytes, n, &s3);
    free(bytes);
    n_changed += fmi2SetFMUstate(c, s3) != fmi2OK;
    follow(c, K0); /* frees the instance with its three states */
}

/* ---- item 4: time ------------------------------------------------------------ */

static void bad_time(int which) {
    fmi2Component c = ready("instance");
    double t = K0 * H;
    mark();
    switch (which) {
    case 0: refused(fmi2DoStep(c, NAN, H, fmi2True), 1);
            refused(fmi2DoStep(c, t + 10 * H, H, fmi2True), 1); break; /* still checked */
    case 1: refused(fmi2DoStep(c, INFINITY, H, fmi2True), 1); break;
    case 2: refused(fmi2DoStep(c, t, NAN, fmi2True), 1); break;
    case 3: refused(fmi2DoStep(c, t, INFINITY, fmi2True), 1); break;
    case 4: refused(fmi2DoStep(c, t, -H, fmi2True), 1); break;
    case 5: refused(fmi2DoStep(c, t, 0.0, fmi2True), 1); break;
    case 6: refused(fmi2DoStep(c, t, 1e-300, fmi2True), 1); break;
    case 7: refused(fmi2DoStep(c, t, t * 1e-17, fmi2True), 1); break;
    default: refused(fmi2DoStep(c, t + 10 * H, H, fmi2True), 1); break;
    }
    follow(c, K0);
}

static void bad_setup(int which) {
    fmi2Component c = inst("instance");
    mark();
    switch (which) {
    case 0: refused(fmi2SetupExperiment(c, 0, 0, NAN, 0, 0), 1); break;
    case 1: refused(fmi2SetupExperiment(c, 0, 0, INFINITY, 0, 0), 1); break;
    case 2: refused(fmi2SetupExperiment(c, 0, 0, 1.0, 1, 0.5), 1); break;
    case 3: refused(fmi2SetupExperiment(c, 0, 0, 0.0, 1, NAN), 1); break;
    default: refused(fmi2SetupExperiment(c, 0, 0, 0.0, 1, INFINITY), 1); break;
    }
    start(c);
    n_changed += advance(c, 0, K0) != 0;
    follow(c, K0);
}

/* startTime 1e20: a step of H does not move time; refused, nothing changes */
static void far_start(int which) {
    fmi2Component c = inst("instance");
    double t0 = 1e20, before[LF_NREAL], after[LF_NREAL], last = 0;
    (void)which;
    if (fmi2SetupExperiment(c, 0, 0, t0, 0, 0) != fmi2OK ||
        fmi2EnterInitializationMode(c) != fmi2OK || fmi2ExitInitializationMode(c) != fmi2OK)
        exit(2);
    fmi2GetReal(c, all_vr, LF_NREAL, before);
    mark();
    refused(fmi2DoStep(c, t0, H, fmi2True), 1);
    fmi2GetReal(c, all_vr, LF_NREAL, after);
    fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &last);
    n_changed += memcmp(before, after, sizeof before) != 0 || last != t0;
    fmi2FreeInstance(c);
    fresh_run();
}

/* ---- item 6: single corrupted fields (checksum sealed again) --------------- */

/* the state at step K0 as bytes; the instance moves on AHEAD steps */
static unsigned char *state_bytes(fmi2Component c, size_t *n) {
    fmi2FMUstate s = NULL;
    unsigned char *b;
    if (fmi2GetFMUstate(c, &s) != fmi2OK || fmi2SerializedFMUstateSize(c, s, n) != fmi2OK)
        exit(2);
    b = (unsigned char *)malloc(*n + 16);
    memset(b, 0, *n + 16);
    if (fmi2SerializeFMUstate(c, s, (fmi2Byte *)b, *n) != fmi2OK) exit(2);
    fmi2FreeFMUstate(c, &s);
    if (advance(c, K0, K0 + AHEAD)) exit(2);
    return b;
}

static fmi2Status set_bytes(fmi2Component c, const unsigned char *b, size_t n) {
    fmi2FMUstate s = NULL;
    fmi2Status st = fmi2DeSerializeFMUstate(c, (const fmi2Byte *)b, n, &s);
    if (st <= fmi2Warning) st = fmi2SetFMUstate(c, s);
    fmi2FreeFMUstate(c, &s);
    return st;
}

#ifdef LF_FNV_OFFSET /* the layout of lf_state.h (absent in runtimes before it) */
static unsigned long long fnv1a(const unsigned char *p, size_t n) {
    unsigned long long h = LF_FNV_OFFSET;
    size_t i;
    for (i = 0; i < n; i++) {
        h ^= p[i];
        h *= LF_FNV_PRIME;
    }
    return h;
}

static void seal(unsigned char *b, size_t n) {
    unsigned long long h = fnv1a(b, n - sizeof h);
    memcpy(b + n - sizeof h, &h, sizeof h);
}

#define VOFF(f) (sizeof(LfStateHeader) + offsetof(LfStateValues, f))
#define HOFF(f) offsetof(LfStateHeader, f)

static void put_d(unsigned char *b, size_t off, double v) { memcpy(b + off, &v, sizeof v); }
static void put_i(unsigned char *b, size_t off, int v) { memcpy(b + off, &v, sizeof v); }
static void put_l(unsigned char *b, size_t off, long v) { memcpy(b + off, &v, sizeof v); }

static void field(int which) {
    fmi2Component c = ready("instance");
    size_t n, work_off = sizeof(LfStateHeader) + sizeof(LfStateValues), hist_off;
    unsigned char *b = state_bytes(c, &n);
    LfStateHeader h;
    int reseal = 1;
    memcpy(&h, b, sizeof h);
    hist_off = work_off + sizeof(double) * (size_t)h.work_len;
    switch (which) {
    case 0: put_i(b, VOFF(solver_ready), 0); break;
    case 1: put_i(b, VOFF(solver_ready), 7); break;
    case 2: put_i(b, HOFF(method), 99); break;
    case 3: put_i(b, VOFF(solver_id), 99); break;
    case 4: put_i(b, VOFF(n_bp), 100000); break;
    case 5: put_i(b, VOFF(n_bp), -1); break;
    case 6: put_i(b, VOFF(state), 12345); break;
    case 7: put_d(b, VOFF(t), NAN); break;
    case 8: put_d(b, VOFF(t), INFINITY); break;
    case 9: put_d(b, VOFF(last_successful_time), K0 * H + 1.0); break;
    case 10: put_d(b, VOFF(t_stop), NAN); break;
    case 11: put_d(b, VOFF(r) + sizeof(double) * LF_VR_X0, NAN); break;
    case 12: put_d(b, VOFF(r) + sizeof(double) * LF_VR_X0, ref[K0][LF_VR_X0] + 1.0); break;
    case 13: put_d(b, VOFF(r) + sizeof(double) * LF_VR_P0, INFINITY); break;
    case 14: put_d(b, VOFF(r) + sizeof(double) * LF_SET_RTOL, -1.0); break;
    case 15: put_d(b, VOFF(r) + sizeof(double) * LF_VR_U0, NAN); break;
    case 16: put_d(b, VOFF(s_h), NAN); break;
    case 17: put_d(b, VOFF(s_opt) + offsetof(LfSolverOptions, rtol), -1.0); break;
    case 18: put_d(b, VOFF(s_t), NAN); break;
    case 19: put_d(b, work_off, NAN); break;
    case 20: put_l(b, VOFF(max_steps), 0); break;
    case 21: put_i(b, VOFF(delay_interp), 7); break;
    case 22: put_i(b, VOFF(outputs_valid), 5); break;
    case 23: put_i(b, HOFF(magic), 0); break;
    case 24: b[HOFF(guid) + 1] ^= 1; break;
    case 25: put_i(b, HOFF(n_real), LF_NREAL + 1); break;
    case 26: { unsigned long long w = h.work_len + 1; memcpy(b + HOFF(work_len), &w, sizeof w); } break;
    case 27: { unsigned long long w = h.size + 8; memcpy(b + HOFF(size), &w, sizeof w); } break;
    case 28: reseal = 0; b[n - 1] ^= 0x40; break;                   /* checksum itself */
    case 29: reseal = 0; put_d(b, VOFF(t), NAN); break;             /* not sealed */
    case 30: reseal = 0; n -= 1; break;                             /* truncated */
    case 31: n += 8; break;                                         /* extended, sealed */
    case 32: reseal = 0; memset(b, 0, 64); n = 64; break;           /* foreign bytes */
    case 33: put_d(b, VOFF(u_d1), NAN); break;
    case 34: put_d(b, VOFF(seen_t), INFINITY); break;
    case 35: put_i(b, VOFF(wants_terminate), 3); break;
    case 36: put_i(b, VOFF(solver_index), 9); break;
    case 37: /* an output the state marks current (returned as saved) not finite */
        put_d(b, VOFF(r) + sizeof(double) * LF_VR_Y0, NAN);
        put_i(b, VOFF(outputs_valid), 1);
        break;
    /* modes */
    case 40: put_d(b, VOFF(q), 99.0); break;
    /* delays */
    case 50: put_l(b, VOFF(hist_count), LF_HIST_CAP + 1); break;
    case 51: put_l(b, VOFF(hist_count), -5); break;
    case 52: put_d(b, VOFF(tau), -1.0); break;
    case 53: put_d(b, VOFF(tau), 1e9); break;
    case 54: put_d(b, hist_off, NAN); break;                        /* first sample's time */
    case 55: put_d(b, hist_off + 3 * sizeof(double), -1e9); break; /* second before first */
    case 56: { /* within the FMU's range, but not the tau its parameters give */
        double tau;
        memcpy(&tau, b + VOFF(tau), sizeof tau);
        put_d(b, VOFF(tau), tau > 0 ? 0.0 : lf_model.delay_max[0] / 2);
    } break;
    default: exit(2);
    }
    if (reseal) seal(b, n);
    mark();
    refused(set_bytes(c, b, n), 1);
    free(b);
    follow(c, K0 + AHEAD);
}

#endif

/* ---- random one-byte corruptions, each in a child process ------------------ */

static unsigned long long rng;
static unsigned long long next_rand(void) { /* xorshift64* */
    rng ^= rng >> 12;
    rng ^= rng << 25;
    rng ^= rng >> 27;
    return rng * 2685821657736338717ULL;
}

enum { R_REFUSED = 0, R_IDENTICAL = 1, R_CHANGED = 2, R_REFUSED_CHANGED = 3, R_SILENT = 4 };

static int one_corruption(fmi2Component c, unsigned char *b, size_t n) {
    fmi2Status st;
    int code;
    mark();
    st = set_bytes(c, b, n);
    if (st > fmi2Warning) {
        code = n_bad_logs == mark_logs ? R_SILENT
               : advance(c, K0 + AHEAD, K0 + AHEAD + M) ? R_REFUSED_CHANGED : R_REFUSED;
    } else {
        code = advance(c, K0, K0 + M) ? R_CHANGED : R_IDENTICAL;
    }
    fmi2FreeInstance(c);
    free(b);
    return code;
}

static int corrupt(unsigned long long seed, int trials, int reseal) {
    fmi2Component c = ready("instance");
    size_t n;
    unsigned char *b = state_bytes(c, &n);
    int counts[5] = {0, 0, 0, 0, 0}, crashed = 0, k;
    rng = seed * 0x9E3779B97F4A7C15ULL + 1;
    for (k = 0; k < trials; k++) {
        size_t off = (size_t)(next_rand() % (reseal ? n - 8 : n));
        unsigned char flip = (unsigned char)(1 + next_rand() % 255);
        pid_t pid = fork();
        int status = 0;
        if (pid == 0) {
            unsigned char *mine = (unsigned char *)malloc(n);
            memcpy(mine, b, n);
            free(b);
            mine[off] ^= flip;
#ifdef LF_FNV_OFFSET
            if (reseal) seal(mine, n);
#else
            if (reseal) exit(R_SILENT + 1);
#endif
            exit(one_corruption(c, mine, n));
        }
        if (pid < 0 || waitpid(pid, &status, 0) != pid) return 2;
        if (WIFEXITED(status) && WEXITSTATUS(status) <= R_SILENT) {
            counts[WEXITSTATUS(status)]++;
        } else {
            crashed++;
            fprintf(stderr, "corruption at byte %lu (xor %u): child ended with %s %d\n",
                    (unsigned long)off, flip, WIFEXITED(status) ? "exit code" : "signal",
                    WIFEXITED(status) ? WEXITSTATUS(status) : WTERMSIG(status));
        }
    }
    printf("corrupt bytes %lu tried %d refused %d identical %d changed %d refused_changed %d "
           "silent %d crashed %d\n", (unsigned long)n, trials, counts[R_REFUSED],
           counts[R_IDENTICAL], counts[R_CHANGED], counts[R_REFUSED_CHANGED], counts[R_SILENT],
           crashed);
    free(b);
    fmi2FreeInstance(c);
    return 0;
}

/* ---- the case table -------------------------------------------------------- */

typedef struct {
    const char *name;
    void (*run)(int);
    int arg;
    int clean;   /* legal calls: only crashes and leaks are failures */
    int needs;   /* 1: modes, 2: delays, 3: inputs, 4: outputs */
} Case;

static const Case cases[] = {
    {"get_real_null_vr", null_arrays, 0, 0, 0}, {"get_real_null_value", null_arrays, 1, 0, 0},
    {"set_real_null_vr", null_arrays, 2, 0, 0}, {"set_real_null_value", null_arrays, 3, 0, 0},
    {"get_integer_null_vr", null_arrays, 4, 0, 0}, {"get_integer_null_value", null_arrays, 5, 0, 0},
    {"set_integer_null_vr", null_arrays, 6, 0, 0}, {"set_integer_null_value", null_arrays, 7, 0, 0},
    {"get_boolean_null_vr", null_arrays, 8, 0, 0}, {"get_boolean_null_value", null_arrays, 9, 0, 0},
    {"set_boolean_null_vr", null_arrays, 10, 0, 0}, {"set_boolean_null_value", null_arrays, 11, 0, 0},
    {"get_string_null_vr", null_arrays, 12, 0, 0}, {"get_string_null_value", null_arrays, 13, 0, 0},
    {"set_string_null_vr", null_arrays, 14, 0, 0}, {"set_string_null_value", null_arrays, 15, 0, 0},
    {"get_real_nvr_2e30", huge_nvr, 0, 0, 0}, {"get_real_nvr_max", huge_nvr, 1, 0, 0},
    {"set_real_nvr_2e30", huge_nvr, 2, 0, 0}, {"set_real_nvr_max", huge_nvr, 3, 0, 0},
    {"get_integer_nvr_2e30", huge_nvr, 4, 0, 0}, {"set_integer_nvr_max", huge_nvr, 7, 0, 0},
    {"get_boolean_nvr_2e30", huge_nvr, 8, 0, 0},
    {"set_real_one_bad_vr", partial_set, 0, 0, 3}, {"set_real_one_fixed", partial_set, 1, 0, 3},
    {"set_integer_one_bad_vr", partial_set, 2, 0, 0},
    {"free_instance_twice", after_free, 0, 0, 0}, {"do_step_after_free", after_free, 1, 0, 0},
    {"get_real_after_free", after_free, 2, 0, 0}, {"freed_address_reused", after_free, 3, 1, 0},
    {"null_instance", null_instance, 0, 0, 0},
    {"input_derivatives_null_vr", derivatives, 0, 0, 3},
    {"input_derivatives_null_order", derivatives, 1, 0, 3},
    {"input_derivatives_null_value", derivatives, 2, 0, 3},
    {"input_derivatives_nvr_max", derivatives, 3, 0, 3},
    {"input_derivatives_not_input", derivatives, 4, 0, 3},
    {"input_derivatives_order_0", derivatives, 5, 0, 3},
    {"input_derivatives_order_3", derivatives, 6, 0, 3},
    {"input_derivatives_nan", derivatives, 7, 0, 3},
    {"input_derivatives_second_inf", derivatives, 8, 0, 3},
    {"output_derivatives_null_vr", derivatives, 9, 0, 0},
    {"output_derivatives_null_order", derivatives, 10, 0, 0},
    {"output_derivatives_null_value", derivatives, 11, 0, 0},
    {"output_derivatives_nvr_max", derivatives, 12, 0, 0},
    {"output_derivatives_order_2", derivatives, 13, 0, 0},
    {"output_derivatives_of_input", derivatives, 14, 0, 3},
    {"get_status_null", status_null, 0, 0, 0}, {"get_real_status_null", status_null, 1, 0, 0},
    {"get_integer_status_null", status_null, 2, 0, 0},
    {"get_boolean_status_null", status_null, 3, 0, 0},
    {"get_string_status_null", status_null, 4, 0, 0},
    {"debug_logging_null", debug_logging, 0, 0, 0},
    {"debug_logging_null_category", debug_logging, 1, 0, 0},
    {"debug_logging_n_max", debug_logging, 2, 0, 0},
    {"instantiate_null_name", instantiate, 0, 0, 0}, {"instantiate_empty_name", instantiate, 1, 0, 0},
    {"instantiate_null_functions", instantiate, 2, 0, 0},
    {"instantiate_null_logger", instantiate, 3, 0, 0},
    {"instantiate_null_guid", instantiate, 4, 0, 0}, {"instantiate_wrong_guid", instantiate, 5, 0, 0},
    {"instantiate_model_exchange", instantiate, 6, 0, 0},
    {"get_fmu_state_null", state_calls, 0, 0, 0}, {"get_fmu_state_foreign", state_calls, 1, 0, 0},
    {"set_fmu_state_null", state_calls, 2, 0, 0}, {"set_fmu_state_foreign", state_calls, 3, 0, 0},
    {"free_fmu_state_foreign", state_calls, 4, 0, 0}, {"free_fmu_state_twice", state_calls, 5, 0, 0},
    {"serialized_size_null", state_calls, 6, 0, 0}, {"serialize_null_bytes", state_calls, 7, 0, 0},
    {"serialize_short_buffer", state_calls, 8, 0, 0},
    {"deserialize_null_bytes", state_calls, 9, 0, 0},
    {"deserialize_null_state", state_calls, 10, 0, 0},
    {"serialized_size_foreign", state_calls, 11, 0, 0},
    {"set_fmu_state_of_other_instance", state_calls, 12, 0, 0},
    {"fmu_states_never_freed", state_leak, 0, 1, 0},
    {"do_step_nan_time", bad_time, 0, 0, 0}, {"do_step_inf_time", bad_time, 1, 0, 0},
    {"do_step_nan_h", bad_time, 2, 0, 0}, {"do_step_inf_h", bad_time, 3, 0, 0},
    {"do_step_negative_h", bad_time, 4, 0, 0}, {"do_step_zero_h", bad_time, 5, 0, 0},
    {"do_step_h_1e-300", bad_time, 6, 0, 0}, {"do_step_h_below_resolution", bad_time, 7, 0, 0},
    {"do_step_wrong_time", bad_time, 8, 0, 0},
    {"setup_nan_start", bad_setup, 0, 0, 0}, {"setup_inf_start", bad_setup, 1, 0, 0},
    {"setup_stop_before_start", bad_setup, 2, 0, 0}, {"setup_nan_stop", bad_setup, 3, 0, 0},
    {"setup_inf_stop", bad_setup, 4, 0, 0}, {"start_time_1e20", far_start, 0, 0, 0},
#ifdef LF_FNV_OFFSET
    {"state_solver_ready_0", field, 0, 0, 0}, {"state_solver_ready_7", field, 1, 0, 0},
    {"state_solver_method_99", field, 2, 0, 0}, {"state_solver_id_99", field, 3, 0, 0},
    {"state_breakpoints_100000", field, 4, 0, 0}, {"state_breakpoints_negative", field, 5, 0, 0},
    {"state_interface_state", field, 6, 0, 0}, {"state_time_nan", field, 7, 0, 0},
    {"state_time_inf", field, 8, 0, 0}, {"state_last_time_after_t", field, 9, 0, 0},
    {"state_stop_time_nan", field, 10, 0, 0}, {"state_x_nan", field, 11, 0, 0},
    {"state_x_not_solver_x", field, 12, 0, 0}, {"state_parameter_inf", field, 13, 0, 0},
    {"state_rtol_negative", field, 14, 0, 0}, {"state_input_nan", field, 15, 0, 3},
    {"state_solver_h_nan", field, 16, 0, 0}, {"state_solver_rtol_negative", field, 17, 0, 0},
    {"state_solver_t_nan", field, 18, 0, 0}, {"state_solver_work_nan", field, 19, 0, 0},
    {"state_max_steps_0", field, 20, 0, 0}, {"state_delay_interp_7", field, 21, 0, 0},
    {"state_outputs_valid_5", field, 22, 0, 0}, {"state_magic", field, 23, 0, 0},
    {"state_guid", field, 24, 0, 0}, {"state_n_real", field, 25, 0, 0},
    {"state_work_len", field, 26, 0, 0}, {"state_size_field", field, 27, 0, 0},
    {"state_checksum", field, 28, 0, 0}, {"state_not_sealed", field, 29, 0, 0},
    {"state_truncated", field, 30, 0, 0}, {"state_extended", field, 31, 0, 0},
    {"state_foreign_bytes", field, 32, 0, 0},
    {"state_input_derivative_nan", field, 33, 0, 0}, {"state_seen_time_inf", field, 34, 0, 0},
    {"state_wants_terminate_3", field, 35, 0, 0}, {"state_solver_index_9", field, 36, 0, 0},
    {"state_mode_99", field, 40, 0, 1},
    {"state_history_count_over", field, 50, 0, 2}, {"state_history_count_negative", field, 51, 0, 2},
    {"state_delay_negative", field, 52, 0, 2}, {"state_delay_1e9", field, 53, 0, 2},
    {"state_history_time_nan", field, 54, 0, 2}, {"state_history_out_of_order", field, 55, 0, 2},
    {"state_output_nan_marked_valid", field, 37, 0, 4},
    {"state_delay_not_its_parameters", field, 56, 0, 2},
#endif
};

static int applies(const Case *k) {
    return k->needs == 0 || (k->needs == 1 && LF_NQ > 0) || (k->needs == 2 && LF_ND > 0) ||
           (k->needs == 3 && LF_NU > 0) || (k->needs == 4 && LF_NY > 0);
}

int main(int argc, char **argv) {
    size_t i, n_cases = sizeof cases / sizeof cases[0];
    const char *verdict;
    verbose = getenv("MISUSE_VERBOSE") != NULL;
    if (argc == 2 && strcmp(argv[1], "list") == 0) {
        for (i = 0; i < n_cases; i++)
            if (applies(&cases[i])) printf("%s\n", cases[i].name);
        return 0;
    }
    if (argc == 6 && strcmp(argv[1], "corrupt") == 0) {
        H = atof(argv[4]);
        make_reference();
        return corrupt(strtoull(argv[2], NULL, 10), atoi(argv[3]), atoi(argv[5]));
    }
    if (argc != 4 || strcmp(argv[1], "case") != 0) {
        fprintf(stderr, "usage: misuse list | case NAME H | corrupt SEED N H RESEAL\n");
        return 2;
    }
    H = atof(argv[3]);
    for (i = 0; i < n_cases && strcmp(cases[i].name, argv[2]) != 0; i++) {
    }
    if (i == n_cases || !applies(&cases[i])) {
        fprintf(stderr, "no case %s for this model\n", argv[2]);
        return 2;
    }
    make_reference();
    cases[i].run(cases[i].arg);
    if (cases[i].clean) verdict = n_changed ? "changed" : "clean";
    else if (n_accepted) verdict = n_changed ? "ok-wrong" : "accepted";
    else if (n_silent) verdict = "silent";
    else if (n_changed) verdict = "changed";
    else verdict = "refused";
    printf("case %s kind %s verdict %s calls %d\n", cases[i].name,
           cases[i].clean ? "clean" : "refuse", verdict, n_calls);
    if (strcmp(verdict, "refused") != 0 && strcmp(verdict, "clean") != 0)
        fprintf(stderr, "last log line: %s\n", last_log);
    return strcmp(verdict, "refused") == 0 || strcmp(verdict, "clean") == 0 ? 0 : 1;
}
