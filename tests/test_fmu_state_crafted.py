"""Crafted FMU states: a real state serialized, one value changed, the
checksum sealed again.  The checksum then vouches for the bytes, so only
the runtime's checks of the values stand between them and the instance:
a non-finite output the state calls valid, a delay that disagrees with the
parameters the state carries, a count past its capacity, a mode value the
model does not have.  Each is refused with Error by the deserialize call
itself (and by the set call), with a log line naming the value, and the
instance goes on from where it was, as if nothing had been tried.  The
untouched state, sealed by the same helper, is accepted.

The layout mirrors lf_state.h (LfStateHeader, LfStateValues); the helper
checks the mirror against the blob's own size and values before it
changes anything, so that a layout change fails here instead of
corrupting the wrong bytes.
"""
from __future__ import annotations

import ctypes
import struct

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave

from loomfmu import build_fmu, load_model

pytestmark = pytest.mark.slow  # builds FMUs

COMM = {"two_mass_force": 0.01, "drive": 0.05, "backrest": 0.01}

# ---- the state's layout (lf_state.h) and its checksum ----------------------

STATE_MAGIC = 0x4C465336
HIST_CAP = 65536  # LF_HIST_CAP, lf_instance.h
FNV_OFFSET, FNV_PRIME = 0xCBF29CE484222325, 0x100000001B3


class Header(ctypes.Structure):
    _fields_ = [("magic", ctypes.c_uint), ("fmi_version", ctypes.c_uint),
                ("n_real", ctypes.c_uint), ("nx", ctypes.c_uint), ("nq", ctypes.c_uint),
                ("nd", ctypes.c_uint), ("ne", ctypes.c_uint), ("nw", ctypes.c_uint),
                ("method", ctypes.c_int), ("size", ctypes.c_ulonglong),
                ("work_len", ctypes.c_ulonglong), ("guid", ctypes.c_char * 64)]


class SolverOptions(ctypes.Structure):
    _fields_ = [("rtol", ctypes.c_double), ("atol", ctypes.c_double),
                ("h_max", ctypes.c_double), ("h_fixed", ctypes.c_double),
                ("max_steps", ctypes.c_long)]


def values_type(h: Header, nu: int) -> type[ctypes.Structure]:
    """LfStateValues for the sizes of header ``h`` and ``nu`` inputs."""
    def d(n):  # LF_DIM
        return max(n, 1)

    D, L, I = ctypes.c_double, ctypes.c_long, ctypes.c_int  # noqa: E741 (C's names)
    fields = [("r", D * h.n_real), ("q", D * d(h.nq)), ("w_cur", D * d(h.nw)),
              ("e_old", D * d(h.ne)), ("dval", D * d(h.nd)), ("tau", D * d(h.nd)),
              ("hist_count", L * d(h.nd)), ("x_set", I * d(h.nx))]
    fields += [(n, D * d(nu)) for n in ("u_d1", "u_d2", "u_t0", "seen_u", "seen_d1", "seen_d2")]
    fields += [(n, D) for n in ("seen_t", "t", "t_start", "t_stop", "rtol_importer",
                                "last_successful_time")]
    fields += [(n, L) for n in ("max_steps", "n_events", "n_newton_fail")]
    fields += [(n, I) for n in ("solver_id", "outputs_valid", "inputs_changed", "delay_interp",
                                "n_bp", "solver_ready", "state", "wants_terminate",
                                "solver_index", "event_pending", "event_index")]
    fields += [("t_event", D), ("ev_t_ok", D), ("ev_x_ok", D * d(h.nx)), ("ev_q_ok", D * d(h.nq)),
               ("kb_ready", I), ("kb_index", I)]
    fields += [(n, D) for n in ("kb_t_land", "kb_t_right", "kb_clear", "kb_dt")]
    fields += [("kb_xdot", D * d(h.nx)), ("kb_e", D * d(h.ne)), ("s_t", D), ("s_t_old", D),
               ("s_h", D), ("s_opt", SolverOptions), ("s_fsal_valid", I)]
    fields += [(n, L) for n in ("s_steps", "s_rejected", "s_rhs", "s_jac", "s_lu")]
    return type("Values", (ctypes.Structure,), {"_fields_": fields})


def fnv1a(data: bytes) -> int:
    h = FNV_OFFSET
    for b in data:
        h = ((h ^ b) * FNV_PRIME) & 0xFFFFFFFFFFFFFFFF
    return h


def seal(blob: bytearray) -> bytes:
    """The checksum recomputed as lf_state_write does: 64-bit FNV-1a of every
    byte before it, stored in the machine's byte order."""
    blob[-8:] = struct.pack("=Q", fnv1a(bytes(blob[:-8])))
    return bytes(blob)


