"""Split objects that hold several touching objects, and join pieces of one, by normalized cuts of their fused 3D points.

Contraction decides whole masks: when masks of two touching objects were
joined (a mask that straddles both, in several views), their object holds both
bodies. In 3D the two bodies are easy to tell apart once all views are fused:
they meet along a short concave crease, where a single object's surface is
continuous. :func:`split_objects` voxelizes each object's points from every
view, links neighbouring voxels (:func:`convexity_graph`; a link across a
concave crease is weak), and bisects the graph by normalized cut
(:func:`normalized_cut`, Shi & Malik 2000) while the best cut costs less than
``max_ncut``; every part becomes an object and every pixel follows its voxel.
The pipeline (``config.split``) runs it twice: on a 6 mm grid, then on a 5 mm grid
with the views' masks as a guard (``masks``, ``own_fraction``), which resolves the
narrow seam where two objects touch but keeps a surface that the masks see as one.
:func:`merge_objects` is the inverse: two touching objects whose union has no cut
cheaper than ``min_ncut`` (above ``max_ncut``) are one body, the pieces of one object
that the masks and matches never connected, and are joined.

Examples
--------
Two touching domes in one object come apart; a single dome stays whole:

>>> import numpy as np
>>> def dome(cx, r=0.05, step=0.003):                 # the upper half of a sphere, seen from above
...     g = np.arange(-r, r + 1e-9, step)
...     x, y = np.meshgrid(g, g)
...     k = x**2 + y**2 <= r * r
...     return np.c_[cx + x[k], y[k], np.sqrt(r * r - x[k] ** 2 - y[k] ** 2)]
>>> cam = (np.eye(3), np.array([[1.0, 0, 0, 0.05], [0, 1, 0, 0], [0, 0, 1, 0.8], [0, 0, 0, 1]]))
>>> two = np.r_[dome(0.0), dome(0.1)]
>>> out, info = split_objects([np.ones((1, len(two)), np.int32)], [two[None]], [cam], rng=0)
>>> np.unique(out[0]).tolist(), info["objects"][0]["part_voxels"]
([1, 2], [417, 401])
>>> one = dome(0.0)
>>> out, info = split_objects([np.ones((1, len(one)), np.int32)], [one[None]], [cam], rng=0)
>>> np.unique(out[0]).tolist()
[1]
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..config import SplitConfig
from ..graphs import combine_keys, group_by_key
from .masks import close_id_gaps, rename_objects

__all__ = ["convexity_graph", "merge_objects", "normalized_cut", "settle_parts", "split_objects", "voxelize"]


def voxelize(points: np.ndarray, voxel_size: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Group points into cubic voxels.

    Parameters
    ----------
    points : float ``[N, 3]``
        Finite points.
    voxel_size : float
        Edge of a voxel (same unit as the points).

    Returns
    -------
    centres : float64 ``[M, 3]``
        Mean point of each occupied voxel, in the order of their first point's sorted key.
    inverse : int64 ``[N]``
        Voxel of each point.
    counts : int64 ``[M]``
        Points per voxel.

    Notes
    -----
    O(N log N) (one sort of packed integer keys, :func:`~graphseg.graphs.group_by_key`).

    Examples
    --------
    >>> c, inv, n = voxelize(np.array([[0.0, 0, 0], [0.1, 0, 0], [1.0, 0, 0]]), 0.5)
    >>> c.round(2).tolist(), inv.tolist(), n.tolist()
    ([[0.05, 0.0, 0.0], [1.0, 0.0, 0.0]], [0, 0, 1], [2, 1])
    """
    if voxel_size <= 0:
        raise ValueError(f"expected voxel_size > 0 (got {voxel_size})")
    P = np.asarray(points, np.float64)
    if P.ndim != 2 or P.shape[1] != 3:
        raise ValueError(f"expected points of shape [N, 3] (got {list(P.shape)})")
    if P.shape[0] == 0:
        return np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros(0, np.int64)
    cell = np.floor(P / voxel_size).astype(np.int64)
    cell -= cell.min(0)
    grouped = group_by_key(combine_keys(list(cell.T), (cell.max(0) + 1).tolist()), stable=False)  # voxels in key order
    inverse, counts = grouped.groups, grouped.counts
    centres = np.stack([np.bincount(inverse, weights=P[:, d], minlength=counts.size) for d in range(3)], 1) / counts[:, None]
    return centres, inverse, counts


