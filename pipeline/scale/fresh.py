"""One job in a Python process of its own: ``python -m pipeline.scale.fresh JOB.pickle RUN.pickle`` runs
the pickled (job, max_samples) with ``batch.run_here`` and pickles the JobRun it returns (``batch.run_one``
sends jobs that plan here: OMPL takes one seed per process)."""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

from .batch import run_here


def main(given: str, taken: str) -> None:
    job, max_samples = pickle.loads(Path(given).read_bytes())
    Path(taken).write_bytes(pickle.dumps(run_here(job, max_samples)))


if __name__ == "__main__":
    main(*sys.argv[1:3])
