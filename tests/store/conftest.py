"""Shared scenes and helpers of the store tests."""

import contextlib
import importlib

import numpy as np
import pytest

from graphseg.scene import Matches
from graphseg.store import per_view_background
from graphseg.testing.scenes import box_scene, exact_matches, oracle_part_masks, random_boxes

SEGMENT = importlib.import_module("graphseg.method.segment")


def partition(result):
    """The objects of a result as a set of frozensets of (view name, mask id), plus the background masks."""
    groups = {}
    for v, m, o in zip(result.mask_view.tolist(), result.mask_id.tolist(), result.mask_object.tolist()):
        groups.setdefault(o, set()).add((result.view_names[v], m))
    return {frozenset(g) for k, g in groups.items() if k}, frozenset(groups.get(0, set()))


@contextlib.contextmanager
def per_view_batch(seed=0):
    """segment() with the store's background rule (each view's background from that view alone)."""
    old = SEGMENT.background_masks
    SEGMENT.background_masks = lambda p, c, conf=None, rng=None: per_view_background(p, c, conf, seed=seed)
    try:
        yield SEGMENT.segment
    finally:
        SEGMENT.background_masks = old


def batch_matches(names, matches_by_name):
    """Matches keyed by index pairs (i < j) of ``names`` from matches keyed by name pairs."""
    out = {}
    for (a, b), m in matches_by_name.items():
        i, j = names.index(a), names.index(b)
        out[(i, j) if i < j else (j, i)] = m if i < j else Matches(m.xy_j, m.xy_i, m.certainty)
    return out


class Lookup:
    """A segmenter and matcher that serve precomputed masks and matches by view name."""

    name = "lookup"

    def __init__(self, masks, matches):
        self.masks, self.matches = masks, matches

    def segment(self, view):
        return self.masks[view.name]

    def match(self, a, b):
        if (a.name, b.name) in self.matches:
            return self.matches[(a.name, b.name)]
        m = self.matches[(b.name, a.name)]
        return Matches(m.xy_j, m.xy_i, m.certainty)


@pytest.fixture(scope="session")
def boxes():
    """Five views of four random boxes, masks split in parts, sparse exact matches."""
    scene = box_scene(random_boxes(3, 4), views=5, shape=(60, 80), arc_deg=220, rng=1, name="boxes")
    masks = oracle_part_masks(scene, 2, rng=0)
    names = [v.name for v in scene.views]
    matches = exact_matches(scene, num_matches=400, rng=0)
    lookup = Lookup(dict(zip(names, masks)), {(names[i], names[j]): m for (i, j), m in matches.items()})
    return scene, lookup


def same_labels(a, b):
    """Label images of the same views equal up to one renaming of the object ids (0 stays 0)."""
    xs = np.concatenate([a.labels[a.view_names.index(n)].ravel() for n in b.view_names])
    ys = np.concatenate([lab.ravel() for lab in b.labels])
    if not np.array_equal(xs == 0, ys == 0):
        return False
    for x, y in [(xs, ys)]:
        pairs = np.unique(np.stack([x, y]), axis=1)
        if len(set(pairs[0])) != pairs.shape[1] or len(set(pairs[1])) != pairs.shape[1]:
            return False
    return True
