"""The graphseg networkx backend: conversion, components, quotient_graph, dispatch hooks,
and networkx's own test files run against it (the way networkx tests its backends)."""

import logging
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from collections import Counter

import networkx as nx
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from graphseg._nx_backend_info import (
    CONTRACTOR_ENV,
    DEFAULT_CONTRACTOR,
    FUNCTIONS,
    default_contractor,
    get_info,
)
from graphseg.graphs.graph import GraphValidationError
from graphseg.graphs.nx_backend import EdgeIndexGraph, component_labels, quotient_graph
from graphseg.graphs.nx_backend.graph import networkx_to_arrays
from graphseg.graphs.nx_backend.interface import SHOULD_RUN_MIN_NODES, BackendInterface
from graphseg.registry import PluginNotFoundError

CONTRACTORS = ["scipy", "star", "union_find"]
COMPONENT_FUNCTIONS = ["connected_components", "number_connected_components", "node_connected_component", "is_connected"]


@pytest.fixture(autouse=True, scope="module")
def no_conversion_cache():
    """Convert on every call: networkx warns (an error here) when it reuses a cached conversion."""
    with nx.config(cache_converted_graphs=False):
        yield


# --- registration -------------------------------------------------------------------------


def test_registered_with_networkx():
    assert "graphseg" in nx.utils.backends.backends
    info = nx.utils.backends.backend_info["graphseg"]
    assert set(info["functions"]) == set(COMPONENT_FUNCTIONS) | {"quotient_graph"}
    for name in info["functions"]:
        assert callable(getattr(BackendInterface, name))
        assert "graphseg" in nx.utils.backends._registered_algorithms[name].backends
    assert nx.config.backends.graphseg.contractor == default_contractor()


