"""What a capture run is: :class:`CaptureSpec` (rig, robot, design, files, order) and its
:class:`ProtocolSpec` (how each sample is taken), in the command line's units (mm, rad).

Each field carries its ``capture`` flag (:func:`lab.specs.option`); the specs refuse a bad
value or combination when they are built, naming the flag, before any file is touched or
the rig moves. :meth:`ProtocolSpec.protocol` is the :class:`~lab.capture.protocol.Protocol`
(SI units) the capture runs; :attr:`CaptureSpec.command` is the command that reproduces
the run, recorded in the journal and the dataset.
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass
from pathlib import Path

from lab.capture.protocol import PROTOCOLS, Protocol
from lab.data.design_spec import DesignSpec
from lab.errors import InputError
from lab.rig.spec import RigSpec
from lab.specs import Spec, non_negative, option, positive

__all__ = ["CaptureSpec", "ProtocolSpec", "ORDERS"]

#: Capture orders (``--order``): a seeded permutation, or the dataset's own order.
ORDERS = ("shuffled", "grid")


def _positive_mm(v) -> str | None:
    return None if positive(v) is None else "must be a positive number of mm"


@dataclass(frozen=True)
class ProtocolSpec(Spec):
    """The capture protocol's flags; :meth:`protocol` is the :class:`Protocol` they mean.

    Attributes
    ----------
    kind : str
        ``wait`` (the paper's protocol) or ``predictive`` (``--protocol``).
    predict_tol_mm : float
        Predictive: record when the predicted settled tip's 3-D std is below this (mm).
    dynamic_model : str or None
        Predictive: a relaxation fitted by ``fit-dynamics`` (DYN.npz); skips the learning.
    no_wait : bool
        Record 0.5 s after the motors arrive instead of waiting until settled.
    no_reset : bool
        Do not erase hysteresis before each sample.
    settle_tol_mm : float
        Settle tolerance (mm).
    reset_rad : float
        Contraction of every cable in the reset (rad).
    """

    kind: str = option(
        "wait",
        choices=PROTOCOLS,
        help="wait: the paper's protocol, record once settled; predictive: learn the foam's relaxation from "
        "the first samples, then record as soon as the settled tip is predicted within --predict-tol-mm "
        "(lab.capture.predictive)",
    )
    predict_tol_mm: float = option(
        0.15,
        type=float,
        check=_positive_mm,
        unit="mm",
        help="predictive: record when the predicted settled tip's 3-D standard deviation is below this, mm",
    )
    dynamic_model: str | None = option(
        help="predictive: a relaxation fitted by 'python -m lab fit-dynamics' (DYN.npz); skips the learning samples"
    )
    no_wait: bool = option(False, help="do not wait until settled: record 0.5 s after the motors arrive")
    no_reset: bool = option(False, help="do not erase hysteresis before each sample")
    settle_tol_mm: float = option(0.1, type=float, check=positive, unit="mm", help="settle tolerance, mm")
    reset_rad: float = option(
        1.0, type=float, check=non_negative, unit="rad", help="contraction of every cable in the reset, rad"
    )

    def __post_init__(self):
        if self.kind == "wait" and self.dynamic_model:
            name = self.name_of
            raise self.field_error(f"{name('dynamic_model')} is for {name('kind')} predictive", "dynamic_model", "kind")
        super().__post_init__()
        if self.kind == "predictive" and (self.no_wait or self.no_reset):
            name = self.name_of
            raise self.field_error(
                f"{name('kind')} predictive replaces waiting; it cannot run with {name('no_wait')} or "
                f"{name('no_reset')}",
                "kind",
                "no_wait",
                "no_reset",
            )
        self.protocol()  # whatever else the protocol refuses

    def protocol(self) -> Protocol:
        """The protocol these flags mean.

        Returns
        -------
        Protocol
            The settings in SI units (m, rad, s).
        """
        return Protocol(
            wait=not self.no_wait,
            reset=not self.no_reset,
            settle_tol_m=1e-3 * self.settle_tol_mm,
            reset_u_rad=self.reset_rad,
            kind=self.kind,
            predict_tol_m=1e-3 * self.predict_tol_mm,
        )

    def relaxation(self):
        """The relaxation of ``--dynamic-model``.

        Returns
        -------
        Relaxation or None
            The fitted relaxation read from ``dynamic_model``, or None without one.
        """
        if not self.dynamic_model:
            return None
        from lab.dynamics.relaxation import load_relaxation

        return load_relaxation(self.dynamic_model)

    def words(self) -> list[str]:
        """The flags that reproduce this spec.

        Returns
        -------
        list of str
            Command-line words, the defaults left out.
        """
        words = []
        if self.kind != "wait":
            words += ["--protocol", self.kind, "--predict-tol-mm", repr(self.predict_tol_mm)]
            if self.dynamic_model:
                words += ["--dynamic-model", str(self.dynamic_model)]
        words += ["--no-wait"] * self.no_wait + ["--no-reset"] * self.no_reset
        if self.settle_tol_mm != 0.1:
            words += ["--settle-tol-mm", repr(self.settle_tol_mm)]
        if self.reset_rad != 1.0:
            words += ["--reset-rad", repr(self.reset_rad)]
        return words


@dataclass(frozen=True)
class CaptureSpec(Spec):
    """One capture run: the ``design``'s commands measured on ``rig`` with ``protocol`` into
    the journal, then written as the dataset ``out``. ``design.seed`` (``--seed``) also seeds
    the shuffled order and an emulated rig's noise.

    Attributes
    ----------
    rig : RigSpec
        The rig to capture on (``--rig``).
    robot : str
        Shipped robot name or path to a TOML description.
    design : DesignSpec
        The commands to capture (a fixed design, a grid or active batches).
    out : str
        Output CSV; metadata goes to OUT.json.
    journal : str or None
        Append-only journal to write or resume; None: OUT with ``.journal.csv``.
    order : str
        Capture order, one of :data:`ORDERS` (the dataset is written in design order).
    protocol : ProtocolSpec
        The capture protocol's settings.
    no_progress : bool
        No progress bar.
    """

    rig: RigSpec = RigSpec("twin")
    robot: str = option("three-cable", help="shipped robot name or path to a TOML description")
    design: DesignSpec = DesignSpec()
    out: str | None = option(required=True, help="output CSV; metadata goes to OUT.json")
    journal: str | None = option(help="append-only journal to write or resume (default: OUT with .journal.csv)")
    order: str = option(
        "shuffled",
        choices=ORDERS,
        help="capture order (the dataset is written in grid/design order either way)",
    )
    protocol: ProtocolSpec = ProtocolSpec()
    no_progress: bool = option(False, help="no progress bar")

    def __post_init__(self):
        super().__post_init__()
        for name, cls in (("rig", RigSpec), ("design", DesignSpec), ("protocol", ProtocolSpec)):
            if not isinstance(getattr(self, name), cls):
                raise InputError(f"capture: {name} must be a {cls.__name__}, got {getattr(self, name)!r}")

    @property
    def seed(self) -> int:
        """``--seed``: of the design (or the active picks), the shuffled order and the rig's noise."""
        return self.design.seed

    @property
    def journal_path(self) -> Path:
        """The journal: ``--journal``, else ``OUT`` with the suffix ``.journal.csv``."""
        return Path(self.journal) if self.journal else Path(self.out).with_suffix(".journal.csv")

    @property
    def progress(self) -> bool:
        return not self.no_progress

    @property
    def command(self) -> str:
        """The command that reproduces this run (for the journal and the dataset's metadata)."""
        words = ["python", "-m", "lab", "capture", "--rig", str(self.rig), "--robot", self.robot]
        words += [*self.design.words(), "--out", str(self.out), "--seed", str(self.seed), "--order", self.order]
        if self.journal:
            words += ["--journal", str(self.journal)]
        return shlex.join(words + self.protocol.words())
