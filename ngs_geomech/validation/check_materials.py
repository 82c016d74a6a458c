"""Validation of the materials of a scene: the data each switched-on physics reads from them (conductivity, heat
capacity, elastic constants, through the physics' own reading), the phase changes and what the Stefan solver
supports, and a temperature-dependent conductivity that stays positive. The range of each single key is declared
with it (:class:`~ngs_geomech.scene.model.Material`) and checked by :func:`~ngs_geomech.scene.schema.recheck`."""

from __future__ import annotations

from ..errors import MaterialError, Problem
from ..geometry.assemble import GeometryModel, scene_dim
from ..heat.materials import (
    CONDUCTIVITY_KEYS,
    conductivity_tensor,
    expression_keys,
    has_phase_change,
    phase_change_problems,
    phase_conductivities,
    volumetric_heat_capacity,
)
from ..mechanics.materials import axisymmetric, elastic_properties, elastic_structure, elastic_varying_keys
from ..scene import expressions
from ..scene.model import Scene
from ..scene.schema import holds_expression
from .expression_values import value_range


def stefan_scene(scene: Scene) -> bool:
    """Whether the scene is solved as a Stefan problem: some material has a phase change and the thermal
    problem is transient (the enthalpy solver replaces the heat solver)."""
    return scene.physics.thermal == "transient" and any(has_phase_change(m) for m in scene.materials.values())


def check_materials(scene: Scene, problems: list[Problem]) -> None:
    dim = scene_dim(scene)
    for name, mat in scene.materials.items():
        if scene.physics.thermal is not None:
            # conductivity and heat capacity are checked separately so that both are reported, each under
            # the key at fault (e.g. materials.granite.rho_c)
            key = "conductivity_principal" if mat.conductivity_principal is not None else "conductivity"
            if mat.conductivity is None and mat.conductivity_principal is None:
                key = ""
            try:
                conductivity_tensor(mat, dim)
            except MaterialError as exc:
                problems.append(Problem(f"materials.{name}.{exc.key}", exc.detail))
            except ValueError as exc:
                problems.append(Problem(f"materials.{name}" + (f".{key}" if key else ""), str(exc)))
        key = "rho_c" if mat.rho_c is not None else "density" if mat.density is not None else "specific_heat"
        try:
            rho_c = volumetric_heat_capacity(mat)
        except MaterialError as exc:
            problems.append(Problem(f"materials.{name}.{exc.key}", exc.detail))
            rho_c = 0.0
        except ValueError as exc:
            problems.append(Problem(f"materials.{name}.{key}", str(exc)))
            rho_c = 0.0
        if scene.physics.thermal == "transient" and rho_c is None:
            problems.append(Problem(f"materials.{name}", "a transient thermal scene needs rho_c "
                                                         "(or density and specific_heat)"))
        if scene.physics.mechanics is not None:
            _check_elastic(scene, name, mat, dim, problems)


def _check_elastic(scene: Scene, name: str, mat, dim: int, problems: list[Problem]) -> None:
    """The elastic data of one material: read as numbers (with every check), or for data that vary (expressions)
    their structure here and their values at sample points (:mod:`.material_values`); what the mechanics cannot
    take varying (the lambda law, the rate terms, E(T) without a temperature) is refused naming the key."""
    varying = elastic_varying_keys(mat)
    try:
        if varying:
            elastic_structure(mat)
        else:
            props = elastic_properties(mat, dim)
            if scene.scene.dimension == "axisymmetric":
                axisymmetric(props.C, props.beta)
    except MaterialError as exc:
        problems.append(Problem(f"materials.{name}.{exc.key}" if exc.key else f"materials.{name}",
                                exc.detail if exc.key else str(exc)))
    except ValueError as exc:
        problems.append(Problem(f"materials.{name}", str(exc)))
    for key in varying:
        why = _varying_refused(scene, mat, key)
        if why:
            problems.append(Problem(f"materials.{name}.{key}", why))
    if scene.mechanics.gravity is not None and mat.density is None:
        problems.append(Problem(f"materials.{name}.density", "gravity is on: every region needs a density"))


