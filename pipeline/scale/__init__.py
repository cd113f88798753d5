"""Batches of jobs and reachability maps, on one machine or a Dask cluster.

``run_batch(jobs, out_dir, client=None)`` (``batch``) and ``reachability_map(robot_or_cell, ...,
client=None)`` (``reach``, a ``ReachabilityMap`` with ``.save(dir)``) run in this process without a
client, or on the workers of a ``distributed.Client``; ``dask_client(workers, scheduler)`` (``cluster``)
opens a LocalCluster or connects to a running scheduler. Dask is imported only when a client is opened.
"""

from .batch import BatchOutcome, run_batch
from .cluster import dask_client, map_chunks
from .reach import reachability_map
from .result import ReachabilityMap

__all__ = ["BatchOutcome", "ReachabilityMap", "dask_client", "map_chunks", "reachability_map", "run_batch"]
