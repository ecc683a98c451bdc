"""Option checks shared by the model backends (graphseg.backends.options)."""

import pytest
from pydantic import BaseModel, ConfigDict

from graphseg.backends.options import ModelBackend, validate_options
from graphseg.scene import SceneError


class Opts(BaseModel):
    model_config = ConfigDict(extra="forbid")
    checkpoint: str | None = None
    threshold: float = 0.5
    sizes: list[float] = [1.0]


def test_unknown_key_names_the_closest():
    with pytest.raises(SceneError) as err:
        validate_options(Opts, {"treshold": 0.3}, "demo")
    assert str(err.value) == "backends.options.demo.treshold: unknown option 'treshold'; valid keys: checkpoint, threshold, sizes; did you mean 'threshold'?"
    with pytest.raises(SceneError) as err:
        validate_options(Opts, {"zzz": 0.3}, "demo")
    assert str(err.value) == "backends.options.demo.zzz: unknown option 'zzz'; valid keys: checkpoint, threshold, sizes"


@pytest.mark.parametrize(
    "options,message",
    [
        ({"threshold": float("inf")}, "backends.options.demo.threshold: expected a finite number (got inf)"),
        ({"sizes": [1.0, float("nan")]}, "backends.options.demo.sizes.1: expected a finite number (got nan)"),
    ],
)
def test_non_finite_values_are_refused(options, message):
    with pytest.raises(SceneError) as err:
        validate_options(Opts, options, "demo")
    assert str(err.value) == message


def test_a_backend_checks_in_its_constructor():
    class Demo(ModelBackend):
        name, extra = "demo", "torch"
        Options = Opts

    assert Demo(threshold=0.25).options.threshold == 0.25
    with pytest.raises(SceneError, match="finite"):
        Demo(threshold=float("-inf"))
