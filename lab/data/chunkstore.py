"""Finished chunks of a long simulation, kept on disk so a killed run resumes.

``simulate(..., checkpoint=DIR)`` writes each chunk's result to ``DIR/chunk_NNNNN.npz``
the moment it finishes (atomically: temporary file + rename, so a kill never leaves a
half-written chunk) and, when started again with the same arguments, solves only the
chunks that are missing. ``DIR/manifest.json`` holds a fingerprint of the run (robot
hash, mesh, the commands and the chunking); a directory left by a different run is
refused rather than mixed in. Chunk results do not depend on where or when they ran,
so a resumed run gives the same numbers as an uninterrupted one. No pickle.

The store never deletes what it did not write. It creates its directory only when the
first chunk is saved (a run that fails earlier leaves nothing behind) and marks a
directory it made with ``DIR/.lab-checkpoint``; :meth:`ChunkStore.remove` deletes its own
files (manifest, chunks, marker) and then the directory only if it made it and it is
empty. A directory holding anything else is refused at once.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import zipfile
from pathlib import Path

import numpy as np

from lab.errors import InputError
from lab.files import atomic_write_text

FORMAT_VERSION = 1
_FIELDS = ("order", "u_motor", "p_tip_W", "iterations", "factorizations", "time_s")
#: Stored when present; a chunk saved without it (tip only) reads it as ``p_tip_W``.
_OPTIONAL = ("y_W",)


class CheckpointError(InputError):
    """A checkpoint directory belongs to another run or is unreadable."""


def fingerprint(robot_sha256: str, n_rings: int, n_axial: int, u_motor: np.ndarray, orders: list) -> dict:
    """What must match for a checkpoint to be resumed: robot, mesh, commands, chunking.

    Parameters
    ----------
    robot_sha256 : str
        SHA-256 of the robot description.
    n_rings, n_axial : int
        The mesh's resolution.
    u_motor : numpy.ndarray
        All commands (N, m), rad.
    orders : list of array_like
        Each chunk's indices into ``u_motor``, in solve order.

    Returns
    -------
    dict
        The fingerprint (JSON-able), stored as the checkpoint's manifest.
    """
    h = hashlib.sha256(np.ascontiguousarray(u_motor, dtype=float).tobytes())
    for order in orders:
        h.update(np.asarray(order, dtype=np.int64).tobytes())
        h.update(b"|")
    return {
        "format_version": FORMAT_VERSION,
        "robot_sha256": robot_sha256,
        "n_rings": None if n_rings is None else int(n_rings),  # None: a body meshed from its file
        "n_axial": None if n_axial is None else int(n_axial),
        "n_samples": int(len(u_motor)),
        "n_chunks": len(orders),
        "commands_and_chunks_sha256": h.hexdigest(),
    }


MARKER = ".lab-checkpoint"
MANIFEST = "manifest.json"
_OURS = re.compile(r"^(manifest\.json|\.lab-checkpoint|chunk_\d{5}\.npz|\.chunk_\d{5}\.tmp\d+\.npz)$")


def foreign_files(directory: str | Path) -> list[str]:
    """Names in ``directory`` that a checkpoint never writes (empty if it does not exist)."""
    d = Path(directory)
    if not d.exists():
        return []
    if not d.is_dir():
        return [d.name]
    return sorted(p.name for p in d.iterdir() if not _OURS.match(p.name))


def _refuse_foreign(directory: Path) -> None:
    foreign = foreign_files(directory)
    if foreign:
        shown = ", ".join(foreign[:5]) + (" ..." if len(foreign) > 5 else "")
        raise CheckpointError(
            f"checkpoint directory {directory} holds files that are not a lab checkpoint's ({shown}); "
            "choose another checkpoint directory (nothing was deleted)"
        )


def check_checkpoint(directory: str | Path, what: str = "checkpoint") -> None:
    """Before any work: refuse (:class:`CheckpointError`) a checkpoint path that is a file,
    a directory holding anything but a checkpoint's files, or a place where the checkpoint
    could not be written."""
    import tempfile

    d = Path(directory)
    if d.exists() and not d.is_dir():
        raise CheckpointError(f"{what} {d} is a file, not a directory")
    _refuse_foreign(d)
    place = d
    while not place.exists() and place.parent != place:  # where mkdir will start
        place = place.parent
    if not place.is_dir():
        raise CheckpointError(f"{what} {d}: {place} is a file, not a directory")
    try:
        with tempfile.NamedTemporaryFile(dir=place, prefix=".lab-probe.", suffix=".tmp"):
            pass
    except OSError as err:
        raise CheckpointError(f"{what} {d}: cannot write in {place} ({err.strerror or err})") from None


class ChunkStore:
    """Chunk results under ``directory`` for the run identified by ``fingerprint``.

    Parameters
    ----------
    directory : str or pathlib.Path
        The checkpoint directory (created at the first save).
    fp : dict
        The run's :func:`fingerprint`; must match an existing manifest (else CheckpointError).
    """

    def __init__(self, directory: str | Path, fp: dict):
        self.directory = Path(directory)
        self.fingerprint = fp
        if self.directory.exists() and not self.directory.is_dir():
            raise CheckpointError(f"checkpoint {self.directory} is a file, not a directory")
        _refuse_foreign(self.directory)
        manifest = self.directory / MANIFEST
        if manifest.exists():
            try:
                old = json.loads(manifest.read_text())
            except json.JSONDecodeError as err:
                raise CheckpointError(
                    f"{manifest}: corrupt manifest ({err}); restarting discards this checkpoint"
                ) from None
            if old != fp:
                diff = sorted(k for k in set(old) | set(fp) if old.get(k) != fp.get(k))
                raise CheckpointError(
                    f"checkpoint {self.directory} belongs to another run (differs in {', '.join(diff)}); "
                    "restarting discards it, or choose another checkpoint"
                )

    def _path(self, i: int) -> Path:
        return self.directory / f"chunk_{i:05d}.npz"

    def _ensure(self) -> None:
        """Create the directory (marked as ours) and the manifest before the first chunk."""
        if not self.directory.exists():
            self.directory.mkdir(parents=True)
            (self.directory / MARKER).write_text(json.dumps({"kind": "lab.checkpoint"}) + "\n")
        if not (self.directory / MANIFEST).exists():
            atomic_write_text(self.directory / MANIFEST, json.dumps(self.fingerprint, indent=2) + "\n")

    def save(self, i: int, result: dict) -> None:
        """Store one chunk's result atomically.

        Parameters
        ----------
        i : int
            The chunk's index.
        result : dict
            Its arrays (keys ``order``, ``u_motor`` (each input in its unit), ``p_tip_W`` m,
            ``y_W`` m (every marker), ...).
        """
        self._ensure()
        tmp = self.directory / f".chunk_{i:05d}.tmp{os.getpid()}.npz"
        try:
            with open(tmp, "wb") as fh:
                np.savez(fh, **{k: np.asarray(result[k]) for k in _FIELDS + _OPTIONAL if k in result})
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, self._path(i))
        finally:
            if tmp.exists():
                tmp.unlink()

    def load(self, orders: list, u_motor: np.ndarray) -> dict[int, dict]:
        """Results of the chunks already finished, checked against the expected commands.

        A chunk file that cannot be read is dropped (and will be solved again).

        Parameters
        ----------
        orders : list of array_like
            Each chunk's indices into ``u_motor``.
        u_motor : numpy.ndarray
            All commands (N, m), rad.

        Returns
        -------
        dict
            Chunk index -> its stored arrays, for the chunks found.
        """
        done = {}
        for i, order in enumerate(orders):
            path = self._path(i)
            if not path.exists():
                continue
            try:
                with np.load(path, allow_pickle=False) as z:
                    res = {k: z[k] for k in _FIELDS}
                    res["y_W"] = z["y_W"] if "y_W" in z.files else res["p_tip_W"]
            except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
                path.unlink()
                continue
            if not (np.array_equal(res["order"], order) and np.array_equal(res["u_motor"], u_motor[order])):
                raise CheckpointError(f"{path} does not hold chunk {i} of this run; restarting discards it")
            done[i] = res
        return done

    def clear(self) -> None:
        """Delete this store's own files (manifest, chunks, temporaries), keeping the directory."""
        clear_checkpoint(self.directory)

    def remove(self) -> None:
        """Delete the store's own files and, if the store made it, its empty directory."""
        remove_checkpoint(self.directory)


def clear_checkpoint(directory: str | Path) -> None:
    """Delete a checkpoint's own files in ``directory`` (``--restart``); nothing else."""
    d = Path(directory)
    _refuse_foreign(d)
    if d.is_dir():
        for p in d.iterdir():
            if _OURS.match(p.name) and p.name != MARKER:
                p.unlink()


def remove_checkpoint(directory: str | Path) -> None:
    """After the dataset has been written: delete the checkpoint's own files, then the
    directory if lab made it (marker) and nothing else is in it."""
    d = Path(directory)
    if not d.is_dir():
        return
    clear_checkpoint(d)
    marker = d / MARKER
    if marker.exists():
        marker.unlink()
        try:
            d.rmdir()  # only if empty: never anybody else's files
        except OSError:
            pass
