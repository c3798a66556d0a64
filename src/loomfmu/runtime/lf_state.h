/* loomfmu shared runtime: the FMU state as a flat byte string (lf_state.c).
 *
 * Layout: LfStateHeader | LfStateValues | solver work (work_len doubles) |
 * history samples (3 doubles each, delay by delay) | pending delay
 * breakpoints (n_bp doubles) | checksum.  The checksum
 * is the 64-bit FNV-1a hash of every byte before it (padding included: the
 * writer zeroes the structs first), stored as an unsigned long long in the
 * machine's byte order.  The layout is declared here so that tests can
 * corrupt single fields and seal the blob again. */
#ifndef LF_STATE_H
#define LF_STATE_H

#include <stddef.h>
#include "lf_instance.h"

#define LF_STATE_MAGIC 0x4C465336u /* "LFS6": the FMI version in the header */
#define LF_STATE_GUID_LEN 64
#define LF_FNV_OFFSET 0xcbf29ce484222325ULL
#define LF_FNV_PRIME 0x100000001b3ULL

typedef struct {
    unsigned magic;
    unsigned fmi_version;      /* LF_FMI_VERSION: the FMI 2.0 and 3.0 builds of one
                                * model share GUID and sizes, not their states */
    unsigned n_real, nx, nq, nd, ne, nw;
    int method;                /* index into lf_methods[], -1: no solver */
    unsigned long long size;   /* bytes of the whole state, checksum included */
    unsigned long long work_len;
    char guid[LF_STATE_GUID_LEN];
} LfStateHeader;

/* The instance's plain-value fields, in one struct for one memcpy each way. */
typedef struct {
    double r[LF_NREAL];
    double q[LF_DIM(LF_NQ)];
    double w_cur[LF_DIM(LF_NW)];
    double e_old[LF_DIM(LF_NE)];
    double dval[LF_DIM(LF_ND)];
    double tau[LF_DIM(LF_ND)];
    long hist_count[LF_DIM(LF_ND)];
    int x_set[LF_DIM(LF_NX)];
    double u_d1[LF_DIM(LF_NU)], u_d2[LF_DIM(LF_NU)], u_t0[LF_DIM(LF_NU)];
    double seen_u[LF_DIM(LF_NU)], seen_d1[LF_DIM(LF_NU)], seen_d2[LF_DIM(LF_NU)], seen_t;
    double t, t_start, t_stop, rtol_importer, last_successful_time;
    long max_steps, n_events, n_newton_fail;
    int solver_id, outputs_valid, inputs_changed, delay_interp, n_bp, solver_ready, state;
    int wants_terminate, solver_index;
    /* an early return's pending event (lf_step.h) and the last point before it */
    int event_pending, event_index;
    double t_event, ev_t_ok;
    double ev_x_ok[LF_DIM(LF_NX)], ev_q_ok[LF_DIM(LF_NQ)];
    /* known breaks (lf_breaks.c): the prediction in use, so that a restored
     * state lands its steps where the original run does */
    int kb_ready, kb_index;
    double kb_t_land, kb_t_right, kb_clear, kb_dt;
    double kb_xdot[LF_DIM(LF_NX)], kb_e[LF_DIM(LF_NE)];
    /* solver fields (the work buffer follows separately) */
    double s_t, s_t_old, s_h;
    LfSolverOptions s_opt;
    int s_fsal_valid;
    long s_steps, s_rejected, s_rhs, s_jac, s_lu;
} LfStateValues;

/* Bytes needed for the instance's current state. */
size_t lf_state_size(const LfInstance *c);
/* Fewest and most bytes any state of this FMU can have (the fixed part;
 * every capacity full and the largest solver workspace): a size outside is
 * not one of its states.  (Inline: no global symbol to prefix.) */
#define LF_STATE_FIXED_BYTES \
    (sizeof(LfStateHeader) + sizeof(LfStateValues) + sizeof(unsigned long long))

static inline size_t lf_state_min_size(void) { return LF_STATE_FIXED_BYTES; }

static inline size_t lf_state_max_size(void) {
    size_t k, work = 0;
    for (k = 0; k < lf_n_methods; k++) {
        size_t w = 2 * (size_t)LF_NX + lf_methods[k]->work_size(LF_NX);
        if (w > work) work = w;
    }
    return LF_STATE_FIXED_BYTES +
           sizeof(double) * (work + 3 * (size_t)LF_ND * LF_HIST_CAP + (size_t)LF_BP_CAP);
}
/* Write the state into buf (lf_state_size bytes), checksum included. */
void lf_state_write(const LfInstance *c, unsigned char *buf);
/* Restore buf (n bytes) if it is an intact state of this FMU: checksum,
 * GUID, sizes, every field in its range, every count within its capacity,
 * the values consistent with the model and the state's own parameters
 * (lf_state_check.h).  A state that fails any check is refused with
 * LF_ERROR and a log line naming the value, and the instance keeps its
 * state (checked before anything is changed). */
LfStatus lf_state_read(LfInstance *c, const unsigned char *buf, size_t n);
/* Every check of lf_state_read (none of them needs the instance's state):
 * LF_ERROR with the reason logged where the bytes are not a state this FMU
 * can take.  Changes nothing (the deserialize functions, before a blob is
 * made). */
LfStatus lf_state_check_bytes(LfInstance *c, const unsigned char *buf, size_t n);

#endif
