"""The typed scene objects. A scene is declared in TOML (see ``geometries/*.toml``) or built in Python
from these same frozen dataclasses; :func:`ngs_geomech.scene.parse.scene_from_dict` reads the former.

Units are SI throughout: lengths in m, times in s (strings like ``"10 year"`` are accepted),
temperatures in degC or K (one convention per scene; only differences enter the physics),
conductivity in W/(m K), volumetric heat capacity rho*c in J/(m^3 K), heat flux in W/m^2,
power density in W/m^3.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..contact.choices import LAWS as CONTACT_LAWS
from ..contact.choices import METHODS as CONTACT_METHODS
from ..linalg.choices import PRECONDITIONERS, SOLVERS
from ..mechanics.choices import FORMULATIONS, NONLINEAR_SOLVERS
from .schema import (
    RELATIVE_TOLERANCE,
    at_most,
    boolean,
    bounded,
    constant,
    dict_of,
    either,
    expr,
    field,
    integer,
    list_of,
    material_value,
    nested,
    number,
    one_of,
    optional,
    positive,
    string,
    time,
)

DIMENSIONS = ("plane", "axisymmetric", "3d")
MECHANICS = ("static", "dynamic", "viscous")
RATE_MECHANICS = ("dynamic", "viscous")
"""The mechanics advanced every time step with inertia and/or viscosity (the global model (2.6)-(2.16))."""
SHAPES_2D = ("rectangle", "polygon", "circle", "profile")
SHAPES_3D = ("box", "cylinder", "prism", "import")
MESH_ELEMENTS = ("simplex", "tensor")
SELECTORS = ("all", "xmin", "xmax", "ymin", "ymax", "zmin", "zmax", "top", "bottom", "lateral")
LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "km": 1e3, "in": 0.0254, "ft": 0.3048}
"""Length units an imported file's coordinates may be read in, in m."""
point = list_of(number)
matrix = list_of(list_of(number))
segment_points = list_of(point, 2)
modulus = at_most(1e21, "Pa")       # elastic moduli: diamond 1.2e12 Pa; stiffness contrasts up to 1e10


@dataclass(frozen=True, kw_only=True)
class SceneInfo:
    """``[scene]``: name, description and spatial setting."""

    name: str = field(string, doc="scene name (used in output file names)")
    description: str = field(string, "", doc="free text")
    temperature_unit: str = field(one_of("C", "K"), "C", doc="unit of all temperatures (labels only)")
    dimension: str = field(one_of(*DIMENSIONS), "plane",
                           doc="'plane' (x, y), 'axisymmetric' (r = x >= 0, z = y, axis x = 0) or '3d'")


@dataclass(frozen=True, kw_only=True)
class Physics:
    """``[physics]``: which problems are solved. Only what is switched on is built."""

    thermal: str | None = field(optional(one_of("steady", "transient")), None,
                                doc="heat conduction (2.17) steady or transient (2.43)")
    mechanics: str | None = field(optional(one_of(*MECHANICS)), None,
                                  doc="'static': (quasi-)static elasticity (2.17)-(2.18), with thermal stresses "
                                      "when thermal is on, solved at the output times; 'dynamic': the global model "
                                      "(2.6)-(2.16) with inertia (density), Kelvin-Voigt viscosity "
                                      "(viscosity_time) and Prony branches (prony), every time step; 'viscous': "
                                      "the same without inertia (quasi-static creep and relaxation)")
    plane_model: str = field(one_of("plane_strain", "plane_stress"), "plane_strain",
                             doc="2D plane scenes: plane strain (eps_zz = 0) or plane stress (sigma_zz = 0)")
    coupling: str = field(one_of("none", "staggered", "iterated"), "none",
                          doc="transient thermo-mechanical scenes: 'none' (the temperature drives the thermal "
                              "stress; mechanics at the output steps only), 'staggered' (problem (P_c): the "
                              "deformation heating -Theta_0 beta : e(u_t) of (2.49) from the previous step's "
                              "displacement rate enters the heat step, mechanics is solved every step) or "
                              "'iterated' (the heat and mechanics steps repeated within a step until they agree)")
    coupling_tolerance: float = field(bounded(number, **RELATIVE_TOLERANCE), 1e-6,
                                      doc="'iterated': relative change of T and u between two passes that ends "
                                          "a step's iteration")
    coupling_max_iterations: int = field(bounded(integer, 1), 20,
        doc="'iterated': passes per step before the run stops")


@dataclass(frozen=True, kw_only=True)
class MeshSettings:
    """``[mesh]``: mesh size and finite element order."""

    maxh: float = field(positive(number), 1.0, doc="global maximal element size, m")
    order: int = field(bounded(integer, 1, 6), 1,
        doc="polynomial order of the fields (curved boundaries to the same order)")
    grading: float = field(bounded(number, 0.05, 1, note="(netgen's finest preset is 0.1)"), 0.3,
                           doc="netgen grading: smaller gives slower growth; below 0.05 netgen's meshes grow far "
                               "beyond the element estimate of max_elements (0.001 gives ten times the elements of "
                               "0.01) and below about 1e-4 netgen runs out of memory or crashes")
    boundary_maxh: dict = field(dict_of(positive(number)), {}, doc="maximal element size per boundary name, m")
    max_elements: int = field(bounded(integer, 1), 5_000_000,
                              doc="largest mesh accepted: a scene whose element count, estimated before meshing from "
                                  "the blocks' areas (volumes) and the element sizes, exceeds it is refused (netgen "
                                  "makes 0.5 to 3 times the estimate); raise it for a larger machine")
    structured: bool = field(boolean, False,
                             doc="a structured (tensor-product) grid instead of netgen's mesher, for scenes whose "
                                 "blocks are all axis-aligned rectangles (plane, axisymmetric) or boxes (3d): the "
                                 "grid lines are every block's sides, each interval cut into equal cells no larger "
                                 "than the axis' size (mesh.sizes), the blocks' maxh and the boundaries' "
                                 "boundary_maxh; names and contact sides as netgen's meshes have them")
    elements: str = field(one_of(*MESH_ELEMENTS), "simplex",
                          doc="structured meshes: 'simplex' (each grid cell split into triangles / tetrahedra) or "
                              "'tensor' (quadrilaterals / hexahedra)")
    sizes: list | None = field(optional(list_of(positive(number))), None,
                               doc="structured meshes: the largest cell size along each axis [hx, hy(, hz)], m "
                                   "(default maxh along every axis); e.g. a strip one cell high: [0.003, 0.1]")


@dataclass(frozen=True, kw_only=True)
class Segment:
    """One piece of a ``profile`` block outline (also of a ``prism``'s): a straight line, a spline or a circular
    arc from the previous point to its end point."""

    line: list | None = field(optional(point), None, doc="end point [x, y] of a straight segment, m")
    spline: list | None = field(optional(list_of(point)), None,
                                doc="points [[x, y], ...] the spline passes through; the last is its end")
    arc: list | None = field(optional(list_of(point, 2)), None,
                             doc="[[x, y] a point the arc passes through, [x, y] its end]: the circular arc from "
                                 "the previous point through the first to the second (three points not on one "
                                 "line), m")
    name: str = field(string, "", doc="boundary name of this segment")


