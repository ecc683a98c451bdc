import builtins
import json

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from graphseg.config import Config
from graphseg.graphs import (
    CorrespondenceGraph,
    coarsen,
    from_networkx,
    from_pyg,
    load_graph,
    load_native,
    read_graphml,
    save_graph,
    save_native,
    to_networkx,
    to_pyg,
    write_graphml,
)

from .conftest import make_graph


def assert_same(a, b, masks=False):
    assert a.num_nodes == b.num_nodes and a.level == b.level
    assert np.array_equal(a.edge_index, b.edge_index)
    assert a.edge_index.dtype == b.edge_index.dtype == np.int64
    assert set(a.edge_attr) == set(b.edge_attr) and set(a.node_attr) == set(b.node_attr)
    for cols_a, cols_b in ((a.edge_attr, b.edge_attr), (a.node_attr, b.node_attr)):
        for k in cols_a:
            assert cols_a[k].dtype == cols_b[k].dtype, k
            assert cols_a[k].shape == cols_b[k].shape, k
            if cols_a[k].dtype.kind == "f":
                np.testing.assert_array_equal(cols_a[k], cols_b[k])  # NaN-aware, exact
            else:
                assert np.array_equal(cols_a[k], cols_b[k]), k
    for k in ("view", "mask_id", "node"):
        assert np.array_equal(a.members[k], b.members[k])
    assert a.meta == b.meta
    if masks:
        assert len(a.masks) == len(b.masks)
        for x, y in zip(a.masks, b.masks):
            assert np.array_equal(x, y)


def test_networkx_roundtrip(toy_graph):
    g = to_networkx(toy_graph)
    assert isinstance(g, nx.MultiGraph)
    assert g.number_of_nodes() == toy_graph.num_nodes and g.number_of_edges() == toy_graph.num_edges
    assert g.nodes[0]["bbox_0"] == toy_graph.node_attr["bbox"][0, 0]
    assert_same(toy_graph, from_networkx(g))


def test_from_plain_networkx_graph():
    g = nx.Graph()
    g.add_node("a", area=3)
    g.add_node("b", area=4)
    g.add_edge("a", "b", weight=0.5)
    cg = from_networkx(g)
    assert cg.num_nodes == 2 and cg.node_attr["area"].tolist() == [3, 4]
    assert cg.edge_attr["weight"].tolist() == [0.5]


def test_graphml_roundtrip_super_graph(toy_graph, tmp_path):
    s = coarsen(toy_graph, np.arange(toy_graph.num_nodes) // 2)
    write_graphml(s, tmp_path / "s.graphml")
    assert_same(s, read_graphml(tmp_path / "s.graphml"))


finite = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=60, deadline=None)
@given(
    st.integers(1, 12),
    st.lists(st.tuples(st.integers(0, 11), st.integers(0, 11), finite, st.integers(-(2**40), 2**40), st.text(min_size=0, max_size=8, alphabet=st.characters(codec="utf-8", categories=["L", "N", "P", "Zs"]))), max_size=15),
    st.sampled_from(["mask", "super"]),
)
def test_graphml_and_native_lossless_property(tmp_path_factory, n, rows, level):
    edges = [(u % n, v % n) for u, v, *_ in rows]
    ei = np.array(edges, np.int64).T.reshape(2, -1)
    g = CorrespondenceGraph(
        n,
        ei,
        {
            "weight": np.array([r[2] for r in rows], np.float64),
            "count": np.array([r[3] for r in rows], np.int64),
            "criterion": np.array([r[4] for r in rows], dtype=str) if rows else np.zeros(0, "<U1"),
            "flag": np.array([r[3] % 2 == 0 for r in rows], bool),
        },
        {"area": np.arange(n, dtype=np.int64) * 7, "centroid": np.linspace(0, 1, 2 * n).reshape(n, 2) / 3},
        level=level,
        meta={"seed": 3, "label": "x"},
    )
    d = tmp_path_factory.mktemp("rt")
    write_graphml(g, d / "g.graphml")
    assert_same(g, read_graphml(d / "g.graphml"))
    save_graph(d / "g.npz", g)
    assert_same(g, load_graph(d / "g.npz"))


