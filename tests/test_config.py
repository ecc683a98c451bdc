import numpy as np
import pytest
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from graphseg.config import (
    Config,
    CriterionSpec,
    load_error_message,
    migrate_config,
    validation_message,
)
from graphseg.graphs import Criterion, EdgeSet, edge_adders


class _Near3D(Criterion):
    """A 3D criterion under another name: --no-3d must drop it by its tag."""

    name = "near_3d_test"

    class Options(BaseModel):
        model_config = ConfigDict(extra="forbid")
        k: int = Field(3, ge=1)

    requires = frozenset({"points"})
    reduce = {"weight": "max"}
    tags = {"dimension": "3d"}

    def __call__(self, graph, evidence):
        return EdgeSet(np.zeros((2, 0), np.int64))


@pytest.fixture
def near3d():
    edge_adders.register("near_3d_test", _Near3D)
    yield _Near3D
    edge_adders.unregister("near_3d_test")


def test_the_paper_preset_follows_the_paper():
    c = Config.preset("paper")
    assert c.criterion_options("pixel_match")["percentile"] == 78 and c.criterion_options("pixel_match")["tau"] is None
    assert c.criterion_options("chamfer_3d")["tau"] == 5e-4
    assert c.criterion_options("chamfer_3d")["stride"] == 2  # one source of defaults: Chamfer3D.Options
    assert c.background.max_overlap == 0.09
    assert c.pairs.max_rotation == 1.2
    assert c.contractor.name == "star" and c.to_dict()["contractor"] == "star"
    assert c.stage_names() == [["pixel_match"], ["chamfer_3d"]]


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_save_load_roundtrip(tmp_path, suffix, near3d):
    c = Config(
        seed=3,
        contractor="union_find",
        stages=[["pixel_match"], [{"chamfer_3d": {"tau": 5e-5, "outliers": "dbscan"}}], [{"near_3d_test": {"k": 5}}]],
    )
    c.save(tmp_path / f"c{suffix}")
    back = Config.load(tmp_path / f"c{suffix}")
    assert back == c and back.to_dict() == c.to_dict()
    assert back.criterion_options("near_3d_test") == {"k": 5}


def test_presets_are_written_in_the_stage_form():
    r = Config.preset("rgbd")
    assert r.criterion_options("pixel_match")["normalization"] == "pair_hits"
    assert r.criterion_options("chamfer_3d")["tau"] == 5e-5
    assert Config.preset("rgbd", pixel_match={"tau": 0.5}).criterion_options("pixel_match")["tau"] == 0.5
    assert Config.preset("rgbd") == Config()  # the default method
    rob = Config.preset("robust")
    assert rob.criterion_options("depth_repulsion")["jump"] == 0.1 and rob.criterion_options("depth_repulsion")["concave"] == 0.2
    assert rob.criterion_options("smooth_adjacency")["color"] == 20.0
    assert rob.criterion_options("chamfer_3d")["outliers"] == "dbscan" and rob.criterion_options("chamfer_3d")["dbscan_min_samples"] == 15
    assert rob.to_dict()["contractor"] == "constrained"
    assert rob.criterion_options("pixel_match") == r.criterion_options("pixel_match")  # rgbd's evidence, robust contraction


def test_string_stages_still_work():
    c = Config(stages=[["pixel_match"], ["chamfer_3d"]])
    assert c.stages == Config.preset("paper").stages  # edge stages alone get the minimum support
    assert isinstance(c.stages[0][0], CriterionSpec)


def test_old_style_files_migrate(tmp_path):
    (tmp_path / "p.yaml").write_text("seed: 5\npixel_match:\n  percentile: 50\nchamfer_3d:\n  tau: 5.0e-5\nstages: [[pixel_match], [chamfer_3d]]\n")
    c = Config.load(tmp_path / "p.yaml")
    assert c.seed == 5 and c.criterion_options("pixel_match")["percentile"] == 50
    assert c.criterion_options("chamfer_3d")["tau"] == 5e-5
    assert "pixel_match" not in c.to_dict()  # saved in the new form only
    (tmp_path / "ao.yaml").write_text("adder_options:\n  dino: {threshold: 0.5}\nstages: [[pixel_match, dino_similarity]]\n")
    c = Config.load(tmp_path / "ao.yaml")
    assert c.stage_names() == [["pixel_match", "dino"]] and c.criterion_options("dino")["threshold"] == 0.5
    assert migrate_config({"dino": {"threshold": 0.1}}) == {}  # no stage uses it: dropped, as it had no effect


