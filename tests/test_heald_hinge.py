"""Hinge loads of seed 002: the seed's phase formulas, the continuous
kinetostatic load, and the dynamic FMUs' N_rem in the rigid limit."""
from __future__ import annotations

import math

import numpy as np
import pytest

from loomfmu.heald import PHASES, hinge_load_kinetostatic, hinge_load_phases
from loomfmu.heald.claims import start_values
from loomfmu.heald.hinge import max_phases, motion, phase_of
from loomfmu.verification.verify import simulate

G = 9.80665


def test_phase_formulas_reproduce_the_seed_by_hand():
    # STB-180 Elitex: m_RR 5.2 kg, healds 9.0 N; a = 4.8 g (table 3); two hinges
    mh = 9.0 / G
    N = hinge_load_phases(m_RR=5.2, m_heald=mh, a_max=4.8 * G, n_hinge=2)
    F_in = (5.2 + mh) * 4.8 * G
    assert N["bottom dwell"] == pytest.approx(-5.2 * G / 2)                     # (7)
    assert N["rise to crossing"] == pytest.approx(-(5.2 * G + F_in) / 2)        # (10)
    assert N["crossing"] == pytest.approx(-(5.2 * G + 9.0) / 2)                 # (11)
    assert N["top dwell"] == pytest.approx(-(5.2 * G + 18.0) / 2)               # (15)
    assert N["fall to crossing"] == pytest.approx((5.2 * (4.8 * G - G) - 18.0) / 2)  # (17)
    assert N["fall to bottom dwell"] == N["rise to crossing"]                   # (19)
    assert set(max_phases(N)) == {"rise to crossing", "fall to bottom dwell"}
    assert list(N) == list(PHASES)


def test_margins_are_explicit_options_within_the_seeds_bands():
    base = hinge_load_phases(m_RR=5.2, m_heald=0.9, a_max=40.0)
    both = hinge_load_phases(m_RR=5.2, m_heald=0.9, a_max=40.0, margin=0.12, friction=0.15)
    for p in PHASES:
        assert both[p] == pytest.approx(base[p] * 1.12 * 1.15)
    for kw in ({"margin": 0.05}, {"margin": 0.2}, {"friction": 0.09}, {"friction": 0.16}):
        with pytest.raises(ValueError, match=next(iter(kw))):
            hinge_load_phases(m_RR=5.2, m_heald=0.9, a_max=40.0, **kw)
    with pytest.raises(ValueError, match="n_hinge"):
        hinge_load_phases(m_RR=5.2, m_heald=0.9, a_max=40.0, n_hinge=0)
    with pytest.raises(ValueError, match="form"):
        hinge_load_phases(m_RR=5.2, m_heald=0.9, a_max=40.0, form="other")


def test_general_form_with_large_warp_moves_the_maximum_to_the_top_dwell():
    N = hinge_load_phases(m_RR=11.9, m_heald=2.46, a_max=2 * G, form="general", N_warp=515.0)
    assert max_phases(N) == ["top dwell"]
    assert N["top dwell"] == pytest.approx(-((11.9 + 2.46) * G + 515.0) / 2)


@pytest.mark.slow
def test_rigid_fmu_hinge_load_is_the_kinetostatic_one(heald_frame_rigid_fmu):
    run = simulate(heald_frame_rigid_fmu.path, rtol=1e-8, output=["N_rem", "h_ddot", "h"])
    phi = 60.0 * run.t
    N = hinge_load_kinetostatic(phi)
    assert np.max(np.abs(run.y["N_rem"] - N)) < 1e-6 * np.ptp(N)
    # and the rigid load peaks (in magnitude, inertia + weight) where the seed says
    H, v, a = motion(phi)
    assert np.max(np.abs(a)) == pytest.approx(0.029 * (9 / 7) ** 2 * 3600 / math.pi, rel=1e-3)


@pytest.mark.slow
def test_dynamic_hinge_load_tends_to_the_kinetostatic_one_as_the_frame_stiffens(
        heald_frame_fmu):
    """N_rem of the spatial FMU minus the rigid kinetostatic load is the
    elastic part sum M_y y''; it must shrink as E grows (rigid limit)."""
    devs = []
    for E in (0.7e11, 5e11):
        vals = start_values("heald_frame", {"E": E, "mu": 300.0})
        run = simulate(heald_frame_fmu.path, rtol=1e-9, atol=1e-13, values=vals,
                       output=["N_rem"])
        N = hinge_load_kinetostatic(60.0 * run.t)
        devs.append(np.max(np.abs(run.y["N_rem"] - N)) / np.ptp(N))
    assert devs[1] < devs[0] / 2, devs
    assert devs[1] < 0.05, devs


def test_phase_classification_covers_the_eight_phases():
    phi = np.linspace(0, 4 * math.pi, 8001)[:-1]
    H, v, _ = motion(phi)
    ph = phase_of(H, v, 0.029)
    assert set(ph) == set(range(8))
    # order over one frame cycle: 1 2 3 4 5 6 7 8 1
    seq = [int(ph[0])] + [int(b) for a, b in zip(ph[:-1], ph[1:]) if a != b]
    assert seq == [0, 1, 2, 3, 4, 5, 6, 7, 0]
