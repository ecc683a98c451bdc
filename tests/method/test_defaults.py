"""One home per default (issue 53): a method function takes its config section itself (``options``,
None meaning the section's defaults), or a keyword that is also a field of the section has no
default of its own, or the section's. ``Config()`` is the one default method."""

import importlib
import inspect

import pytest

from graphseg import config as C

#: (module, function, section, function keyword -> section field where the names differ)
CASES = [
    ("graphseg.method.split", "split_objects", C.SplitConfig, {}),
    ("graphseg.method.split", "merge_objects", C.SplitConfig, {}),
    ("graphseg.method.segment", "apply_min_support", C.ObjectConfig, {}),
    ("graphseg.method.join", "join_objects", C.SplitConfig, {"min_shared": "join_shared"}),
    ("graphseg.method.join", "join_by_masks", C.SplitConfig, {"min_cover": "mask_join", "max_color": "mask_join_color"}),
    ("graphseg.method.masks", "snap_to_masks", C.SplitConfig, {"share": "snap_share"}),
    ("graphseg.method.trim", "trim_rims", C.TrimConfig, {}),
    ("graphseg.method.grow", "grow_rims", C.GrowConfig, {}),
    ("graphseg.method.refine", "refine_labels", C.RefineConfig, {}),
    ("graphseg.geometry", "select_pairs", C.PairConfig, {}),
    ("graphseg.method.masks", "compose_masks", C.MaskConfig, {}),
    ("graphseg.method.masks", "compose_masks", C.BackgroundConfig, {}),
]


@pytest.mark.parametrize(("module", "name", "section", "alias"), CASES, ids=[f"{c[1]}-{c[2].__name__}" for c in CASES])
def test_a_function_keyword_has_the_sections_default_or_none(module, name, section, alias):
    fn = getattr(importlib.import_module(module), name)
    params = inspect.signature(fn).parameters
    if "options" in params:  # the section itself: no field of it is a keyword as well
        assert params["options"].annotation in (f"{section.__name__} | None", section) and params["options"].default is None
        assert not set(params) & set(section.model_fields), f"{name} takes {section.__name__} and some of its fields"
        return
    checked = 0
    for param, p in inspect.signature(fn).parameters.items():
        field = alias.get(param, param)
        if field not in section.model_fields:
            continue
        checked += 1
        default = section.model_fields[field].default
        if p.default is inspect.Parameter.empty or default is None:  # required, or the section's None switches the step off
            continue
        assert p.default == default, f"{name}({param}={p.default!r}) but {section.__name__}.{field} = {default!r}"
    assert checked, f"{name} shares no keyword with {section.__name__}"


def test_config_is_the_default_method_and_presets_are_differences_over_it():
    from graphseg.presets import PRESETS

    assert C.Config() == C.Config.preset("rgbd") and PRESETS["rgbd"] == {}
    for name, diff in PRESETS.items():
        assert set(diff) <= {"stages", "contractor", "background", "split"}, name  # each preset names only what it changes
    paper = C.Config.preset("paper")
    assert paper.criterion_options("chamfer_3d")["tau"] == 5e-4 and paper.background.max_overlap == 0.09
    assert "split" not in paper.step_names() and "split" in C.Config().step_names()
