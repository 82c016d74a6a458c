"""Front-following meshes for the Stefan problem (:mod:`ngs_geomech.adapt.stefan`, issue 6 section 2,
time-dependent): the Neumann two-phase strip on meshes remeshed at the front (2 levels from a 0.05 m base) is as
accurate as the uniform mesh of the same finest size with a fraction of its unknowns, the heat content is kept
across every remesh (lumped projection), and the energy balance closes with the transfers counted."""

from __future__ import annotations

import pytest

from ngs_geomech.verification import stefan as st
from ngs_geomech.verification.stefan_adaptive import neumann_adaptive, neumann_uniform

pytestmark = pytest.mark.usefixtures("one_thread")


def test_front_following_meshes_match_the_uniform_front_error_with_few_unknowns():
    p = st.TWO_PHASE
    uni = neumann_uniform(p, 0.0125, 0.0025, 0.05, 0.5)
    ada = neumann_adaptive(p, 0.05, 2, 0.0025, 0.05, 0.5, layers=6, remesh_every=0, transfer="projection")
    print(f"\nuniform h = 0.0125: {uni['ndof']} dofs, front error {uni['front_rel_error']:.2e}, {uni['wall_s']:.2f} s; "
          f"front-following (h_min {ada['h_min']:.3g}): {ada['ndof_mean']:.0f} dofs (mean), front error "
          f"{ada['front_rel_error']:.2e}, {ada['remeshes']} remeshes, largest heat change at a transfer "
          f"{ada['transfer_error_max']:.1e}, energy imbalance {ada['energy_imbalance_rel']:.1e}")
    assert ada["remeshes"] >= 1 and ada["ndof_mean"] < 0.25 * uni["ndof"]
    assert ada["front_rel_error"] < 1.5 * uni["front_rel_error"]
    assert ada["transfer_error_max"] < 1e-4 and ada["energy_imbalance_rel"] < 1e-10