@dataclass(frozen=True, kw_only=True)
class Block:
    """``[[blocks]]``: one body. Later blocks are cut out of earlier ones (painter's order)."""

    name: str = field(string, doc="region (material) name")
    shape: str = field(one_of(*SHAPES_2D, *SHAPES_3D),
                       doc="rectangle, polygon, circle, profile | box, cylinder, prism (a polygon or profile "
                           "extruded), import (a STEP or BREP file)")
    origin: list | None = field(optional(point), None,
                                doc="lower corner (rectangle, box); prism: the point of the profile's plane where "
                                    "the outline's (0, 0) lies (default [0, 0, 0]), m")
    size: list | None = field(optional(point), None, doc="extent (rectangle, box), m")
    points: list | None = field(optional(list_of(point)), None,
                                doc="polygon corners in order (also a prism's outline), m")
    edges: list | None = field(optional(list_of(string)), None,
                               doc="polygon: boundary name of each side (side i runs from point i to i+1); prism: "
                                   "the name of the side face extruded from it")
    start: list | None = field(optional(point), None, doc="profile (also a prism's outline): start point, m")
    segments: list | None = field(optional(list_of(nested(Segment))), None,
                                  doc="profile (also a prism's outline): outline pieces; a prism's side faces "
                                      "take their names")
    center: list | None = field(optional(point), None, doc="circle centre, or cylinder base centre, m")
    radius: float | None = field(optional(number), None, doc="circle or cylinder radius, m")
    height: float | None = field(optional(number), None, doc="cylinder height, m")
    axis: list | None = field(optional(point), None,
                              doc="cylinder axis direction (default z); prism: the extrusion direction (default "
                                  "u x v, normal to the outline's plane)")
    directions: list | None = field(optional(list_of(point, 2)), None,
                                    doc="prism: two orthogonal directions [u, v] of the outline's plane (the "
                                        "outline's x runs along u, its y along v; default [[1, 0, 0], [0, 1, 0]])")
    length: float | None = field(optional(positive(number)), None,
                                 doc="prism: extrusion length along axis, m")
    file: str | None = field(optional(string), None,
                             doc="import: a STEP (.step, .stp) or BREP (.brep) file, relative to the scene file "
                                 "(a scene built in Python or a --set value: to the working directory); only read")
    length_unit: str = field(one_of("declared", *LENGTH_UNITS), "declared",
                             doc="import: the unit of the file's coordinates: 'declared' (the unit a STEP file "
                                 "declares, converted to m; BREP files declare none and are read in m) or one of "
                                 + ", ".join(LENGTH_UNITS) + " (the numbers as written, whatever unit the file "
                                 "declares; netgen.occ's WriteStep labels its numbers mm: read its files with 'm' "
                                 "when they were built in m)")
    solids: dict = field(dict_of(string), {},
                         doc="import: region name of the file's named solids (file name -> region); solids "
                             "left out are the region named like the block")
    faces: dict = field(dict_of(string), {},
                        doc="import: boundary name of the file's named faces (file name -> boundary); faces left "
                            "out keep the file's name")
    boundaries: dict = field(dict_of(either(string, list_of(string), what="a selector or list of selectors")),
                             {}, doc="boundary name -> selector(s) of this block's own sides: "
                                     + ", ".join(SELECTORS))
    maxh: float | None = field(optional(positive(number)), None, doc="maximal element size in this block, m")


@dataclass(frozen=True, kw_only=True)
class Cut:
    """``[[cuts]]``: a plane (3D) or a line (2D) that splits blocks in two, after the blocks are assembled
    (painter's order). Axes: x east, y north, z up (2D: x east, y up). In 3D the plane passes through ``point``
    with strike azimuth ``strike`` (degrees clockwise from north = +y) and dips by ``dip`` degrees from the
    horizontal to the right of the strike (right-hand rule): its upward normal is
    (sin(dip) cos(strike), -sin(dip) sin(strike), cos(dip)). In 2D the line through ``point`` dips by ``dip``
    towards +x (strike 0) or -x (strike 180). Each block's part above the plane (the side the upward normal
    points to; for dip = 90 the side the dip direction points to) and the part below become regions of the
    names in ``parts``; the cut face between them is an interface declared in ``[[interfaces]]`` like any other
    (blocks = the two parts; glued, or contact for a fault), or, when none is declared, a glued interface named
    ``name`` (one block cut) or ``<name>_<block>`` (several). A part named '' is removed: the cut face is then
    an outer boundary named ``name``."""

    name: str = field(string, doc="the cut's name (of the cut face: interface or boundary)")
    point: list = field(point, doc="a point of the plane (line), m")
    dip: float = field(bounded(number, 0, 90, unit="deg"), doc="dip from the horizontal, degrees in [0, 90]")
    strike: float = field(bounded(number, 0, 360, hi_open=True, unit="deg"), 0.0,
                          doc="strike azimuth, degrees clockwise from north (+y) in [0, 360); the plane dips to "
                              "its right. 2D: 0 (dipping towards +x) or 180 (towards -x)")
    blocks: list = field(list_of(string), doc="the blocks (or parts of earlier cuts) it splits")
    parts: list = field(list_of(list_of(string, 2)),
                        doc="for each block: [name of the part above, name of the part below] ('' removes that "
                            "part)")


@dataclass(frozen=True, kw_only=True)
class ContactMechanics:
    """The mechanical contact law of an interface or a rigid foundation (2.23)-(2.27): non-penetration
    always; friction per ``law``. Used only when physics.mechanics is on."""

    law: str = field(one_of(*CONTACT_LAWS), "frictionless",
                     doc="'frictionless' (2.27), 'tresca' (slip bound g_c, (2.24)-(2.26)) or 'coulomb' "
                         "(slip bound friction * normal pressure); in 3D the tangential traction is a vector with "
                         "|q| <= the slip bound")
    slip_bound: object = field(optional(expr), None,
                               doc="Tresca slip bound g_c, Pa: a number or an expression of x, y (z), "
                                   "evaluated at the contact nodes")
    friction: object = field(optional(material_value(bounded(number, 0, note="(0: frictionless)"))), None,
                             doc="Coulomb friction coefficient F_c (>= 0; 0 is frictionless contact): a number or an "
                                 "expression of x, y (z), r, evaluated at the contact nodes")
    method: str = field(one_of(*CONTACT_METHODS), "ssn",
                        doc="'ssn': semi-smooth Newton / primal-dual active set on the augmented Lagrangian "
                            "(exact constraints; the default), 'penalty': plain penalty (penetration "
                            "~ pressure / augmentation), 'uzawa': the seed's Uzawa algorithm (2.66) for the "
                            "friction multipliers (reference; slow; 2D only)")
    uzawa_step: float | None = field(optional(positive(number)), None,
                                     doc="method = 'uzawa': the step rho of the friction multipliers, Pa/m (> 0; "
                                         "default 2 x the largest stiffness entry over the extent of the contact "
                                         "side, 2 E/L; a step above about 2 E/L oscillates and is halved after 30 "
                                         "steps without progress)")
    augmentation: float | None = field(optional(positive(number)), None,
                                       doc="augmentation / penalty parameter c, Pa/m (default: the largest "
                                           "stiffness entry of the materials over the nodal size, E/h)")
    search_distance: float | None = field(optional(positive(number)), None,
                                          doc="largest initial gap seen as contact, m (default a quarter of "
                                              "the contact side's extent); points of the side farther from the "
                                              "other side never come into contact")
    frictional_heating: bool | None = field(optional(boolean), None,
                                            doc="true: in coupled scenes (physics.coupling 'staggered' or "
                                                "'iterated') with a frictional law, the power tau_t . [du_t/dt] "
                                                "dissipated by sliding (W/m^2) enters the heat or Stefan step as an "
                                                "interface heat source, shared between the two sides by "
                                                "heat_partition (docs/methods.md, 'Frictional heating'); unset or "
                                                "false: off")
    heat_partition: object = field(optional(either(bounded(number, 0, 1), one_of("effusivity"),
                                                   what="a number in [0, 1] or 'effusivity'")), None,
                                   doc="frictional_heating: the share of the frictional heat entering the contact "
                                       "side's body (the interface's master block; the rest enters the other "
                                       "block), or 'effusivity': sqrt(k rho c) of the side's material over the sum "
                                       "of both sides' (the split of two half-spaces in perfect contact). Default "
                                       "'effusivity' on an interface, 1 on a foundation (the rigid foundation is "
                                       "not modelled: the whole heat enters the body)")