def test_unknown_keys_criteria_and_options_name_the_key(tmp_path):
    (tmp_path / "bad.yaml").write_text("pixel_mach:\n  percentile: 50\n")
    with pytest.raises(ValidationError, match="pixel_mach"):
        Config.load(tmp_path / "bad.yaml")
    (tmp_path / "list.yaml").write_text("- 1\n")
    with pytest.raises(ValueError, match="mapping"):
        Config.load(tmp_path / "list.yaml")
    with pytest.raises(ValidationError, match=r"unknown edge criterion 'chamfer3d'; installed choices: pixel_match, chamfer_3d"):
        Config(stages=[["chamfer3d"]])
    with pytest.raises(ValidationError, match=r"chamfer_3d: unknown option 'taus'; valid options: tau, voxel_size"):
        Config(stages=[[{"chamfer_3d": {"taus": 1}}]])
    with pytest.raises(ValidationError, match=r"pixel_match: option 'percentile'"):
        Config(pixel_match={"percentile": 120})
    with pytest.raises(ValidationError, match=r"unknown contractor 'stra'"):
        Config(contractor="stra")
    with pytest.raises(ValidationError, match=r"\{name: \{options\}\}"):
        Config(stages=[[{"pixel_match": {}, "chamfer_3d": {}}]])
    with pytest.raises(ValidationError):
        Config(stages=[])


def test_without_3d_acts_on_the_dimension_tag(near3d):
    c = Config(stages=[["pixel_match", "dino"], ["chamfer_3d"], [{"near_3d_test": {"k": 2}}]])
    assert c.without_3d().stage_names() == [["pixel_match", "dino"]]
    assert Config.minus().stage_names() == [["pixel_match"]]
    assert Config(stages=[["chamfer_3d"]]).without_3d().stage_names() == [["pixel_match"]]


def test_requires_and_reduce_come_from_the_criteria():
    assert Config().requires() == {"matches", "points", "confidence"}
    assert "features" in Config(stages=[["pixel_match", "dino"]]).requires()
    assert Config().edge_reduce()["distance"] == "min"


def test_conflicting_reductions_are_refused():
    class Summer(Criterion):
        name = "summer_test"
        reduce = {"weight": "sum"}

        def __call__(self, graph, evidence):  # pragma: no cover - never called
            raise AssertionError

    edge_adders.register("summer_test", Summer)
    try:
        with pytest.raises(ValidationError, match="merge edge column 'weight' differently"):
            Config(stages=[["pixel_match", "summer_test"]])
    finally:
        edge_adders.unregister("summer_test")


def test_yaml_written_by_hand_in_the_new_form(tmp_path):
    (tmp_path / "c.yaml").write_text("stages:\n  - [pixel_match]\n  - [{chamfer_3d: {tau: 5.0e-5}}]\ncontractor: {union_find: {}}\n")
    c = Config.load(tmp_path / "c.yaml")
    assert c.criterion_options("chamfer_3d")["tau"] == 5e-5 and c.contractor.name == "union_find"
    assert yaml.safe_load(yaml.safe_dump(c.to_dict())) == c.to_dict()


def _message(**data):
    with pytest.raises(ValidationError) as err:
        Config(**data)
    return validation_message(err.value)


@pytest.mark.parametrize(
    "data,start",
    [
        ({"background": {"plane_tolerence": 0.02}}, "background.plane_tolerence: unknown key 'plane_tolerence'; did you mean 'plane_tolerance'? valid keys: enabled, plane, plane_tolerance, "),
        ({"masks": {"min_aera": 3}}, "masks.min_aera: unknown key 'min_aera'; did you mean 'min_area'? valid keys: min_area"),
        ({"pairs": {"max_rotaton": 1.0}}, "pairs.max_rotaton: unknown key 'max_rotaton'; did you mean 'max_rotation'? valid keys: mode, auto_max_views, max_rotation, max_translation, translation_scale"),
        ({"output": {"strid": 2}}, "output.strid: unknown key 'strid'; did you mean 'stride'? valid keys: voxel_size, stride"),
        ({"backends": {"lifer": "rgbd"}}, "backends.lifer: unknown key 'lifer'; did you mean 'lifter'? valid keys: segmenter, matcher, lifter, num_matches, features, options"),
        ({"contractr": "star"}, "contractr: unknown key 'contractr'; did you mean 'contractor'? valid keys: background, masks, "),
        ({"colour": "red"}, "colour: unknown key 'colour'; valid keys: background, masks, "),
    ],
)
def test_misspelt_keys_name_the_closest_and_list_the_section(data, start):
    assert _message(**data).startswith(start)


