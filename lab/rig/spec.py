"""Which rig a command runs on: :class:`RigSpec`, the typed form of the ``--rig`` option.

``--rig`` is one string -- ``sim``, ``twin``, ``twin:DEFECTS.toml``, ``twin:random:SEED``,
``twin:foam:SEED`` (a member of the second family, :mod:`lab.asbuilt.foam`: defects
outside the calibrator's model class too), ``twin:pneumatic:SEED`` (a cast-silicone arm
driven by pressure chambers, :mod:`lab.asbuilt.pneumatic`), ``hardware:CONFIG.toml``, or for ``track`` alone
``none``: no rig at all, the IK's commands written for a lab to send to its own robot --
and :meth:`RigSpec.parse` is the only place
that reads it; ``str(spec)`` writes it back. The FEM mesh of a simulated or emulated rig
(``--n-rings``/``--n-axial``) is the :class:`~lab.fem.MeshSpec` field ``mesh``, which the
string does not carry. :func:`lab.rig.make_rig` builds the rig a spec names. Every
problem is a :class:`~lab.errors.FieldError` naming the rig string ``RigSpec.rig`` (the
command line writes its ``--rig`` there).
"""

from __future__ import annotations

from dataclasses import dataclass

from lab.asbuilt.family import FAMILIES, RIG, parse_robot_seed
from lab.errors import FieldError
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.specs import Spec

__all__ = ["RigSpec", "RIG_KINDS", "RIG_FORMS"]

#: The kinds of rig: the nominal quasi-static FEM, the emulated as-built robot, the real one,
#: and none (``track --rig none``: solve the IK only; :func:`lab.rig.make_rig` refuses it).
RIG_KINDS = ("sim", "twin", "hardware", "none")
#: The forms ``--rig`` accepts, as its help and errors name them.
RIG_FORMS = "sim, twin[:DEFECTS.toml], twin:random:SEED, twin:foam:SEED, twin:pneumatic:SEED or hardware:CONFIG.toml"
#: How an error names the FEM mesh's fields.
MESH_FIELDS = ("MeshSpec.n_rings", "MeshSpec.n_axial")


