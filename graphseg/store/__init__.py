"""The persistent store: a scene graph that grows view by view (issue 23).

* :class:`SceneGraph` (:mod:`.scenegraph`): open or create a store, add views,
  read the result, the persistent object ids and the history of merges and splits;
* :func:`update` (:mod:`.update`): the incremental graph update;
* :func:`assign_ids` / :func:`deciding_edges` (:mod:`.ids`): stable ids and why objects merged or split;
* :mod:`.layout`: the folder on disk, its format version, the lock and the atomic commit;
* :func:`view_background` (:mod:`.background`): the store's per-view background rule;
* :mod:`.commands`: what the command line does with a store.

See ``docs/store.md``.
"""

from __future__ import annotations

from .background import per_view_background, view_background
from .ids import assign_ids, deciding_edges
from .incremental import Snapshot, ViewData, prepare_view, update
from .layout import FORMAT, READS, VERSION, StoreError, StoreLockedError, is_store
from .scenegraph import AddReport, SceneGraph

__all__ = [
    "SceneGraph",
    "AddReport",
    "StoreError",
    "StoreLockedError",
    "is_store",
    "update",
    "prepare_view",
    "ViewData",
    "Snapshot",
    "assign_ids",
    "deciding_edges",
    "view_background",
    "per_view_background",
    "FORMAT",
    "VERSION",
    "READS",
]
