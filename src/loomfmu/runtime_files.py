"""The shared C runtime's files and the facts Python needs about it."""
from __future__ import annotations

from pathlib import Path

RUNTIME_DIR = Path(__file__).parent / "runtime"

#: Sources of the shared runtime (compiled with -Wall -Wextra -Werror).
RUNTIME_SOURCES = ("lf_fmi2.c", "lf_fmi2_state.c", "lf_fmi2_deriv.c", "lf_runtime.c",
                   "lf_newton.c", "lf_delay.c", "lf_events.c", "lf_step.c", "lf_inputs.c",
                   "lf_validity.c", "lf_solvers.c", "lf_dopri5.c", "lf_rodas4.c", "lf_linalg.c",
                   "lf_state.c")
RUNTIME_HEADERS = ("lf_model.h", "lf_fmi2_internal.h", "lf_runtime.h", "lf_internal.h", "lf_solver.h",
                   "lf_solver_impl.h", "lf_linalg.h", "lf_state.h", "lf_prefix.h")

#: Global symbols of the runtime and the generated declaration; an FMU's
#: lf_prefix.h renames each to <modelIdentifier>_<symbol> (the builder checks
#: with nm that no other global symbol is left).
RUNTIME_SYMBOLS = (
    "lf_check_step", "lf_check_validity", "lf_consistent_modes", "lf_delayed_rates", "lf_delayed_values",
    "lf_do_step", "lf_dopri5", "lf_fmi2_allowed", "lf_fmi2_check_vrs", "lf_fmi2_free_states", "lf_fmi2_live",
    "lf_fmi2_null_arg", "lf_eval_events", "lf_eval_fn", "lf_first_nonfinite", "lf_free",
    "lf_get_integer", "lf_get_real", "lf_handle_events", "lf_hist_push", "lf_hist_step",
    "lf_init_delays", "lf_initial_modes", "lf_initial_states", "lf_initialize",
    "lf_input_derivative_check", "lf_input_derivative_set", "lf_input_now", "lf_input_set",
    "lf_inputs_at", "lf_inputs_moved", "lf_inputs_reset", "lf_inputs_seen",
    "lf_output_derivative", "lf_solve_dFdw", "lf_validity_at_start", "lf_validity_restart",
    "lf_near_zero_extremum",
    "lf_instantiate", "lf_log", "lf_log_category_names", "lf_lu_factor", "lf_lu_piv_doubles",
    "lf_lu_solve", "lf_methods", "lf_model", "lf_n_methods", "lf_next_breakpoint", "lf_ode_of",
    "lf_prepare_initial", "lf_reset_values", "lf_rhs", "lf_rk4", "lf_rodas4",
    "lf_rodas4_clear_history", "lf_set_integer", "lf_set_real", "lf_set_solver", "lf_solve_w",
    "lf_solver_free", "lf_solver_init", "lf_solver_reset", "lf_state_read", "lf_state_size",
    "lf_state_write", "lf_sv_all_finite", "lf_sv_bad_bound", "lf_sv_callback_error",
    "lf_sv_copy_vec", "lf_sv_err_norm", "lf_sv_eval_rhs", "lf_sv_give_up",
    "lf_sv_initial_step", "lf_sv_plan_step", "lf_sv_set_msg", "lf_sv_start_failure",
    "lf_update_outputs",
)

#: Log categories, in the order of LfLogCategory in lf_runtime.h; written into
#: the generated declaration (LF_LOG_CATEGORY_NAMES) and the model description.
LOG_CATEGORIES = (
    ("logEvents", "event located inside a step, solver restarted"),
    ("logStatusWarning", "warnings: values outside their range, adjusted settings "
     "(always logged)"),
    ("logStatusDiscard", "step not completed: solver failure or non-finite values "
     "(always logged)"),
    ("logStatusError", "invalid calls and values (always logged)"),
    ("logSolver", "solver statistics"),
)