class State:
    """A serialized state's header and values, to change and seal again."""

    def __init__(self, blob: bytes, nu: int):
        self.blob = bytes(blob)
        self.h = Header.from_buffer_copy(self.blob)
        self.V = values_type(self.h, nu)
        self.v = self.V.from_buffer_copy(self.blob, ctypes.sizeof(Header))
        # the mirror matches the bytes: format, sealed as written, every part's size
        assert self.h.magic == STATE_MAGIC and self.h.size == len(self.blob)
        assert seal(bytearray(self.blob)) == self.blob
        hist = 3 * sum(self.v.hist_count[k] for k in range(self.h.nd))
        assert len(self.blob) == (ctypes.sizeof(Header) + ctypes.sizeof(self.V) + 8 * (
            self.h.work_len + hist + self.v.n_bp) + 8)

    def sealed(self, **changes) -> bytes:
        """The state with ``changes`` (field -> {index: value} or value)
        applied, checksum sealed again."""
        v = self.V.from_buffer_copy(self.blob, ctypes.sizeof(Header))
        for name, value in changes.items():
            if isinstance(value, dict):
                target = getattr(v, name)
                for i, x in value.items():
                    target[i] = x
            elif name.startswith("s_opt."):
                setattr(v.s_opt, name[6:], value)
            else:
                setattr(v, name, value)
        out = bytearray(self.blob)
        start = ctypes.sizeof(Header)
        out[start:start + ctypes.sizeof(self.V)] = bytes(v)
        return seal(out)


# ---- the FMUs and instances -------------------------------------------------

_BUILT: dict = {}


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    def get(name, fmi_version=2):
        key = (name, fmi_version)
        if key not in _BUILT:
            _BUILT[key] = build_fmu(load_model(name), out_dir=tmp_path_factory.mktemp("crafted"),
                                    fmi_version=fmi_version, validate=False).path
        return _BUILT[key]
    return get


def _n_inputs(md) -> int:
    return sum(v.causality == "input" for v in md.modelVariables)


def _start(s, comm, n=6):
    """Initialize and take n steps; the outputs read (outputs_valid = 1)."""
    s.start()
    for k in range(n):
        s.fmu.doStep(k * comm, comm)
    return n * comm


def _refused(s, blob, *expected):
    """``blob`` is refused by fmi2DeSerializeFMUstate with the lines
    ``expected`` logged (an Error, no state made)."""
    n_log = len(s.log)
    with pytest.raises(FMICallException):
        s.fmu.deSerializeFMUstate(blob)
    said = [m for status, _, m in s.log[n_log:] if status == 3]
    for line in expected:
        assert any(line in m for m in said), (line, said)
    assert any("fmi2DeSerializeFMUstate" in m and "nothing done" in m for m in said), said
    return said


def _keeps_going(s, t, comm, outputs):
    """The instance is where it was before the refusals: its outputs as
    they were, and the step after them the step from the state saved
    before (bit for bit)."""
    state = s.fmu.getFMUstate()
    y0 = s.get(*outputs)
    s.fmu.doStep(t, comm)
    after = s.get(*outputs)
    s.fmu.setFMUstate(state)
    assert s.get(*outputs) == y0
    s.fmu.doStep(t, comm)
    assert s.get(*outputs) == after
    s.fmu.freeFMUstate(state)


def _crafted_and_refused(s, t, comm, outputs, good, *cases):
    """Each (blob, expected lines) is refused; the instance keeps its state;
    the untouched state, sealed again, is still accepted."""
    y = s.get(*outputs)
    for blob, expected in cases:
        _refused(s, blob, *expected)
        assert s.get(*outputs) == y  # nothing of the instance changed
    _keeps_going(s, t, comm, outputs)
    state = s.fmu.deSerializeFMUstate(good.sealed())
    s.fmu.setFMUstate(state)
    s.fmu.freeFMUstate(state)


# ---- the cases ---------------------------------------------------------------


def test_nan_output_in_a_state_with_valid_outputs_is_refused(fmu, slave_factory):
    """outputs_valid = 1 and a NaN output: fmi2GetReal would return the NaN
    with OK right after the restore (the saved outputs are returned as
    they are).  Refused; the same NaN with outputs_valid = 0 (outputs not
    yet computed) is a state, accepted, its output computed again."""
    name, comm = "two_mass_force", COMM["two_mass_force"]
    s = slave_factory(fmu(name))
    outputs = ["F_c", "x1_out", "v1_out"]
    t = _start(s, comm)
    y = s.get(*outputs)
    good = State(s.fmu.serializeFMUstate(s.fmu.getFMUstate()), _n_inputs(s.md))
    vr = s.vr["x1_out"]
    assert good.v.outputs_valid == 1 and good.v.r[vr] == y[1]
    cases = [(good.sealed(r={vr: float("nan")}),
              ["FMU state refused: output x1_out is NaN", "outputs_valid = 1"]),
             (good.sealed(r={s.vr["F_c"]: float("inf")}),
              ["FMU state refused: output F_c is +inf"])]
    for _ in range(3):
        s.fmu.doStep(t, comm)
        t += comm
    _crafted_and_refused(s, t, comm, outputs, good, *cases)
    # not marked valid: recomputed when read
    state = s.fmu.deSerializeFMUstate(good.sealed(r={vr: float("nan")}, outputs_valid=0))
    s.fmu.setFMUstate(state)
    assert s.get(*outputs) == y