def _varying_refused(scene: Scene, mat, key: str) -> str:
    """Why the mechanics cannot take the expression of elastic key ``key`` ('' when it can)."""
    if mat.rheology_lambda != 1.0 and key != "density":
        return (f"an expression with rheology_lambda = {mat.rheology_lambda:g}: the lambda law (2.1)-(2.5) takes "
                "numbers for the elastic data of its region (A_ref and the secant stiffness are built per region); "
                "use rheology_lambda = 1 or numbers")
    if (mat.viscosity_time is not None or mat.prony) and scene.physics.mechanics in ("dynamic", "viscous") \
            and key not in ("density", "stress_free_temperature"):      # the rate terms take C only
        return ("an expression in a region with viscosity_time or prony: the rate terms C^v = viscosity_time C and "
                "C_k = modulus_ratio C take numbers for C; give the elastic data as numbers there")
    if key == "youngs_modulus" and expressions.TEMPERATURE in expressions.uses(mat.youngs_modulus):
        if scene.physics.thermal is None:
            return ("depends on T, but physics.thermal is off: the mechanics has no temperature to take E(T) at; "
                    "switch the thermal problem on or give E of x, y, z only")
        if scene.physics.mechanics in ("dynamic", "viscous"):
            return (f"depends on T: {scene.physics.mechanics} mechanics assembles its stiffness matrix once; give E "
                    "of x, y, z only (static mechanics takes E(T), re-assembled at each solve)")
    return ""


def check_phase_change(scene: Scene, problems: list[Problem]) -> None:
    """Phase-change keys of each material, and what the Stefan solver supports (seed (2.46)-(2.51), (2.55): P1,
    lumped, backward Euler, numbers for the heat capacities per region, conductivity tensors k_phase K_hat per phase
    (the phases scale one anisotropy) or k_phase G(x) (the phases share a variation in x, y, z); k (1 + b (T - T_ref))
    allowed; plane, axisymmetric or 3D; temperature, flux
    and heat transfer (Robin) conditions)."""
    pcm = [n for n, m in scene.materials.items() if has_phase_change(m)]
    for name, mat in scene.materials.items():
        for key, msg in phase_change_problems(mat):
            problems.append(Problem(f"materials.{name}.{key}", msg))
    if not pcm:
        return
    ph = scene.physics
    if ph.thermal is None:
        problems.append(Problem(f"materials.{pcm[0]}.phase_change_temperature", "a phase change needs "
                                "physics.thermal = 'transient' (the Stefan problem), but physics.thermal is off"))
        return
    if ph.thermal == "steady":
        problems.append(Problem("physics.thermal", f"'steady' with a phase change in {pcm}: the Stefan problem is "
                                "time-dependent (the phase boundary moves); use thermal = 'transient' with [time], "
                                "or remove phase_change_temperature"))
        return
    why = f"the Stefan (phase change) solver, used because of the phase change in {pcm},"
    if scene.mesh.order != 1:
        problems.append(Problem("mesh.order", f"{scene.mesh.order}: {why} uses lumped P1 elements; set "
                                "mesh.order = 1 (refine with mesh.maxh instead)"))
    if scene.time is not None and scene.time.scheme != "backward_euler":
        problems.append(Problem("time.scheme", f"{scene.time.scheme!r}: {why} steps with backward Euler (seed "
                                "(2.55)); set time.scheme = 'backward_euler'"))
    dim = scene_dim(scene)
    for name, mat in scene.materials.items():
        varying = expression_keys(mat) + [k for k in ("conductivity_liquid", "conductivity_liquid_principal")
                                          if holds_expression(getattr(mat, k))]
        for key in varying:
            message = _stefan_expression_problem(mat, key, why)
            if message:
                problems.append(Problem(f"materials.{name}.{key}", message))
        if any(k in CONDUCTIVITY_KEYS for k in varying):
            continue                    # conductivities of x, y, z: sampled by material_values
        # conductivity_temperature_coefficient: k(T) = k (1 + b (T - T_ref)) in both phases (the Kirchhoff
        # variable is then piecewise quadratic); that k stays positive is checked at the temperatures reached
        try:
            conductivity_tensor(mat, dim)
        except ValueError:
            continue                    # reported by check_materials
        if has_phase_change(mat) and not phase_change_problems(mat):
            try:                        # the liquid's tensor proportional to the solid's (one K_hat per region)
                phase_conductivities(mat, dim)
            except MaterialError as exc:
                problems.append(Problem(f"materials.{name}.{exc.key}", exc.detail))