@dataclass(frozen=True, kw_only=True)
class Interface(ContactMechanics):
    """``[[interfaces]]``: where two blocks touch; ``glued`` (conforming mesh) or ``contact``
    (independent, possibly non-matching meshes, coupled weakly). A contact interface carries heat (mortar
    coupling) and, in mechanical scenes, the contact law of the inherited keys (law, friction, ...).

    A ``contact`` interface between blocks that do not touch (an initial gap, e.g. a canister in a borehole)
    names its two sides with ``sides``: the gap closes under load (mechanics, initial gaps measured along the
    contact side's normal up to ``search_distance``). Without conductance keys it carries no heat (for heat both
    sides are outer boundaries, insulated unless a thermal condition is given there).

    Contact conductance (``conductance``, ``conductance_coefficient``/``conductance_exponent``,
    ``gap_conductivity``, ``emissivities``): heat crosses the interface as q = h(p, g) (T_m - T_s) plus
    radiation, with h following the mechanics' contact pressure p and gap g at every coupled step
    (:mod:`ngs_geomech.heat.conductance`); without mechanics p = 0 and g is the geometry's gap."""

    name: str = field(string, doc="interface name")
    blocks: list = field(list_of(string, 2), doc="the two block names")
    type: str = field(one_of("glued", "contact"), "glued", doc="'glued' or 'contact'")
    master: str | None = field(optional(string), None,
                               doc="contact: block whose side carries the coupling (default the first)")
    thermal_penalty: float | None = field(optional(number), None,
                                          doc="phase-change (Stefan) scenes: the contact interface passes heat by a "
                                              "penalty on the temperature jump, conductance thermal_penalty * k / h "
                                              "(W/(m^2 K); dimensionless, default 1e3: a jump of about 1/1000 of "
                                              "the drop over one element); other scenes couple exactly (mortar)")
    sides: list | None = field(optional(list_of(string, 2)), None,
                               doc="contact between blocks that do not touch (initial gap): [boundary name on "
                                   "the first block, boundary name on the second block], from the blocks' "
                                   "boundaries selectors or polygon/profile edge names; each name only on its "
                                   "block. Touching blocks leave it out (their shared side is found)")
    # -- thermal contact conductance (heat and Stefan scenes; ngs_geomech.heat.conductance) --
    conductance: object = field(optional(either(positive(number, "W/(m^2 K)"), one_of("perfect"),
                                                list_of(list_of(number, 2)),
                                                what="a positive number (W/(m^2 K)), 'perfect', or a table "
                                                     "[[p (Pa), h (W/(m^2 K))], ...]")), None,
                                doc="contact conductance h_c of the closed parts (heat crosses the interface as "
                                    "q = h (T_m - T_s)): a number, W/(m^2 K); a table [[p, h], ...] of the contact "
                                    "pressure p (Pa, increasing, >= 0) -> h (W/(m^2 K), >= 0), piecewise linear, "
                                    "constant beyond its ends; or 'perfect' (T and the flux continuous: the mortar "
                                    "coupling of heat scenes, the thermal_penalty of Stefan scenes; the default "
                                    "between touching blocks when no conductance key is given)")
    conductance_coefficient: float | None = field(optional(positive(number)), None,
                                                  doc="power law h_c = C p^m of the closed parts: C, "
                                                      "W/(m^2 K) Pa^-m (p the contact pressure of the mechanics, "
                                                      "Pa; needs mechanics and coupling)")
    conductance_exponent: float | None = field(optional(bounded(number, 0, 3)), None,
                                               doc="power law h_c = C p^m: the exponent m (dimensionless, in "
                                                   "[0, 3]; about 0.95 for rough metal surfaces)")
    gap_conductivity: float | None = field(optional(positive(number, "W/(m K)")), None,
                                           doc="conductivity k_gap of the gap's fill (gas, water), W/(m K): the "
                                               "interface passes k_gap / max(g, minimum_gap) (W/(m^2 K)) more, g "
                                               "the gap (m)")
    minimum_gap: float | None = field(optional(positive(number, "m")), None,
                                      doc="the gap floor g_min of k_gap / max(g, g_min), m (about the surfaces' "
                                          "roughness; default 1e-6 m): a closed or nearly closed interface "
                                          "conducts as a gap of g_min")
    emissivities: list | None = field(optional(list_of(bounded(number, 0, 1, lo_open=True), 2)), None,
                                      doc="radiation between the faces: [emissivity of the master side, of the "
                                          "minion side] (in (0, 1]); q_rad = sigma eps (T_m^4 - T_s^4), eps = "
                                          "1/(1/e1 + 1/e2 - 1), T absolute")
    radiation: str | None = field(optional(one_of("exact", "linearized")), None,
                                  doc="with emissivities: 'exact' (T^4 in Newton's method; the default in heat "
                                      "scenes) or 'linearized' (h_rad = sigma eps (T_m^2 + T_s^2)(T_m + T_s) at the "
                                      "temperatures of the start of the step; the default and the only choice in "
                                      "Stefan scenes)")


@dataclass(frozen=True, kw_only=True)
class Foundation(ContactMechanics):
    """``[boundary_conditions.NAME.foundation]``: a rigid, fixed, straight (2D) or plane (3D) foundation the
    boundary NAME may touch (Signorini contact with the law of the inherited keys).
    Initial gaps are the distances from the boundary to the foundation line (plane) along the boundary's
    normal."""

    point: list = field(list_of(number), doc="a point of the foundation surface, m")
    normal: list = field(list_of(number), doc="the foundation's outward normal (pointing towards the body)")


expansion_value = either(material_value(number), list_of(list_of(material_value(number))),
                         what="a number or a symmetric 3x3 matrix (1/K); the number and each entry may be an "
                              "expression of x, y, z, r")
LAMBDA_LAW = ("the lambda law (2.1)-(2.5) takes rheology_lambda and reference_strain as numbers (its secant factor "
              "and reference energy are built per region)")
