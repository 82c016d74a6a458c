"""Elastic material data (numpy only): Voigt helpers, stiffness builders, rotations, thermal stresses,
2D reductions and the checks of :func:`ngs_geomech.mechanics.materials.elastic_properties`."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ngs_geomech.heat.materials import rotation_matrix
from ngs_geomech.mechanics import materials as em
from ngs_geomech.scene.model import Material, Orthotropic, TransverselyIsotropic

E, NU, ALPHA = 30e9, 0.25, 1e-5
ORTHO = dict(E=(60e9, 20e9, 10e9), nu=(0.2, 0.25, 0.3), G=(8e9, 5e9, 4e9))
TI = dict(E_plane=40e9, E_axis=15e9, nu_plane=0.2, nu_axis=0.15, G_axis=6e9)


def sym(rng, scale=1.0):
    a = rng.normal(size=(3, 3)) * scale
    return a + a.T


def lame(E_, nu):
    return E_ * nu / ((1 + nu) * (1 - 2 * nu)), E_ / (2 * (1 + nu))


def general_c():
    """An orthotropic stiffness turned by three Euler angles: fully anisotropic in the global axes."""
    return em.rotate_voigt(em.orthotropic(**ORTHO), em.rotation([20, 35, -50], 3))


# -------------------------------------------------------------------------------------------------- Voigt

def test_voigt_round_trips_and_energy():
    rng = np.random.default_rng(0)
    eps, sig = sym(rng), sym(rng)
    e, s = em.to_voigt_strain(eps), em.to_voigt_stress(sig)
    assert np.allclose(e[3:], 2 * eps[[1, 0, 0], [2, 2, 1]])     # yz, xz, xy engineering shears
    assert np.allclose(s[3:], sig[[1, 0, 0], [2, 2, 1]])
    assert np.allclose(em.from_voigt_strain(e), eps)
    assert np.allclose(em.from_voigt_stress(s), sig)
    assert math.isclose(float(np.sum(sig * eps)), float(s @ e))    # sigma : eps = s . e


def test_isotropic_and_lame():
    C = em.isotropic(E, NU)
    lam, mu = lame(E, NU)
    assert np.allclose(C, em.from_lame(lam, mu))
    assert np.allclose(C[:3, :3], lam + 2 * mu * np.eye(3))
    assert np.allclose(np.diag(C)[3:], mu)
    # uniaxial stress gives E and nu
    e = np.linalg.solve(C, [1e6, 0, 0, 0, 0, 0])
    assert math.isclose(1e6 / e[0], E) and math.isclose(-e[1] / e[0], NU) and math.isclose(-e[2] / e[0], NU)
    assert em.isotropic_constants(C) == pytest.approx((E, NU))


def test_orthotropic_compliance_and_constants():
    S = em.orthotropic_compliance(**ORTHO)
    E1, E2, E3 = ORTHO["E"]
    nu12, nu13, nu23 = ORTHO["nu"]
    assert math.isclose(-S[1, 0] * E2, nu12 * E2 / E1)             # nu21 = nu12 E2/E1
    assert math.isclose(S[0, 2], -nu13 / E1) and math.isclose(S[1, 2], -nu23 / E2)
    assert np.allclose(1 / np.diag(S)[3:], [4e9, 5e9, 8e9])                     # G23, G13, G12
    C = em.orthotropic(**ORTHO)
    assert np.allclose(C @ S, np.eye(6), atol=1e-12)
    k = em.engineering_constants(C)
    assert np.allclose(k.E, ORTHO["E"]) and np.allclose(k.nu, ORTHO["nu"]) and np.allclose(k.G, ORTHO["G"])
    assert em.isotropic_constants(C) is None


def test_orthotropic_equal_constants_is_isotropic():
    G = E / (2 * (1 + NU))
    assert np.allclose(em.orthotropic((E, E, E), (NU, NU, NU), (G, G, G)), em.isotropic(E, NU), rtol=1e-12)


def test_transversely_isotropic():
    G = E / (2 * (1 + NU))
    assert np.allclose(em.transversely_isotropic(E, E, NU, NU, G), em.isotropic(E, NU), rtol=1e-12)
    C = em.transversely_isotropic(**TI)
    e = np.linalg.solve(C, [0, 0, 1e6, 0, 0, 0])                    # load along the axis 3
    assert math.isclose(1e6 / e[2], TI["E_axis"]) and math.isclose(-e[0] / e[2], TI["nu_axis"])
    assert math.isclose(e[0], e[1])
    e = np.linalg.solve(C, [1e6, 0, 0, 0, 0, 0])                    # load in the plane
    assert math.isclose(1e6 / e[0], TI["E_plane"]) and math.isclose(-e[1] / e[0], TI["nu_plane"])
    k = em.engineering_constants(C)
    assert np.allclose(k.G, [TI["E_plane"] / (2 * (1 + TI["nu_plane"])), TI["G_axis"], TI["G_axis"]])
    # isotropic in the 1-2 plane: any rotation about axis 3 leaves it unchanged
    assert np.allclose(em.rotate_voigt(C, em.rotation(37, 2)), C, rtol=1e-12, atol=1e-12 * C.max())


# ------------------------------------------------------------------------------------------------ checks

def test_check_positive_definite():
    C = em.isotropic(E, NU)
    assert np.array_equal(em.check_positive_definite(C.tolist(), "stiffness_voigt"), C)
    bad = C.copy()
    bad[0, 1] *= 1.01
    with pytest.raises(em.MaterialError, match="^stiffness_voigt: .*not symmetric") as exc:
        em.check_positive_definite(bad, "stiffness_voigt")
    assert exc.value.key == "stiffness_voigt" and isinstance(exc.value, ValueError)
    neg = C.copy()
    neg[3, 3] = -1e9
    with pytest.raises(em.MaterialError, match=r"^orthotropic: .*not positive definite \(eigenvalues -1e\+09"):
        em.check_positive_definite(neg, "orthotropic")
    with pytest.raises(em.MaterialError, match="^k .*6x6"):
        em.check_positive_definite(np.eye(3), "k")
    nan = C.copy()
    nan[0, 0] = np.nan
    with pytest.raises(em.MaterialError, match="^k: .*non-finite"):
        em.check_positive_definite(nan, "k")


# --------------------------------------------------------------------------------------------- rotations

def test_rotation():
    R = em.rotation(30, 2)
    assert R.shape == (3, 3)
    assert np.allclose(R[:2, :2], rotation_matrix(30, 2)) and np.allclose(R[2], [0, 0, 1])
    assert np.allclose(em.rotation([30], 2), R)
    assert np.allclose(em.rotation([10, 20, 30], 3), rotation_matrix([10, 20, 30], 3))
    assert np.allclose(em.rotation(10, 3), em.rotation([10, 0, 0], 3))
    assert np.allclose(em.rotation([0, 0, 90], 2) @ [0, 0, 1], [0, -1, 0])    # axis 3 into the plane
    for bad, dim in (([1, 2], 2), ([1], 3), ([1, 2, 3, 4], 3), (float("nan"), 2)):
        with pytest.raises(ValueError):
            em.rotation(bad, dim)


def test_bond_matrix_transforms_stress_and_strain():
    rng = np.random.default_rng(1)
    R = em.rotation([20, 35, -50], 3)
    M = em.bond_matrix(R)
    sig, eps = sym(rng), sym(rng)
    assert np.allclose(M @ em.to_voigt_stress(sig), em.to_voigt_stress(R @ sig @ R.T))
    assert np.allclose(np.linalg.inv(M).T @ em.to_voigt_strain(eps), em.to_voigt_strain(R @ eps @ R.T))
    assert np.allclose(em.bond_matrix(rotation_matrix(30, 2)), em.bond_matrix(em.rotation(30, 2)))


def test_rotate_voigt():
    R = em.rotation([20, 35, -50], 3)
    iso = em.isotropic(E, NU)
    assert np.allclose(em.rotate_voigt(iso, R), iso, atol=1e-9 * E)
    C = em.orthotropic(**ORTHO)
    turned = em.rotate_voigt(C, em.rotation(90, 2))
    k = em.engineering_constants(turned)
    assert np.allclose(k.E, [ORTHO["E"][1], ORTHO["E"][0], ORTHO["E"][2]])     # E1 and E2 swapped
    assert np.allclose(em.rotate_voigt(em.rotate_voigt(C, R), R.T), C, atol=1e-9 * C.max())
    # the stress of a rotated strain is the rotated stress
    rng = np.random.default_rng(2)
    eps_m = sym(rng, 1e-4)
    s_m = em.from_voigt_stress(C @ em.to_voigt_strain(eps_m))
    s_g = em.from_voigt_stress(em.rotate_voigt(C, R) @ em.to_voigt_strain(R @ eps_m @ R.T))
    assert np.allclose(s_g, R @ s_m @ R.T, atol=1e-9 * np.abs(s_m).max())


# ------------------------------------------------------------------------------------------------ thermal

def test_expansion_and_thermal_stress():
    assert np.array_equal(em.expansion_tensor(ALPHA), ALPHA * np.eye(3))
    a = [[1e-5, 1e-6, 0], [1e-6, 2e-5, 0], [0, 0, 3e-5]]
    assert np.array_equal(em.expansion_tensor(a), np.array(a))
    with pytest.raises(em.MaterialError, match="^thermal_expansion .*not symmetric"):
        em.expansion_tensor([[1e-5, 1e-6, 0], [0, 1e-5, 0], [0, 0, 1e-5]])
    with pytest.raises(em.MaterialError, match="^thermal_expansion .*3x3"):
        em.expansion_tensor([[1e-5, 0], [0, 1e-5]])
    beta = em.thermal_stress_tensor(em.isotropic(E, NU), em.expansion_tensor(ALPHA))
    assert np.allclose(beta, E * ALPHA / (1 - 2 * NU) * np.eye(3))             # 3 K alpha
    C = general_c()
    alpha = em.expansion_tensor(a)
    assert np.allclose(em.to_voigt_stress(em.thermal_stress_tensor(C, alpha)), C @ em.to_voigt_strain(alpha))


# --------------------------------------------------------------------------------------------- reductions

def test_plane_stress_isotropic():
    C = em.isotropic(E, NU)
    beta = em.thermal_stress_tensor(C, ALPHA * np.eye(3))
    r = em.plane_stress(C, beta)
    Q = E / (1 - NU**2) * np.array([[1, NU, 0], [NU, 1, 0], [0, 0, (1 - NU) / 2]])
    assert np.allclose(r.Q, Q)
    assert np.allclose(r.beta, E * ALPHA / (1 - NU) * np.array([1, 1, 0]))
    assert np.allclose(r.strain_out[0], [-NU / (1 - NU), -NU / (1 - NU), 0]) and np.allclose(r.strain_out[1:], 0)
    assert np.allclose(r.strain_out_thermal, [ALPHA * (1 + NU) / (1 - NU), 0, 0])
    assert np.allclose(em.plane_stress(C, em.to_voigt_stress(beta)).beta, r.beta)      # Voigt beta accepted


def test_plane_stress_anisotropic_is_exact():
    C = general_c()
    beta = em.thermal_stress_tensor(C, em.expansion_tensor([[1e-5, 2e-6, 1e-6], [2e-6, 2e-5, 0], [1e-6, 0, 3e-5]]))
    r = em.plane_stress(C, beta)
    e_in, dT = np.array([1e-4, -3e-4, 2e-4]), 40.0
    e = np.zeros(6)
    e[[0, 1, 5]] = e_in
    e[[2, 3, 4]] = r.strain_out @ e_in + r.strain_out_thermal * dT
    s = C @ e - em.to_voigt_stress(beta) * dT
    assert np.allclose(s[[2, 3, 4]], 0, atol=1e-9 * np.abs(s).max())
    assert np.allclose(s[[0, 1, 5]], r.Q @ e_in - r.beta * dT)
    assert np.allclose(r.Q, r.Q.T) and np.linalg.eigvalsh(r.Q).min() > 0


def test_plane_strain():
    C = em.isotropic(E, NU)
    beta = em.thermal_stress_tensor(C, ALPHA * np.eye(3))
    r = em.plane_strain(C, beta)
    D = E / ((1 + NU) * (1 - 2 * NU)) * np.array([[1 - NU, NU, 0], [NU, 1 - NU, 0], [0, 0, (1 - 2 * NU) / 2]])
    assert np.allclose(r.D, D)
    assert np.allclose(r.beta, E * ALPHA / (1 - 2 * NU) * np.array([1, 1, 0]))
    e_in, dT = np.array([1e-4, -3e-4, 2e-4]), 40.0
    sxx, syy, _ = r.D @ e_in - r.beta * dT
    szz = r.stress_out[0] @ e_in - r.beta_out[0] * dT
    assert math.isclose(szz, NU * (sxx + syy) - E * ALPHA * dT)                # textbook plane strain s_zz
    assert np.allclose(r.stress_out[1:], 0) and np.allclose(r.beta_out[1:], 0)
    g = em.plane_strain(general_c(), np.zeros((3, 3)))
    assert np.allclose(g.stress_out, general_c()[np.ix_([2, 3, 4], [0, 1, 5])])


def test_axisymmetric():
    C = em.isotropic(E, NU)
    beta = em.thermal_stress_tensor(C, ALPHA * np.eye(3))
    r = em.axisymmetric(C, beta)
    lam, mu = lame(E, NU)
    assert np.allclose(r.D[:3, :3], lam + 2 * mu * np.eye(3)) and np.allclose(r.D[3], [0, 0, 0, mu])
    assert np.allclose(r.beta, E * ALPHA / (1 - 2 * NU) * np.array([1, 1, 1, 0]))
    # transversely isotropic with its axis along the symmetry axis (y = z here)
    ti = em.rotate_voigt(em.transversely_isotropic(**TI), em.rotation([0, 0, 90], 2))
    assert math.isclose(em.engineering_constants(ti).E[1], TI["E_axis"])
    r = em.axisymmetric(ti, np.zeros((3, 3)))
    assert math.isclose(r.D[0, 0], r.D[2, 2]) and math.isclose(r.D[3, 3], TI["G_axis"])
    # tilted within the r-z plane: couples the normal strains to rz only, allowed
    in_plane = em.rotate_voigt(em.transversely_isotropic(**TI), em.rotation([30, 0, 90], 2))
    assert abs(em.axisymmetric(in_plane, np.zeros((3, 3))).D[0, 3]) > 1e8
    # tilted out of the r-z plane (axis with a hoop component) couples to torsion
    tilted = em.rotate_voigt(em.transversely_isotropic(**TI), em.rotation([0, 0, 60], 2))
    with pytest.raises(ValueError, match="^sandstone: stiffness couples"):
        em.axisymmetric(tilted, np.zeros((3, 3)), name="sandstone")
    with pytest.raises(ValueError, match="^material: thermal stress tensor has torsional"):
        em.axisymmetric(C, [[1, 0, 0], [0, 1, 0.5], [0, 0.5, 1]])


# --------------------------------------------------------------------------------------- elastic_properties

def test_elastic_properties_isotropic():
    m = Material(youngs_modulus=E, poisson_ratio=NU, thermal_expansion=ALPHA, stress_free_temperature=15.0,
                 density=2650.0)
    p = em.elastic_properties(m, 2)
    assert np.allclose(p.C, em.isotropic(E, NU))
    assert np.allclose(p.beta, E * ALPHA / (1 - 2 * NU) * np.eye(3))
    assert p.T0 == 15.0 and p.density == 2650.0 and p.lam == 1.0 and p.linear
    assert p.youngs_modulus_and_poisson() == pytest.approx((E, NU))
    assert p.max_poisson == pytest.approx(NU)
    assert p.A_ref == pytest.approx(1e-6 * p.C[0, 0])
    with pytest.raises(ValueError):
        p.C[0, 0] = 1.0                                                   # read-only
    lam, mu = lame(E, NU)
    q = em.elastic_properties(Material(lame_lambda=lam, lame_mu=mu), 3)
    assert np.allclose(q.C, p.C) and np.allclose(q.beta, 0) and q.density is None
    r = em.elastic_properties(Material(youngs_modulus=E, poisson_ratio=NU, elastic_rotation=[10, 20, 30]), 3)
    assert np.allclose(r.C, p.C, atol=1e-9 * E)


def test_elastic_properties_anisotropic_and_rotation():
    m = Material(orthotropic=Orthotropic(E=list(ORTHO["E"]), nu=list(ORTHO["nu"]), G=list(ORTHO["G"])),
                 elastic_rotation=90, thermal_expansion=[[1e-5, 0, 0], [0, 2e-5, 0], [0, 0, 3e-5]])
    p = em.elastic_properties(m, 2)
    k = em.engineering_constants(p.C)
    assert np.allclose(k.E, [20e9, 60e9, 10e9])
    assert np.allclose(p.alpha, np.diag([2e-5, 1e-5, 3e-5]), atol=1e-20)          # alpha turned with the axes
    assert np.allclose(p.beta, em.thermal_stress_tensor(p.C, p.alpha))
    assert p.youngs_modulus_and_poisson() is None
    assert 0 < p.max_poisson < 0.5
    t = em.elastic_properties(Material(transversely_isotropic=TransverselyIsotropic(**TI)), 3)
    assert np.allclose(t.C, em.transversely_isotropic(**TI))
    turned = em.elastic_properties(Material(transversely_isotropic=TransverselyIsotropic(**TI),
                                            elastic_rotation=[10, 20, 30]), 3)
    assert turned.max_poisson == pytest.approx(t.max_poisson)                     # rotation invariant
    s = em.elastic_properties(Material(stiffness_voigt=general_c().tolist()), 3)
    assert np.allclose(s.C, general_c())
    # nearly incompressible anisotropic material: the estimate tends to 0.5
    soft = em.elastic_properties(Material(transversely_isotropic=TransverselyIsotropic(
        E_plane=1e9, E_axis=1e9, nu_plane=0.4999, nu_axis=0.4999, G_axis=1e8)), 3)
    assert 0.49 < soft.max_poisson < 0.5


def test_nonlinear_law():
    p = em.elastic_properties(Material(youngs_modulus=E, poisson_ratio=NU, rheology_lambda=0.7,
                                       reference_strain=2e-3), 3)
    assert not p.linear and p.A_ref == pytest.approx(4e-6 * p.C[0, 0])
    e = np.array([1e-3, -2e-4, 3e-4, 1e-4, 0, 2e-4])
    delta = 1e-6

    def W(v):
        return p.energy(v @ p.C @ v, delta)

    h = 1e-9
    grad = np.array([(W(e + h * u) - W(e - h * u)) / (2 * h) for u in np.eye(6)])
    stress = p.secant_factor(e @ p.C @ e, delta) * (p.C @ e)
    assert np.allclose(grad, stress, rtol=1e-5)
    assert p.energy(0.0, delta) == 0.0
    # at A1 = A_ref the secant factor is lam (1 + delta)^(lam-1)
    assert p.secant_factor(p.A_ref, 0.0) == pytest.approx(0.7)
    lin = em.elastic_properties(Material(youngs_modulus=E, poisson_ratio=NU), 3)
    assert lin.secant_factor(123.0) == 1.0 and lin.energy(2.0) == 1.0
    assert np.allclose(lin.secant_factor(np.array([1.0, 2.0])), 1.0)


GOOD_TI = dict(TI)
BAD_MATERIALS = [
    ({}, ""),
    (dict(youngs_modulus=E, poisson_ratio=NU, lame_mu=1e9), "lame_mu"),
    (dict(youngs_modulus=E, poisson_ratio=NU, stiffness_voigt=np.eye(6).tolist()), "stiffness_voigt"),
    (dict(youngs_modulus=E), "poisson_ratio"),
    (dict(poisson_ratio=NU), "youngs_modulus"),
    (dict(lame_mu=1e9), "lame_lambda"),
    (dict(youngs_modulus=-E, poisson_ratio=NU), "youngs_modulus"),
    (dict(youngs_modulus=0.0, poisson_ratio=NU), "youngs_modulus"),
    (dict(youngs_modulus=E, poisson_ratio=0.5), "poisson_ratio"),
    (dict(youngs_modulus=E, poisson_ratio=-1.0), "poisson_ratio"),
    (dict(lame_lambda=1e9, lame_mu=0.0), "lame_mu"),
    (dict(lame_lambda=-1e9, lame_mu=1e9), "lame_lambda"),
    (dict(orthotropic=Orthotropic(E=[1e9, -1e9, 1e9], nu=[0.2, 0.2, 0.2], G=[1e9, 1e9, 1e9])), "orthotropic.E[1]"),
    (dict(orthotropic=Orthotropic(E=[1e9, 1e9, 1e9], nu=[0.2, 0.2, 0.2], G=[1e9, 0, 1e9])), "orthotropic.G[1]"),
    (dict(orthotropic=Orthotropic(E=[1e9, 1e9, 1e9], nu=[0.9, 0.9, 0.9], G=[1e9, 1e9, 1e9])), "orthotropic"),
    (dict(transversely_isotropic=TransverselyIsotropic(**{**GOOD_TI, "E_axis": -1.0})),
     "transversely_isotropic.E_axis"),
    (dict(transversely_isotropic=TransverselyIsotropic(**{**GOOD_TI, "G_axis": 0.0})),
     "transversely_isotropic.G_axis"),
    (dict(transversely_isotropic=TransverselyIsotropic(**{**GOOD_TI, "nu_plane": -1.0})),
     "transversely_isotropic.nu_plane"),
    (dict(transversely_isotropic=TransverselyIsotropic(**{**GOOD_TI, "nu_axis": 1.5})), "transversely_isotropic"),
    (dict(stiffness_voigt=(np.eye(6) + np.triu(np.ones((6, 6)), 1)).tolist()), "stiffness_voigt"),
    (dict(stiffness_voigt=(-np.eye(6)).tolist()), "stiffness_voigt"),
    (dict(stiffness_voigt=np.eye(3).tolist()), "stiffness_voigt"),
    (dict(youngs_modulus=E, poisson_ratio=NU, thermal_expansion=[[1, 2, 0], [0, 1, 0], [0, 0, 1]]),
     "thermal_expansion"),
    (dict(youngs_modulus=E, poisson_ratio=NU, thermal_expansion=[[1, 0], [0, 1]]), "thermal_expansion"),
    (dict(youngs_modulus=E, poisson_ratio=NU, elastic_rotation=[1, 2]), "elastic_rotation"),
    (dict(youngs_modulus=E, poisson_ratio=NU, rheology_lambda=0.0), "rheology_lambda"),
    (dict(youngs_modulus=E, poisson_ratio=NU, reference_strain=-1e-3), "reference_strain"),
    (dict(youngs_modulus=E, poisson_ratio=NU, density=-1.0), "density"),
]


@pytest.mark.parametrize("kw, key", BAD_MATERIALS, ids=[f"{i}-{k or 'none'}" for i, (_, k) in
                                                        enumerate(BAD_MATERIALS)])
def test_elastic_properties_errors_name_their_key(kw, key):
    with pytest.raises(em.MaterialError) as exc:
        em.elastic_properties(Material(**kw), 2)
    assert exc.value.key == key
    assert str(exc.value).startswith(key)
    if not key:
        assert "youngs_modulus + poisson_ratio" in str(exc.value) and "stiffness_voigt" in str(exc.value)


def test_error_messages_read_well():
    with pytest.raises(em.MaterialError, match=r"^youngs_modulus must be positive, got -1e\+09 Pa"):
        em.elastic_properties(Material(youngs_modulus=-1e9, poisson_ratio=NU), 3)
    with pytest.raises(em.MaterialError, match=r"^poisson_ratio must be in \(-1, 0.5\), got 0.6"):
        em.elastic_properties(Material(youngs_modulus=1e9, poisson_ratio=0.6), 3)
    with pytest.raises(em.MaterialError, match="^orthotropic: .*eigenvalues"):
        em.elastic_properties(Material(orthotropic=Orthotropic(E=[1e9] * 3, nu=[0.9] * 3, G=[1e9] * 3)), 3)
    with pytest.raises(em.MaterialError, match="^stiffness_voigt conflicts with youngs_modulus"):
        em.elastic_properties(Material(youngs_modulus=E, poisson_ratio=NU, stiffness_voigt=np.eye(6).tolist()), 3)
