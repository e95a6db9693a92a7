"""The foam family's draw: defects the calibrator cannot fit (``twin:foam:SEED``, :data:`lab.asbuilt.FOAM`).

Member ``seed`` of the ``twin:random`` family (:data:`lab.asbuilt.RANDOM`) differs from its
description only in what ``calibrate`` has parameters for. :func:`draw_foam` draws
member ``seed`` of the *foam* family: exactly the same in-class draws (softness, gradient,
eyelet shifts, slack, play, lag, motors, mocap noise -- the same random streams, so the
same values wherever the eyelet limits of the two meshes agree, as on both shipped
robots), plus, from independent streams (:data:`FOAM_RANGES`; ``docs/design/rig.md``):

* the compressible foam law (``law = "hyperfoam"``): mu, beta from
  :func:`lab.fem.materials.hyperfoam.hyperfoam_matching` of the description's E and nu (the same
  small-strain stiffness, scaled per tet by softness and gradient), alpha U(4, 20): one-term
  hyperfoam (Storakers 1986, J. Mech. Phys. Solids 34:125) fits of open-cell flexible
  polyurethane foams give alpha of several to ~20 (Mills, Polymer Foams Handbook, 2007;
  Schrodt et al. 2005, Technische Mechanik 25:162); alpha = 2 is the neo-Hookean-like case;
* the base tilted U(0, 2) deg about a random horizontal axis (levelled by eye);
* frame W registered turned U(0, 1) deg about a random axis and shifted U(-2, 2) mm per axis
  (an OptiTrack ground plane set with a calibration square placed by hand);
* each cable's own stiffness logU(200, 2000) N/m (k = E A / L: nylon or low-tension braided
  line, E 2-10 GPa, 0.2-0.4 mm, 0.3-0.5 m free: 130-4200 N/m; 200 N/m costs ~15 % of the tip's
  motion, 2000 N/m ~2 %, in series with the description's 5 kN/m spring);
* creep, a third lag mode: fraction U(0.02, 0.10), tau U(60, 600) s;
* a finer emulator mesh than the description's (:func:`foam_mesh`: one more ring, 30 % more
  layers), so that the nominal FEM's discretisation is a modelling error too.

Results on a member are an **emulated as-built robot (foam family)**;
:meth:`lab.asbuilt.Family.toml` writes it as a commented defects file (``python -m lab
defects --foam SEED``), which read back with ``--rig twin:FILE`` is the same robot.
"""

from __future__ import annotations

import math

import numpy as np

from lab.asbuilt.draw import check_seed, draw_member, rounded
from lab.description import RobotDescription
from lab.fem.materials.hyperfoam import hyperfoam_matching

__all__ = ["FOAM_RANGES", "foam_mesh", "draw_foam"]

#: (low, high) of each out-of-class field, SI units (deg, m, N/m, s); the cable stiffness
#: is drawn log-uniformly, the rest uniformly. See the module docstring for why.
FOAM_RANGES = {
    "hyperfoam_alpha": (4.0, 20.0),
    "tilt_deg": (0.0, 2.0),
    "frame_rotation_deg": (0.0, 1.0),
    "frame_offset_m": (-2e-3, 2e-3),
    "cable_stiffness_n_per_m": (200.0, 2000.0),
    "creep_fraction": (0.02, 0.10),
    "creep_tau_s": (60.0, 600.0),
}
#: The emulator mesh: the description's rings plus this many ...
FOAM_EXTRA_RINGS = 1
#: ... and its layers plus this share (rounded up; 20 layers -> 26).
FOAM_EXTRA_AXIAL = 0.3


def foam_mesh(robot: RobotDescription, n_rings: int | None = None, n_axial: int | None = None) -> tuple[int, int]:
    """``(n_rings, n_axial)`` of a foam member's emulator: the arguments where given, else
    finer than the description's (:data:`FOAM_EXTRA_RINGS`, :data:`FOAM_EXTRA_AXIAL`)."""
    rings = robot.n_rings + FOAM_EXTRA_RINGS if n_rings is None else int(n_rings)
    layers = robot.n_axial + math.ceil(round(FOAM_EXTRA_AXIAL * robot.n_axial, 9)) if n_axial is None else int(n_axial)
    return rings, layers


def _u(rng: np.random.Generator, key: str, size=None):
    lo, hi = FOAM_RANGES[key]
    return rng.uniform(lo, hi, size)


def draw_foam(robot: RobotDescription, seed: int, n_rings: int | None, n_axial: int | None) -> tuple[dict, dict]:
    """The drawn defects document of foam member ``seed`` and the notes its comments need.

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot.
    seed : int
        The member, an integer >= 0.
    n_rings, n_axial : int or None
        The emulator mesh (None: :func:`foam_mesh`'s, finer than the description's).

    Returns
    -------
    tuple of dict
        The parsed TOML document (:func:`lab.asbuilt.parse.parse_defects` validates it) and
        the notes :func:`lab.asbuilt.writer.defects_toml` writes as comments.
    """
    seed = check_seed(seed)
    rings, layers = foam_mesh(robot, n_rings, n_axial)
    data, notes = draw_member(robot, seed, rings, layers)  # the in-class draws of twin:random:SEED
    rng = np.random.default_rng([seed, 0, 2])  # streams of their own: the in-class ones untouched
    alpha = float(_u(rng, "hyperfoam_alpha"))
    tilt, azimuth = float(_u(rng, "tilt_deg")), float(rng.uniform(0.0, 360.0))
    rotation, axis = float(_u(rng, "frame_rotation_deg")), rng.standard_normal(3)  # a uniform direction
    offset = _u(rng, "frame_offset_m", 3)
    creep, creep_tau = float(_u(rng, "creep_fraction")), float(_u(rng, "creep_tau_s"))
    mu, beta = hyperfoam_matching(robot.youngs_modulus_pa, robot.poisson_ratio, alpha)
    data["material"].update(
        law="hyperfoam",
        hyperfoam_mu_pa=rounded(mu, 2),
        hyperfoam_alpha=rounded(alpha, 2),
        hyperfoam_beta=rounded(beta, 6),
    )
    lo, hi = FOAM_RANGES["cable_stiffness_n_per_m"]
    for i, table in enumerate(data["cables"]):  # a cable's draw does not depend on the others
        k = math.exp(np.random.default_rng([seed, 1 + i, 2]).uniform(math.log(lo), math.log(hi)))
        table["stiffness_n_per_m"] = rounded(k, 0)
    data["lag"].update(creep_fraction=rounded(creep, 3), creep_tau_s=rounded(creep_tau, 1))
    data["mocap"].update(
        frame_rotation_deg=rounded(rotation, 3),
        frame_rotation_axis=[rounded(c, 4) for c in axis / np.linalg.norm(axis)],
        frame_offset_m=[rounded(c, 6) for c in offset],
    )
    a = math.radians(azimuth)
    data["mount"] = {"tilt_deg": rounded(tilt, 3), "tilt_axis": [rounded(math.cos(a), 4), rounded(math.sin(a), 4), 0.0]}
    return data, {**notes, "tilt_azimuth_deg": azimuth}
