"""Front-following meshes for the Stefan problem (:mod:`ngs_geomech.adapt.front_following`, the implementation
scene runs use; issue 6 section 2, time-dependent): the Neumann two-phase strip, written as a scene started at
t = 0.05 s from the exact temperature, on meshes remeshed at the front (2 levels from a 0.05 m base) has a front
error within 1.5 times the uniform mesh's of the same finest size (started from the exact enthalpy; measured 4.4e-3
against 3.3e-3) with an eighth of its unknowns (measured 368 mean against 2842), the heat content is kept across
every remesh (lumped projection), and the energy balance closes with the transfers counted."""

from __future__ import annotations

import pytest

from ngs_geomech.verification import stefan as st
from ngs_geomech.verification.stefan_adaptive import neumann_adaptive, neumann_uniform

pytestmark = pytest.mark.usefixtures("one_thread")


def test_front_following_meshes_match_the_uniform_front_error_with_few_unknowns():
    p = st.TWO_PHASE
    uni = neumann_uniform(p, 0.0125, 0.0025, 0.05, 0.5)
    ada = neumann_adaptive(p, 0.05, 2, 0.0025, 0.05, 0.5, layers=6, remesh_every=0)
    print(f"\nuniform h = 0.0125: {uni['ndof']} dofs, front error {uni['front_rel_error']:.2e}, {uni['wall_s']:.2f} s; "
          f"front-following (h_min {ada['h_min']:.3g}): {ada['ndof_mean']:.0f} dofs (mean), front error "
          f"{ada['front_rel_error']:.2e}, {ada['remeshes']} remeshes ({ada['repeated_steps']} steps repeated), "
          f"largest heat change at a transfer {ada['transfer_error_max']:.1e}, energy imbalance "
          f"{ada['energy_imbalance_rel']:.1e}")
    assert ada["remeshes"] >= 1 and ada["ndof_mean"] < 0.25 * uni["ndof"]
    assert ada["front_rel_error"] < 1.5 * uni["front_rel_error"]
    assert ada["transfer_error_max"] < 1e-4 and ada["energy_imbalance_rel"] < 1e-10
