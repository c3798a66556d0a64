/* loomfmu shared runtime: the FMI facades' version-independent function
 * bodies (lf_facade_ops.h).
 *
 * An FMU state is a blob of lf_state_write's bytes (checksummed, checked
 * field by field by lf_state_read) in the instance's list, so that freeing
 * the instance frees every state the importer did not, and a pointer the
 * instance did not make is refused without being dereferenced. */
#include <stdio.h>
#include <string.h>

#include "lf_facade_ops.h"
#include "lf_base.h"
#include "lf_runtime.h"
#include "lf_state.h"

void lf_state_names(int mask, const char *const names[], int n_names, char *buf,
                    size_t size) {
    int i;
    size_t used = 0;
    buf[0] = '\0';
    for (i = 0; i < n_names; i++) {
        int n;
        if (!(mask & (1 << i))) continue;
        n = snprintf(buf + used, size - used, "%s%s", used ? ", " : "", names[i]);
        if (n < 0 || (size_t)n >= size - used) return;
        used += (size_t)n;
    }
}

int lf_check_state(LfInstance *c, const char *fn, int bits, int mask,
                   const char *const names[], int n_names) {
    char now[64], allowed[200];
    if (bits & mask) return 1;
    lf_state_names(bits, names, n_names, now, sizeof now);
    lf_state_names(mask, names, n_names, allowed, sizeof allowed);
    lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s must not be called in state %s; allowed "
           "in: %s", c->run.t, fn, now[0] ? now : "unknown", allowed);
    return 0;
}

static int category_index(const char *name) {
    int k;
    for (k = 0; name && k < LF_N_LOG; k++)
        if (strcmp(name, lf_log_category_names[k]) == 0) return k;
    return -1;
}

LfStatus lf_set_debug_logging(LfInstance *c, const char *fn, int on, size_t n,
                              const char *const categories[]) {
    size_t i;
    int k;
    if (n == 0) {
        for (k = 0; k < LF_N_LOG; k++) c->unsaved.log_on[k] = on;
        return LF_OK;
    }
    if (!categories) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "%s: categories is NULL (with nCategories = %lu)",
               fn, (unsigned long)n);
        return LF_ERROR;
    }
    if (n > LF_N_LOG * 16) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "%s: nCategories = %lu, expected at most %d (the "
               "FMU has %d categories)", fn, (unsigned long)n, LF_N_LOG * 16, LF_N_LOG);
        return LF_ERROR;
    }
    for (i = 0; i < n; i++) /* all known, or nothing changes */
        if (category_index(categories[i]) < 0) {
            lf_log(c, LF_ERROR, LF_LOG_ERROR, "%s: unknown category %s", fn,
                   categories[i] ? categories[i] : "(null)");
            return LF_ERROR;
        }
    for (i = 0; i < n; i++) c->unsaved.log_on[category_index(categories[i])] = on;
    return LF_OK;
}

LfStatus lf_set_reals(LfInstance *c, const unsigned vr[], size_t nvr, const double v[],
                      int *rtol_set) {
    LfSetUndo u;
    LfStatus worst = LF_OK;
    size_t i;
    int rtol = 0;
    lf_undo_save(c, &u);
    for (i = 0; i < nvr; i++) {
        LfStatus st = lf_set_real(c, vr[i], v[i]);
        if (st > LF_WARNING) {
            lf_undo_restore(c, &u);
            return LF_ERROR;
        }
        if (st == LF_WARNING) worst = LF_WARNING;
        if (vr[i] == LF_SET_RTOL) rtol = 1;
    }
    if (rtol) *rtol_set = 1;
    return worst;
}

/* ---- FMU states ------------------------------------------------------------------ */

static LfStatus null_arg(LfInstance *c, const char *fn, const char *arg) {
    lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: %s is NULL; nothing done", c->run.t, fn, arg);
    return LF_ERROR;
}