def convexity_graph(
    centres: np.ndarray,
    eyes: np.ndarray,
    *,
    radius: float,
    neighbors: int = 10,
    normal_neighbors: int = 20,
    concave_angle: float = 10.0,
    concave_margin: float = 0.05,
    concave_weight: float = 0.1,
) -> Any:
    """Neighbour graph of surface samples whose links across concave creases are weak.

    Parameters
    ----------
    centres : float ``[M, 3]``
        Surface samples (voxel centres).
    eyes : float ``[M, 3]``
        A camera centre that saw each sample: normals are turned towards it.
    radius : float
        Samples further apart are never linked.
    neighbors : int
        Links per sample (its nearest samples within ``radius``).
    normal_neighbors : int
        Samples in the plane fit of each normal.
    concave_angle : float
        Degrees; normals closer than this always give a full link (noise on a flat face).
    concave_margin : float
        A link is concave when ``(n_a - n_b) . (x_a - x_b) / |x_a - x_b| < -concave_margin``
        (convex surfaces give a positive value; Stein et al. 2014).
    concave_weight : float
        Weight of a concave link (others weigh 1).

    Returns
    -------
    scipy.sparse.csr_matrix ``[M, M]``
        Symmetric weights.

    Notes
    -----
    O(M log M) for the k-d tree queries plus O(M) small eigen-problems.

    Examples
    --------
    >>> x = np.array([[0.0, 0, 0], [0.01, 0, 0], [0.02, 0, 0]])
    >>> W = convexity_graph(x, np.tile([0.0, 0, 1], (3, 1)), radius=0.015, normal_neighbors=3)
    >>> W.toarray().tolist()
    [[0.0, 1.0, 0.0], [1.0, 0.0, 1.0], [0.0, 1.0, 0.0]]
    """
    from scipy.sparse import coo_matrix
    from scipy.spatial import cKDTree

    X = np.asarray(centres, np.float64)
    m = X.shape[0]
    if m < 2:
        return coo_matrix((m, m)).tocsr()
    tree = cKDTree(X)
    _, nn = tree.query(X, k=min(normal_neighbors, m))
    nn = np.asarray(nn).reshape(m, -1)
    Q = X[nn] - X[nn].mean(1, keepdims=True)
    _, vec = np.linalg.eigh(np.einsum("nki,nkj->nij", Q, Q))
    N = vec[:, :, 0]
    N[np.einsum("ni,ni->n", N, np.asarray(eyes, np.float64) - X) < 0] *= -1
    dist, nb = tree.query(X, k=min(neighbors + 1, m), distance_upper_bound=radius)
    dist, nb = np.asarray(dist).reshape(m, -1)[:, 1:], np.asarray(nb).reshape(m, -1)[:, 1:]
    a = np.repeat(np.arange(m), nb.shape[1])
    b = nb.ravel()
    keep = np.isfinite(dist.ravel())
    a, b = a[keep], b[keep]
    a, b = np.minimum(a, b), np.maximum(a, b)  # each pair once, however many ends found it
    _, first = np.unique(a * m + b, return_index=True)
    a, b = a[first], b[first]
    D = X[a] - X[b]
    convex = np.einsum("ni,ni->n", N[a] - N[b], D) / np.maximum(np.linalg.norm(D, axis=1), 1e-12)
    same = np.einsum("ni,ni->n", N[a], N[b]) > np.cos(np.deg2rad(concave_angle))
    w = np.where((convex < -concave_margin) & ~same, concave_weight, 1.0)
    W = coo_matrix((np.r_[w, w], (np.r_[a, b], np.r_[b, a])), shape=(m, m)).tocsr()
    W.eliminate_zeros()  # concave_weight 0: no link at all across a concave crease
    return W


def normalized_cut(W: Any, *, min_size: int = 1, rng: Any = None) -> tuple[np.ndarray, float]:
    """The best two-way normalized cut along the graph's Fiedler vector.

    Parameters
    ----------
    W : scipy.sparse matrix ``[M, M]``
        Symmetric non-negative weights of a connected graph.
    min_size : int
        Each side holds at least this many nodes.
    rng : None, int or numpy.random.Generator, keyword-only
        Start vector of the eigen-solver.

    Returns
    -------
    side : bool ``[M]``
        One side of the best cut (all False when no cut leaves ``min_size`` on both sides).
    ncut : float
        ``cut / vol(side) + cut / vol(other)`` (inf when there is no cut).

    Notes
    -----
    One sparse shift-invert eigen-solve (O(M^1.5) for these near-planar
    graphs), then 46 thresholds of the eigenvector (Shi & Malik 2000).

    Examples
    --------
    >>> from scipy.sparse import csr_matrix
    >>> A = np.ones((4, 4)) - np.eye(4)
    >>> W = np.kron(np.eye(2), A); W[3, 4] = W[4, 3] = 0.1       # two cliques, one weak link
    >>> side, nc = normalized_cut(csr_matrix(W), min_size=2, rng=0)
    >>> sorted({int(side[:4].sum()), int(side[4:].sum())}), round(float(nc), 3)
    ([0, 4], 0.017)
    """
    from scipy.sparse import diags, identity
    from scipy.sparse.linalg import eigsh

    m = W.shape[0]
    none = (np.zeros(m, bool), float("inf"))
    if m < max(2 * min_size, 3):
        return none
    degree = np.asarray(W.sum(1)).ravel()
    if (degree <= 0).any():
        return none
    inv_sqrt = diags(1.0 / np.sqrt(degree))
    L = (identity(m) - inv_sqrt @ W @ inv_sqrt).tocsc()
    gen = np.random.default_rng(rng)
    if m <= 200:
        vals, vecs = np.linalg.eigh(L.toarray())
    else:
        vals, vecs = eigsh(L, k=2, sigma=-1e-3, which="LM", v0=gen.standard_normal(m))
    fiedler = inv_sqrt @ vecs[:, np.argsort(vals)[1]]
    coo = W.tocoo()
    upper = coo.row < coo.col
    a, b, w = coo.row[upper], coo.col[upper], coo.data[upper]
    total = float(degree.sum())
    best = none
    for t in np.unique(np.percentile(fiedler, np.arange(5, 96, 2))):
        side = fiedler > t
        n_side = int(side.sum())
        if n_side < min_size or m - n_side < min_size:
            continue
        cut = float(w[side[a] != side[b]].sum())
        vol = float(degree[side].sum())
        ncut = cut / vol + cut / (total - vol)
        if ncut < best[1]:
            best = (side, ncut)
    return best