def test_native_roundtrip_with_masks_and_recontract(toy_graph, tmp_path):
    s = coarsen(toy_graph, toy_graph.contract("union_find"))
    save_native(tmp_path / "r.npz", {"g2d": toy_graph, "g3d": s}, arrays={"cluster": np.arange(3)}, meta={"k": 1})
    f = load_native(tmp_path / "r.npz")
    assert_same(toy_graph, f.graphs["g2d"], masks=True)
    assert_same(s, f.graphs["g3d"], masks=True)
    assert all(a is b for a, b in zip(f.graphs["g2d"].masks, f.graphs["g3d"].masks))  # stored once
    assert f.arrays["cluster"].tolist() == [0, 1, 2] and f.meta == {"k": 1}
    # contract again without any backend
    again = f.graphs["g2d"].contract("star", rng=0)
    assert np.array_equal(again, toy_graph.contract("union_find"))


def test_native_rejects_foreign_files(tmp_path):
    np.savez(tmp_path / "x.npz", a=np.zeros(2))
    with pytest.raises(ValueError, match="not a graphseg native file"):
        load_graph(tmp_path / "x.npz")
    hdr = np.frombuffer(json.dumps({"format": "other", "version": 1, "graphs": {}}).encode(), np.uint8)
    np.savez(tmp_path / "y.npz", __header__=hdr)
    with pytest.raises(ValueError, match="expected format"):
        load_graph(tmp_path / "y.npz")
    hdr = np.frombuffer(json.dumps({"format": "graphseg-graph", "version": 99, "graphs": {}}).encode(), np.uint8)
    np.savez(tmp_path / "z.npz", __header__=hdr)
    with pytest.raises(ValueError, match="unsupported version"):
        load_graph(tmp_path / "z.npz")
    save_native(tmp_path / "two.npz", {"a": make_graph(), "b": make_graph(1)})
    with pytest.raises(ValueError, match="expected one graph"):
        load_graph(tmp_path / "two.npz")
    with pytest.raises(ValueError, match="may not contain"):
        save_native(tmp_path / "bad.npz", {"a/b": make_graph()})


def test_pyg_roundtrip_with_torch_geometric(toy_graph):
    pytest.importorskip("torch_geometric")
    from torch_geometric.data import Data

    data = to_pyg(toy_graph)
    assert isinstance(data, Data)
    assert tuple(data.edge_index.shape) == (2, toy_graph.num_edges)
    assert data.edge_attr.shape[0] == toy_graph.num_edges
    back = from_pyg(data)
    assert np.array_equal(back.edge_index, toy_graph.edge_index)
    for k, v in toy_graph.node_attr.items():
        np.testing.assert_array_equal(back.node_attr[k], v)
    for k, v in toy_graph.edge_attr.items():
        np.testing.assert_array_equal(back.edge_attr[k], v)


def test_pyg_dict_fallback_without_torch_geometric(toy_graph, monkeypatch):
    pytest.importorskip("torch")
    real_import = builtins.__import__

    def fake_import(name, *args, **kwargs):
        if name.startswith("torch_geometric"):
            raise ImportError("no PyG")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", fake_import)
    data = to_pyg(toy_graph)
    assert isinstance(data, dict)
    assert data["edge_index"].dtype.is_floating_point is False
    assert data["edge_criterion"] == toy_graph.edge_attr["criterion"].tolist()
    back = from_pyg(data)
    np.testing.assert_array_equal(back.edge_attr["weight"], toy_graph.edge_attr["weight"])


