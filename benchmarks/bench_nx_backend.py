"""Benchmark networkx dispatching to graphseg: nx.connected_components(G, backend="graphseg").

Random sparse graphs (N nodes, 1.5 N uniformly random edges: average degree about 3,
many small components besides a giant one) for N = 1e4, 1e5, 1e6, built as a
``networkx.Graph`` with integer labels. Per method, conversion and algorithm are timed
apart (best of ``--repeat``, one run at 1e6):

* ``networkx``: networkx's own ``connected_components`` (no conversion).
* ``graphseg[C]``: conversion = ``EdgeIndexGraph.from_networkx`` (what networkx calls
  for ``backend="graphseg"``); algorithm = ``nx.connected_components`` on the converted
  graph with contractor ``C`` (cluster vector plus the component sets); ``cluster_s``
  = the contractor alone. ``total_s`` of the default contractor is measured end to end
  through ``backend="graphseg"`` with the conversion cache off.
* ``scipy.csgraph``: conversion = ``nx.to_scipy_sparse_array``; algorithm =
  ``scipy.sparse.csgraph.connected_components`` (a label vector, no sets).

Every method's components are checked against networkx's (same sets, same order; scipy:
same count). Writes benchmarks/results/nx_backend.json and .md.

Usage: python benchmarks/bench_nx_backend.py [--sizes 10000 100000 1000000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _common import print_table, timed, write_json  # noqa: E402

CONTRACTORS = ["scipy", "star", "union_find"]


def random_graph(n: int, degree: float, seed: int):
    import networkx as nx

    rng = np.random.default_rng(seed)
    ei = rng.integers(0, n, (2, int(degree * n / 2)))
    G = nx.Graph()
    G.add_nodes_from(range(n))
    G.add_edges_from(ei.T.tolist())
    return G


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    ap.add_argument("--degree", type=float, default=3.0, help="average degree (edges = degree * N / 2)")
    ap.add_argument("--repeat", type=int, default=3, help="best of; graphs of 1e6+ nodes run once")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default="benchmarks/results/nx_backend.json")
    args = ap.parse_args(argv)

    import networkx as nx
    from graphseg.graphs.nx_backend._info import default_contractor
    from scipy.sparse.csgraph import connected_components as csgraph_cc

    from graphseg.graphs.nx_backend import EdgeIndexGraph, component_labels

    default = default_contractor()
    t_start = time.perf_counter()
    rows = []
    for n in args.sizes:
        rep = args.repeat if n < 1_000_000 else 1
        t = time.perf_counter()
        G = random_graph(n, args.degree, args.seed)
        build_s = time.perf_counter() - t
        m = G.number_of_edges()
        print(f"N={n}: built networkx graph with {m} edges in {build_s:.1f} s", flush=True)
        base = {"nodes": n, "edges": m}

        nx_s, expected = timed(lambda: list(nx.connected_components(G)), rep)
        rows.append({**base, "method": "networkx", "convert_s": 0.0, "algo_s": nx_s, "total_s": nx_s, "components": len(expected)})

        conv_s, g = timed(lambda: EdgeIndexGraph.from_networkx(G), rep)
        for c in CONTRACTORS:
            cluster_s, _ = timed(lambda: component_labels(g, contractor=c), rep)
            algo_s, got = timed(lambda: list(nx.connected_components(g, backend="graphseg", contractor=c)), rep)
            if got != expected:
                raise AssertionError(f"graphseg[{c}] components differ from networkx at N={n}")
            row = {**base, "method": f"graphseg[{c}]", "convert_s": conv_s, "cluster_s": cluster_s, "algo_s": algo_s,
                   "total_s": conv_s + algo_s, "components": len(got)}
            if c == default:
                with nx.config(cache_converted_graphs=False):
                    row["total_s"], got = timed(lambda: list(nx.connected_components(G, backend="graphseg")), rep)
                row["method"] += " (default)"
                assert got == expected
            rows.append(row)

        sp_conv_s, A = timed(lambda: nx.to_scipy_sparse_array(G, format="csr"), rep)
        sp_s, (k, _) = timed(lambda: csgraph_cc(A, directed=False), rep)
        if k != len(expected):
            raise AssertionError(f"scipy found {k} components, networkx {len(expected)} at N={n}")
        rows.append({**base, "method": "scipy.csgraph", "convert_s": sp_conv_s, "algo_s": sp_s, "total_s": sp_conv_s + sp_s, "components": k})
        for r in rows:
            if r["nodes"] == n:
                r["algo_vs_nx"] = nx_s / r["algo_s"]
                r["total_vs_nx"] = nx_s / r["total_s"]
        print(f"N={n} done ({time.perf_counter() - t_start:.0f} s so far)", flush=True)
        G = g = A = None  # free the large graphs before the next size

    print()
    cols = ["nodes", "edges", "method", "convert_s", "cluster_s", "algo_s", "total_s", "algo_vs_nx", "total_vs_nx", "components"]
    table = print_table(rows, cols)
    fastest = {}
    for n in args.sizes:
        ours = [r for r in rows if r["nodes"] == n and r["method"].startswith("graphseg")]
        fastest[n] = min(ours, key=lambda r: r["cluster_s"])["method"].split("[")[1].split("]")[0]
    print(f"fastest contractor (cluster_s) per size: {fastest}; default: {default}")
    runtime = time.perf_counter() - t_start
    write_json(args.json, {"degree": args.degree, "repeat": args.repeat, "seed": args.seed, "default_contractor": default,
                           "fastest_contractor": {str(k): v for k, v in fastest.items()}, "runtime_s": runtime, "rows": rows})
    md = Path(args.json).with_suffix(".md")
    md.write_text(
        f"# bench_nx_backend.py: nx.connected_components through the graphseg backend\n\n"
        f"Random graphs, N nodes and {args.degree / 2:g} N random edges, integer labels; best of {args.repeat} "
        f"(one run at 1e6 nodes). convert_s: networkx graph -> backend format (graphseg: "
        f"EdgeIndexGraph.from_networkx; scipy: nx.to_scipy_sparse_array). algo_s: graphseg = "
        f"contractor + component sets through nx.connected_components; scipy = label vector only. "
        f"cluster_s: the contractor alone. total_s of the default contractor: measured end to end via "
        f"backend=\"graphseg\" with the conversion cache off; otherwise convert_s + algo_s. "
        f"*_vs_nx: networkx's time / this time.\n\n{table}\n\n"
        f"Fastest contractor by cluster_s: {fastest}; default: {default}. Runtime {runtime:.0f} s.\n"
    )
    print(f"wrote {md}")
    return {"rows": rows}


if __name__ == "__main__":
    main()