def settle_parts(W: Any, parts: Sequence[np.ndarray], *, band: int = 3, max_ratio: float = 1.0) -> tuple[list[np.ndarray], int]:
    """Redraw the border between every two parts along the weakest links near it (a minimum cut).

    The normalized cut chooses which voxels to separate by one threshold on a
    smooth eigenvector, so its border can run a voxel or two beside the
    crease where the two bodies meet. Here, for every two parts ``A`` and
    ``B`` that share a link, the voxels of both within ``band`` links of that
    border are drawn again by a minimum ``A``-``B`` cut of the link weights,
    between the voxels of ``A`` and of ``B`` just outside the band (an s-t
    minimum cut; SciPy's maximum flow, Dinic's method). A pair where either
    part has no voxel outside the band is left as it is. The cheapest border
    follows the weak links across a concave crease where there is one. A
    voxel that some minimum cuts put on one side and others on the other (a
    tie, as on a flat seam where every border costs the same) keeps its part,
    and a voxel further than ``band`` links from the border never moves.

    Parameters
    ----------
    W : scipy.sparse matrix ``[M, M]``
        Link weights (:func:`convexity_graph`); zero = no link. A link given
        in one direction only counts both ways (``max(W, W.T)``).
    parts : list of int arrays
        A partition of ``0..M-1`` (voxel indices per part).
    band : int
        Voxels at most this many links from the other part are drawn again
        (0: nothing moves).
    max_ratio : float
        A border is drawn again only where the minimum cut costs at most this
        share of the links it crosses now (1: wherever a cheaper cut exists;
        0.5: only where the present border is at least twice as dear).

    Returns
    -------
    parts : list of int64 arrays
        The new partition, part ``k`` for input part ``k`` (a part that lost
        every voxel comes back empty); the inputs are not modified.
    moved : int
        Voxels whose part changed.

    Notes
    -----
    One maximum flow (Dinic) per pair of touching parts on the band's voxels
    (O(V^2 E) in the worst case; a few milliseconds for the few hundred voxels
    of a band), plus ``band`` sparse products over all of ``W`` per pair. Pairs
    are drawn in order of their part indices. Weights are scaled to integer
    capacities (1000 per unit weight); a band whose capacities would not fit
    in 32 bits raises ``ValueError``.

    Examples
    --------
    A chain of samples whose link 5-6 is weak (a crease); the first cut put
    samples 4 and 5 on the right. Drawn again, the border moves onto the weak link:

    >>> import numpy as np
    >>> from scipy.sparse import coo_matrix
    >>> w = np.array([1, 1, 1, 1, 1, 0.1, 1, 1, 1, 1]); a = np.arange(10); b = a + 1
    >>> W = coo_matrix((np.r_[w, w], (np.r_[a, b], np.r_[b, a])), shape=(11, 11)).tocsr()
    >>> parts, moved = settle_parts(W, [np.arange(4), np.arange(4, 11)], band=3)
    >>> [p.tolist() for p in parts], moved
    ([[0, 1, 2, 3, 4, 5], [6, 7, 8, 9, 10]], 2)
    """
    import operator

    from scipy.sparse import coo_matrix, csr_matrix
    from scipy.sparse.csgraph import breadth_first_order, maximum_flow

    band = operator.index(band)
    if band < 0 or not max_ratio >= 0:
        raise ValueError(f"expected band >= 0 and max_ratio >= 0 (got {band}, {max_ratio})")
    W = csr_matrix(W, dtype=np.float64)
    W.sum_duplicates()
    W = W.maximum(W.T).tocsr()  # a link given one way counts both ways
    m = W.shape[0]
    idx_all = [np.asarray(p, np.int64).ravel() for p in parts]
    sizes = sum(p.size for p in idx_all)
    if any(p.size and (p.min() < 0 or p.max() >= m) for p in idx_all):
        raise ValueError(f"expected part indices in 0..{m - 1}")
    pid = np.full(m, -1, np.int64)
    for k, p in enumerate(idx_all):
        pid[p] = k
    if (pid < 0).any() or sizes != m:
        raise ValueError(f"expected parts that cover all {m} voxels once (got {int((pid < 0).sum())} without a part, {sizes} indices)")
    coo = W.tocoo()
    link = (coo.data > 0) & (coo.row != coo.col)
    rows, cols = coo.row[link].astype(np.int64), coo.col[link].astype(np.int64)
    cap = np.maximum(np.round(coo.data[link] * 1000), 1).astype(np.int64)  # integer capacities, 1000 per full link
    adj = csr_matrix((np.ones(rows.size), (rows, cols)), shape=(m, m))
    if band == 0 or len(parts) < 2:
        return [np.flatnonzero(pid == k) for k in range(len(parts))], 0
    start = pid.copy()
    pairs = np.unique(np.sort(np.c_[start[rows], start[cols]][start[rows] != start[cols]], axis=1), axis=0)
    for A, B in pairs:
        both = (pid == A) | (pid == B)
        border = (pid[rows] == A) & (pid[cols] == B)
        near = np.zeros(m, bool)
        near[rows[border]] = near[cols[border]] = True
        for _ in range(band - 1):
            near |= ((adj @ near.astype(np.float64)) > 0) & both
        outside = ((adj @ near.astype(np.float64)) > 0) & both & ~near
        ta, tb = np.flatnonzero(outside & (pid == A)), np.flatnonzero(outside & (pid == B))
        if ta.size == 0 or tb.size == 0:  # a part lies wholly in the band: no interior to anchor the cut
            continue
        nodes = np.flatnonzero(near | outside)
        idx = np.full(m, -1, np.int64)
        idx[nodes] = np.arange(nodes.size)
        s, t = nodes.size, nodes.size + 1
        inner = (idx[rows] >= 0) & (idx[cols] >= 0)
        present = int(cap[border].sum())  # the border as it is: a cut that leaves the anchors alone
        anchor = present + 1  # more than the minimum cut: the anchors never move
        if max(anchor, int(cap[inner].max(initial=0))) > np.iinfo(np.int32).max:
            raise ValueError(f"expected link weights whose band capacities fit in 32 bits (got {anchor} for one border)")
        G = coo_matrix(
            (
                np.r_[cap[inner], np.full(ta.size + tb.size, anchor)].astype(np.int32),
                (np.r_[idx[rows[inner]], np.full(ta.size, s), idx[tb]], np.r_[idx[cols[inner]], idx[ta], np.full(tb.size, t)]),
            ),
            shape=(nodes.size + 2, nodes.size + 2),
        ).tocsr()
        G.sum_duplicates()
        flow = maximum_flow(G, s, t, method="dinic")
        if flow.flow_value > max_ratio * present:  # the border is not clearly dearer than the cheapest one
            continue
        residual = (G - flow.flow).tocsr()  # the flow is antisymmetric: reverse arcs carry its amount
        residual.data = (residual.data > 0).astype(np.int32)
        residual.eliminate_zeros()
        # every minimum cut puts the voxels reachable from s on A's side and those that reach t on B's;
        # a voxel between the two (a tie: several cuts cost the same) keeps its part
        to_a = np.zeros(nodes.size + 2, bool)
        to_a[breadth_first_order(residual, s, directed=True, return_predecessors=False)] = True
        to_b = np.zeros(nodes.size + 2, bool)
        to_b[breadth_first_order(residual.T.tocsr(), t, directed=True, return_predecessors=False)] = True
        drawn = np.flatnonzero(near)
        pid[drawn] = np.where(to_a[idx[drawn]], A, np.where(to_b[idx[drawn]], B, pid[drawn]))
    return [np.flatnonzero(pid == k) for k in range(len(parts))], int((pid != start).sum())


