"""A lazy roadmap per cell, reused across the planned moves of every job in it (LazyPRM: Bohlin and Kavraki,
"Path planning using lazy PRM", ICRA 2000).

``Roadmap(model)``: ROADMAP_NODES configurations drawn once from a fixed seed (ROADMAP_SEED) in the robot's
joint limits, kept when they keep the planning margins, each joined to its ROADMAP_NEIGHBOURS nearest in time
(the slowest joint's step over its top speed). No edge is checked when the roadmap is made: an edge is checked
when a query's shortest path takes it (every unchecked edge of that path), its verdict is kept for every later
query, and the shortest path is searched again without the edges found blocked (SciPy's Dijkstra), until a
path is free or none is left. The answer is the shortest free path of the roadmap, whatever earlier queries
found out, so the same query gives the same path in any process. ``roadmap_of(model)`` makes a cell's roadmap
once per process (the first query pays for its nodes: ~1,000 collision checks).
"""

from __future__ import annotations

import time
import weakref
from dataclasses import dataclass

import numpy as np

#: Nodes, neighbours per node, the neighbours a query's start and goal are joined to, the seed.
ROADMAP_NODES = 1000
ROADMAP_NEIGHBOURS = 10
END_NEIGHBOURS = 30
ROADMAP_SEED = 0
#: Most draws per node kept (a cell where fewer than 1 in 20 configurations is free has no roadmap).
MAX_DRAWS_PER_NODE = 20
#: A route is given up when it would take longer (at top speed) than this many times the straight
#: edge plus ROUTE_SLACK_S [s]: no detour a programmer would keep.
ROUTE_FACTOR = 6.0
ROUTE_SLACK_S = 1.0

_roadmaps: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def roadmap_of(model, valid) -> Roadmap | None:
    """The roadmap of ``model`` (a CollisionModel), made on first use with ``valid(Q) -> bool (k,)`` (the
    planning margins of configurations Q (k, dof)); None for an arm with a continuous joint (no box to draw in)
    or a cell too crowded to fill one."""
    if model not in _roadmaps:
        _roadmaps[model] = None if model.robot.limits.continuous.any() else Roadmap.made(model.robot, valid)
    return _roadmaps[model]