def _stefan_expression_problem(mat, key: str, why: str) -> str:
    """Why the Stefan solver refuses the expression of ``key`` ("" when it takes it): conductivities of x, y, z are
    taken (the phases sharing the variation, checked at sample points by
    :func:`~ngs_geomech.validation.material_values.check_phase_conductivity_values`), not of T, and no heat capacity
    (the nodal enthalpy graph holds numbers per region and phase)."""
    if key in CONDUCTIVITY_KEYS:
        if any(expressions.TEMPERATURE in expressions.uses(e) for e in _texts(getattr(mat, key))):
            return (f"depends on T: {why} takes conductivities of x, y, z only (its Kirchhoff variable theta(T) is "
                    "one piecewise law per region); give the temperature dependence as "
                    "conductivity_temperature_coefficient (k (1 + b (T - T_ref)) in both phases)")
        return ""
    if key == "density" and mat.specific_heat is None and not (
            has_phase_change(mat) and (mat.latent_heat is not None or mat.specific_heat_liquid is not None)):
        return ""                       # the density of the mechanics only (rho_c, the volumetric latent heat given)
    return (f"an expression: {why} takes the heat capacity as a number per region and phase (its nodal enthalpy "
            "graph e(T) is built from C_s, C_l and L per material, one graph per material at every node); the "
            "conductivities may vary in x, y, z, and expressions of x, y, z, T for the heat capacity are taken by the "
            "heat solver of scenes without phase change")


def _texts(value) -> list[str]:
    if isinstance(value, str):
        return [value]
    if isinstance(value, (list, tuple)):
        return [e for v in value for e in _texts(v)]
    return []


def check_conductivity_range(scene: Scene, geo: GeometryModel, problems: list[Problem]) -> None:
    """k(T) = k (1 + b (T - T_ref)) must be positive at the temperatures a region surely takes: its initial
    temperature and the prescribed temperatures on its block's boundaries."""
    if scene.physics.thermal is None:
        return
    for name, mat in scene.materials.items():
        b, t_ref = mat.conductivity_temperature_coefficient, mat.reference_temperature
        if b == 0.0 or name not in geo.regions:
            continue
        data = [(f"initial.regions.{name}" if name in scene.initial.regions else "initial.temperature",
                 scene.initial.regions.get(name, scene.initial.temperature), ("region", (name,)))]
        if scene.physics.thermal == "steady":
            data = []
        data += [(f"boundary_conditions.{n}.temperature", bc.temperature, ("boundary", (n,)))
                 for n, bc in scene.boundary_conditions.items()
                 if bc.temperature is not None and n in geo.block_boundaries.get(name, ())]
        for key, value, target in data:
            r = value_range(geo, value, target)
            bad = [T for T in (r or ()) if not 1 + b * (T - t_ref) > 0]
            if bad:
                problems.append(Problem(f"materials.{name}.conductivity_temperature_coefficient", f"k(T) = k (1 + b "
                                        f"(T - T_ref)) with b = {b:g} 1/K, T_ref = {t_ref:g} is not positive at "
                                        f"T = {bad[0]:g} given by {key} (positive only for T "
                                        f"{'>' if b > 0 else '<'} {t_ref - 1 / b:.6g})"))
                break