def test_drive_state_with_a_delay_other_than_its_parameters_give_is_refused(fmu,
                                                                             slave_factory):
    """The drive's delay u is tau = 0.5 s (its parameter tau).  A state with
    tau[0] = 0 (within the range the FMU allows, but not what its
    parameters give) would read the delayed input now instead of 0.5 s
    ago; refused, as is 0.25 s.  So is a solver step limit longer than the
    delay (the steps would need history not yet computed)."""
    name, comm = "drive", COMM["drive"]
    s = slave_factory(fmu(name))
    outputs = ["n_out", "u_delayed", "phi_out"]
    t = _start(s, comm)
    good = State(s.fmu.serializeFMUstate(s.fmu.getFMUstate()), _n_inputs(s.md))
    assert good.v.tau[0] == 0.5 and good.v.r[s.vr["tau"]] == 0.5
    assert good.v.s_opt.h_max <= 0.5
    for _ in range(3):
        s.fmu.doStep(t, comm)
        t += comm
    _crafted_and_refused(
        s, t, comm, outputs, good,
        (good.sealed(tau={0: 0.0}),
         ["FMU state refused: delay u has tau = 0 s, its parameters give 0.5 s"]),
        (good.sealed(tau={0: 0.25}),
         ["FMU state refused: delay u has tau = 0.25 s, its parameters give 0.5 s"]),
        (good.sealed(**{"s_opt.h_max": 1.0}),
         ["FMU state refused: solver step limit h_max = 1 s is longer than delay u"]))


def test_drive_state_with_more_history_than_its_capacity_is_refused(fmu, slave_factory):
    """hist_count past the history's capacity: refused by the deserialize
    call, naming the delay."""
    name, comm = "drive", COMM["drive"]
    s = slave_factory(fmu(name))
    outputs = ["n_out", "u_delayed", "phi_out"]
    t = _start(s, comm)
    good = State(s.fmu.serializeFMUstate(s.fmu.getFMUstate()), _n_inputs(s.md))
    assert 0 < good.v.hist_count[0] < HIST_CAP
    _crafted_and_refused(
        s, t, comm, outputs, good,
        (good.sealed(hist_count={0: HIST_CAP + 1}),
         ["FMU state refused: history samples of delay u = 65537"]))


def test_state_with_a_mode_value_the_model_does_not_have_is_refused(fmu, slave_factory):
    """The backrest's friction modes take the values of their declaration
    only: 99 is refused by the deserialize call, naming the mode."""
    name, comm = "backrest", COMM["backrest"]
    s = slave_factory(fmu(name))
    outputs = ["phi1_out", "omega2_out"]
    t = _start(s, comm)
    good = State(s.fmu.serializeFMUstate(s.fmu.getFMUstate()), _n_inputs(s.md))
    _crafted_and_refused(
        s, t, comm, outputs, good,
        (good.sealed(q={0: 99.0}), ["FMU state refused: mode_O1 = 99"]))


def test_fmi3_drive_state_with_tau_0_is_refused(fmu):
    """FMI 3.0: fmi3DeserializeFMUState refuses the drive's state with
    tau[0] = 0 with the same line; the instance steps on."""
    path = fmu("drive", 3)
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    log = []

    def logger(env, status, category, message):
        log.append((status, message.decode()))

    f = FMU3Slave(guid=md.instantiationToken, unzipDirectory=extract(str(path)),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="crafted")
    f.instantiate(logMessage=logger, loggingOn=True)
    try:
        f.enterInitializationMode(startTime=0.0)
        f.exitInitializationMode()
        comm = COMM["drive"]
        for k in range(6):
            f.doStep(k * comm, comm)
        good = State(f.serializeFMUState(f.getFMUState()), _n_inputs(md))
        assert good.h.fmi_version == 3 and good.v.tau[0] == 0.5
        n_log = len(log)
        with pytest.raises(FMICallException):
            f.deserializeFMUState(good.sealed(tau={0: 0.0}))
        said = [m for status, m in log[n_log:] if status == 3]
        assert any("FMU state refused: delay u has tau = 0 s, its parameters give 0.5 s" in m
                   for m in said), said
        f.doStep(6 * comm, comm)  # steps on from where it was
        f.setFMUState(f.deserializeFMUState(good.sealed()))  # the untouched one is a state
        f.doStep(6 * comm, comm)
        assert f.getFloat64([vr["n_out"]])[0] > 0
    finally:
        f.terminate()
        f.freeInstance()