def test_networkx_import_reads_backend_info_without_warnings():
    # networkx reads backend_info halfway through its own import and turns a failure into
    # a RuntimeWarning; -W error makes any such failure fail this test.
    code = "import networkx as nx; print(sorted(nx.utils.backends.backend_info['graphseg']['functions']))"
    out = subprocess.run([sys.executable, "-W", "error", "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == str(sorted(FUNCTIONS))


def test_info_default_contractor_env(monkeypatch):
    monkeypatch.setenv(CONTRACTOR_ENV, "star")
    assert get_info()["default_config"] == {"contractor": "star"}
    monkeypatch.delenv(CONTRACTOR_ENV)
    assert get_info()["default_config"] == {"contractor": DEFAULT_CONTRACTOR}
    assert set(get_info()["functions"]) == set(FUNCTIONS)


# --- conversion ---------------------------------------------------------------------------


def test_conversion_hand_computed():
    G = nx.Graph()
    G.add_nodes_from(["a", "b", "c", "d"])
    G.add_edges_from([("b", "a", {"w": 2.5}), ("c", "c"), ("a", "c", {"w": 4.0})])
    ei, nodes, cols = networkx_to_arrays(G, edge_attrs={"w": 1})
    assert nodes == ["a", "b", "c", "d"]
    assert ei.dtype == np.int64 and ei.shape == (2, 3)
    assert sorted(map(tuple, ei.T.tolist())) == [(0, 1), (0, 2), (2, 2)]
    assert (ei[0] <= ei[1]).all()
    w = dict(zip(map(tuple, ei.T.tolist()), cols["w"].tolist()))
    assert w == {(0, 1): 2.5, (0, 2): 4.0, (2, 2): 1.0} and cols["w"].dtype == np.float64


@pytest.mark.parametrize(
    "nodes",
    [[0, 1, 2, 3], [7, -2, 30, 5], [2**70, 1, 2, 3], ["x", 1, (0, 1), 2.5]],
    ids=["range", "ints", "huge-int", "mixed"],
)
def test_conversion_label_kinds(nodes):
    G = nx.Graph()
    G.add_nodes_from(nodes)
    G.add_edges_from([(nodes[3], nodes[0]), (nodes[1], nodes[1])])
    g = EdgeIndexGraph.from_networkx(G)
    assert list(g) == nodes and g.num_nodes == 4
    assert sorted(map(tuple, g.edge_index.T.tolist())) == [(0, 3), (1, 1)]
    assert g.labels_of(np.array([3, 0])) == [nodes[3], nodes[0]]
    assert all(type(x) is type(y) for x, y in zip(g.labels_of(np.arange(4)), nodes))
    back = g.to_networkx()
    assert list(back) == nodes and set(map(frozenset, back.edges())) == set(map(frozenset, G.edges()))


def test_conversion_multigraph_view_and_errors():
    M = nx.MultiGraph([(0, 1), (0, 1), (1, 2)])
    assert EdgeIndexGraph.from_networkx(M).edge_index.tolist() == [[0, 1], [1, 2]]
    view = nx.path_graph(5).subgraph([4, 1, 2])
    g = EdgeIndexGraph.from_networkx(view)
    assert list(g) == list(view) and g.labels_of(g.edge_index.ravel()) != []
    assert {frozenset(g.labels_of(e)) for e in g.edge_index.T} == {frozenset((1, 2))}
    with pytest.raises(NotImplementedError, match="directed DiGraph"):
        networkx_to_arrays(nx.DiGraph([(0, 1)]))
    with pytest.raises(NotImplementedError, match="multigraph"):
        networkx_to_arrays(M, edge_attrs={"weight": 1})
    with pytest.raises(TypeError, match="got list"):
        BackendInterface.convert_from_nx([1, 2], name="connected_components", graph_name="G")


def test_edge_index_graph_validation_and_no_mutation():
    ei = np.array([[0, 1], [1, 2]])
    g = EdgeIndexGraph(ei, 3, nodes="xyz")
    assert ei.flags.writeable and not g.edge_index.flags.writeable
    assert g.edge_index is not ei and len(g) == 3 and "y" in g and [0] not in g
    with pytest.raises(GraphValidationError, match="got 3"):
        EdgeIndexGraph([[0], [3]], 3)
    with pytest.raises(ValueError, match="expected 3 node labels"):
        EdgeIndexGraph([[0], [1]], 3, nodes="xy")
    with pytest.raises(ValueError, match="1 repeated"):
        EdgeIndexGraph([[0], [1]], 3, nodes="xyx")
    with pytest.raises(ValueError, match=r"edge_attr\['w'\]"):
        EdgeIndexGraph([[0], [1]], 3, edge_attr={"w": [1, 2]})
    assert BackendInterface.convert_from_nx(g) is g
    assert BackendInterface.convert_to_nx(5) == 5
    assert isinstance(BackendInterface.convert_to_nx(g), nx.Graph)


# --- components ---------------------------------------------------------------------------


def _toy():
    G = nx.Graph([("a", "b"), ("b", "c"), ("d", "e"), ("f", "f")])
    G.add_node("g")
    return G


@pytest.mark.parametrize("contractor", CONTRACTORS)
def test_components_hand_computed(contractor):
    G = _toy()
    comps = list(nx.connected_components(G, backend="graphseg", contractor=contractor))
    assert comps == [{"a", "b", "c"}, {"d", "e"}, {"f"}, {"g"}]
    assert nx.number_connected_components(G, backend="graphseg", contractor=contractor) == 4
    assert nx.node_connected_component(G, "e", backend="graphseg", contractor=contractor) == {"d", "e"}
    assert nx.is_connected(G, backend="graphseg", contractor=contractor) is False
    assert nx.is_connected(nx.path_graph(4), backend="graphseg", contractor=contractor) is True
    assert component_labels(G, contractor=contractor).tolist() == [0, 0, 0, 1, 1, 2, 3]


def test_components_edge_cases():
    empty = nx.Graph()
    assert list(nx.connected_components(empty, backend="graphseg")) == []
    assert nx.number_connected_components(empty, backend="graphseg") == 0
    with pytest.raises(nx.NetworkXPointlessConcept, match="null graph"):
        nx.is_connected(empty, backend="graphseg")
    assert nx.is_connected(nx.Graph([(0, 0)]), backend="graphseg") is True
    with pytest.raises(KeyError):
        nx.node_connected_component(_toy(), "zz", backend="graphseg")
    with pytest.raises(nx.NetworkXNotImplemented):
        nx.number_connected_components(nx.DiGraph([(0, 1)]), backend="graphseg")
    # Components are fresh sets: clearing one changes nothing else.
    comps = list(nx.connected_components(_toy(), backend="graphseg"))
    comps[0].clear()
    assert comps[1] == {"d", "e"}


def test_conversion_is_cached_by_networkx():
    G = _toy()
    with nx.config(cache_converted_graphs=True):
        assert nx.number_connected_components(G, backend="graphseg") == 4
        (cached,) = G.__networkx_cache__["backends"]["graphseg"].values()
        assert isinstance(cached, EdgeIndexGraph) and cached.source is G
        with pytest.warns(UserWarning, match="cached graph is being used for the 'graphseg' backend"):
            assert nx.number_connected_components(G, backend="graphseg") == 4
        G.add_edge("a", "g")  # networkx clears the cache on mutation
        assert nx.number_connected_components(G, backend="graphseg") == 3


def test_backend_graph_dispatches_by_itself():
    g = EdgeIndexGraph([[0, 2], [1, 3]], 5, nodes=["p", "q", "r", "s", "t"])
    assert list(nx.connected_components(g)) == [{"p", "q"}, {"r", "s"}, {"t"}]
    assert nx.number_connected_components(g) == 3 and not nx.is_connected(g)


def test_contractor_config_is_used():
    G = _toy()
    with nx.config.backends.graphseg(contractor="no_such_contractor"):
        with pytest.raises(PluginNotFoundError, match="no_such_contractor"):
            list(nx.connected_components(G, backend="graphseg"))
    with nx.config.backends.graphseg(contractor="star"):
        assert nx.number_connected_components(G, backend="graphseg") == 4
    with pytest.raises(ValueError, match="'gaec' reads signed edge attributes"):
        nx.number_connected_components(G, backend="graphseg", contractor="gaec")


# --- hypothesis: graphseg == networkx ------------------------------------------------------

LABELS = st.one_of(st.integers(-50, 50), st.text(max_size=3), st.tuples(st.integers(0, 3), st.integers(0, 3)))


@st.composite
def labelled_graphs(draw):
    kind = draw(st.sampled_from(["range", "shuffled", "ints", "mixed"]))
    n = draw(st.integers(0, 40))
    if kind == "range":
        nodes = list(range(n))
    elif kind == "shuffled":
        nodes = draw(st.permutations(range(n)))
    elif kind == "ints":
        nodes = draw(st.lists(st.integers(-(2**40), 2**40), unique=True, max_size=40))
    else:
        nodes = draw(st.lists(LABELS, unique=True, max_size=40))
    G = draw(st.sampled_from([nx.Graph, nx.MultiGraph]))()
    G.add_nodes_from(nodes)  # nodes without edges stay isolated
    if nodes:
        idx = st.integers(0, len(nodes) - 1)
        pairs = draw(st.lists(st.tuples(idx, idx), max_size=2 * len(nodes)))  # self-loops included
        G.add_edges_from((nodes[i], nodes[j]) for i, j in pairs)
        if draw(st.booleans()):
            G = G.subgraph(draw(st.lists(st.sampled_from(nodes), max_size=len(nodes))))
    return G


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(labelled_graphs(), st.sampled_from(CONTRACTORS), st.data())
def test_components_match_networkx(G, contractor, data):
    expected = list(nx.connected_components(G))
    got = list(nx.connected_components(G, backend="graphseg", contractor=contractor))
    assert got == expected  # same sets in the same order
    assert nx.number_connected_components(G, backend="graphseg", contractor=contractor) == len(expected)
    if len(G):
        assert nx.is_connected(G, backend="graphseg", contractor=contractor) == nx.is_connected(G)
        v = data.draw(st.sampled_from(list(G)))
        assert nx.node_connected_component(G, v, backend="graphseg", contractor=contractor) == nx.node_connected_component(G, v)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 30), st.integers(0, 60), st.integers(0, 2**32 - 1))