conductivity_scalar = material_value(positive(number, "W/(m K)"), temperature=True)
"""A conductivity, W/(m K): a positive number, or an expression of x, y, z, r and T (positive where it applies)."""
conductivity_value = either(conductivity_scalar, list_of(list_of(material_value(number, temperature=True))),
                            what="a positive number or a symmetric positive definite matrix [[kxx, kxy], [kxy, kyy]]; "
                                 "the number and each entry may be an expression of x, y, z, r, T")


@dataclass(frozen=True, kw_only=True)
class PronyTerm:
    """One Maxwell branch of a material's Prony series."""

    modulus_ratio: float = field(positive(number), doc="C_k / C")
    relaxation_time: float = field(positive(time, "s"), doc="tau_k, s")


@dataclass(frozen=True, kw_only=True)
class Orthotropic:
    """Orthotropic engineering constants in the material axes 1, 2, 3 (Pa); nu_ij = -eps_j / eps_i."""

    E: list = field(list_of(material_value(positive(modulus, "Pa")), 3),
                    doc="[E1, E2, E3], Pa (each a number or an expression of x, y, z, r)")
    nu: list = field(list_of(material_value(number), 3), doc="[nu12, nu13, nu23] (numbers or expressions)")
    G: list = field(list_of(material_value(positive(modulus, "Pa")), 3),
                    doc="[G12, G13, G23], Pa (numbers or expressions)")


@dataclass(frozen=True, kw_only=True)
class TransverselyIsotropic:
    """Transversely isotropic constants: isotropic in the 1-2 plane, axis 3 (e.g. bedding normal)."""

    E_plane: object = field(material_value(positive(modulus, "Pa")),
                            doc="Young's modulus in the plane of isotropy, Pa (a number or an expression of x, y, "
                                "z, r, as every entry here)")
    E_axis: object = field(material_value(positive(modulus, "Pa")), doc="Young's modulus along the axis, Pa")
    nu_plane: object = field(material_value(bounded(number, -1, lo_open=True)),
                             doc="Poisson ratio in the plane (nu12)")
    nu_axis: object = field(material_value(number), doc="Poisson ratio nu31 = -eps_1/eps_3 under axial load")
    G_axis: object = field(material_value(positive(modulus, "Pa")),
                           doc="shear modulus in planes containing the axis (G13), Pa")


@dataclass(frozen=True, kw_only=True)
class Material:
    """``[materials.REGION]``: material data of one region, SI units.

    Phase change (two-phase Stefan problem, seed (2.46)-(2.51), (2.55)): a region with
    ``phase_change_temperature`` Theta_R (degC or K) melts above and freezes below it. Its enthalpy (J/m^3) is
    e = C_s (T - Theta_R) for T < Theta_R, in [0, L] at Theta_R (the mushy part; liquid fraction e / L) and
    L + C_l (T - Theta_R) above, with C_s = ``rho_c`` (or density * specific_heat) of the solid,
    C_l = ``rho_c_liquid`` (or density * ``specific_heat_liquid``) and the volumetric latent heat
    L = density * ``latent_heat`` (J/kg) or ``latent_heat_volumetric`` (J/m^3); the conductivity is
    ``conductivity`` (or ``conductivity_principal``: solid) and ``conductivity_liquid`` (or
    ``conductivity_liquid_principal``), W/(m K): numbers or tensors, the liquid's proportional to the solid's (the
    phases scale one anisotropy). The conductivities may vary in x, y, z when the two phases share the variation
    (k_l(x) = c k_s(x), c one constant per region); the heat capacities and the latent heat are numbers. The phase
    boundary is where the liquid fraction is 1/2. Only transient, backward Euler, P1 (mesh.order = 1) scenes (plane,
    axisymmetric or 3D).
    """

    conductivity: object = field(optional(conductivity_value), None,
                                 doc="thermal conductivity kappa_ij, W/(m K): scalar or full symmetric tensor; the "
                                     "scalar and the entries may be expressions of x, y, z, r (m) and T (the "
                                     "temperature, scene unit; the heat solver's Newton iteration takes "
                                     "d kappa/dT): positive (definite) where they apply")
    conductivity_principal: list | None = field(optional(list_of(conductivity_scalar)), None,
                                                doc="principal conductivities, W/(m K) (with conductivity_angle); "
                                                    "numbers or expressions of x, y, z, r, T")
    conductivity_angle: object = field(optional(either(number, point, what="an angle or 3 angles")), None,
                                       doc="rotation of the principal axes, degrees: one angle in 2D "
                                           "(from x), Z-Y-X Euler angles [a, b, c] in 3D")
    conductivity_temperature_coefficient: float = field(number, 0.0,
                                                        doc="b in kappa(T) = kappa (1 + b (T - T_ref)), 1/K")
    reference_temperature: float = field(number, 0.0, doc="T_ref of the conductivity law, degC or K")
    viscosity_time: float | None = field(optional(positive(time, "s")), None,
                                         doc="Kelvin-Voigt viscosity C^v = viscosity_time * C (s; dynamic or viscous "
                                             "mechanics)")
    prony: list = field(list_of(nested(PronyTerm)), [],
                        doc="Prony series of Maxwell branches in parallel with the (relaxed) elastic C: "
                            "[{modulus_ratio = r, relaxation_time = tau}, ...], C_k = r C")
    conductivity_pressure_coefficient: float = field(number, 0.0,
                                                     doc="c_p in kappa(T, p) = kappa(T) (1 + c_p p), 1/Pa, p the "
                                                         "mean pressure (compression > 0) of the mechanics; needs "
                                                         "physics.coupling (the pressure of the last mechanics "
                                                         "solve enters each heat step)")
    rho_c: object = field(optional(material_value(positive(number, "J/(m^3 K)"), temperature=True)), None,
                          doc="volumetric heat capacity rho*c, J/(m^3 K): a number or an expression of x, y, z, r "
                              "and T (transient heat: the step takes rho c at theta T_new + (1 - theta) T_old; "
                              "Newton takes d(rho c)/dT)")
    density: object = field(optional(material_value(positive(number, "kg/m^3"))), None,
                            doc="rho, kg/m^3 (with specific_heat; gravity, inertia): a number or an expression of "
                                "x, y, z, r")
    specific_heat: object = field(optional(material_value(positive(number, "J/(kg K)"), temperature=True)), None,
                                  doc="c, J/(kg K) (with density): a number or an expression of x, y, z, r and T")
    youngs_modulus: object = field(optional(material_value(positive(modulus, "Pa"), temperature=True)), None,
                                   doc="E, Pa (isotropic, with poisson_ratio): a number or an expression of x, y, z, r "
                                       "and T (the temperature of the thermal solution, scene unit; needs "
                                       "physics.thermal)")
    poisson_ratio: object = field(optional(material_value(bounded(number, -1, 0.5, lo_open=True, hi_open=True))),
                                  None, doc="nu (isotropic): a number or an expression of x, y, z, r")
    lame_lambda: object = field(optional(material_value(modulus)), None,
                                doc="Lame lambda, Pa (with lame_mu; the bulk modulus lambda + 2 mu / 3 > 0): a number "
                                    "or an expression of x, y, z, r")
    lame_mu: object = field(optional(material_value(positive(modulus, "Pa"))), None,
                            doc="shear modulus mu, Pa (with lame_lambda): a number or an expression of x, y, z, r")
    orthotropic: Orthotropic | None = field(optional(nested(Orthotropic)), None, doc="orthotropic constants")
    transversely_isotropic: TransverselyIsotropic | None = field(optional(nested(TransverselyIsotropic)), None,
                                                                 doc="transversely isotropic constants")
    stiffness_voigt: list | None = field(optional(list_of(list_of(material_value(modulus)))), None,
                                         doc="full 6x6 stiffness c_ijkl in Voigt order xx, yy, zz, yz, xz, xy "
                                             "(engineering shear strains), Pa; symmetric positive definite (2.38); "
                                             "entries numbers or expressions of x, y, z, r (symmetric as written)")
    elastic_rotation: object = field(optional(either(number, point, what="an angle or 3 angles")), None,
                                     doc="rotation of the material axes, degrees: about z (2D), Z-Y-X Euler (3D)")
    thermal_expansion: object = field(optional(expansion_value), None,
                                      doc="linear thermal expansion alpha, 1/K: scalar or symmetric 3x3 tensor "
                                          "(beta_ij = c_ijkl alpha_kl, (2.18)); the scalar and the entries may be "
                                          "expressions of x, y, z, r")
    stress_free_temperature: object = field(material_value(number), 0.0,
                                            doc="T0 of the thermal stress -beta (T - T0), degC or K: a number or an "
                                                "expression of x, y, z, r")
    rheology_lambda: float = field(constant(positive(at_most(10.0)), LAMBDA_LAW), 1.0,
                                   doc="lambda of W = A1^lambda (2.1): <1 softening, 1 linear, >1 hardening (at most "
                                       "10: the secant stiffness scales with (A1/A_ref)^(lambda-1), which overflows "
                                       "for larger exponents); a number (a material with lambda != 1 takes numbers for "
                                       "its elastic constants)")
    reference_strain: float = field(constant(positive(number), LAMBDA_LAW), 1e-3,
                                    doc="strain scale of the lambda law: c* = lambda (A1/A_ref)^(lambda-1) c with "
                                        "A_ref the A1 of this uniaxial strain; a number")
    phase_change_temperature: float | None = field(
        optional(number), None,
        doc="Theta_R of (2.46)-(2.48), degC or K: the region melts (freezes) at this temperature; the Stefan problem "
            "in enthalpy form (2.49)-(2.51), (2.55) replaces the heat equation (physics.thermal = 'transient'). "
            "rho_c (or density * specific_heat) and conductivity are then the solid's")
    latent_heat: float | None = field(optional(bounded(number, 0, unit="J/kg")), None,
                                      doc="latent heat of fusion L per unit mass, J/kg, with density: the "
                                          "volumetric latent heat of (2.48) is density * latent_heat")
    latent_heat_volumetric: float | None = field(optional(bounded(number, 0, unit="J/m^3")), None,
                                                 doc="rho L, J/m^3, instead of latent_heat (e.g. ice content "
                                                     "of a frozen soil: porosity * 917 kg/m^3 * 334 kJ/kg)")
    rho_c_liquid: float | None = field(optional(positive(number, "J/(m^3 K)")), None,
                                       doc="volumetric heat capacity of the liquid phase, J/(m^3 K)")
    specific_heat_liquid: float | None = field(optional(positive(number, "J/(kg K)")), None,
                                               doc="specific heat of the liquid phase, J/(kg K), with density "
                                                   "(instead of rho_c_liquid; the density is that of both phases)")
    conductivity_liquid: object = field(optional(either(material_value(positive(number, "W/(m K)")),
                                                        list_of(list_of(material_value(number))),
                                                        what="a positive number or a symmetric positive definite "
                                                             "matrix [[kxx, kxy], [kxy, kyy]] (W/(m K)); the number "
                                                             "and each entry may be an expression of x, y, z, r")),
                                        None,
                                        doc="thermal conductivity of the liquid phase, W/(m K): a number (isotropic) "
                                            "or a tensor proportional to the solid's (conductivity); the Kirchhoff "
                                            "variable (2.50) is piecewise linear. Expressions of x, y, z, r: the "
                                            "ratio to the solid's conductivity must be one constant over the region")
    conductivity_liquid_principal: list | None = field(
        optional(list_of(material_value(positive(number, "W/(m K)")))), None,
        doc="principal conductivities of the liquid phase, W/(m K), in the axes of conductivity_angle (instead of "
            "conductivity_liquid): proportional to the solid's conductivity_principal (numbers or expressions of "
            "x, y, z, r, the ratio one constant over the region)")