def _labelled_points(labels: Sequence[np.ndarray], points: Sequence[np.ndarray], cameras: Sequence[tuple[Any, Any]], masks: Sequence[np.ndarray] | None = None) -> tuple[np.ndarray, ...] | None:
    """Every labelled pixel with a finite point, in views with a camera: ``view, rows, cols, points, object, mask code, camera centres``."""
    n = len(labels)
    chunks = []
    for i in range(n):
        if cameras[i][1] is None:
            continue
        lab = np.asarray(labels[i])
        rows, cols = np.nonzero(lab > 0)
        p = np.asarray(points[i])[rows, cols].astype(np.float64)
        ok = np.isfinite(p).all(1)
        mk = np.asarray(masks[i])[rows[ok], cols[ok]].astype(np.int64) if masks is not None else np.zeros(int(ok.sum()), np.int64)
        chunks.append((np.full(int(ok.sum()), i), rows[ok], cols[ok], p[ok], lab[rows[ok], cols[ok]].astype(np.int64), mk))
    if not chunks:
        return None
    view, rows, cols, P, obj, mask = (np.concatenate(c) for c in zip(*chunks))
    mask = np.where(mask > 0, view * (int(mask.max(initial=0)) + 1) + mask, -1)  # one code per (view, mask); -1 = none
    centre = np.array([np.asarray(c[1], np.float64)[:3, 3] if c[1] is not None else np.zeros(3) for c in cameras]).reshape(n, 3)
    return view, rows, cols, P, obj, mask, centre