def test_edge_index_graph_components_match_networkx(n, e, seed):
    rng = np.random.default_rng(seed)
    ei = rng.integers(0, max(n, 1), (2, e if n else 0))
    g = EdgeIndexGraph(ei, n)
    ref = nx.empty_graph(n)
    ref.add_edges_from(ei.T.tolist())
    assert list(nx.connected_components(g)) == list(nx.connected_components(ref))


# --- quotient_graph -----------------------------------------------------------------------


def test_quotient_hand_computed():
    G = nx.Graph()
    G.add_edges_from([(0, 1, {"weight": 2}), (1, 2, {"weight": 5}), (2, 3), (3, 0, {"weight": 7}), (0, 0)])
    Q = nx.quotient_graph(G, [{0, 1}, {2, 3}], backend="graphseg")
    A, B = frozenset({0, 1}), frozenset({2, 3})
    assert list(Q) == [A, B]
    assert Q[A][B]["weight"] == 5 + 7  # edges 1-2 and 3-0
    assert Q.nodes[A]["nnodes"] == 2 and Q.nodes[A]["nedges"] == 2  # 0-1 and the self-loop 0-0
    assert Q.nodes[A]["density"] == 2.0 and Q.nodes[B]["density"] == 1.0
    assert set(Q.nodes[A]["graph"].edges()) == {(0, 1), (0, 0)}
    R = nx.quotient_graph(G, {"x": [0, 1], "y": [2]}, relabel=True, backend="graphseg")  # 3 uncovered
    assert list(R.edges(data="weight")) == [(0, 1, 5)] and set(R.nodes[1]["graph"]) == {2}
    # A backend graph: weights from its column, or 1 per edge without one.
    g = EdgeIndexGraph([[0, 1, 0], [1, 2, 2]], 3, edge_attr={"weight": [1.5, 2.0, 4.0]})
    assert list(nx.quotient_graph(g, [{0}, {1, 2}]).edges(data="weight")) == [(frozenset({0}), frozenset({1, 2}), 5.5)]
    plain = quotient_graph(EdgeIndexGraph([[0, 1, 0], [1, 2, 2]], 3), [{0}, {1, 2}])
    assert list(plain.edges(data="weight")) == [(frozenset({0}), frozenset({1, 2}), 2)]
    assert set(plain.nodes[frozenset({1, 2})]["graph"].edges()) == {(1, 2)}


