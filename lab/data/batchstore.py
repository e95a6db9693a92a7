"""Measured batches of an active-sampling run (:mod:`lab.learn.active`), kept on disk so a killed run resumes.

``python -m lab simulate --active N --batch B`` saves each simulated batch (the initial
design is batch 0) as ``DIR/chunk_NNNNN.npz`` the moment it is solved: the fields of a
:mod:`lab.data.chunkstore` chunk plus ``entry_json``, the batch's log entry. Started
again with the same arguments, it loads the batches in order and continues after the
last one: the next batch depends only on the seed and the data so far. The directory
follows :class:`~lab.data.chunkstore.ChunkStore`'s rules (a manifest with the run's
fingerprint, refused when it belongs to another run; a directory holding anything else
refused; only its own files ever deleted).
"""

from __future__ import annotations

import json
import os
import zipfile

import numpy as np

from lab.data.chunkstore import _FIELDS, _OPTIONAL, CheckpointError, ChunkStore


class BatchStore(ChunkStore):
    """The batches of the active run identified by ``fingerprint``, in ``directory``."""

    def save_batch(self, i: int, result: dict, entry: dict) -> None:
        """Store batch ``i``: ``result`` with the chunk fields (``order``, ``u_motor``,
        ``p_tip_W``, ``iterations``, ``factorizations``, ``time_s``; ``y_W`` when present) and its log ``entry``."""
        self._ensure()
        tmp = self.directory / f".chunk_{i:05d}.tmp{os.getpid()}.npz"
        try:
            with open(tmp, "wb") as fh:
                arrays = {k: np.asarray(result[k]) for k in _FIELDS + _OPTIONAL if k in result}
                np.savez(fh, **arrays, entry_json=np.array(json.dumps(entry, sort_keys=True)))
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, self._path(i))
        finally:
            if tmp.exists():
                tmp.unlink()

    def load_batches(self) -> list[dict]:
        """The batches saved so far, in order (each the chunk fields plus ``entry``). An
        unreadable batch file ends the list and is deleted, with every later one (they
        were picked from data that included it), to be measured again."""
        batches, i = [], 0
        while self._path(i).exists():
            try:
                with np.load(self._path(i), allow_pickle=False) as z:
                    res = {k: z[k] for k in _FIELDS}
                    res["y_W"] = z["y_W"] if "y_W" in z.files else res["p_tip_W"]
                    res["entry"] = json.loads(str(z["entry_json"]))
            except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
                j = i
                while self._path(j).exists():
                    self._path(j).unlink()
                    j += 1
                break
            if res["u_motor"].ndim != 2 or res["p_tip_W"].shape != (len(res["u_motor"]), 3):
                raise CheckpointError(f"{self._path(i)} is not a batch of this run; restarting discards it")
            batches.append(res)
            i += 1
        return batches