def test_every_section_lists_its_own_keys():
    for name, field in Config.model_fields.items():
        model = field.annotation
        if isinstance(model, type) and issubclass(model, BaseModel) and not hasattr(model, "_registry"):  # sections, not plugin specs
            msg = _message(**{name: {"zzz_not_a_key": 1}})
            assert msg == f"{name}.zzz_not_a_key: unknown key 'zzz_not_a_key'; valid keys: {', '.join(model.model_fields)}", msg


@pytest.mark.parametrize(
    "data,message",
    [
        ({"background": {"plane_tolerance": float("inf")}}, "background.plane_tolerance: Input should be a finite number (got inf)"),
        ({"background": {"plane_tolerance": float("nan")}}, "background.plane_tolerance: Input should be a finite number (got nan)"),
        ({"background": {"max_distance": float("inf")}}, "background.max_distance: Input should be a finite number (got inf)"),
        ({"pairs": {"max_translation": float("inf")}}, "pairs.max_translation: Input should be a finite number (got inf)"),
        ({"output": {"voxel_size": float("inf")}}, "output.voxel_size: Input should be a finite number (got inf)"),
        ({"stages": [["pixel_match"], [{"chamfer_3d": {"tau": float("inf")}}]]}, "stages.1.0: chamfer_3d: option 'tau': expected a finite number (got inf)"),
        ({"chamfer_3d": {"tau": float("inf")}}, "stages.1.0: chamfer_3d: option 'tau': expected a finite number (got inf)"),
        ({"backends": {"options": {"geometric": {"min_area": float("inf")}}}}, "backends.options: geometric.min_area: expected a finite number (got inf)"),
        ({"seed": -1}, "seed: Input should be greater than or equal to 0 (got -1)"),
    ],
)
def test_numbers_must_be_finite(data, message):
    assert _message(**data) == message


def test_no_default_is_infinite():
    from graphseg.graphs.criterion import non_finite

    for name in ("paper", "rgbd", "robust"):
        assert non_finite(Config.preset(name).to_dict()) is None, name


def test_assignment_is_checked_too():
    c = Config()
    with pytest.raises(ValidationError, match="finite"):
        c.background.plane_tolerance = float("inf")


@pytest.mark.parametrize(
    "name,text,message",
    [
        ("c.yaml", "background:\n  plane: true\n - x\n", "line 3, column 2: expected <block end>, but found '<block sequence start>' (while parsing a block mapping that starts at line 1, column 1)"),
        ("c.yaml", "seed: 1\n\tmasks: {}\n", "line 2, column 1: found character '\\t' that cannot start any token (while scanning for the next token)"),
        ("c.json", '{\n  "seed": 1\n  "masks": {}\n}', "line 3, column 3: Expecting ',' delimiter"),
        ("c.yaml", b"seed: \xff\n", "not UTF-8 text (byte 0xff at offset 6)"),
    ],
)
def test_syntax_errors_give_line_and_column(name, text, message, tmp_path):
    p = tmp_path / name
    p.write_bytes(text if isinstance(text, bytes) else text.encode())
    with pytest.raises((ValueError, yaml.YAMLError)) as err:
        Config.load(p)
    assert load_error_message(err.value) == message