def test_quotient_errors_and_declared_limits():
    G = nx.path_graph(4)
    for bad in ([{0, 1}, {1, 2, 3}], [{0, 1}, {2, 3, 9}], [[0, 0], [1, 2, 3]]):
        with pytest.raises(nx.NetworkXException, match="exactly one part"):
            nx.quotient_graph(G, bad, backend="graphseg")
        with pytest.raises(nx.NetworkXException, match="exactly one part"):
            nx.quotient_graph(G, bad)
    declared = [
        (nx.DiGraph([(0, 1)]), [{0}, {1}], "directed"),
        (nx.MultiGraph([(0, 1)]), [{0}, {1}], "multigraphs"),
        (G, lambda u, v: u == v, "equivalence relation"),
    ]
    for graph, partition, word in declared:
        reason = BackendInterface.can_run("quotient_graph", (graph, partition), {})
        assert isinstance(reason, str) and word in reason
        with pytest.raises(NotImplementedError, match="not implemented by 'graphseg'"):
            nx.quotient_graph(graph, partition, backend="graphseg")
    with pytest.raises(NotImplementedError, match="edge_relation"):
        quotient_graph(G, [{0}, {1, 2, 3}], edge_relation=lambda b, c: True)
    assert BackendInterface.can_run("quotient_graph", (G, [{0, 1, 2, 3}]), {"create_using": nx.DiGraph}) != True  # noqa: E712


