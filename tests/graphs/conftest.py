import numpy as np
import pytest

from graphseg.graphs import CorrespondenceGraph


def make_graph(seed=0, views=3, with_points=True):
    """A small mask-level graph with masks, 3D columns and mixed edges."""
    rng = np.random.default_rng(seed)
    labels, points = [], []
    for _ in range(views):
        lab = rng.integers(0, 4, (6, 7)).astype(np.int32)
        labels.append(lab)
        p = rng.normal(size=(6, 7, 3)).astype(np.float32)
        p[0, 0] = np.nan
        points.append(p)
    g = CorrespondenceGraph.from_masks(labels, points if with_points else None, meta={"name": "toy", "seed": seed})
    n = g.num_nodes
    ei = np.array([[0, 1, 2, 0], [1, 2, 3, 1]]) % n
    g = g.add_edges(
        ei,
        {
            "criterion": np.array(["pixel_match", "pixel_match", "chamfer_3d", "dino"]),
            "weight": np.array([0.5, 0.25, 0.125, np.nan]),
            "stage": np.array([0, 0, 1, 1]),
            "count": np.array([10, 3, -1, -1]),
        },
    )
    return g


@pytest.fixture
def toy_graph():
    return make_graph()