@dataclass(frozen=True)
class RigSpec(Spec):
    """One rig, as ``--rig`` names it (see the module docstring).

    Attributes
    ----------
    kind : str
        One of :data:`RIG_KINDS` (``none`` only where :meth:`parse` was told it is allowed).
    defects_path : str or None
        A twin's defects file (TOML); None: the robot's shipped defects.
    family_seed : int or None
        A twin that is member SEED (>= 0) of the family ``family``; None: no family member.
    config_path : str or None
        A hardware rig's configuration file (TOML).
    mesh : MeshSpec
        FEM mesh overrides (rings, axial layers) of a ``sim`` or ``twin`` rig.
    family : str
        A name in :data:`lab.asbuilt.FAMILIES`: ``random``, ``foam`` or ``pneumatic``.
    """

    kind: str = "sim"
    defects_path: str | None = None
    family_seed: int | None = None
    config_path: str | None = None
    mesh: MeshSpec = MeshSpec()
    family: str = "random"

    def __post_init__(self):
        super().__post_init__()
        if self.kind not in RIG_KINDS:
            raise FieldError(f"unknown rig kind {self.kind!r} ({RIG}): expected {RIG_FORMS}", RIG)
        if not isinstance(self.mesh, MeshSpec):
            raise FieldError(f"{RIG}: mesh must be a MeshSpec, got {self.mesh!r}", RIG)
        seed = self.family_seed
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
            raise FieldError(
                f"{RIG} twin:random:SEED: the robot seed must be a non-negative integer, got {seed!r}", RIG
            )
        if self.family not in FAMILIES:
            raise FieldError(
                f"{RIG} twin:FAMILY:SEED: unknown family {self.family!r}, expected one of {tuple(FAMILIES)}", RIG
            )
        if self.family != "random" and seed is None:
            raise FieldError(f"{RIG} twin:{self.family}:SEED needs the robot's seed (e.g. twin:{self.family}:3)", RIG)
        given = {
            "defects file": self.defects_path is not None,
            "robot seed": seed is not None,
            "configuration file": self.config_path is not None,
        }
        allowed = {
            "sim": (),
            "twin": ("defects file", "robot seed"),
            "hardware": ("configuration file",),
            "none": (),
        }[self.kind]
        wrong = [what for what, set_ in given.items() if set_ and what not in allowed]
        if wrong:
            raise FieldError(f"{RIG} {self.kind} takes no {' or '.join(wrong)}", RIG)
        if self.defects_path is not None and seed is not None:
            raise FieldError(f"{RIG} twin takes a defects file or twin:random:SEED, not both", RIG)
        if self.kind == "hardware" and not self.config_path:
            raise FieldError(f"rig 'hardware' needs a configuration file: {RIG} hardware:RIG.toml", RIG)
        if self.kind in ("hardware", "none") and not self.mesh.is_default:
            raise FieldError(
                f"{'/'.join(MESH_FIELDS)} set the FEM mesh of {RIG} sim or an emulated twin, not {self.kind}",
                *MESH_FIELDS,
                RIG,
            )

    @classmethod
    def parse(cls, text: RigSpec | str, *, mesh: MeshSpec | None = None, allow_none: bool = False) -> RigSpec:
        """The spec of a ``--rig`` string (a spec is returned as it is).

        Raises InputError naming the problem: an unknown kind, ``sim`` or ``none`` with an
        argument, ``twin:random`` without a seed or with a bad one, ``hardware`` without a file.

        Parameters
        ----------
        text : RigSpec or str
            The ``--rig`` string (one of :data:`RIG_FORMS`), or a spec.
        mesh : MeshSpec, optional
            Its FEM mesh; None keeps a spec's mesh (the default mesh for a string).
        allow_none : bool
            Whether ``none`` (no rig) is a form this command takes.

        Returns
        -------
        RigSpec
            The parsed spec.
        """
        if isinstance(text, RigSpec):
            return text if mesh is None else text.replace(mesh=mesh)
        mesh = MeshSpec() if mesh is None else mesh
        text = str(text)
        kind, _, arg = text.partition(":")
        if kind == "none":
            if not allow_none:
                raise FieldError(f"{RIG} none (no rig) is taken by `track` only; this command needs {RIG_FORMS}", RIG)
            if arg:
                raise FieldError(f"rig 'none' takes no argument ({RIG} none), got {text!r}", RIG)
            return cls("none", mesh=mesh)
        if kind == "sim":
            if arg:
                raise FieldError(f"rig 'sim' takes no argument ({RIG} sim), got {text!r}", RIG)
            return cls("sim", mesh=mesh)
        if kind == "twin":
            family, _, robot_seed = arg.partition(":")
            if family in FAMILIES:
                if not robot_seed:
                    raise FieldError(
                        f"rig {text!r} needs the robot's seed: {RIG} twin:{family}:SEED (e.g. twin:{family}:3)", RIG
                    )
                seed = parse_robot_seed(robot_seed, text, family)
                return cls("twin", family_seed=seed, mesh=mesh, family=family)
            return cls("twin", defects_path=arg or None, mesh=mesh)
        if kind == "hardware":
            if not arg:
                raise FieldError(f"rig 'hardware' needs a configuration file: {RIG} hardware:RIG.toml", RIG)
            return cls("hardware", config_path=arg, mesh=mesh)
        raise FieldError(f"unknown rig {text!r} ({RIG}): expected {RIG_FORMS}", RIG)

    def __str__(self) -> str:
        """The ``--rig`` string of this spec (without the mesh, which has its own flags)."""
        if self.kind == "twin":
            if self.family_seed is not None:
                return f"twin:{self.family}:{self.family_seed}"
            return "twin" if self.defects_path is None else f"twin:{self.defects_path}"
        if self.kind == "hardware":
            return f"hardware:{self.config_path}"
        return self.kind

    def as_dict(self) -> dict:
        """The fields as JSON-ready values, and the ``--rig`` string as ``rig``.

        Returns
        -------
        dict
            Field name -> JSON-ready value, ``mesh`` as a dict, ``rig`` the ``--rig``
            string; ``family`` only for a family other than ``random`` (a random member's
            metadata reads as before).
        """
        d = {**super().as_dict(), "mesh": self.mesh.as_dict(), "rig": str(self)}
        if self.family == "random":
            del d["family"]
        return d

    @property
    def file(self) -> str | None:
        """The file the spec reads (a defects or configuration path), else None."""
        return self.defects_path if self.kind == "twin" else self.config_path

    @property
    def label(self) -> str:
        """What results on this rig are: "FEM", "emulated as-built robot" (with "(foam family)"
        on a ``twin:foam`` member, "(pneumatic family)" on a ``twin:pneumatic`` one), "hardware"
        or "model prediction" (no rig)."""
        if self.kind == "twin":
            return FAMILIES[self.family].label
        return {"sim": "FEM", "hardware": "hardware", "none": "model prediction"}[self.kind]

    @property
    def has_rig(self) -> bool:
        """Whether there is a rig to run on (every kind but ``none``)."""
        return self.kind != "none"

    @property
    def has_dynamics(self) -> bool:
        """Whether the rig moves in time (a twin or hardware; ``sim`` settles instantly)."""
        return self.kind in ("twin", "hardware")

    def require_dynamics(self) -> RigSpec:
        """This spec, or InputError for ``sim``, whose quasi-static FEM has no dynamics.

        Returns
        -------
        RigSpec
            ``self``, when the rig moves in time (a twin or hardware).
        """
        if not self.has_rig:
            raise FieldError(f"{RIG} none is no rig: it has no dynamics to learn or stream", RIG)
        if not self.has_dynamics:
            raise FieldError(f"{RIG} sim is the quasi-static FEM: it has no dynamics to learn or stream", RIG)
        return self