def _surface_graph(
    P: np.ndarray, eye: np.ndarray, voxel_size: float, *, min_voxels: int, concave_angle: float, concave_margin: float, concave_weight: float
) -> tuple[np.ndarray, Any]:
    """Voxels of points ``P`` (seen from camera centres ``eye``) and their :func:`convexity_graph`; ``W`` is None below ``min_voxels`` voxels."""
    centres, inverse, counts = voxelize(P, voxel_size)
    m = counts.size
    if m < min_voxels:
        return inverse, None
    eyes = np.stack([np.bincount(inverse, weights=eye[:, d], minlength=m) for d in range(3)], 1) / counts[:, None]
    return inverse, convexity_graph(
        centres, eyes, radius=3 * voxel_size, concave_angle=concave_angle, concave_margin=concave_margin, concave_weight=concave_weight
    )


def _parts(W: Any, nodes: np.ndarray, *, max_ncut: float, min_size: int, depth: int, gen: np.random.Generator) -> list[np.ndarray]:
    """Recursive bisection of the subgraph on ``nodes``: connected pieces first, then normalized cuts."""
    from scipy.sparse.csgraph import connected_components

    sub = W[nodes][:, nodes]
    count, comp = connected_components(sub, directed=False)
    if count > 1:
        sizes = np.bincount(comp)
        big = np.flatnonzero(sizes >= min_size)
        main = int(np.argmax(sizes))
        if big.size >= 2:  # separate bodies; small loose pieces go with the largest
            comp = np.where(np.isin(comp, big), comp, main)
            return [p for c in big for p in _parts(W, nodes[comp == c], max_ncut=max_ncut, min_size=min_size, depth=depth + 1, gen=gen)]
        parts = _parts(W, nodes[comp == main], max_ncut=max_ncut, min_size=min_size, depth=depth + 1, gen=gen)
        parts[0] = np.r_[parts[0], nodes[comp != main]]
        return parts
    if depth > 8 or nodes.size < 2 * min_size:
        return [nodes]
    side, ncut = normalized_cut(sub, min_size=min_size, rng=gen)
    if ncut >= max_ncut:
        return [nodes]
    return [
        *_parts(W, nodes[side], max_ncut=max_ncut, min_size=min_size, depth=depth + 1, gen=gen),
        *_parts(W, nodes[~side], max_ncut=max_ncut, min_size=min_size, depth=depth + 1, gen=gen),
    ]


def _owned_parts(parts: list[np.ndarray], W: Any, inverse: np.ndarray, mask: np.ndarray, own_fraction: float, own_cover: float) -> list[np.ndarray]:
    """Merge every part that its own masks do not cover into its most strongly linked neighbour, smallest first."""
    parts = list(parts)
    valid = mask >= 0
    codes, code = np.unique(mask[valid], return_inverse=True)
    coo = W.tocoo()
    while len(parts) > 1:
        part = np.empty(inverse.max() + 1, np.int64)
        for k, p in enumerate(parts):
            part[p] = k
        hist = np.bincount(code.ravel() * len(parts) + part[inverse[valid]], minlength=codes.size * len(parts)).reshape(-1, len(parts))
        share = hist / np.maximum(hist.sum(1, keepdims=True), 1)
        owned = (hist * (share >= own_fraction)).sum(0) >= own_cover * np.maximum(hist.sum(0), 1)
        if owned.all():
            break
        k = int(min(np.flatnonzero(~owned), key=lambda j: parts[j].size))
        at = part[coo.row] == k
        links = np.bincount(part[coo.col[at]], weights=coo.data[at], minlength=len(parts))
        links[k] = -1.0
        j = int(np.argmax(links))
        parts[j] = np.r_[parts[j], parts[k]]
        del parts[k]
    return parts