@st.composite
def partitioned_graphs(draw):
    n = draw(st.integers(0, 25))
    nodes = draw(st.permutations(range(n))) if draw(st.booleans()) else [f"n{i}" for i in range(n)]
    G = nx.Graph()
    G.add_nodes_from(nodes)
    if n:
        idx = st.integers(0, n - 1)
        for i, j, w in draw(st.lists(st.tuples(idx, idx, st.one_of(st.none(), st.integers(-3, 9))), max_size=3 * n)):
            G.add_edge(nodes[i], nodes[j], **({} if w is None else {"weight": w}))
    k = draw(st.integers(1, 6))
    block_of = draw(st.lists(st.integers(-1, k - 1), min_size=n, max_size=n))  # -1: not covered
    blocks = [[v for v, b in zip(nodes, block_of) if b == i] for i in range(k)]
    if draw(st.booleans()):
        blocks = [b for b in blocks if b]  # sometimes keep empty blocks
    as_dict = draw(st.booleans())
    return G, ({f"b{i}": b for i, b in enumerate(blocks)} if as_dict else blocks)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(partitioned_graphs(), st.booleans())
def test_quotient_matches_networkx(case, relabel):
    G, partition = case
    expected = nx.quotient_graph(G, partition, relabel=relabel)
    got = nx.quotient_graph(G, partition, relabel=relabel, backend="graphseg")
    assert type(got) is type(expected)
    assert list(got) == list(expected)
    for v in expected:
        de, dg = expected.nodes[v], got.nodes[v]
        assert list(dg) == list(de)
        assert (dg["nnodes"], dg["nedges"], dg["density"]) == (de["nnodes"], de["nedges"], de["density"])
        assert set(dg["graph"]) == set(de["graph"])
        assert set(map(frozenset, dg["graph"].edges())) == set(map(frozenset, de["graph"].edges()))

    def weights(H):
        return {frozenset((u, v)): w for u, v, w in H.edges(data="weight")}

    assert weights(got) == weights(expected)


# --- dispatch hooks -----------------------------------------------------------------------


def test_can_run_and_should_run(caplog):
    assert BackendInterface.can_run("connected_components", (nx.path_graph(3),), {}) is True
    assert "directed" in BackendInterface.can_run("is_connected", (nx.DiGraph(),), {})
    assert "does not implement" in BackendInterface.can_run("pagerank", (nx.path_graph(3),), {})
    small, large = nx.path_graph(3), nx.empty_graph(SHOULD_RUN_MIN_NODES)
    assert isinstance(BackendInterface.should_run("connected_components", (small,), {}), str)
    assert BackendInterface.should_run("connected_components", (large,), {}) is True
    with caplog.at_level(logging.DEBUG, logger="networkx.utils.backends"):
        with nx.config(backend_priority=["graphseg"]):  # automatic dispatch: small graphs stay in networkx
            assert nx.number_connected_components(small) == 1
            assert nx.number_connected_components(large) == SHOULD_RUN_MIN_NODES
    text = caplog.text
    assert "Backend 'graphseg' shouldn't run `number_connected_components`" in text
    assert text.count("Using backend 'graphseg' for call to 'number_connected_components'") == 1


def test_on_start_tests_marks_known_failures(monkeypatch):
    from graphseg.graphs.nx_backend import interface

    class Item:
        def __init__(self, file, name):
            self.path, self.name, self.marks = type("P", (), {"name": file})(), name, []

        def add_marker(self, mark):
            self.marks.append(mark)

    items = [Item("test_a.py", "test_x"), Item("test_a.py", "test_y")]
    BackendInterface.on_start_tests(items)
    assert items[0].marks == [] and items[1].marks == []
    monkeypatch.setitem(interface.KNOWN_NX_TEST_FAILURES, ("test_a.py", "test_y"), "because")
    BackendInterface.on_start_tests(items)
    assert items[0].marks == [] and items[1].marks[0].kwargs["reason"] == "because"