def test_lifted_points_get_their_own_criterion_options():
    """Issue 20: estimated point maps (sfm, dust3r, da3) run chamfer_3d with fragment_ratio 0.5;
    measured depth keeps the preset's options."""
    cfg = Config.preset("rgbd")
    assert cfg.criterion_options("chamfer_3d")["fragment_ratio"] is None
    sfm = cfg.for_lifter("sfm")
    assert sfm.criterion_options("chamfer_3d")["fragment_ratio"] == 0.5
    assert sfm.criterion_options("chamfer_3d")["tau"] == cfg.criterion_options("chamfer_3d")["tau"]  # the rest kept
    assert cfg.for_lifter("rgbd") is cfg and cfg.for_lifter(None) is cfg and cfg.for_lifter("given") is cfg
    assert cfg.criterion_options("chamfer_3d")["fragment_ratio"] is None  # not mutated
    assert sfm.objects.model_dump(exclude={"min_measured", "min_object_fraction"}) == cfg.objects.model_dump(exclude={"min_measured", "min_object_fraction"})
    assert (cfg.objects.min_measured, cfg.objects.min_object_fraction) == (0.0, 0.0)  # measured depth: off
    assert (sfm.objects.min_measured, sfm.objects.min_object_fraction) == (0.1, 0.008)  # estimated points: issue 52
    mine_objects = Config.preset("rgbd", objects={"min_object_fraction": 0.002}).for_lifter("sfm").objects
    assert mine_objects.min_object_fraction == 0.002 and mine_objects.min_measured == 0.1  # a field the user changed wins over the default
    three = Config.preset("rgbd", lifted={"objects": {"min_views": 3}}).for_lifter("sfm")
    assert three.objects.min_views == 3 and three.objects.merge_seen == cfg.objects.merge_seen
    assert three.objects.min_measured == 0.0  # the user's lifted.objects replaces the whole default
    off = Config.preset("rgbd", lifted={"criteria": {}, "objects": {}, "split": {}, "backend_options": {}, "trim": {}, "grow": {}})
    assert off.for_lifter("sfm") is off
    assert cfg.split.merge_ncut == 0.022 and sfm.split.merge_ncut is None  # estimated points never join objects
    assert cfg.split.max_ncut == 0.012 and sfm.split.max_ncut == 0.025  # estimated points split at dearer cuts
    assert cfg.split.join_shared is None and sfm.split.join_shared == 0.3  # estimated points join pieces by their border
    assert sfm.split.model_dump(exclude={"merge_ncut", "max_ncut", "join_shared"}) == cfg.split.model_dump(exclude={"merge_ncut", "max_ncut", "join_shared"})  # the rest kept
    mine = Config.preset("rgbd", lifted={"split": {"max_ncut": 0.02}}).for_lifter("sfm").split
    assert mine.max_ncut == 0.02 and mine.merge_ncut == 0.022  # the user's lifted.split replaces the whole default
    own = Config.preset("rgbd", split={"max_ncut": 0.015}).for_lifter("sfm").split
    assert own.max_ncut == 0.015 and own.merge_ncut is None  # a split field the user changed wins over the default
    both = Config.preset("rgbd", split={"max_ncut": 0.015}, lifted={"split": {"max_ncut": 0.02}}).for_lifter("sfm").split
    assert both.max_ncut == 0.02  # ... but not over the user's own lifted.split
    assert cfg.split.max_ncut == 0.012 and cfg.lifted.split == {"merge_ncut": None, "max_ncut": 0.025, "join_shared": 0.3}  # nothing mutated
    joins = Config.preset("rgbd", lifted={"split": {}}).for_lifter("sfm")
    assert joins.split == cfg.split
    with pytest.raises(ValidationError, match="merge_sen"):
        Config(lifted={"objects": {"merge_sen": True}})
    with pytest.raises(ValidationError, match="merge_ncutt"):
        Config(lifted={"split": {"merge_ncutt": None}})
    with pytest.raises(ValidationError, match="unknown option 'fragment_ration'"):
        Config(lifted={"criteria": {"chamfer_3d": {"fragment_ration": 0.5}}})
    with pytest.raises(ValidationError, match="nope"):
        Config(lifted={"criteria": {"nope": {}}})


def test_lifted_points_get_their_own_backend_options():
    """Issue 20: the matcher runs with a colour test on estimated points only; the user's
    own options for that backend are kept and win, and nothing is mutated."""
    cfg = Config.preset("rgbd", backends={"options": {"reprojection": {"stride": 2}, "geometric": {"min_area": 10}}})
    sfm = cfg.for_lifter("sfm")
    assert sfm.backends.options["reprojection"] == {"stride": 2, "max_color_distance": 30.0}
    assert sfm.backends.options["geometric"] == {"min_area": 10}
    assert cfg.backends.options["reprojection"] == {"stride": 2}  # not mutated
    assert cfg.for_lifter("rgbd") is cfg
    mine = Config.preset("rgbd", lifted={"backend_options": {"reprojection": {"max_color_distance": 12.0, "color_blur": 0.0}}})
    assert mine.for_lifter("dust3r").backends.options["reprojection"] == {"max_color_distance": 12.0, "color_blur": 0.0}
    off = Config.preset("rgbd", backends={"options": {"reprojection": {"max_color_distance": None}}})  # e.g. --backend-option
    assert off.for_lifter("sfm").backends.options["reprojection"] == {"max_color_distance": None}