def split_objects(
    labels: Sequence[np.ndarray],
    points: Sequence[np.ndarray],
    cameras: Sequence[tuple[Any, Any]],
    options: SplitConfig | None = None,
    *,
    masks: Sequence[np.ndarray] | None = None,
    num_objects: int | None = None,
    rng: Any = None,
) -> tuple[list[np.ndarray], dict[str, Any]]:
    """Split every object whose fused 3D points fall into parts joined by a cheap cut.

    Parameters
    ----------
    labels : list of int ``[H, W]``
        Object ids per view (0 = none), consistent across views.
    points : list of float ``[H, W, 3]``
        World point maps (NaN = invalid); pixels without a point keep their label.
    cameras : list of ``(K, cam_to_world [4, 4])``
        Only the camera centres are read (to orient the normals); a view whose
        ``cam_to_world`` is None takes no part (its pixels keep their labels).
    options : graphseg.config.SplitConfig, optional
        The ``split`` section (default: its defaults). Read here:
        ``voxel_size`` (voxel edge in metres; neighbours are linked up to 3
        voxels apart), ``max_ncut`` (a part is cut in two while its best
        normalized cut, :func:`normalized_cut`, is below this), ``min_voxels``
        (every part keeps at least this many voxels), ``concave_weight``,
        ``concave_angle``, ``concave_margin`` (links across concave creases,
        :func:`convexity_graph`), ``own_fraction`` and ``own_cover`` (see
        ``masks``; ``own_fraction`` None: every cut stands) and
        ``settle_band`` (after the cuts, the voxels of two touching parts
        within this many links of their border are divided again by a minimum
        cut of the link weights, :func:`settle_parts`, before the ``masks``
        guard; 0 keeps the cuts' borders).
    masks : list of int ``[H, W]``, optional, keyword-only
        The 2D masks per view (an id per mask, 0 = none). When given, a part
        stands only if masks of its own (each with at least ``own_fraction``
        of its pixels in the part) cover at least ``own_cover`` of the part's
        pixels: a cut that the views' segmenter did not draw (a duck's neck)
        is undone, the part joining the neighbour it has the strongest links to.
    num_objects : int, optional, keyword-only
        The largest object id in use (default: the largest in ``labels``); new
        parts are numbered after it.
    rng : None, int or numpy.random.Generator, keyword-only
        Start vectors of the eigen-solver.

    Returns
    -------
    labels : list of int ``[H, W]``
        New arrays (the inputs are not modified); the largest part of a split
        object keeps its id, the others get new ids after the largest one.
    info : dict
        ``objects``: one entry per object that was examined, ``{"object",
        "voxels", "parts", "part_voxels"}``; ``num_objects``: the largest id now;
        ``first_new``: the first id given to a new part (parts got ids
        ``first_new..num_objects``); ``settled``: voxels that
        :func:`settle_parts` moved.

    Notes
    -----
    O(P log P) for the P labelled pixels (voxelization), plus the graph and
    eigen-solves on a few thousand voxels per object: about 0.1-0.3 s for 10
    views of 640x480 (``benchmarks/bench_presets.py``).
    """
    n = len(labels)
    if not (len(points) == len(cameras) == n):
        raise ValueError(f"expected labels, points and cameras for the same views (got {n}, {len(points)}, {len(cameras)})")
    sp = options if options is not None else SplitConfig()
    voxel_size, min_voxels, max_ncut, settle_band = sp.voxel_size, sp.min_voxels, sp.max_ncut, sp.settle_band
    own_fraction, own_cover = sp.own_fraction, sp.own_cover
    if voxel_size <= 0 or min_voxels < 1 or max_ncut < 0 or settle_band < 0:
        raise ValueError(
            f"expected voxel_size > 0, min_voxels >= 1, max_ncut >= 0 and settle_band >= 0 (got {voxel_size}, {min_voxels}, {max_ncut}, {settle_band})"
        )
    out = [np.array(lab, copy=True) for lab in labels]
    top = max(int(max((int(lab.max()) for lab in out if lab.size), default=0)), int(num_objects or 0))
    first_new = top + 1
    gen = np.random.default_rng(rng)
    crease = sp.model_dump(include={"concave_angle", "concave_margin", "concave_weight"})
    entries: list[dict[str, Any]] = []
    settled = 0
    got = _labelled_points(out, points, cameras, masks)
    if got is None:
        return out, {"objects": entries, "num_objects": top, "first_new": first_new, "settled": settled}
    view, rows, cols, P, obj, mask, centre = got
    order = np.argsort(obj, kind="stable")
    bounds = np.searchsorted(obj[order], np.arange(1, top + 2))
    for o in range(1, top + 1):
        sel = order[bounds[o - 1] : bounds[o]]
        if sel.size < 2 * min_voxels:
            continue
        inverse, W = _surface_graph(P[sel], centre[view[sel]], voxel_size, min_voxels=2 * min_voxels, **crease)
        if W is None:
            continue
        m = W.shape[0]
        parts = _parts(W, np.arange(m), max_ncut=max_ncut, min_size=min_voxels, depth=0, gen=gen)
        if settle_band > 0 and len(parts) > 1:
            parts, moved = settle_parts(W, parts, band=settle_band)
            parts = [p for p in parts if p.size]
            settled += moved
        if masks is not None and own_fraction is not None and len(parts) > 1:
            parts = _owned_parts(parts, W, inverse, mask[sel], own_fraction, own_cover)
        parts.sort(key=lambda p: (-p.size, int(p.min())))
        entries.append({"object": o, "voxels": int(m), "parts": len(parts), "part_voxels": [int(p.size) for p in parts]})
        if len(parts) < 2:
            continue
        part_id = np.empty(m, np.int64)
        part_id[parts[0]] = o
        for p in parts[1:]:
            top += 1
            part_id[p] = top
        new = part_id[inverse]
        vs, rs, cs = view[sel], rows[sel], cols[sel]
        for i in np.unique(vs):
            at = vs == i
            out[i][rs[at], cs[at]] = new[at].astype(out[i].dtype)
    return out, {"objects": entries, "num_objects": top, "first_new": first_new, "settled": settled}


