"""From a scene to the elastic problem's plain inputs (:class:`ElasticSetup`)."""

from __future__ import annotations

import ngsolve as ngs
import numpy as np

from .. import parallel
from ..errors import MaterialError, Problem, SceneError, SolverError
from ..fem.coefficients import expression_function
from ..geometry.assemble import GeometryModel
from ..scene import expressions
from ..scene.model import Scene
from .forms import ElasticSetup, mixed_regions
from .materials import elastic_properties, elastic_varying_keys, varying_elastic_properties


def mechanics_model(scene: Scene) -> str:
    """'plane_strain' | 'plane_stress' | 'axisymmetric' | '3d' for a scene."""
    if scene.scene.dimension == "3d":
        return "3d"
    if scene.scene.dimension == "axisymmetric":
        return "axisymmetric"
    return scene.physics.plane_model


def axis_boundaries(mesh, names) -> list[str]:
    """Boundary names all of whose vertices lie on the axis x = 0 (axisymmetric scenes: u_r = 0 there). Collective
    on a distributed mesh (a rank's part may hold none of a boundary's elements, rank 0 none at all)."""
    pts = np.array([v.point for v in mesh.vertices], dtype=float).reshape(-1, mesh.dim)
    lo = [parallel.allmin(mesh, float(pts[:, k].min()) if len(pts) else np.inf) for k in range(mesh.dim)]
    hi = [parallel.allmax(mesh, float(pts[:, k].max()) if len(pts) else -np.inf) for k in range(mesh.dim)]
    size = max(h - low for h, low in zip(hi, lo))
    out = []
    for name in names:
        els = list(mesh.Boundaries(name).Elements())
        off_axis = any(abs(mesh[v].point[0]) > 1e-9 * size for el in els for v in el.vertices)
        if parallel.anyof(mesh, bool(els)) and not parallel.anyof(mesh, off_axis):
            out.append(name)
    return out


SAMPLES = 400
"""Most mesh vertices per region at which varying elastic data are read as numbers (representative values)."""


