"""Stage 5: (u, y) data -- which commands to sample, simulating them, and dataset files.

:mod:`.designs` picks safe motor commands (grids, Sobol, space-filling designs) and
:mod:`.chunks` cuts them into walks (:mod:`.commands_file` reads the commands a lab sent);
:mod:`.simulation` solves them with the FEM on joblib workers or a Dask cluster, resumable
through :mod:`.chunkstore`; :mod:`.dataset` reads and writes the CSV + JSON-sidecar format
that simulated and captured data share. The sampling flags are one :class:`DesignSpec`
(:mod:`.design_spec`); :mod:`.simulated_dataset` writes a simulated fixed design as a
dataset, and :mod:`.batchstore` keeps an active design's batches.
:mod:`.repeatability` and :mod:`.diagnostics` measure what a static model can reach on a
dataset (repeatability floor, hysteresis, drift, outliers: ``python -m lab inspect``).
:mod:`.importing` reads external measurements (:class:`ImportSpec`) into a dataset.
"""

from lab.data.chunks import Chunk, grid_chunks, nearest_neighbour_chunks, nearest_walk, ordered_chunks
from lab.data.chunkstore import CheckpointError, ChunkStore, fingerprint
from lab.data.commands_file import read_commands
from lab.data.dataset import (
    columns,
    dataset_markers,
    input_units,
    marker_names,
    output_columns,
    read_dataset,
    sidecar_path,
    write_dataset,
)
from lab.data.design_spec import DesignSpec
from lab.data.designs import (
    DESIGNS,
    design_commands,
    empty_strata,
    grid_commands,
    maximin_commands,
    min_distance,
    random_commands,
    sobol_commands,
)
from lab.data.diagnostics import InspectSpec, drift, inspect_dataset, inspect_file, outliers
from lab.data.import_spec import ImportSpec
from lab.data.importing import Measurements, import_dataset, read_measurements
from lab.data.maximin import greedy_maximin
from lab.data.repeatability import (
    hysteresis,
    local_residuals,
    neighbour_pairs,
    repeatability_floor,
    scaled_commands,
)
from lab.data.sequences import contiguous_blocks, sequence_ids, sequence_starts_of
from lab.data.simulated_dataset import simulate_fixed, simulate_given, solve_batch, write_simulated
from lab.data.simulation import default_jobs, simulate, solve_chunk

__all__ = [
    "DesignSpec",
    "simulate_fixed",
    "simulate_given",
    "read_commands",
    "ordered_chunks",
    "solve_batch",
    "write_simulated",
    "Chunk",
    "grid_commands",
    "sobol_commands",
    "DESIGNS",
    "design_commands",
    "random_commands",
    "empty_strata",
    "maximin_commands",
    "greedy_maximin",
    "min_distance",
    "grid_chunks",
    "nearest_neighbour_chunks",
    "nearest_walk",
    "solve_chunk",
    "simulate",
    "default_jobs",
    "CheckpointError",
    "fingerprint",
    "ChunkStore",
    "columns",
    "output_columns",
    "marker_names",
    "dataset_markers",
    "input_units",
    "write_dataset",
    "sidecar_path",
    "read_dataset",
    "sequence_ids",
    "sequence_starts_of",
    "contiguous_blocks",
    "InspectSpec",
    "inspect_dataset",
    "inspect_file",
    "local_residuals",
    "drift",
    "outliers",
    "scaled_commands",
    "neighbour_pairs",
    "repeatability_floor",
    "hysteresis",
    "ImportSpec",
    "Measurements",
    "read_measurements",
    "import_dataset",
]
