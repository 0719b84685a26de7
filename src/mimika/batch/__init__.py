"""Batch stimulus and data-set generation: a YAML spec → many rendered, FACS-labelled images.

:func:`load_spec` reads and validates a spec (:mod:`mimika.batch.spec`), :func:`make_plan`
expands it into items with their AU values after the AU Blender (:mod:`mimika.batch.plan`) and
:func:`run_batch` renders the items on a Dask cluster (:mod:`mimika.batch.run`). Dask is imported
only when a batch actually runs.
"""

from mimika.batch.plan import Item, Plan, make_plan
from mimika.batch.spec import BatchSpec, SpecError, load_spec, parse_spec

__all__ = ["BatchReport", "BatchSpec", "Item", "Plan", "SpecError", "load_spec", "make_plan",
           "parse_spec", "run_batch"]


def __getattr__(name: str):
    if name in ("run_batch", "BatchReport"):
        from mimika.batch import run

        return getattr(run, name)
    raise AttributeError(f"module 'mimika.batch' has no attribute {name!r}")
