"""Closed-loop result files as a per-pass table (chapter 09; files in ``data/closed_loop/``).

:func:`pass_rows` reads ``track --closed-loop`` results (:mod:`.closed_loop`) into one row per
(trajectory, model, mode, pass); :func:`.pass_rows` output feeds
:func:`lab.viz.closed_loop.plot_closed_loop`.
"""

from __future__ import annotations

from pathlib import Path

from lab.tracking.track import TrackResultError, read_result

#: the chapter's goals, mean error in m after the passes: per model label
GOALS_M = {"real": 3e-4, "sim": 5e-4}


def model_label(model_path) -> str:
    """``real``/``sim`` for the shipped ``model_{real,sim}_*.npz``, else the file's stem."""
    stem = Path(str(model_path)).stem
    for label in ("real", "sim"):
        if stem.startswith(f"model_{label}_"):
            return label
    return stem


def pass_rows(paths) -> list[dict]:
    """Rows ``trajectory, model, mode, pass, mean_error_m, max_error_m, n_skipped, file`` (errors
    in m) from closed-loop result files: ``paths`` a folder (its ``*.json``) or a list of files.
    A file that is no closed-loop result raises :class:`.track.TrackResultError`."""
    if isinstance(paths, (str, Path)) and Path(paths).is_dir():
        paths = sorted(Path(paths).glob("*.json"))
    elif isinstance(paths, (str, Path)):
        paths = [paths]
    rows = []
    for path in paths:
        doc = read_result(path)
        if not isinstance(doc.get("passes"), list) or "closed_loop" not in doc.get("info", {}):
            raise TrackResultError(f"{path}: not a closed-loop track result (no 'passes')")
        for p in doc["passes"]:
            rows.append(
                {
                    "trajectory": doc.get("trajectory", "custom"),
                    "model": model_label(doc["info"].get("model") or "soft-ik"),
                    "mode": doc["info"]["closed_loop"]["mode"],
                    "pass": int(p["pass"]),
                    "mean_error_m": float(p["mean_error_m"]),
                    "max_error_m": float(p["max_error_m"]),
                    "n_skipped": int(p.get("n_skipped", 0)),
                    "file": Path(path).name,
                }
            )
    return rows