@dataclass(frozen=True, kw_only=True)
class BoundaryCondition:
    """``[boundary_conditions.NAME]``: one condition per boundary name; unnamed boundaries are insulated."""

    temperature: object = field(optional(expr), None, doc="prescribed temperature T (2.19), degC or K")
    flux: object = field(optional(expr), None,
                         doc="prescribed heat flux into the body q0 = kappa_ij dT/dx_j n_i (2.21), W/m^2")
    insulated: bool = field(boolean, False, doc="kappa dT/dn = 0 (2.20)")
    heat_transfer_coefficient: float | None = field(optional(positive(number)), None,
                                                    doc="Robin: q = h (T_ambient - T), W/(m^2 K)")
    ambient_temperature: object = field(optional(expr), None, doc="Robin ambient temperature, degC or K")
    displacement: list | None = field(optional(list_of(either(expr, one_of("free"), what="an expression or 'free'"))),
                                      None, doc="prescribed displacement u0 (2.20), m, per component; 'free' "
                                                "leaves a component free")
    traction: list | None = field(optional(list_of(expr)), None, doc="surface force P (2.19), Pa, per component")
    pressure: object = field(optional(expr), None, doc="normal pressure p (traction -p n), Pa")
    symmetry: bool = field(boolean, False, doc="symmetry u_n = 0, tau_t = 0 (2.16) on a straight boundary")
    foundation: Foundation | None = field(optional(nested(Foundation)), None,
                                          doc="contact with a rigid foundation (Signorini, friction)")


@dataclass(frozen=True, kw_only=True)
class Source:
    """``[[sources]]``: heat source W (2.6) / Q (2.17) in one region."""

    region: str = field(string, doc="region the heat is released in")
    power: float | None = field(optional(number), None,
                                doc="total power P0, W (plane scenes: W per m of depth); spread uniformly over "
                                    "the region: density P0 / volume, W/m^3 (plane: P0 / area)")
    density: object = field(optional(expr), None, doc="power density Q(x, t), W/m^3 (instead of power)")
    decay: list = field(list_of(list_of(either(number, time, what="a number or a time"), 2)), [],
                        doc="[[a_i, tau_i], ...]: P(t) = P0 sum a_i exp(-(t - start)/tau_i); empty: constant")
    start: float = field(time, 0.0, doc="switch-on time, s")


@dataclass(frozen=True, kw_only=True)
class Initial:
    """``[initial]``: initial temperature, optionally per region; initial velocity (dynamic mechanics)."""

    temperature: object = field(expr, 0.0, doc="initial temperature T(x, 0), degC or K")
    regions: dict = field(dict_of(expr), {}, doc="region name -> initial temperature there")
    velocity: list | None = field(optional(list_of(expr)), None,
                                  doc="initial velocity u_t(x, 0), m/s, one expression per component "
                                      "(physics.mechanics = 'dynamic')")