class Roadmap:
    """Nodes ``Q`` (n, dof) [rad or m] and undirected edges ``pairs`` (m, 2) (node indices, lower first)
    with their ``weights`` (m,) [s at top speed]; ``verdicts`` (m,): 1 free, -1 blocked, 0 not checked."""

    def __init__(self, Q: np.ndarray, qd_max: np.ndarray):
        from scipy.spatial import cKDTree

        self.Q, self.qd_max = Q, qd_max
        self.tree = cKDTree(Q / qd_max)
        _, near = self.tree.query(Q / qd_max, ROADMAP_NEIGHBOURS + 1, p=np.inf)
        pairs = np.sort(np.stack([np.repeat(np.arange(len(Q)), ROADMAP_NEIGHBOURS), near[:, 1:].ravel()], axis=1),
                        axis=1)
        self.pairs = np.unique(pairs[pairs[:, 0] != pairs[:, 1]], axis=0)
        self.weights = self._weights(Q[self.pairs[:, 0]], Q[self.pairs[:, 1]])
        self.verdicts = np.zeros(len(self.pairs), dtype=np.int8)
        self.index = {(int(a), int(b)): k for k, (a, b) in enumerate(self.pairs)}
        self.entries = _Entries.sorted(self.pairs, len(Q) + 2)

    @classmethod
    def made(cls, robot, valid) -> Roadmap | None:
        rng = np.random.default_rng(ROADMAP_SEED)
        nodes: list[np.ndarray] = []
        for _ in range(MAX_DRAWS_PER_NODE):
            Q = robot.random_configurations(rng, ROADMAP_NODES)
            nodes += list(Q[valid(Q)])
            if len(nodes) >= ROADMAP_NODES:
                return cls(np.array(nodes[:ROADMAP_NODES]), robot.limits.qd_max)
        return None

    def _weights(self, A: np.ndarray, B: np.ndarray) -> np.ndarray:
        return np.abs((B - A) / self.qd_max).max(axis=1) + 1e-12

    def path(self, q_start: np.ndarray, q_goal: np.ndarray, checks, deadline: float) -> np.ndarray | None:
        """The shortest free path from ``q_start`` to ``q_goal`` through the roadmap (k, dof), ends
        included, or None: none shorter than ROUTE_FACTOR times the straight edge plus ROUTE_SLACK_S, or
        none found by ``deadline`` (``time.perf_counter``). ``checks``: the query's
        ``pipeline.cell.planning._Checks`` (its remembered edge checks). Whether a free route exists
        within the limit does not depend on what earlier queries found out: the answer is the same in any
        process, unless the deadline cuts it short."""
        from scipy.sparse import csr_matrix
        from scipy.sparse.csgraph import dijkstra

        n = len(self.Q)
        ends = np.array([q_start, q_goal])
        _, near = self.tree.query(ends / self.qd_max, END_NEIGHBOURS, p=np.inf)
        pairs = np.vstack([self.pairs, np.stack([np.repeat([n, n + 1], END_NEIGHBOURS), near.ravel()], axis=1)])
        weights = np.concatenate([self.weights,
                                  self._weights(ends.repeat(END_NEIGHBOURS, axis=0), self.Q[near.ravel()])])
        verdicts = np.concatenate([self.verdicts, np.zeros(2 * END_NEIGHBOURS, dtype=np.int8)])
        index = self.index | {(int(a), int(b)): len(self.pairs) + k
                              for k, (a, b) in enumerate(pairs[len(self.pairs):])}
        Q = np.vstack([self.Q, ends])
        longest = ROUTE_FACTOR * float(self._weights(ends[:1], ends[1:])[0]) + ROUTE_SLACK_S
        for end in (n, n + 1):             # an end whose every edge into the roadmap is blocked (deep in a fixture)
            own = len(self.pairs) + np.nonzero(pairs[len(self.pairs):, 0] == end)[0]
            if not any(_checked(Q, pairs, verdicts, [k], checks) for k in own[np.argsort(weights[own])]):
                return None
        # the graph made once with each edge both ways, in canonical order (rows, then columns): a blocked edge's
        # weight is made inf (Dijkstra never takes it) at its two ``positions``
        entries = self.entries.with_edges(pairs[len(self.pairs):], len(self.pairs))
        positions = np.empty(len(entries.ids), dtype=np.int64)
        positions[entries.ids] = np.arange(len(entries.ids))
        positions = positions.reshape(-1, 2).T
        graph = csr_matrix((np.where(verdicts < 0, np.inf, weights)[entries.ids // 2], entries.columns,
                            np.searchsorted(entries.rows, np.arange(n + 3))), shape=(n + 2, n + 2))
        try:
            while time.perf_counter() < deadline:
                distance, previous = dijkstra(graph, directed=True, indices=n, return_predecessors=True,
                                              limit=longest)
                if not distance[n + 1] <= longest:
                    return None
                route = [n + 1]
                while route[-1] != n:
                    route.append(int(previous[route[-1]]))
                route.reverse()
                edges = [index.get((a, b), index.get((b, a))) for a, b in zip(route[:-1], route[1:])]
                unknown = [k for k in edges if verdicts[k] == 0]
                if _checked(Q, pairs, verdicts, unknown, checks):
                    return Q[route]
                graph.data[positions[:, [k for k in unknown if verdicts[k] < 0]].ravel()] = np.inf
            return None
        finally:
            self.verdicts = verdicts[:len(self.verdicts)]


@dataclass(frozen=True)
class _Entries:
    """A graph's entries, each edge k of ``pairs`` both ways (id 2k: row pairs[k, 0], id 2k + 1: the other way), in
    canonical order (by ``keys``: row, then column, of a matrix of ``size`` rows)."""

    ids: np.ndarray
    rows: np.ndarray
    columns: np.ndarray
    keys: np.ndarray
    size: int

    @classmethod
    def sorted(cls, pairs: np.ndarray, size: int) -> _Entries:
        rows, columns = pairs.ravel(), pairs[:, ::-1].ravel()
        keys = rows * size + columns
        order = np.argsort(keys)
        return cls(order, rows[order], columns[order], keys[order], size)

    def with_edges(self, pairs: np.ndarray, first: int) -> _Entries:
        """These entries and those of ``pairs`` (edges ``first``, ``first`` + 1, ...), merged in canonical order."""
        more = _Entries.sorted(pairs, self.size)
        at = np.searchsorted(self.keys, more.keys)
        return _Entries(np.insert(self.ids, at, more.ids + 2 * first), np.insert(self.rows, at, more.rows),
                        np.insert(self.columns, at, more.columns), np.insert(self.keys, at, more.keys), self.size)


def _checked(Q: np.ndarray, pairs: np.ndarray, verdicts: np.ndarray, unknown: list[int], checks) -> bool:
    """Whether the ``unknown`` edges (indices into ``pairs``) are all free, each checked and its verdict kept
    in ``verdicts`` (every blocked edge of a route found at once: fewer searches)."""
    for k in unknown:
        verdicts[k] = 1 if checks.edge(Q[pairs[k, 0]], Q[pairs[k, 1]]) else -1
    return all(verdicts[k] > 0 for k in unknown)
