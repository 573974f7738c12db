"""Many specimens at once: ``neurofuzzy fit-many`` in Python.

- :func:`read_manifest` (:class:`Specimen`): the manifest, one row per specimen, checked;
- :func:`fit_many` (:class:`Cohort`): every specimen one task on Dask (``dask.distributed``,
  imported only here, when a batch runs: ``pip install 'neurofuzzy[batch]'``), results
  written incrementally, resumable;
- :func:`fit_specimen`: one specimen's fit, the one of ``neurofuzzy fit``;
- :func:`cohort_report`: the materials, words and comparison of the groups.
"""

from .cohort import cohort_report, cohort_summary, median_difference
from .manifest import Specimen, read_manifest
from .run import Cohort, fit_many
from .task import fit_quality, fit_specimen

__all__ = ["read_manifest", "Specimen", "fit_many", "Cohort", "fit_specimen", "fit_quality",
           "cohort_report", "cohort_summary", "median_difference"]