def test_method_becomes_stages_and_contractor_when_the_config_is_built():
    """Issue 24: Config.method is resolved by the Config validator, not later by whoever runs it."""
    sam3d = Config(method="sam3d")
    assert sam3d.stage_names() == [["bidirectional_overlap"]] and sam3d.contractor.model_dump() == "star"
    mc = Config.preset("rgbd", method="maskclustering")
    assert mc.stage_names() == [["view_consensus"]] * 3 and mc.contractor.model_dump() == "star"
    minus = Config.preset("robust", method="graphseg-minus")
    assert all(c.info().dimension != "3d" for s in minus.edge_stages for c in s) and minus.contractor == Config.preset("robust").contractor
    for cfg in (sam3d, mc, minus):
        assert Config.model_validate(cfg.to_dict()) == cfg  # idempotent: a saved config reloads to the same run
    assert not hasattr(Config, "for_method")  # the validator does the work; no method to call
    assert Config.preset("rgbd").stage_names() == [["pixel_match"], ["chamfer_3d"]]  # graphseg keeps its stages
    assert mc.operations == minus.operations == Config.preset("rgbd").operations  # and every method keeps the graph operations


def test_lifted_preset_swaps_stages_and_contractor_for_estimated_points_only():
    """LiftedConfig.preset: estimated points run another preset's stages and contractor; measured depth keeps its own."""
    cfg = Config.preset("rgbd", lifted={"preset": "robust"})
    est = cfg.for_lifter("sfm")
    assert est.stage_names() == Config.preset("robust").stage_names() and est.contractor == Config.preset("robust").contractor
    assert est.criterion_options("chamfer_3d")["fragment_ratio"] == 0.5  # the criteria overrides still apply on top
    assert cfg.for_lifter("rgbd") is cfg and est.for_lifter("sfm") == est  # idempotent
    assert Config.preset("rgbd").lifted.preset is None
    with pytest.raises(ValidationError, match="unknown preset 'robsut'"):
        Config.preset("rgbd", lifted={"preset": "robsut"})


@pytest.mark.parametrize(
    ("stages", "line"),
    [
        ([["pixel_match"], "split", ["chamfer_3d"]], "stages: graph operations come after the last edge stage (got [pixel_match], split, [chamfer_3d])"),
        ([["pixel_match"], "trim", "split"], "stages: pixel refiners come after every graph operation that decides objects (got [pixel_match], trim, split)"),
        ([["pixel_match"], {"split": {"max_ncut": 0.1}}], "stages.1: split: takes its options from the split section, not from stages (got max_ncut)"),
        ([["pixel_match"], "splt"], "stages.1: unknown graph operation 'splt'; installed choices: support, split, merge, join_shared, mask_join, snap, support_final, refine, grow, trim"),
        (["split"], "stages: stages must start with non-empty lists of criteria (the edge stages)"),
    ],
)
def test_the_step_list_is_validated_with_one_line(stages, line):
    """Issue 53: the step list's rules, each broken once, give one line naming it."""
    from pydantic import ValidationError

    from graphseg.config import validation_message

    with pytest.raises(ValidationError) as err:
        Config(stages=stages)
    assert validation_message(err.value) == line


def test_old_enabled_switches_become_operations_and_edge_stages_alone_get_the_support():
    assert Config(stages=[["pixel_match"]]).step_names() == [["pixel_match"], "support", "support_final"]
    old = Config.preset("paper", split={"enabled": True}, trim={"enabled": True})  # a config file of before the step list
    assert old.step_names()[2:] == ["support", "split", "merge", "join_shared", "mask_join", "snap", "support_final", "trim"]
    assert Config.preset("rgbd", split={"enabled": False}).step_names()[2:] == ["support", "support_final"]
    assert Config.model_validate(old.to_dict()) == old  # saved in the new form, reloads to the same method
