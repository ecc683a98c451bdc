"""One home for the presets' names and the default preset: :mod:`graphseg.config`."""

import argparse
import inspect

from graphseg.batch import run_batch
from graphseg.batch.tasks import configurations
from graphseg.config import DEFAULT_PRESET, PRESET_NAMES, PRESETS, Config


def test_the_names_derive_from_the_presets_default_first():
    assert PRESET_NAMES[0] == DEFAULT_PRESET == "rgbd"
    assert sorted(PRESET_NAMES) == sorted(PRESETS) and len(set(PRESET_NAMES)) == len(PRESET_NAMES)
    assert Config.preset(DEFAULT_PRESET) == Config() != Config.preset("paper")  # Config() is the default preset


def test_batch_starts_from_the_default_preset():
    for fn in (run_batch, configurations):
        assert inspect.signature(fn).parameters["preset"].default is None  # None: DEFAULT_PRESET
    (unset,) = configurations(["graphseg"])
    (named,) = configurations(["graphseg"], preset=DEFAULT_PRESET)
    (paper,) = configurations(["graphseg"], preset="paper")
    assert unset.config == named.config != paper.config


def _preset_actions(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return {name: a for name, p in sub.choices.items() for a in p._actions if "--preset" in a.option_strings}


def test_the_command_line_offers_the_config_presets():
    from graphseg.cli import build_parser

    actions = _preset_actions(build_parser())
    assert {"run", "demo", "batch", "add"} <= set(actions)
    for name, action in actions.items():
        assert tuple(action.choices) == PRESET_NAMES, name
        assert action.default in (DEFAULT_PRESET, None), name  # add: None = the store's own / DEFAULT_PRESET for a new one