LfStatus lf_fmustate_get(LfInstance *c, LfBlob **list, const char *fn, void **state) {
    LfBlob **old = NULL, *b;
    size_t n;
    if (!state) return null_arg(c, fn, "FMUstate");
    if (*state && !(old = lf_blob_find(c, list, fn, *state))) return LF_ERROR;
    n = lf_state_size(c);
    if (old && (*old)->n == n) {
        b = *old;
    } else {
        if (!(b = lf_blob_alloc(c, list, n))) return LF_ERROR; /* *state left as it was */
        if (*state) lf_blob_free(c, lf_blob_find(c, list, fn, *state));
    }
    lf_state_write(c, b->data);
    *state = b;
    return LF_OK;
}

LfStatus lf_fmustate_set(LfInstance *c, LfBlob **list, const char *fn, void *state) {
    LfBlob **b;
    if (!state) return null_arg(c, fn, "FMUstate");
    if (!(b = lf_blob_find(c, list, fn, state))) return LF_ERROR;
    return lf_state_read(c, (*b)->data, (*b)->n) == LF_OK ? LF_OK : LF_ERROR;
}

LfStatus lf_fmustate_free(LfInstance *c, LfBlob **list, const char *fn, void **state) {
    LfBlob **b;
    if (!state) return null_arg(c, fn, "FMUstate");
    if (!*state) return LF_OK; /* FMI: a NULL state is ignored */
    if (!(b = lf_blob_find(c, list, fn, *state))) return LF_ERROR;
    lf_blob_free(c, b);
    *state = NULL;
    return LF_OK;
}

LfStatus lf_fmustate_size(LfInstance *c, LfBlob **list, const char *fn, void *state,
                          size_t *size) {
    LfBlob **b;
    if (!size) return null_arg(c, fn, "size");
    if (!(b = lf_blob_find(c, list, fn, state))) return LF_ERROR;
    *size = (*b)->n;
    return LF_OK;
}

LfStatus lf_fmustate_serialize(LfInstance *c, LfBlob **list, const char *fn, void *state,
                               unsigned char *bytes, size_t size) {
    LfBlob **b;
    if (!bytes) return null_arg(c, fn, "serializedState");
    if (!(b = lf_blob_find(c, list, fn, state))) return LF_ERROR;
    if (size < (*b)->n) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: expected a buffer of %lu bytes but "
               "was %lu", c->run.t, fn, (unsigned long)(*b)->n, (unsigned long)size);
        return LF_ERROR;
    }
    memcpy(bytes, (*b)->data, (*b)->n);
    return LF_OK;
}

/* A size larger than any state of this FMU is refused here, before anything
 * is allocated or read (near SIZE_MAX the blob's size would wrap); then the
 * bytes' integrity (size, checksum, format, this FMU and FMI version) and
 * every field's value (lf_state_check_bytes: the checks of lf_state_read),
 * so that truncated, corrupted or crafted bytes are an Error of this call,
 * not of the fmi*SetFMUState after it.  Setting the state checks again. */
LfStatus lf_fmustate_deserialize(LfInstance *c, LfBlob **list, const char *fn,
                                 const unsigned char *bytes, size_t size, void **state) {
    LfBlob *b;
    if (!bytes) return null_arg(c, fn, "serializedState");
    if (!state) return null_arg(c, fn, "FMUstate");
    if (size > lf_state_max_size()) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: size = %lu bytes, expected %lu ... "
               "%lu (the sizes of this FMU's states; the serialized size function gives a "
               "state's size); nothing done", c->run.t, fn, (unsigned long)size,
               (unsigned long)lf_state_min_size(), (unsigned long)lf_state_max_size());
        return LF_ERROR;
    }
    if (*state && !lf_blob_find(c, list, fn, *state)) return LF_ERROR;
    if (lf_state_check_bytes(c, bytes, size) != LF_OK) {
        lf_log(c, LF_ERROR, LF_LOG_ERROR, "t = %.17g: %s: the %lu bytes are not a state this "
               "FMU can take (the line before says why); no FMU state made, nothing done", c->run.t,
               fn, (unsigned long)size);
        return LF_ERROR;
    }
    if (!(b = lf_blob_alloc(c, list, size))) return LF_ERROR;
    memcpy(b->data, bytes, size);
    if (*state) lf_blob_free(c, lf_blob_find(c, list, fn, *state));
    *state = b;
    return LF_OK;
}