def region_samples(mesh, name: str, temperature=None, limit: int = SAMPLES) -> list[dict]:
    """Sample points of region ``name``: its mesh vertices (of every rank of a distributed mesh), sorted and thinned
    evenly to at most ``limit``, as dicts of x, y, z, r (m) and T (the value of ``temperature`` there, 0 without
    one). Collective on a distributed mesh."""
    arr = (mesh.ngmesh.Elements3D() if mesh.dim == 3 else mesh.ngmesh.Elements2D()).NumPy()
    index = np.asarray(arr["index"], dtype=np.int64) - 1
    materials = list(mesh.GetMaterials())
    region = materials.index(name) if name in materials else -1
    nodes = np.asarray(arr["nodes"], dtype=np.int64)[index == region]
    ids = np.unique(nodes[nodes > 0]) - 1
    pts = np.asarray(mesh.ngmesh.Coordinates())[ids] if len(ids) else np.zeros((0, mesh.dim))
    pts = parallel.concat(mesh, pts)
    pts = np.unique(np.round(pts, 12), axis=0)
    pts = pts[::max(1, -(-len(pts) // limit))]
    T = (parallel.point_values(mesh, temperature, pts[:, :mesh.dim])[:, 0] if temperature is not None and len(pts)
         else np.zeros(len(pts)))
    T = np.where(np.isfinite(T), T, 0.0)
    full = np.zeros((len(pts), 3))
    full[:, :pts.shape[1]] = pts[:, :3]
    return [{"x": float(p[0]), "y": float(p[1]), "z": float(p[2]), "r": float(p[0]), "T": float(t)}
            for p, t in zip(full, T)]


def region_properties(scene: Scene, mesh, temperature=None) -> dict:
    """Region -> ElasticProperties of a validated scene: numbers as they are; a material whose elastic keys hold
    expressions read at :func:`region_samples` (representative numbers and the expressions:
    :func:`~.materials.varying_elastic_properties`). SceneError naming the key and the mesh vertex where varying
    data are refused (validation samples the geometry, not the mesh)."""
    dim = 3 if scene.scene.dimension == "3d" else 2
    out = {}
    for name, m in scene.materials.items():
        if not elastic_varying_keys(m):
            out[name] = elastic_properties(m, dim)
            continue
        try:
            out[name] = varying_elastic_properties(m, dim, region_samples(mesh, name, temperature))
        except MaterialError as exc:
            raise SceneError([Problem(f"materials.{name}.{exc.key}", f"{exc.detail} (a mesh vertex of region "
                                      f"{name!r})")], source=f"scene {scene.scene.name!r}") from None
    return out


def check_elastic_temperatures(forms, where: str) -> None:
    """Before a solve of ``forms`` (ElasticForms) whose stiffness depends on T: read each such region's data at its
    vertices at the current temperature with every check of the number path; SolverError naming the material, the
    key and the point where they stop holding (validation sees only the temperatures a region surely takes)."""
    for name, p in forms.setup.props.items():
        m = p.varying.material if p.varying is not None else None
        if m is None or not (isinstance(m.youngs_modulus, str)
                                 and expressions.TEMPERATURE in expressions.uses(m.youngs_modulus)):
            continue
        try:
            varying_elastic_properties(m, forms.dim, region_samples(forms.mesh, name, forms.setup.temperature))
        except MaterialError as exc:
            raise SolverError(f"elastic solve at {where}: materials.{name}.{exc.key} {exc.detail}: the temperature "
                              "of the run takes the elastic data of the material out of their range") from None


def elastic_setup(scene: Scene, geo: GeometryModel, mesh, temperature=None, *, interpolate=None) -> ElasticSetup:
    """The ElasticSetup of a validated scene on its mesh; ``temperature`` is the heat solution CF or None;
    ``interpolate`` the thermal part's map of a CF into its temperature space (for a varying T0), or None."""
    props = region_properties(scene, mesh, temperature)
    ms = scene.mechanics
    setup = ElasticSetup(props=props, model=mechanics_model(scene), order=scene.mesh.order,
                         gravity=tuple(ms.gravity) if ms.gravity else None,
                         temperature=temperature, regularization=ms.regularization, formulation=ms.formulation,
                         interpolate_T0=interpolate)
    for name, bc in scene.boundary_conditions.items():
        if bc.displacement is not None:
            setup.dirichlet[name] = [None if c == "free" else expression_function(c) for c in bc.displacement]
        elif bc.traction is not None:
            setup.traction[name] = [expression_function(c) for c in bc.traction]
        elif bc.pressure is not None:
            setup.pressure[name] = expression_function(bc.pressure)
        elif bc.symmetry:
            setup.symmetry.append(name)
    s0 = ms.initial_stress
    if s0 is not None:
        n = 2 if setup.model == "plane_strain" else len(s0)   # plane strain: the in-plane block of a 3x3 table
        setup.initial_stress = [[expression_function(c) for c in row[:n]] for row in s0[:n]]
        if len(s0) > n:                                       # and its zz entry, the out-of-plane prestress
            setup.initial_stress_zz = expression_function(s0[2][2])
    if setup.model == "axisymmetric":
        taken = set(setup.dirichlet) | set(setup.symmetry)
        setup.axis = [n for n in axis_boundaries(mesh, sorted(set(mesh.GetBoundaries()))) if n not in taken]
    return setup


def probe_fields(u, measures: dict, dim: int) -> dict:
    """The mechanical quantities probes may record: displacement components (m) and stress measures (Pa)."""
    fields = {"displacement_x": u[0], "displacement_y": u[1], "von_mises": measures["von_mises"],
              "mean_stress": measures["mean_stress"], "sigma_1": measures["sigma_1"], "sigma_3": measures["sigma_3"]}
    if dim == 3:
        fields["displacement_z"] = u[2]
    return fields


def mechanics_warnings(scene: Scene, setup: ElasticSetup) -> list[str]:
    """Warnings a user should see before trusting the result (logged as warnings, kept in summary.json)."""
    mixed, notes = mixed_regions(setup)
    out = list(notes)
    if scene.mesh.order == 1:
        for name, p in setup.props.items():
            nu = p.max_poisson
            if nu is not None and nu > 0.49 and name not in mixed:
                out.append(f"materials.{name}: Poisson ratio {nu:.4f} > 0.49 with P1 elements of the displacement "
                           "formulation locks (stresses and displacements far too small); use mechanics.formulation "
                           "= 'mixed' or mesh.order = 2 or higher")
    for name, p in setup.props.items():
        if p.lam < 0.5:
            out.append(f"materials.{name}: rheology_lambda {p.lam:g} < 0.5 makes the stress-strain law non-monotone "
                       "(the energy is not convex): solutions may localize or not be unique")
    return out


SMALL_STRAIN_LIMIT = 0.1
"""The largest displacement gradient max |grad u| (Frobenius norm, root mean square over an element) the linear,
small-strain theory of the model is trusted with: at |grad u| = 0.1 the Green strain differs from the linear one
by ~5 % and rotations reach ~6 degrees. The maximum over elements grows under refinement at corners and contact
edges (a singular strain); the built-in scenes reach 0.0065-0.0102 at their quick levels (repository_section,
contact_melting, plate_collision) and plate_collision 0.058 at 30 km elements: the limit keeps clear of those
and catches moduli or loads off by orders of magnitude."""

SMALL_STRAIN_WARNING = "the displacement leaves the small-strain range"
"""The start of the warning of :func:`small_strain_warning` (one per run)."""


def small_strain_warning(forms, where: str) -> str | None:
    """The warning for the last solve of ``forms`` (an ElasticForms) when max |grad u| > SMALL_STRAIN_LIMIT,
    naming the value, its region, max |u| (element RMS, m) and the model's extent (m); None inside the range.
    Three element-wise integrals, no Python loop over the elements; collective on a distributed mesh."""
    mesh = forms.mesh
    u = forms.displacement()
    G = ngs.Grad(u)
    vol = np.asarray(ngs.Integrate(ngs.CoefficientFunction(1.0), mesh, element_wise=True))
    with np.errstate(invalid="ignore", divide="ignore"):
        g = np.sqrt(np.asarray(ngs.Integrate(ngs.InnerProduct(G, G), mesh, element_wise=True)) / vol)
        um = np.sqrt(np.asarray(ngs.Integrate(ngs.InnerProduct(u, u), mesh, element_wise=True)) / vol)
    local = (-1.0, "", 0.0, 0.0)
    if g.size:
        i = int(np.nanargmax(g)) if np.any(np.isfinite(g)) else 0
        pts = mesh.ngmesh.Coordinates()
        local = (float(g[i]), mesh[ngs.ElementId(ngs.VOL, i)].mat, float(np.nanmax(um)),
                 float(np.max(np.ptp(pts, axis=0))))
    gathered = parallel.allgather(mesh, local)
    gmax, region, _, _ = max(gathered)
    if not gmax > SMALL_STRAIN_LIMIT:
        return None
    umax, extent = max(x[2] for x in gathered), max(x[3] for x in gathered)
    return (f"{SMALL_STRAIN_WARNING} of the linear theory at {where}: max |grad u| = {gmax:.3g} > "
            f"{SMALL_STRAIN_LIMIT:g} (region {region}), max |u| = {umax:.3g} m in a model {extent:.3g} m across; "
            "check the moduli (Pa) and the loads, the result is not reliable")


def watch_small_strain(mech, where: str) -> None:
    """After a mechanics solve: append :func:`small_strain_warning` to ``mech.warnings`` (the run's summary
    warnings) the first time it applies in the run."""
    if any(w.startswith(SMALL_STRAIN_WARNING) for w in mech.warnings):
        return
    w = small_strain_warning(mech.forms, where)
    if w is not None:
        mech.warnings.append(w)
