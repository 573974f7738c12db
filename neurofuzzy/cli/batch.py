"""``neurofuzzy fit-many``: many specimens as tasks on Dask (:func:`neurofuzzy.batch.fit_many`)."""

from __future__ import annotations

import sys

from .common import print_json, written

__all__ = ["fit_many", "EXIT_SOME_FAILED"]

#: some specimens failed (their errors are recorded; the others' results are written)
EXIT_SOME_FAILED = 1


def fit_many(args) -> int:
    from ..batch import fit_many as run
    from ..extras import require

    require("batch", "fit-many (specimens as tasks on Dask)")       # before any work
    cohort = run(args.manifest, args.out, report=args.report, scheduler=args.scheduler,
                 workers=args.workers, resume=args.resume, seed=args.seed,
                 progress=not args.quiet)
    if args.json:
        print_json(cohort.to_dict())
    else:
        print(f"fit-many: {len(cohort.specimens)} specimens: {len(cohort.ok)} fitted"
              + (f" ({len(cohort.resumed)} kept from an earlier run)" if cohort.resumed else "")
              + f", {len(cohort.failed)} failed ({cohort.seconds:.1f} s)")
        written(cohort.table, cohort.report)
    if cohort.failed:
        for ident in cohort.failed:
            print(f"neurofuzzy: failed: {ident}: {cohort.records[ident]['error']}",
                  file=sys.stderr)
        return EXIT_SOME_FAILED
    return 0
