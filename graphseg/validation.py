"""Validation of plugin options: one-line errors that name the key and the valid ones.

Shared by the edge criteria, the contractors, the backends and the
configuration, so it depends on nothing in graphseg (pydantic only).
:func:`validate_options` checks a mapping against a plugin's ``Options``
model (extra keys forbidden) and refuses NaN and infinities anywhere;
:func:`options_from` is the constructor rule of every plugin base class:
an ``Options`` instance or keywords, not both.

Examples
--------
>>> from pydantic import BaseModel, ConfigDict
>>> class Ring(BaseModel):
...     model_config = ConfigDict(extra="forbid")
...     step: int = 1
>>> validate_options(Ring, {"step": 2}, label="ring")
Ring(step=2)
>>> validate_options(Ring, {"stpe": 2}, label="ring")
Traceback (most recent call last):
...
graphseg.validation.CriterionOptionsError: ring: unknown option 'stpe'; valid options: step; did you mean 'step'?
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

from pydantic import BaseModel, ConfigDict, ValidationError

__all__ = ["CriterionOptionsError", "NoOptions", "did_you_mean", "non_finite", "validate_options", "options_from"]


class CriterionOptionsError(ValueError):
    """Raised when options do not fit a criterion's ``Options``; names the key and the valid ones."""


class NoOptions(BaseModel):
    """``Options`` of a criterion (or contractor) without options."""

    model_config = ConfigDict(extra="forbid")


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """The hint ``did you mean 'x'?`` for the closest of ``choices`` to ``word`` (``difflib``), or ``""``.

    Examples
    --------
    >>> did_you_mean("stpe", ["step", "tau"])
    "did you mean 'step'?"
    >>> did_you_mean("zzz", ["step", "tau"])
    ''
    """
    import difflib

    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1)
    return f"did you mean {close[0]!r}?" if close else ""


def non_finite(value: Any, path: str = "") -> tuple[str, float] | None:
    """The first float in ``value`` (nested dicts, lists, models) that is NaN or infinite, as ``(path, value)``.

    Examples
    --------
    >>> non_finite({"a": 1.0, "b": [0.5, float("inf")]})
    ('b.1', inf)
    >>> non_finite({"a": 1.0, "b": "inf"}) is None
    True
    """
    if isinstance(value, BaseModel):
        value = {k: getattr(value, k) for k in type(value).model_fields}
    if isinstance(value, float):
        return None if math.isfinite(value) else (path, value)
    if isinstance(value, Mapping):
        items: Iterable[tuple[Any, Any]] = value.items()
    elif isinstance(value, (list, tuple)):
        items = enumerate(value)
    else:
        return None
    for key, item in items:
        found = non_finite(item, f"{path}.{key}" if path else str(key))
        if found is not None:
            return found
    return None


def validate_options(options_model: type[BaseModel] | None, options: Mapping[str, Any] | None, *, label: str = "criterion") -> BaseModel | dict[str, Any]:
    """Validate ``options`` against ``options_model``; legacy classes (no model) keep the dict.

    Every float, however deeply nested, must be finite (NaN and infinities are
    refused even where the plugin's own model would allow them).

    Raises
    ------
    CriterionOptionsError
        One line naming the bad key and listing the valid ones (with the closest
        valid key for a misspelt one).

    Examples
    --------
    >>> validate_options(NoOptions, {}, label="x")
    NoOptions()
    >>> validate_options(NoOptions, {"k": 3}, label="x")
    Traceback (most recent call last):
    ...
    graphseg.validation.CriterionOptionsError: x: unknown option 'k'; valid options: (none)
    >>> from graphseg.graphs.chamfer import Chamfer3D
    >>> validate_options(Chamfer3D.Options, {"tua": 1e-4}, label="chamfer_3d")
    Traceback (most recent call last):
    ...
    graphseg.validation.CriterionOptionsError: chamfer_3d: unknown option 'tua'; valid options: tau, voxel_size, stride, outliers, outlier_k, outlier_std_ratio, dbscan_eps, dbscan_min_samples, prune, min_confidence, spacing_factor, fragment_ratio; did you mean 'tau'?
    >>> validate_options(Chamfer3D.Options, {"tau": float("inf")}, label="chamfer_3d")
    Traceback (most recent call last):
    ...
    graphseg.validation.CriterionOptionsError: chamfer_3d: option 'tau': expected a finite number (got inf)
    """
    data = dict(options or {})
    if options_model is None:
        checked: BaseModel | dict[str, Any] = data
    else:
        valid = ", ".join(options_model.model_fields) or "(none)"
        try:
            checked = options_model.model_validate(data)
        except ValidationError as err:
            first = err.errors()[0]
            key = ".".join(str(x) for x in first["loc"]) or "(options)"
            if first["type"] == "extra_forbidden":
                hint = did_you_mean(str(first["loc"][-1]) if first["loc"] else key, options_model.model_fields)
                raise CriterionOptionsError(f"{label}: unknown option {key!r}; valid options: {valid}" + (f"; {hint}" if hint else "")) from None
            raise CriterionOptionsError(f"{label}: option {key!r}: {first['msg']} (got {first.get('input')!r}); valid options: {valid}") from None
    bad = non_finite(checked)
    if bad is not None:
        raise CriterionOptionsError(f"{label}: option {bad[0]!r}: expected a finite number (got {bad[1]!r})")
    return checked


def options_from(options_model: type[BaseModel], options: BaseModel | None, kwargs: Mapping[str, Any], *, label: str) -> BaseModel:
    """The validated ``Options`` of a plugin built as ``Plugin(options)`` or ``Plugin(**kwargs)``.

    Parameters
    ----------
    options_model : pydantic model class
        The plugin's ``Options``.
    options : Options instance or None
        Used as is (it must be an instance of ``options_model``).
    kwargs : mapping
        Options as keywords, validated by :func:`validate_options`; only
        when ``options`` is None.
    label : str
        The plugin's name, for messages.

    Raises
    ------
    CriterionOptionsError
        For a misspelt or bad keyword option.
    TypeError
        When both forms are given, or ``options`` is of another model.

    Examples
    --------
    >>> options_from(NoOptions, None, {}, label="star")
    NoOptions()
    >>> options_from(NoOptions, NoOptions(), {"k": 1}, label="star")
    Traceback (most recent call last):
    ...
    TypeError: star: give options either as an Options instance or as keywords, not both
    """
    if options is None:
        checked = validate_options(options_model, kwargs, label=label)
        assert isinstance(checked, BaseModel)  # options_model is a model here
        return checked
    if kwargs:
        raise TypeError(f"{label}: give options either as an Options instance or as keywords, not both")
    if not isinstance(options, options_model):
        raise TypeError(f"{label}: expected {options_model.__name__} options (got {type(options).__name__})")
    return options
