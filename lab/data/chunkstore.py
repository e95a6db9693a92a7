"""Finished chunks of a long simulation, kept on disk so a killed run resumes.

``simulate(..., checkpoint=DIR)`` writes each chunk's result to ``DIR/chunk_NNNNN.npz``
the moment it finishes (atomically: temporary file + rename, so a kill never leaves a
half-written chunk) and, when started again with the same arguments, solves only the
chunks that are missing. ``DIR/manifest.json`` holds a fingerprint of the run (robot
hash, mesh, the commands and the chunking); a directory left by a different run is
refused rather than mixed in. Chunk results do not depend on where or when they ran,
so a resumed run gives the same numbers as an uninterrupted one. No pickle.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import zipfile
from pathlib import Path

import numpy as np

from lab.errors import InputError
from lab.files import atomic_write_text

FORMAT_VERSION = 1
_FIELDS = ("order", "u_motor", "p_tip_W", "iterations", "factorizations", "time_s")


class CheckpointError(InputError):
    """A checkpoint directory belongs to another run or is unreadable."""


def fingerprint(robot_sha256: str, n_rings: int, n_axial: int, u_motor: np.ndarray, orders: list) -> dict:
    """What must match for a checkpoint to be resumed: robot, mesh, commands, chunking."""
    h = hashlib.sha256(np.ascontiguousarray(u_motor, dtype=float).tobytes())
    for order in orders:
        h.update(np.asarray(order, dtype=np.int64).tobytes())
        h.update(b"|")
    return {
        "format_version": FORMAT_VERSION,
        "robot_sha256": robot_sha256,
        "n_rings": int(n_rings),
        "n_axial": int(n_axial),
        "n_samples": int(len(u_motor)),
        "n_chunks": len(orders),
        "commands_and_chunks_sha256": h.hexdigest(),
    }


class ChunkStore:
    """Chunk results under ``directory`` for the run identified by ``fingerprint``."""

    def __init__(self, directory: str | Path, fp: dict):
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        manifest = self.directory / "manifest.json"
        if manifest.exists():
            try:
                old = json.loads(manifest.read_text())
            except json.JSONDecodeError as err:
                raise CheckpointError(f"{manifest}: corrupt manifest ({err}); delete {self.directory}") from None
            if old != fp:
                diff = sorted(k for k in set(old) | set(fp) if old.get(k) != fp.get(k))
                raise CheckpointError(
                    f"checkpoint {self.directory} belongs to another run (differs in {', '.join(diff)}); "
                    f"delete it, or restart from scratch"
                )
        else:
            atomic_write_text(manifest, json.dumps(fp, indent=2) + "\n")

    def _path(self, i: int) -> Path:
        return self.directory / f"chunk_{i:05d}.npz"

    def save(self, i: int, result: dict) -> None:
        """Store chunk ``i``'s result (keys ``order``, ``u_motor``, ``p_tip_W``, ...)."""
        tmp = self.directory / f".chunk_{i:05d}.tmp{os.getpid()}.npz"
        with open(tmp, "wb") as fh:
            np.savez(fh, **{k: np.asarray(result[k]) for k in _FIELDS})
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, self._path(i))

    def load(self, orders: list, u_motor: np.ndarray) -> dict[int, dict]:
        """Results of the chunks already finished, checked against the expected commands.

        A chunk file that cannot be read is dropped (and will be solved again)."""
        done = {}
        for i, order in enumerate(orders):
            path = self._path(i)
            if not path.exists():
                continue
            try:
                with np.load(path, allow_pickle=False) as z:
                    res = {k: z[k] for k in _FIELDS}
            except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
                path.unlink()
                continue
            if not (np.array_equal(res["order"], order) and np.array_equal(res["u_motor"], u_motor[order])):
                raise CheckpointError(f"{path} does not hold chunk {i} of this run; delete {self.directory}")
            done[i] = res
        return done

    def remove(self) -> None:
        """Delete the checkpoint directory (after the dataset has been written)."""
        shutil.rmtree(self.directory, ignore_errors=True)