# --- networkx's own tests against the backend ----------------------------------------------

#: networkx's test packages for the implemented functions: run from the installed networkx.
NX_TEST_PACKAGES = ["networkx.algorithms.components", "networkx.algorithms.minors"]


def run_networkx_tests(tmp_path, packages, timeout=600):
    """Run installed networkx test packages with NETWORKX_TEST_BACKEND=graphseg; parse the results."""
    (tmp_path / "pytest.ini").write_text("[pytest]\n")  # keep graphseg's own pytest settings out
    log, junit = tmp_path / "nx.log", tmp_path / "junit.xml"
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NETWORKX_", "PYTEST_"))}
    env.update(NETWORKX_TEST_BACKEND="graphseg", NETWORKX_FALLBACK_TO_NX="True")
    cmd = [
        sys.executable, "-m", "pytest", "-c", str(tmp_path / "pytest.ini"), "-p", "no:cacheprovider", "-q",
        f"--junitxml={junit}", f"--log-file={log}", "--log-file-level=DEBUG", "--pyargs", *packages,
    ]
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=timeout)
    suite = ET.parse(junit).getroot()
    suite = suite if suite.tag == "testsuite" else suite.find("testsuite")
    counts = {k: int(suite.get(k, 0)) for k in ("tests", "failures", "errors", "skipped")}
    text = log.read_text()
    dispatched = Counter(re.findall(r"Using backend 'graphseg' for call to '(\w+)'", text))
    cannot = Counter(re.findall(r"Backend 'graphseg' can't run `(\w+)` with arguments: .*?, because: ([^\n]*)", text))
    raised = re.findall(r"Backend 'graphseg' raised when calling '(\w+)'", text)
    return proc, counts, dispatched, cannot, raised


def test_networkx_component_tests_pass_on_backend(tmp_path):
    proc, counts, dispatched, cannot, raised = run_networkx_tests(tmp_path, NX_TEST_PACKAGES)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert counts["failures"] == 0 and counts["errors"] == 0
    assert counts["tests"] - counts["skipped"] >= 150, counts  # 161 collected with networkx 3.6.1
    for name in COMPONENT_FUNCTIONS + ["quotient_graph"]:
        assert dispatched[name] > 0, (name, dispatched)
    # Every call graphseg declined is declared by can_run with a reason; none raised.
    assert not raised
    assert {name for name, _ in cannot} <= {"quotient_graph"}
    print(f"\nnetworkx tests: {counts}; graphseg calls: {dict(dispatched)}; declined: {dict(cannot)}")


@pytest.mark.slow
@pytest.mark.skipif(not os.environ.get("GRAPHSEG_NX_WIDE_TESTS"), reason="set GRAPHSEG_NX_WIDE_TESTS=1: ~550 networkx tests that call connected_components inside (about 80 s)")
def test_networkx_wider_tests_pass_on_backend(tmp_path):
    packages = NX_TEST_PACKAGES + [
        "networkx.algorithms.connectivity",
        "networkx.generators.tests.test_trees",
        "networkx.generators.tests.test_classic",
        "networkx.generators.tests.test_cographs",
        "networkx.algorithms.tests.test_swap",
        "networkx.algorithms.tests.test_dominating",
        "networkx.algorithms.tests.test_cycles",
        "networkx.algorithms.approximation.tests.test_kcomponents",
        "networkx.algorithms.flow.tests.test_gomory_hu",
    ]
    proc, counts, dispatched, cannot, raised = run_networkx_tests(tmp_path, packages, timeout=1200)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert counts["failures"] == 0 and counts["errors"] == 0 and not raised
    assert sum(dispatched.values()) > 1000, dispatched
