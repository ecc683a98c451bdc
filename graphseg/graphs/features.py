"""Feature-similarity edge addition (criterion ``dino``).

Nodes whose mask-mean feature vectors (DINO features in practice) have cosine
similarity ``>= threshold`` are joined. Features come in as arrays: per node
``[N, D]``, or per view per pixel ``[h, w, D]`` at any resolution (labels are
resampled to the feature grid by nearest neighbour).

Examples
--------
>>> import numpy as np
>>> f = np.array([[1.0, 0], [0.9, 0.1], [0, 1]])
>>> feature_similarity_edges(f, 0.95, cross_view_only=False).edge_index.tolist()
[[0], [1]]
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from .criterion import Criterion
from .evidence import EdgeSet, Evidence
from .graph import CorrespondenceGraph

__all__ = ["node_mean_features", "feature_similarity_edges", "FeatureSimilarity"]


def node_mean_features(node_labels: Sequence[np.ndarray], features: Sequence[np.ndarray], num_nodes: int) -> np.ndarray:
    """Mean feature vector per node ``[N, D]`` from per-pixel maps ``[h, w, D]``.

    Nodes with no pixel on any feature grid get a zero vector. O(total pixels x D).

    Examples
    --------
    >>> lab = [np.array([[0, 0], [1, -1]])]
    >>> feat = [np.array([[[1.0], [3.0]], [[5.0], [7.0]]])]
    >>> node_mean_features(lab, feat, 2).ravel().tolist()
    [2.0, 5.0]
    """
    d = int(np.asarray(features[0]).shape[-1])
    total = np.zeros((num_nodes, d))
    count = np.zeros(num_nodes)
    for lab, f in zip(node_labels, features):
        f = np.asarray(f, np.float64)
        h, w = f.shape[:2]
        H, W = lab.shape
        ys = np.minimum((np.arange(h) + 0.5) * H / h, H - 1).astype(np.int64)
        xs = np.minimum((np.arange(w) + 0.5) * W / w, W - 1).astype(np.int64)
        small = np.asarray(lab)[ys[:, None], xs[None, :]].reshape(-1)
        ok = small >= 0
        ids = small[ok]
        ff = f.reshape(-1, d)[ok]
        count += np.bincount(ids, minlength=num_nodes)
        for k in range(d):
            total[:, k] += np.bincount(ids, weights=ff[:, k], minlength=num_nodes)
    return total / np.maximum(count, 1)[:, None]


def feature_similarity_edges(
    node_features: np.ndarray,
    threshold: float,
    *,
    node_view: np.ndarray | None = None,
    cross_view_only: bool,
    block: int = 1024,
) -> EdgeSet:
    """Edges between nodes whose features have cosine similarity ``>= threshold``.

    Parameters
    ----------
    node_features : float ``[N, D]``
    threshold : float
        Cosine similarity.
    node_view : int ``[N]``, optional
        With ``cross_view_only=True``, nodes of the same view are never joined.
    cross_view_only : bool
    block : int
        Rows per block of the similarity matrix (memory O(block x N)).

    The option defaults live in :class:`FeatureSimilarity.Options`; here
    ``threshold`` and ``cross_view_only`` are required.

    Returns
    -------
    EdgeSet
        Columns ``criterion`` ("dino"), ``similarity`` and ``weight`` (= similarity).

    Notes
    -----
    O(N^2 D) time in blocks of matrix products.
    """
    f = np.asarray(node_features, np.float64)
    n = f.shape[0]
    norm = np.linalg.norm(f, axis=1)
    fn = f / np.maximum(norm, 1e-12)[:, None]
    valid = norm > 0
    us, vs, ss = [], [], []
    for s in range(0, n, block):
        sim = fn[s : s + block] @ fn.T
        a, b = np.nonzero(sim >= threshold)
        a = a + s
        sel = (a < b) & valid[a] & valid[b]
        if cross_view_only and node_view is not None:
            sel &= node_view[a] != node_view[b]
        us.append(a[sel])
        vs.append(b[sel])
        ss.append(sim[a[sel] - s, b[sel]])
    u = np.concatenate(us) if us else np.zeros(0, np.int64)
    v = np.concatenate(vs) if vs else np.zeros(0, np.int64)
    sim = np.concatenate(ss) if ss else np.zeros(0)
    return EdgeSet(np.stack([u, v]).astype(np.int64), {"criterion": np.full(u.size, "dino"), "similarity": sim, "weight": sim})


class FeatureSimilarity(Criterion):
    """The ``dino`` criterion: a thin class around :func:`feature_similarity_edges`.

    ``Evidence.features`` is either per node ``[N, D]`` or a list of per-view
    per-pixel maps ``[h, w, D]``.

    Examples
    --------
    >>> g = CorrespondenceGraph(3, node_attr={"view": [0, 1, 1]})
    >>> ev = Evidence([], features=np.array([[1.0, 0], [1, 0.1], [0, 1]]))
    >>> FeatureSimilarity(threshold=0.9)(g, ev).edge_index.tolist()
    [[0], [1]]
    """

    class Options(BaseModel):
        """Options of ``dino``."""

        model_config = ConfigDict(extra="forbid")
        threshold: float = Field(0.8, ge=-1, le=1, description="cosine similarity")
        cross_view_only: bool = False

    name = "dino"
    requires = frozenset({"features"})
    reduce = {"similarity": "max", "weight": "max"}
    tags = {"dimension": "2d"}
    options: FeatureSimilarity.Options

    def __call__(self, graph: CorrespondenceGraph, evidence: Evidence) -> EdgeSet:
        feats = evidence.features
        if feats is None:
            raise ValueError("the dino criterion needs features (Evidence.features)")
        if isinstance(feats, np.ndarray) and feats.ndim == 2:
            if feats.shape[0] != graph.num_nodes:
                raise ValueError(f"expected node features of shape [{graph.num_nodes}, D] (got {list(feats.shape)})")
            nf = feats
        else:
            nf = node_mean_features(evidence.node_labels, feats, graph.num_nodes)
        view = graph.node_attr.get("view")
        return feature_similarity_edges(nf, self.options.threshold, node_view=view, cross_view_only=self.options.cross_view_only)