def _cut_cost(W: Any, side: np.ndarray) -> float:
    """``cut / vol(side) + cut / vol(other)`` of one two-way partition (inf when a side has no volume)."""
    degree = np.asarray(W.sum(1)).ravel()
    vol = float(degree[side].sum())
    rest = float(degree.sum()) - vol
    if vol <= 0 or rest <= 0:
        return float("inf")
    coo = W.tocoo()
    cut = float(coo.data[side[coo.row] & ~side[coo.col]].sum())
    return cut / vol + cut / rest


def _union_cut(W: Any, *, min_size: int, gen: np.random.Generator) -> float:
    """What the split would pay to cut a graph: 0 for two separate bodies, else its best normalized cut (inf: too small to cut)."""
    from scipy.sparse.csgraph import connected_components

    count, comp = connected_components(W, directed=False)
    if count > 1:
        sizes = np.bincount(comp)
        if int((sizes >= min_size).sum()) >= 2:
            return 0.0
        keep = comp == int(np.argmax(sizes))
        W = W[keep][:, keep]
    return normalized_cut(W, min_size=min_size, rng=gen)[1]


def merge_objects(
    labels: Sequence[np.ndarray],
    points: Sequence[np.ndarray],
    cameras: Sequence[tuple[Any, Any]],
    options: SplitConfig | None = None,
    *,
    num_objects: int | None = None,
    rng: Any = None,
) -> tuple[list[np.ndarray], dict[str, Any]]:
    """Join touching objects whose fused 3D points form one body (the inverse of :func:`split_objects`).

    Two objects touch when they share a voxel or have voxels within three voxel
    edges of each other (each voxel counted for the object with most of its
    points). Two touching objects, each with points in at least ``min_voxels``
    voxels, are joined when the cheapest normalized cut found in their union's
    :func:`convexity_graph` costs at least ``min_ncut``: the cut between the two
    objects and the best cut along the Fiedler vector (:func:`normalized_cut`,
    ``min_voxels`` a side) are both tried. No concave crease or gap separates
    them, so they are pieces of one object that the views' masks and matches
    did not connect. The pair whose union is hardest to cut is joined first,
    then the pairs of the joined object are measured again, until no pair
    qualifies. With ``min_ncut`` above the split's ``max_ncut``, a union that
    the split would cut is never joined.

    Parameters
    ----------
    labels : list of int ``[H, W]``
        Object ids per view (0 = none), consistent across views.
    points : list of float ``[H, W, 3]``
        World point maps (NaN = invalid).
    cameras : list of ``(K, cam_to_world [4, 4])``
        Only the camera centres are read; a view whose ``cam_to_world`` is None
        takes no part in the measurement (its labels are still renamed).
    options : graphseg.config.SplitConfig, optional
        The ``split`` section (default: its defaults). Read here: the voxel
        graph's ``voxel_size``, ``min_voxels``, ``concave_weight``,
        ``concave_angle`` and ``concave_margin`` (as in
        :func:`split_objects`), and ``merge_ncut``, the ``min_ncut`` above:
        join when the cheapest cut found in the union costs at least this
        (None: never join).
    num_objects : int, optional, keyword-only
        The largest object id in use (default: the largest in ``labels``).
    rng : None, int or numpy.random.Generator, keyword-only
        Start vectors of the eigen-solver.

    Returns
    -------
    labels : list of int ``[H, W]``
        New arrays of the input dtypes (the inputs are not modified): each
        joined object takes the smaller id, and the ids above a freed one move
        down to close the gap. Labels <= 0 are kept.
    info : dict
        ``merges``: ``{"ids", "ncut"}`` per join, in order, with the ids as
        they were before any renaming (``ncut`` None: the union is too small to
        cut at all); ``mapping``: int64 ``[T + 1]`` with ``T = max(num_objects,
        largest label)``, the new id of every old id (0 stays 0);
        ``num_objects``: the largest id now.

    Notes
    -----
    One voxelization and k-d tree of all labelled points, then per touching
    pair one voxel graph and, unless the cut between the two is already below
    ``min_ncut``, one eigen-solve (again for the pairs of a joined object):
    0.08-0.23 s for 10 views of 640x480 with the ``rgbd`` preset
    (``benchmarks/bench_presets.py``).

    Examples
    --------
    Two halves of one dome, labelled as two objects, are joined; two domes side
    by side stay apart:

    >>> import numpy as np
    >>> from graphseg.config import SplitConfig
    >>> def dome(cx, r=0.05, step=0.003):
    ...     g = np.arange(-r, r + 1e-9, step)
    ...     x, y = np.meshgrid(g, g)
    ...     k = x**2 + y**2 <= r * r
    ...     return np.c_[cx + x[k], y[k], np.sqrt(r * r - x[k] ** 2 - y[k] ** 2)]
    >>> cam = (np.eye(3), np.array([[1.0, 0, 0, 0.05], [0, 1, 0, 0], [0, 0, 1, 0.8], [0, 0, 0, 1]]))
    >>> one = dome(0.0)
    >>> halves = np.where(one[:, 1] < 0, 1, 2).astype(np.int32)[None]
    >>> out, info = merge_objects([halves], [one[None]], [cam], SplitConfig(min_voxels=100), rng=0)
    >>> np.unique(out[0]).tolist(), [m["ids"] for m in info["merges"]]
    ([1], [[1, 2]])
    >>> two = np.r_[dome(0.0), dome(0.1)]
    >>> sides = np.where(two[:, 0] < 0.05, 1, 2).astype(np.int32)[None]
    >>> out, info = merge_objects([sides], [two[None]], [cam], SplitConfig(min_voxels=100), rng=0)
    >>> np.unique(out[0]).tolist(), info["merges"]
    ([1, 2], [])
    """
    from scipy.spatial import cKDTree

    n = len(labels)
    if not (len(points) == len(cameras) == n):
        raise ValueError(f"expected labels, points and cameras for the same views (got {n}, {len(points)}, {len(cameras)})")
    sp = options if options is not None else SplitConfig()
    voxel_size, min_voxels = sp.voxel_size, sp.min_voxels
    min_ncut = np.inf if sp.merge_ncut is None else sp.merge_ncut
    if voxel_size <= 0 or min_voxels < 1 or min_ncut < 0:
        raise ValueError(f"expected voxel_size > 0, min_voxels >= 1 and min_ncut >= 0 (got {voxel_size}, {min_voxels}, {min_ncut})")
    top = max(int(max((int(np.max(lab)) for lab in labels if np.size(lab)), default=0)), int(num_objects or 0))
    mapping = np.arange(top + 1, dtype=np.int64)
    merges: list[dict[str, Any]] = []
    got = _labelled_points(labels, points, cameras) if top > 1 and np.isfinite(min_ncut) else None
    if got is not None and got[3].shape[0]:
        gen = np.random.default_rng(rng)
        crease = sp.model_dump(include={"concave_angle", "concave_margin", "concave_weight"})
        view, _, _, P, obj, _, centre = got
        # which objects touch: voxels of one grid, each owned by the object with most of its points
        centres, inverse, _ = voxelize(P, voxel_size)
        cells = group_by_key(combine_keys([inverse, obj], [centres.shape[0], top + 1]))  # (voxel, object) pairs, by voxel, then object
        vox, lab, count = inverse[cells.first], obj[cells.first], cells.counts
        big = np.bincount(lab, minlength=top + 1) >= min_voxels  # objects with points in at least min_voxels voxels
        best = np.lexsort((-count, vox))
        first = np.r_[True, vox[best][1:] != vox[best][:-1]]
        owner = np.zeros(centres.shape[0], np.int64)
        owner[vox[best][first]] = lab[best][first]
        near = cKDTree(centres).query_pairs(3 * voxel_size, output_type="ndarray")
        shared = np.flatnonzero(vox[1:] == vox[:-1])  # two objects in one voxel (consecutive keys)
        a = np.r_[owner[near[:, 0]], lab[shared]]
        b = np.r_[owner[near[:, 1]], lab[shared + 1]]
        cross = (a != b) & big[a] & big[b]
        pairs = set(zip(np.minimum(a, b)[cross].tolist(), np.maximum(a, b)[cross].tolist()))
        order = np.argsort(obj, kind="stable")
        bounds = np.searchsorted(obj[order], np.arange(top + 2))
        members = {int(o): order[bounds[o] : bounds[o + 1]] for o in np.flatnonzero(big)}
        cost: dict[tuple[int, int], float] = {}
        while pairs:
            for a_, b_ in sorted(pairs - cost.keys()):  # the union's own surface graph (normals from its points only)
                sel = np.r_[members[a_], members[b_]]
                inverse, W = _surface_graph(P[sel], centre[view[sel]], voxel_size, min_voxels=2, **crease)
                if W is None:  # fewer than 2 voxels: nothing to cut
                    cost[(a_, b_)] = float("inf")
                    continue
                # the cut between the two objects is one cut of the union: below min_ncut, no eigen-solve is needed
                share = np.bincount(inverse[: members[a_].size], minlength=W.shape[0]) / np.bincount(inverse, minlength=W.shape[0])
                between = _cut_cost(W, share >= 0.5)
                cost[(a_, b_)] = between if between < min_ncut else min(between, _union_cut(W, min_size=min_voxels, gen=gen))
            (a_, b_), nc = max(cost.items(), key=lambda kv: (kv[1], -kv[0][0], -kv[0][1]))
            if nc < min_ncut:
                break
            merges.append({"ids": [a_, b_], "ncut": float(nc) if np.isfinite(nc) else None})
            members[a_] = np.r_[members[a_], members.pop(b_)]
            mapping[mapping == b_] = a_
            renamed = ((a_ if x == b_ else x, a_ if y == b_ else y) for x, y in pairs)
            pairs = {(min(x, y), max(x, y)) for x, y in renamed if x != y}
            cost = {k: v for k, v in cost.items() if a_ not in k and b_ not in k}
    if merges:
        freed = np.zeros(top + 1, bool)
        freed[[m["ids"][1] for m in merges]] = True
        mapping = close_id_gaps(mapping, freed)
    return rename_objects(labels, mapping if merges else None), {"merges": merges, "mapping": mapping, "num_objects": int(mapping.max(initial=0))}