def test_to_pyg_without_torch_names_the_extra(toy_graph, monkeypatch):
    real_import = builtins.__import__

    def fake_import(name, *args, **kwargs):
        if name == "torch" or name.startswith("torch."):
            raise ImportError("no torch")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", fake_import)
    monkeypatch.delitem(__import__("sys").modules, "torch", raising=False)
    with pytest.raises(ImportError, match=r'pip install "graphseg\[torch\]"'):
        to_pyg(toy_graph)


def test_graphml_edges_lack_the_attributes_they_have_no_value_for(tmp_path):
    """Stage 1's Chamfer edges have no pixel count, ratio or multiplicity: no -1 / nan placeholders in the file."""
    import xml.etree.ElementTree as ET

    from graphseg.pipeline import run
    from graphseg.testing.scenes import TWO_BOXES, box_scene

    result = run(box_scene(TWO_BOXES), Config.preset("paper"))  # the paper's pixel_match: its edges have every column
    assert len(result.graphs) == 2
    g1 = result.graphs[1]
    assert g1.num_edges and (g1.edge_attr["count"] == -1).all() and np.isnan(g1.edge_attr["ratio"]).all()  # in memory: placeholders
    for s, g in enumerate(result.graphs):
        path = tmp_path / f"stage{s}.graphml"
        write_graphml(g, path)
        ns = {"g": "http://graphml.graphdrawing.org/xmlns"}
        root = ET.parse(path).getroot()
        names = {k.get("id"): k.get("attr.name") for k in root.findall("g:key", ns)}
        values = [(names[d.get("key")], d.text) for e in root.iter("{http://graphml.graphdrawing.org/xmlns}edge") for d in e.findall("g:data", ns)]
        placeholders = [(k, v) for k, v in values if k in ("count", "ratio", "multiplicity") and v is not None and v.strip().lower() in ("-1", "nan")]
        assert placeholders == [], s
        assert all(v.strip().lower() != "nan" for _, v in values if v is not None)
        nxg = nx.read_graphml(path)  # plain networkx reads it; those edges simply lack the keys
        assert nxg.number_of_edges() == g.num_edges
        if s == 1:
            assert all("count" not in d and "ratio" not in d and "multiplicity" not in d and "weight" in d for *_, d in nxg.edges(data=True))
        else:
            assert all("count" in d and d["count"] > 0 for *_, d in nxg.edges(data=True))
        back = read_graphml(path)  # the placeholders come back in memory: lossless (str columns may get a narrower width)
        assert np.array_equal(back.edge_index, g.edge_index) and set(back.edge_attr) == set(g.edge_attr)
        for k, col in g.edge_attr.items():
            if col.dtype.kind == "U":
                assert back.edge_attr[k].tolist() == col.tolist(), k
            else:
                assert back.edge_attr[k].dtype == col.dtype, k
                np.testing.assert_array_equal(back.edge_attr[k], col)  # NaN-aware, exact


def test_graphml_omits_missing_values_per_element_of_vector_columns(tmp_path):
    g = CorrespondenceGraph(
        3,
        [[0, 1, 0], [1, 2, 2]],
        {"weight": np.array([0.5, np.nan, 0.25]), "count": np.array([-1, 4, 7]), "box": np.array([[1.0, np.nan], [np.nan, np.nan], [2.0, 3.0]]),
         "flag": np.array([False, True, False]), "criterion": np.array(["a", "b", ""])},
    )
    write_graphml(g, tmp_path / "g.graphml")
    edges = sorted(nx.read_graphml(tmp_path / "g.graphml", force_multigraph=True).edges(keys=True, data=True), key=lambda t: int(t[2]))
    assert [sorted(k for k in d if k != "graphseg_src") for *_, d in edges] == [
        ["box_0", "criterion", "flag", "weight"],
        ["count", "criterion", "flag"],
        ["box_0", "box_1", "count", "criterion", "flag", "weight"],
    ]
    assert_same(g, read_graphml(tmp_path / "g.graphml"))
    assert "count" in to_networkx(g).edges[0, 1, 0]  # the networkx view keeps them unless asked
