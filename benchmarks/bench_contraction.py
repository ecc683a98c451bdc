"""Benchmark contractors on random graphs: star vs union-find vs scipy vs networkx.

Random graphs with N nodes and 5 N uniformly random edges (N = 1e4, 1e5, 1e6).
networkx runs only while its previous size, scaled by 10, stays under 60 s.

Targets (issue 2): star <= 3x scipy's time at 1e6 nodes; star >= 20x faster than
networkx at the largest size networkx runs.

Usage: python benchmarks/bench_contraction.py [--sizes 10000 100000 1000000] [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _common import peak_traced_mb, print_table, timed, write_json  # noqa: E402

from graphseg.graphs import canonical_cluster, randomized_star_contraction, union_find_contraction  # noqa: E402


def scipy_cc(ei: np.ndarray, n: int) -> np.ndarray:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    adj = coo_matrix((np.ones(ei.shape[1], np.int8), (ei[0], ei[1])), shape=(n, n))
    return connected_components(adj, directed=False)[1]


def networkx_cc(ei: np.ndarray, n: int) -> np.ndarray:
    import networkx as nx

    g = nx.Graph()
    g.add_nodes_from(range(n))
    g.add_edges_from(ei.T.tolist())
    out = np.empty(n, np.int64)
    for k, comp in enumerate(nx.connected_components(g)):
        out[list(comp)] = k
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    ap.add_argument("--degree", type=int, default=5, help="edges per node")
    ap.add_argument("--json", default="benchmarks/results/contraction.json")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)

    rows = []
    nx_allowed, nx_last = True, None
    for n in args.sizes:
        rng = np.random.default_rng(args.seed)
        ei = rng.integers(0, n, (2, args.degree * n))
        ref = canonical_cluster(scipy_cc(ei, n))
        methods = {
            "star": lambda: randomized_star_contraction(ei, n, rng=1),
            "scipy": lambda: scipy_cc(ei, n),
            "union_find": lambda: union_find_contraction(ei, n),
        }
        if nx_allowed:
            methods["networkx"] = lambda: networkx_cc(ei, n)
        res = {"nodes": n, "edges": int(ei.shape[1])}
        for name, fn in methods.items():
            repeat = 3 if n <= 100_000 and name in ("star", "scipy") else 1
            t, out = timed(fn, repeat)
            assert np.array_equal(canonical_cluster(out), ref), name
            res[f"{name}_s"] = t
            res[f"{name}_peak_mb"] = peak_traced_mb(fn) if not (name == "networkx" and t > 20) else None
            if name == "networkx":
                nx_last = t
        _, rounds = randomized_star_contraction(ei, n, rng=1, return_rounds=True)
        res["star_rounds"] = rounds
        res["star/scipy"] = res["star_s"] / res["scipy_s"]
        if "networkx_s" in res:
            res["networkx/star"] = res["networkx_s"] / res["star_s"]
        rows.append(res)
        if nx_last is not None and nx_last * 10 > 60:
            nx_allowed = False
    cols = ["nodes", "edges", "star_s", "scipy_s", "union_find_s", "networkx_s", "star_rounds",
            "star/scipy", "networkx/star", "star_peak_mb", "scipy_peak_mb", "union_find_peak_mb", "networkx_peak_mb"]
    print_table(rows, cols)
    largest = rows[-1]
    nx_rows = [r for r in rows if "networkx_s" in r]
    targets = {
        "star_le_3x_scipy_at_largest": bool(largest["star/scipy"] <= 3.0),
        "star_ge_20x_networkx_at_largest_nx_size": bool(nx_rows and nx_rows[-1]["networkx/star"] >= 20.0),
    }
    print("targets:", targets)
    write_json(args.json, {"rows": rows, "targets": targets})
    return {"rows": rows, "targets": targets}


if __name__ == "__main__":
    main()