@dataclass(frozen=True, kw_only=True)
class Dynamics:
    """``[dynamics]``: time integration of physics.mechanics = 'dynamic'."""

    rho_inf: float = field(number, 1.0, doc="generalized-alpha spectral radius at infinite frequency, [0, 1]: 1 "
                                            "no numerical damping (energy conserving, contact never adds energy), "
                                            "0 the highest modes damped in one step")
    mass: str = field(one_of("auto", "consistent", "lumped"), "auto",
                      doc="'lumped' (row sums, P1; with contact the contact nodes' mass is moved to their "
                          "neighbours: no chattering), 'consistent', or 'auto' (lumped with contact and P1)")


@dataclass(frozen=True, kw_only=True)
class MechanicsSettings:
    """``[mechanics]``: loads and nonlinear solver of the elastic problem."""

    gravity: list | None = field(optional(point), None, doc="gravitational acceleration vector, m/s^2")
    formulation: str = field(one_of(*FORMULATIONS), "auto",
                             doc="'displacement', 'mixed' (displacement-pressure: Taylor-Hood for order >= 2, "
                                 "stabilized P1-P1; isotropic linear regions, for Poisson ratios near 1/2) or "
                                 "'auto' (mixed in the isotropic regions with nu > 0.45 when the law is linear)")

    initial_stress: list | None = field(optional(list_of(list_of(expr))), None,
                                        doc="initial (e.g. lithostatic) stress tensor sigma0, Pa (expressions): "
                                            "dim x dim; plane strain also takes 3x3 with xz = yz = 0, whose zz "
                                            "entry is the out-of-plane prestress (sigma_zz = zz + the plane-strain "
                                            "elastic and thermal part; without it sigma_zz has no prestress)")
    nonlinear_solver: str = field(one_of(*NONLINEAR_SOLVERS), "newton",
                                  doc="for rheology_lambda != 1: Newton on W (line search) or the secant modules "
                                      "method (2.32)-(2.34)")
    secant_relaxation: float | None = field(optional(bounded(number, 0, 2, lo_open=True)), None,
                                            doc="secant method step: none (default) takes the energy-minimising "
                                                "step along the secant direction; 1.0 is the plain method (2.32)")
    tolerance: float = field(bounded(number, **RELATIVE_TOLERANCE), 1e-8,
                             doc="relative tolerance of the nonlinear iteration")
    max_iterations: int = field(bounded(integer, 1), 100, doc="iteration limit of the nonlinear solver")
    uzawa_max_steps: int = field(bounded(integer, 1), 1000,
        doc="contacts with method = 'uzawa': the most Uzawa steps (2.66) "
            "per contact solve (>= 1)")
    regularization: float = field(bounded(number, 0), 1e-6,
        doc="delta in (A1/A_ref + delta)^lambda (lambda < 1 is singular "
            "at zero strain)")
    nested_levels: int = field(bounded(integer, 0, 6), 0,
        doc="Newton on the lambda law (no contact): start from the solution on "
            "meshes 2^k times coarser (mesh.maxh and boundary_maxh scaled), k = "
            "nested_levels ... 1, each started from the one before (nested "
            "iteration); 0: from the linear elastic solution")


@dataclass(frozen=True, kw_only=True)
class SolverSettings:
    """``[solver]``: the linear solver of the heat and elasticity systems and of the contact and Stefan Newton steps
    (GMRES with an augmented-Lagrangian AMG preconditioner, :mod:`ngs_geomech.contact.krylov`; GMRES with
    h1amg, :mod:`ngs_geomech.stefan.solver`); the mortar heat coupling, dynamic contact and the mixed formulation
    always solve directly."""

    linear: str = field(one_of(*SOLVERS), "auto",
                        doc="'direct' (sparse Cholesky / UMFPACK), 'iterative' (CG with BDDC for order >= 2, two-level "
                            "AMG for 3D P2 elasticity, AMG for P1; contact Newton steps by GMRES with an augmented-"
                            "Lagrangian AMG preconditioner) or 'auto' (iterative above 60k unknowns per system in 3D, "
                            "1M in 2D; contact Newton steps above 20k displacement dofs in 3D, Stefan Newton steps "
                            "above 5k nodes in 3D)")
    tolerance: float = field(bounded(number, **RELATIVE_TOLERANCE), 1e-10,
                             doc="relative residual of the iterative solver")
    max_iterations: int = field(bounded(integer, 1), 2000, doc="iteration limit of the iterative solver")
    preconditioner: str = field(one_of(*PRECONDITIONERS), "auto",
                                doc="of the iterative solver: 'auto' (serial: two-level AMG for 3D P2 elasticity, "
                                    "BDDC with an AMG vertex problem for 3D P2 heat, BDDC for order >= 2 otherwise, "
                                    "AMG for P1; distributed: 'gamg' when petsc4py is installed, else BDDC), 'bddc' "
                                    "(BDDC with the vertex problem factored directly, order >= 2) or 'gamg' (PETSc's "
                                    "CG with algebraic multigrid and the rigid-body near-null space; needs the extra "
                                    "'petsc')")


@dataclass(frozen=True, kw_only=True)
class TimeSettings:
    """``[time]``: time interval and step control."""

    start: float = field(time, 0.0, doc="start time, s")
    end: float = field(time, doc="end time, s")
    dt: float = field(positive(time), doc="first time step, s")
    dt_growth: float = field(bounded(number, 1), 1.0, doc="factor applied to dt after each step")
    dt_max: float | None = field(optional(time), None, doc="largest time step, s")
    scheme: str = field(one_of("backward_euler", "crank_nicolson"), "backward_euler",
                        doc="theta scheme: backward Euler (theta=1) or Crank-Nicolson (theta=1/2)")
    startup_steps: int = field(bounded(integer, 0), 0,
                               doc="crank_nicolson: take the first N steps with backward Euler (Rannacher's "
                                   "start-up: damps the stiff modes that a source or boundary value switched on "
                                   "at the start excites and Crank-Nicolson never damps; 2-4 typical)")
    stefan_step_control: str = field(one_of("adaptive", "halving"), "adaptive",
                                     doc="scenes with phase change: how the Stefan solver divides a step into "
                                         "substeps (dt / 2^k, k <= 6; the output times stay): 'adaptive' keeps "
                                         "the substep from step to step, finer after Newton failures, many Newton "
                                         "iterations or a front crossing many element layers, coarser (up to dt) "
                                         "after easy substeps; 'halving' starts every step at dt and halves a "
                                         "failed one recursively")


PROBE_THERMAL = ("temperature", "liquid_fraction", "front")
"""Probe quantities of the heat (Stefan) problem, recorded at every step."""
PROBE_PHASE = ("liquid_fraction", "front")
"""Probe quantities of a phase change."""
PROBE_MECHANICAL = ("displacement_x", "displacement_y", "displacement_z", "von_mises", "mean_stress", "sigma_1",
                    "sigma_3")
"""Probe quantities of the mechanics, recorded when it is solved."""
PROBE_QUANTITIES = PROBE_THERMAL + PROBE_MECHANICAL


