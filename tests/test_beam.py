"""The benchmark link (obsnl.studies.cantilever) against analytic beam theory and the facts of docs/observer_bank.md 2.1-2.3."""

from __future__ import annotations

import math

import numpy as np
import pytest

from obsnl.studies.cantilever import DEFAULT_LINK_FILE, BreathingCrack, build_cantilever, element_channels, read_link_spec
from obsnl.errors import DataError, ModelError

#: beta_n L of a clamped-free Euler-Bernoulli beam (roots of cos x cosh x = -1)
BETA_L = (1.8751, 4.6941, 7.8548, 10.9955)


@pytest.fixture(scope="module")
def beam():
    return build_cantilever()


def test_spec_numbers_are_those_of_the_notes(beam):
    s = beam.spec
    assert s.bending_stiffness == pytest.approx(700.0)  # EI = 700 N m^2
    assert s.mass_per_length == pytest.approx(3.14)  # rho A = 3.14 kg/m
    assert beam.n_dof == 12 and beam.system().n_states == 24
    assert "001_d0508a78c5399696.txt" in s.source


@pytest.mark.parametrize("mode", range(4))
def test_modal_frequencies_within_one_percent_of_the_analytic_cantilever(beam, mode):
    s = beam.spec
    f_exact = BETA_L[mode] ** 2 / (2 * math.pi * s.length**2) * math.sqrt(s.bending_stiffness / s.mass_per_length)
    assert beam.modal_frequencies()[mode] == pytest.approx(f_exact, rel=0.01)


def test_rayleigh_damping_gives_one_percent_at_modes_1_and_3(beam):
    lam = np.linalg.eigvals(beam.system().A)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))]
    zeta = -lam.real / np.abs(lam)
    assert zeta[0] == pytest.approx(0.01, rel=1e-9) and zeta[2] == pytest.approx(0.01, rel=1e-9)
    alpha, beta = beam.rayleigh
    assert alpha == pytest.approx(0.690, rel=0.01) and beta == pytest.approx(2.95e-5, rel=0.01)


def test_element_matrices_have_the_rigid_body_and_dipole_properties(beam):
    le, ei = beam.element_length, beam.spec.bending_stiffness
    for rigid in ([1.0, 0.0, 1.0, 0.0], [0.0, 1.0, le, 1.0]):  # translation, rotation about node 1
        assert np.allclose(beam.Ke @ rigid, 0.0, atol=1e-9 * np.abs(beam.Ke).max())
    one = np.array([1.0, 0.0, 1.0, 0.0])
    assert one @ beam.Me @ one == pytest.approx(beam.spec.mass_per_length * le)  # element mass
    h = element_channels(le)[:, 0]
    assert np.allclose(beam.Ke @ h, 2 * ei / le * h)  # K_e [0,-1,0,1] = (2 EI / L) [0,-1,0,1]
    hs = element_channels(le, ("shear",))[:, 0]
    k = beam.Ke @ [0.0, 1.0, 0.0, 1.0]
    assert abs(hs @ k) == pytest.approx(np.linalg.norm(k))  # shear pattern parallel to K_e [0, 1, 0, 1]


def test_conditioning_facts_of_the_notes(beam):
    assert np.linalg.cond(beam.M) == pytest.approx(2.0e4, rel=0.1)
    assert np.linalg.cond(beam.K) == pytest.approx(2.6e4, rel=0.1)
    assert np.abs(np.linalg.eigvals(beam.system().A)).max() == pytest.approx(2.2e4, rel=0.05)


def test_breathing_crack_opens_about_half_the_time_and_softens(beam):
    sim = beam.simulate(dt=5e-4, duration=4.0, crack=BreathingCrack(2, 0.3, onset=1.0))
    assert 0.45 <= sim.open_fraction <= 0.56  # docs/observer_bank.md 2.3: 0.50-0.52
    assert np.all(sim.n_true[sim.t < 1.0] == 0.0)
    healthy = beam.simulate(dt=5e-4, duration=4.0)
    assert np.allclose(sim.x[sim.t < 1.0], healthy.x[healthy.t < 1.0])
    # curvature of element 2 at the open steps is negative, and the dipole force then opposes it (positive)
    kappa = sim.x[:, beam.dof("theta2")] - sim.x[:, beam.dof("theta1")]
    opened = sim.n_true != 0
    assert opened.any() and np.all(kappa[opened] < 0) and np.all(sim.n_true[opened] > 0)


def test_sensor_sets_and_distributions(beam):
    C = beam.output_matrix("S2")
    assert C.shape == (4, 24) and C[0, beam.dof("theta2")] == 1.0 and C[3, beam.dof("w6")] == 1.0
    N = beam.crack_distribution(1, ("moment", "shear"))
    assert N.shape == (24, 2) and np.allclose(N[:12], 0.0)
    # the root element's clamped DOFs are dropped: its force acts on node 1 only
    F = beam.M @ N[12:]
    assert np.allclose(F[2:], 0.0)


def test_bad_names_are_refused(beam, tmp_path):
    with pytest.raises(ModelError, match="clamped"):
        beam.dof("w0")
    with pytest.raises(ModelError, match="bad DOF name"):
        beam.dof("phi3")
    with pytest.raises(ModelError, match="unknown sensor set"):
        beam.output_matrix("S9")
    with pytest.raises(ModelError, match="elements are 1..6"):
        beam.gather(7)
    with pytest.raises(ModelError, match="severity"):
        BreathingCrack(2, 1.5)
    with pytest.raises(ModelError, match="not found"):
        read_link_spec(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text(DEFAULT_LINK_FILE.read_text(encoding="utf-8").replace("[damping]", "[dampin]"))
    with pytest.raises(ModelError, match="damping"):
        read_link_spec(bad)
    with pytest.raises(DataError, match="dt"):
        beam.simulate(dt=0.0, duration=1.0)
