/* loomfmu runtime: the step of dopri5 (lf_dopri5.c), included there four times:
 * DP_STEP_FN names the function (scalar builds for 1, 2 and n states and,
 * with GCC, a vectorized one).  Needs the tableau's DP_* names of lf_dopri5.c
 * and DP_N: the number of states (a constant in the builds for one and two
 * states, s->ode.n otherwise).  Each stage's argument is checked for
 * finiteness where the loop forms it (nan_bits, lf_solver_impl.h);
 * DP_BAD(nan_bits) reads the check and clears it for the next stage. */
static LfStatus DP_STEP_FN(LfSolver *s, double t_bound) {
    const size_t n = DP_N;
    double *w = LF_PRIV(s);
    double *k1 = w + DP_K1 * n, *k2 = w + DP_K2 * n, *k3 = w + DP_K3 * n, *k4 = w + DP_K4 * n;
    double *k5 = w + DP_K5 * n, *k6 = w + DP_K6 * n, *k7 = w + DP_K7 * n;
    double *y = w + DP_Y * n, *ynew = w + DP_YNEW * n;
    double *x = s->x, *lerr_old = w + DP_NVEC * n + DP_S_LERR;
    const double t = s->t, hmax = s->opt.h_max, atol = s->opt.atol, rtol = s->opt.rtol;
    double h;
    int rejected = 0, cause = CAUSE_NONE, attempts = 0, stiff, land, keep, grow;
    uint64_t nan_bits = 0; /* the stage argument's finiteness check */
    size_t i;
    LfStatus st;

    if (!(t_bound > t)) return lf_sv_bad_bound(s, t_bound);
    if (!s->fsal_valid) {
        st = lf_sv_eval_rhs(s, t, x, k1);
        if (st != LF_OK) return lf_sv_start_failure(s, st);
        s->fsal_valid = 1;
        *lerr_old = DP_LERR_OLD0; /* a fresh start: no previous step to remember */
    }
    h = s->h;
    if (!(h > 0.0)) h = lf_sv_initial_step(s, k1, k2, k3, 5.0, fmin(hmax, t_bound - t));
    if (h > hmax) h = hmax;

    for (;;) {
        double h_prop = h, t_new, hmin, err, fac, lerr;
        int last;
        if (++attempts > LF_MAX_ATTEMPTS) return lf_sv_give_up(s, h, 0.0, cause, 1);
        if (lf_sv_plan_step(s, t_bound, &h, &t_new, &last, &hmin)) return lf_sv_give_up(s, h, hmin, cause, 0);

        DP_IVDEP
        for (i = 0; i < n; i++) {
            y[i] = x[i] + h * DP_A21 * k1[i];
            nan_bits |= lf_sv_nan_bits(y[i]);
        }
        st = lf_sv_eval_rhs_checked(s, t + DP_C2 * h, y, k2, DP_BAD(nan_bits));
        if (st != LF_OK) goto failed;
        DP_IVDEP
        for (i = 0; i < n; i++) {
            y[i] = x[i] + h * (DP_A31 * k1[i] + DP_A32 * k2[i]);
            nan_bits |= lf_sv_nan_bits(y[i]);
        }
        st = lf_sv_eval_rhs_checked(s, t + DP_C3 * h, y, k3, DP_BAD(nan_bits));
        if (st != LF_OK) goto failed;
        DP_IVDEP
        for (i = 0; i < n; i++) {
            y[i] = x[i] + h * (DP_A41 * k1[i] + DP_A42 * k2[i] + DP_A43 * k3[i]);
            nan_bits |= lf_sv_nan_bits(y[i]);
        }
        st = lf_sv_eval_rhs_checked(s, t + DP_C4 * h, y, k4, DP_BAD(nan_bits));
        if (st != LF_OK) goto failed;
        DP_IVDEP
        for (i = 0; i < n; i++) {
            y[i] = x[i] + h * (DP_A51 * k1[i] + DP_A52 * k2[i] + DP_A53 * k3[i] + DP_A54 * k4[i]);
            nan_bits |= lf_sv_nan_bits(y[i]);
        }
        st = lf_sv_eval_rhs_checked(s, t + DP_C5 * h, y, k5, DP_BAD(nan_bits));
        if (st != LF_OK) goto failed;
        DP_IVDEP
        for (i = 0; i < n; i++) {
            y[i] = x[i] + h * (DP_A61 * k1[i] + DP_A62 * k2[i] + DP_A63 * k3[i] +
                               DP_A64 * k4[i] + DP_A65 * k5[i]);
            nan_bits |= lf_sv_nan_bits(y[i]);
        }
        st = lf_sv_eval_rhs_checked(s, t_new, y, k6, DP_BAD(nan_bits));
        if (st != LF_OK) goto failed;
        DP_IVDEP
        for (i = 0; i < n; i++) {
            ynew[i] = x[i] + h * (DP_A71 * k1[i] + DP_A73 * k3[i] + DP_A74 * k4[i] +
                                  DP_A75 * k5[i] + DP_A76 * k6[i]);
            nan_bits |= lf_sv_nan_bits(ynew[i]);
        }
        st = lf_sv_eval_rhs_checked(s, t_new, ynew, k7, DP_BAD(nan_bits));
        if (st != LF_OK) goto failed;

        /* the error estimate over its scale (lf_sv_err_norm's arithmetic, in
         * a loop of independent elements; ynew is finite, checked above, so
         * the scale is max(|x|, |ynew|) without lf_sv_err_norm's NaN case),
         * then the sum in order.  Into k2, which neither the error nor the
         * dense output reads: y keeps the sixth stage's argument for the
         * stiffness estimate below, and this loop comes first, where the
         * vectorizer takes it (after the estimate's branches it did not) */
        DP_IVDEP
        for (i = 0; i < n; i++) {
            double a0 = fabs(x[i]), a1 = fabs(ynew[i]);
            double sk = atol + rtol * (a0 > a1 ? a0 : a1);
            k2[i] = h * (DP_E1 * k1[i] + DP_E3 * k3[i] + DP_E4 * k4[i] + DP_E5 * k5[i] +
                         DP_E6 * k6[i] + DP_E7 * k7[i]) / sk;
        }
        for (i = 0, err = 0.0; i < n; i++) err += k2[i] * k2[i];
        err = n > 0 ? sqrt(err / (double)n) : 0.0;
        if (!isfinite(err)) {
            st = LF_DISCARD;
            goto failed;
        }
        /* Hairer's DOPRI5 controller with Lund stabilization (Hairer, Norsett,
         * Wanner I, IV.2, and his code): 1/fac = err^(1/5 - 3/4 beta)
         * err_old^-beta / 0.9, h_new = h fac within [h/5, 10 h]; the last
         * accepted step's error damps the step size's oscillation where
         * stability, not accuracy, limits the step (beta = 0: the classical
         * 0.9 err^-1/5), beta = 0.08 where the stiffness estimate says so
         * (stiff, below; lf_dopri5.c).  In logarithms: one log and one exp a
         * step, the slot keeps log(max(err_old, 1e-4)); none below
         * DP_ERR_TINY, where 1/fac is 10 (its cap) whatever err_old
         * (lf_dopri5.c), and none where a step shortened to land on t_bound
         * keeps the proposal h_prop for the next one (dp_land_keeps); such
         * a step does not update the slot. */
        land = err <= 1.0 && last && !rejected && h < h_prop;
        keep = land && dp_land_keeps(err, h, h_prop);
        grow = LF_DP_LAND_GROW && keep && dp_land_may_grow(err, h, h_prop);
        /* the stronger gains where stability bounds the step (lf_dopri5.c),
         * from Hairer's estimate at t + h: y still holds the sixth stage's
         * argument.  Only where the step size depends on it */
        stiff = 0;
        if (LF_DP_SWITCH && (!keep || grow) && err <= 1.0 &&
            (land && !grow ? 1 : err >= DP_ERR_TINY_S)) {
            double sn = 0.0, sd = 0.0;
            DP_IVDEP
            for (i = 0; i < n; i++) {
                double a = k7[i] - k6[i], b = ynew[i] - y[i];
                sn += a * a;
                sd += b * b;
            }
            stiff = sd > 0.0 && h * h * sn > DP_STIFF_HL * DP_STIFF_HL * sd;
        }
        if (keep && !grow) { /* the next step takes h_prop (lf_dopri5.c) */
            lerr = DP_LERR_OLD0; /* (not read) */
            fac = 0.0;
        } else if ((!land || grow) && err < (stiff ? DP_ERR_TINY_S : DP_ERR_TINY)) {
            lerr = DP_LERR_OLD0; /* what the slot would keep: err < 1e-4 */
            fac = 0.1;
        } else {
            lerr = lf_ln(err);
            if (err > 1.0) /* a rejected step: the error's own power */
                fac = lf_exp(DP_EXPO1 * lerr) / 0.9;
            else if (stiff)
                fac = lf_exp(DP_EXPO1_S * lerr - DP_BETA_S * *lerr_old) / 0.9;
            else
                fac = lf_exp(DP_EXPO1 * lerr - DP_BETA * *lerr_old) / 0.9;
        }
        if (err <= 1.0) {
            double hnew, *k1old = w + DP_K1OLD * n;
            if (fac > 5.0) fac = 5.0;
            if (keep) { /* shortened to land on t_bound (lf_dopri5.c) */
                if (grow && fac < 0.1) fac = 0.1;
                hnew = grow && fac * h_prop < h ? h / fac : h_prop;
            } else if (land) { /* ... and this error predicts h_prop fails */
                hnew = fac * h_prop <= h ? h_prop : h / fac;
            } else {
                if (fac < 0.1) fac = 0.1;
                if (rejected && fac < 1.0) fac = 1.0;
                hnew = h / fac;
            }
            /* a step shortened to land on t_bound has an error that says
             * nothing of the step size's trend: the full step's is kept */
            if (!(last && h < h_prop)) *lerr_old = lerr > DP_LERR_OLD0 ? lerr : DP_LERR_OLD0;
            /* the dense output's coefficients from the stages when it is
             * read (dp_dense): k3..k7 stay until the next step, k1 is kept */
            if (!s->dense_unused) {
                w[DP_NVEC * n + DP_S_H] = h;
                for (i = 0; i < n; i++) k1old[i] = k1[i];
            }
            DP_IVDEP
            for (i = 0; i < n; i++) { /* (a loop: n is small, a memmove call is not) */
                s->x_old[i] = x[i];
                x[i] = ynew[i];
                k1[i] = k7[i]; /* FSAL */
            }
            s->t_old = t;
            s->t = t_new;
            s->h = fmin(hnew, hmax);
            s->n_steps++;
            return LF_OK;
        }
        if (fac > 5.0) fac = 5.0;
        h /= fac;
        rejected = 1;
        cause = CAUSE_ERRTEST;
        s->n_rejected++;
        continue;
    failed:
        if (st != LF_DISCARD) return lf_sv_callback_error(s, st, t + h);
        h *= 0.25;
        rejected = 1;
        cause = CAUSE_NONFINITE;
        s->n_rejected++;
    }
}