@dataclass(frozen=True, kw_only=True)
class Probe:
    """``[[output.probes]]``: a value recorded at each output time."""

    name: str = field(string, doc="probe name (key in summary.json)")
    quantity: str = field(one_of(*PROBE_QUANTITIES), "temperature",
                          doc="field to sample; with phase change also 'liquid_fraction' (0 solid .. 1 liquid, "
                              "at a point or over a region) and 'front' (with line: the distance in m from the "
                              "line's first point to the first crossing of liquid_fraction = 0.5 along it, "
                              "recorded as null while there is none)")
    point: list | None = field(optional(point), None, doc="a point, m")
    line: list | None = field(optional(segment_points), None,
                              doc="front probes: [[x0, y0], [x1, y1]] (3D: [x, y, z]), m, sampled finely from the "
                                  "first point to the second")
    region: str | None = field(optional(string), None, doc="a region (max/min/mean over it)")
    boundary: str | None = field(optional(string), None, doc="a boundary (max/min/mean over it)")
    statistic: str = field(one_of("value", "max", "min", "mean"), "value",
                           doc="'value' at a point, or max/min/mean over a region or boundary")
    limit: float | None = field(optional(number), None,
                                doc="a reference value (e.g. a design limit, in the probe's units) drawn as a "
                                    "dashed line in the probe figure")


@dataclass(frozen=True, kw_only=True)
class Section:
    """``[[output.sections]]``: a plane section of a 3D scene the fields are drawn on at the last time: the
    temperature (``figures/temperature_section_<name>.png``) and, with mechanics, the von Mises stress
    (``von_mises_section_<name>.png``), sampled on a regular grid in the plane, with the cut of the blocks'
    boundaries and interfaces."""

    name: str = field(string, doc="section name (part of the figure file names)")
    point: list = field(list_of(number, 3), doc="a point of the plane, [x, y, z], m")
    normal: list = field(list_of(number, 3),
                         doc="the plane's normal [nx, ny, nz] (not zero). Normal to an axis (e.g. [0, 1, 0]) the "
                             "plane is drawn in the other two coordinates in order (x and z); otherwise in u "
                             "(horizontal, along v x normal) and v (up the plane: the steepest ascent of z in it)")
    window: list | None = field(optional(list_of(number, 4)), None,
                                doc="[umin, umax, vmin, vmax] of the figure in the plane's coordinates (above), m; "
                                    "default: the domain's bounding box cut by the plane")


@dataclass(frozen=True, kw_only=True)
class Output:
    """``[output]``: what is written (VTK series, figures, summary.json)."""

    vtk: bool = field(boolean, True, doc="write a VTK series (.vtu per output time and a .pvd)")
    contact_vtp: bool = field(boolean, True,
                              doc="mechanics with contact: write each contact's series <scene>_contact_<name> (.vtp "
                                  "per output time and a .pvd: nodal pressure, traction, gap, slip, status, slip "
                                  "bound), independently of vtk (the only nodal output of the multipliers)")
    every: int = field(bounded(integer, 1), 1, doc="write VTK every N-th step (the last step is always written)")
    checkpoint_every: int | None = field(optional(bounded(integer, 0, note="(0: no checkpoints)")), None,
                                         doc="time-dependent runs: a checkpoint every N steps (0: no periodic ones; a "
                                             "failing step still saves the last good state); default every tenth "
                                             "of the steps and at least every 5 minutes of wall time")
    figures: bool = field(boolean, True, doc="write PNG figures")
    subdivision: int = field(bounded(integer, 0, 6, note="(each level splits every element into 2^dim cells)"), 0,
                             doc="VTK subdivision of each element (for order > 1; 0 writes every field at the "
                                 "element vertices, > 0 draws curved and high-order fields on subdivided cells "
                                 "through NGSolve's slower VTKOutput); 6 levels already write 4096 (2D) or 262144 "
                                 "(3D) cells per element")
    figure_window: list | None = field(optional(list_of(number, 4)), None,
                                       doc="[xmin, xmax, ymin, ymax] of an extra zoomed field figure, m")
    probes: list = field(list_of(nested(Probe)), [], doc="probes recorded over time")
    sections: list | None = field(optional(list_of(nested(Section))), None,
                                  doc="3D scenes: plane sections the fields are drawn on at the last time "
                                      "(default: the three mid-planes of the domain's bounding box, normal to x, y "
                                      "and z, named 'x', 'y', 'z'; [] draws none)")


ESTIMATORS = ("zz", "residual")
INDICATORS = ("contact_zone", "phase_front")
MARKERS = ("doerfler", "maximum", "uniform")


@dataclass(frozen=True, kw_only=True)
class Adaptivity:
    """``[adaptivity]``: stationary scenes refined by SOLVE -> ESTIMATE -> MARK -> REFINE
    (:mod:`ngs_geomech.adapt`) before the output is written on the final mesh; transient scenes with a phase
    change (plane) on meshes that follow the phase boundary (``indicators = ['phase_front']``: the scene's
    geometry remeshed with a fine size at the liquid-fraction 1/2 iso-line, the enthalpy carried over;
    :mod:`ngs_geomech.adapt.front_following`); time-dependent scenes with static mechanics and a contact
    (plane, axisymmetric) on meshes that follow the contact zones (``indicators = ['contact_zone']``: remeshed
    with a fine size at the active set's ends and the stick/slip transitions at each mechanics solve, temperature,
    displacement and multipliers carried over; with ``['contact_zone', 'phase_front']`` the phase boundary as well;
    :mod:`ngs_geomech.adapt.contact_following`); transient heat scenes without such indicators on a mesh
    adapted once to the steady heat problem with the start time's data (then the run on it). estimator, marker,
    theta and max_refinements are not used then."""

    estimator: str = field(one_of(*ESTIMATORS), "zz",
                           doc="'zz' (flux / stress recovery, Zienkiewicz-Zhu) or 'residual' (element residual "
                               "and jumps)")
    target: str | None = field(optional(one_of("heat", "mechanics")), None,
                               doc="the problem whose error is estimated (default: mechanics when on, else heat)")
    indicators: list = field(list_of(one_of(*INDICATORS)), [],
                             doc="elements flagged in addition: 'contact_zone' (the active set's boundary and "
                                 "stick/slip transitions of every mechanical contact; in time-dependent scenes: "
                                 "meshes that follow them); transient scenes with a phase change: 'phase_front' "
                                 "(the elements the liquid fraction 1/2 crosses: front-following meshes)")
    marker: str = field(one_of(*MARKERS), "doerfler",
                        doc="'doerfler' (bulk: the fewest elements holding theta of the squared estimate), "
                            "'maximum' (eta_T >= theta max eta) or 'uniform'")
    theta: float = field(number, 0.5, doc="the marker's parameter, in (0, 1]")
    tolerance: float | None = field(optional(number), None,
                                    doc="stop when the estimate (energy norm, the estimator's units) is below it")
    max_dofs: int | None = field(optional(integer), None, doc="stop before a mesh would exceed this many dofs")
    max_refinements: int = field(integer, 6, doc="stop after this many refinements")
    levels: int = field(integer, 2, doc="time-dependent scenes: halvings of the element size at the phase "
                                        "boundary / the contact transitions: h = h_base / 2^levels, h_base the "
                                        "median longest edge (m) of the scene's own mesh in the phase-change "
                                        "regions / at the contact sides")
    layers: int = field(integer, 2, doc="time-dependent scenes: rings of elements around the ones the front (the "
                                        "transition) crosses that are kept fine (the band it may move in)")
    remesh_every: int = field(integer, 0, doc="'phase_front': remesh after every this many time steps at the "
                                              "front of the step's end; 0 (default): only when the front "
                                              "reaches elements coarser than the band's (1.25x), and then that "
                                              "step is repeated on the new mesh (refined at the front's "
                                              "positions before and after it). 'contact_zone': the same per "
                                              "mechanics solve (a solve whose transitions left the band is "
                                              "solved again on the new mesh)")


DISTRIBUTIONS = ("uniform", "normal", "lognormal", "triangular")
UNCERTAINTY_MODES = ("worst_scenario", "monte_carlo", "quasi_monte_carlo")


@dataclass(frozen=True, kw_only=True)
class UncertainParameter:
    """``[[uncertainty.parameters]]``: one uncertain input, known only in an interval (the admissible set of the
    worst-scenario method) and, for the stochastic modes, with a distribution on it."""

    name: str = field(string, doc="parameter name (in tables and results)")
    keys: list = field(list_of(string), doc="scene items the parameter sets, as --set paths (e.g. "
                                            "'materials.granite.conductivity', 'sources.0.power'); one value "
                                            "drives all of them")
    interval: list = field(list_of(number, 2), doc="[lower, upper] in the items' units ('value') or as a "
                                                   "factor on each item's own value ('factor')")
    scale: str = field(one_of("value", "factor"), "value",
                       doc="'value': the items take the parameter's value; 'factor': each item is its scene "
                           "value times the parameter")
    nominal: float | None = field(optional(number), None,
                                  doc="the nominal value (default: the scene's value of the first item for "
                                      "'value', 1 for 'factor', or the interval's midpoint)")
    distribution: str = field(one_of(*DISTRIBUTIONS), "uniform",
                              doc="stochastic modes: 'uniform' on the interval, 'normal' (mean, std) or "
                                  "'lognormal' (median, sigma of ln) truncated to the interval, 'triangular' "
                                  "(mode) on the interval")
    mean: float | None = field(optional(number), None, doc="normal: mean (default: the midpoint)")
    std: float | None = field(optional(number), None, doc="normal: standard deviation")
    median: float | None = field(optional(number), None, doc="lognormal: median (default: geometric midpoint)")
    sigma: float | None = field(optional(number), None, doc="lognormal: standard deviation of ln(value)")
    mode: float | None = field(optional(number), None, doc="triangular: the most likely value")
    unit: str = field(string, "", doc="unit shown in tables")


@dataclass(frozen=True, kw_only=True)
class Criterion:
    """``[[uncertainty.criteria]]``: a figure of a run's ``summary.json`` to watch over the admissible set."""

    name: str = field(string, doc="criterion name")
    summary: str = field(string, doc="dotted path into summary.json, e.g. 'probes.canister_buffer_max_3.max' or "
                                     "'mechanics.contact.interfaces.fault.max_slip_over_time_m'")
    sense: str = field(one_of("both", "max", "min"), "both",
                       doc="worst scenario: search the maximum, the minimum or both")
    unit: str = field(string, "", doc="unit shown in tables")
    limit: float | None = field(optional(number), None,
                                doc="a design limit: the worst-scenario margin, the probability of exceeding it "
                                    "(stochastic modes)")


@dataclass(frozen=True, kw_only=True)
class Uncertainty:
    """``[uncertainty]``: uncertain data and the criteria to watch (:mod:`ngs_geomech.uncertainty`); used by
    ``ngs-geomech uncertain``, ignored by ``ngs-geomech run`` (which runs the scene's own values)."""

    mode: str = field(one_of(*UNCERTAINTY_MODES), "worst_scenario",
                      doc="'worst_scenario' (design + local search for the max/min of each criterion), "
                          "'monte_carlo' or 'quasi_monte_carlo' (randomized Sobol) with confidence intervals")
    parameters: list = field(list_of(nested(UncertainParameter)), doc="the uncertain inputs")
    criteria: list = field(list_of(nested(Criterion)), doc="the figures to watch")
    samples: int = field(integer, 16, doc="worst scenario: design points (Latin hypercube); stochastic: samples")
    vertices: str = field(one_of("auto", "yes", "no"), "auto",
                          doc="worst scenario: add the 2^d corners of the box ('auto': when 2^d <= samples)")
    local_search: bool = field(boolean, True,
                               doc="worst scenario: improve the best design point by projected-gradient steps "
                                   "with finite-difference derivatives")
    max_local_iterations: int = field(integer, 4, doc="gradient steps per criterion and sense")
    fd_step: float = field(number, 0.02, doc="finite-difference step, relative to each interval's width")
    derivative_check: bool = field(boolean, False,
                                   doc="measure the finite-difference gradient at the nominal point with steps "
                                       "0.1, 0.01, 0.001 (forward) and central (costs 4 d runs)")
    replicates: int = field(integer, 8, doc="quasi_monte_carlo: independently scrambled Sobol replicates")
    confidence: float = field(number, 0.95, doc="level of the confidence intervals")
    seed: int = field(integer, 1, doc="random seed of the design / samples")


@dataclass(frozen=True, kw_only=True)
class Scene:
    """A whole scene: geometry, materials, conditions, physics, time and output settings."""

    scene: SceneInfo = field(nested(SceneInfo), doc="name and dimension")
    blocks: list = field(list_of(nested(Block)), doc="bodies")
    cuts: list = field(list_of(nested(Cut)), [], doc="planes (lines) splitting blocks")
    physics: Physics = field(nested(Physics), Physics(), doc="physics switched on")
    mesh: MeshSettings = field(nested(MeshSettings), MeshSettings(), doc="mesh settings")
    interfaces: list = field(list_of(nested(Interface)), [], doc="block interfaces")
    materials: dict = field(dict_of(nested(Material)), {}, doc="materials per region")
    boundary_conditions: dict = field(dict_of(nested(BoundaryCondition)), {}, doc="per boundary name")
    sources: list = field(list_of(nested(Source)), [], doc="heat sources")
    mechanics: MechanicsSettings = field(nested(MechanicsSettings), MechanicsSettings(), doc="mechanics settings")
    initial: Initial = field(nested(Initial), Initial(), doc="initial conditions")
    time: TimeSettings | None = field(optional(nested(TimeSettings)), None, doc="time settings (transient)")
    dynamics: Dynamics = field(nested(Dynamics), Dynamics(), doc="dynamic mechanics settings")
    solver: SolverSettings = field(nested(SolverSettings), SolverSettings(), doc="linear solver settings")
    output: Output = field(nested(Output), Output(), doc="output settings")
    adaptivity: Adaptivity | None = field(optional(nested(Adaptivity)), None,
                                          doc="adaptive refinement (stationary scenes)")
    uncertainty: Uncertainty | None = field(optional(nested(Uncertainty)), None,
                                            doc="uncertain data and criteria (ngs-geomech uncertain)")
