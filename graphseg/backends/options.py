"""The backend contract: one pydantic ``Options`` model per backend, and the checks shared by the model backends.

Every registered backend (segmenters, matchers, lifters, feature extractors)
derives from :class:`Backend` and declares its settings once, as a nested
pydantic ``Options`` model (unknown keys forbidden) that holds every default.
It is built one way: ``Backend(options)`` with an ``Options`` instance, or
``Backend(**kwargs)`` validated into ``Options``; ``self.options`` holds the
validated values. Users set them with ``--backend-option NAME.KEY=VALUE`` on
the command line or under ``backends: {options: {NAME: {KEY: VALUE}}}`` in the
config file. A misspelt or bad option fails in the constructor, before any
image is processed, with one line naming the key, the valid keys and the
closest one. Run-wide settings (``seed``, ``num_matches``) are ``Options``
fields where a backend takes them; the pipeline fills them from the config
when the options leave them unset (:func:`option_fields` says which).

Model backends (``sam2``, ``loftr``, ``roma``, ...) derive from
:class:`ModelBackend`, which adds the pip ``extra`` that installs their
packages; every check that can fail (package, checkpoint file) runs in their
constructor too.

Examples
--------
>>> from pydantic import BaseModel, ConfigDict
>>> class Demo(Backend):
...     name = "demo"
...     class Options(BaseModel):
...         model_config = ConfigDict(extra="forbid")
...         size: int = 4
>>> Demo(size=8).options.size, Demo(Demo.Options(size=8)).options.size
(8, 8)
>>> import inspect; str(inspect.signature(Demo))
'(options=None, /, *, size: int = 4)'
>>> try:
...     Demo(sise=8)
... except ValueError as err:
...     print(err)
backends.options.demo.sise: unknown option 'sise'; valid keys: size; did you mean 'size'?
>>> class Scaled(ModelBackend):
...     name, extra = "scaled", "torch"
...     class Options(BaseModel):
...         model_config = ConfigDict(extra="forbid")
...         scale: float = 1.0
>>> try:
...     Scaled(scale=float("nan"))
... except ValueError as err:
...     print(err)
backends.options.scaled.scale: expected a finite number (got nan)
"""

from __future__ import annotations

import inspect
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

from pydantic import BaseModel, ValidationError

from ..registry import MissingDependencyError, install_hint
from ..scene import SceneError
from ..validation import NoOptions

__all__ = ["Backend", "ModelBackend", "NoOptions", "validate_options", "backend_options", "option_fields", "require_backend", "checkpoint_path"]


def validate_options(model: type[BaseModel], options: Mapping[str, Any], backend: str) -> Any:
    """Validate ``options`` against ``model``; raise one-line :class:`SceneError` naming the key.

    Parameters
    ----------
    model : pydantic model class
        The backend's ``Options`` (``extra="forbid"``).
    options : mapping
        Keyword arguments given to the constructor. Paths (``os.PathLike``)
        are turned into strings first.
    backend : str
        Registry name, used in the field path ``backends.options.BACKEND.KEY``.

    Returns
    -------
    pydantic model
        The validated ``model`` instance.

    Raises
    ------
    SceneError
        For an unknown key (the message lists the valid keys and the closest
        one), a bad value, or a float that is NaN or infinite.

    Examples
    --------
    >>> validate_options(NoOptions, {}, "rgbd")
    NoOptions()
    >>> try:
    ...     validate_options(NoOptions, {"scale": 2}, "rgbd")
    ... except SceneError as err:
    ...     print(err)
    backends.options.rgbd.scale: unknown option 'scale'; valid keys: (none)
    """
    from ..validation import did_you_mean, non_finite

    data = {k: os.fspath(v) if isinstance(v, os.PathLike) else v for k, v in options.items()}
    try:
        checked = model(**data)
    except ValidationError as err:
        e = err.errors()[0]
        key = ".".join(str(p) for p in e["loc"]) or "?"
        field = f"backends.options.{backend}.{key}"
        if e["type"] == "extra_forbidden":
            valid = ", ".join(model.model_fields) or "(none)"
            hint = did_you_mean(str(e["loc"][-1]) if e["loc"] else key, model.model_fields)
            raise SceneError(f"unknown option {key!r}; valid keys: {valid}" + (f"; {hint}" if hint else ""), field=field) from None
        msg = str(e["msg"]).removeprefix("Value error, ")
        got = repr(e.get("input"))
        raise SceneError(msg if got in msg else f"{msg} (got {got})", field=field) from None
    bad = non_finite(checked)
    if bad is not None:
        raise SceneError(f"expected a finite number (got {bad[1]!r})", field=f"backends.options.{backend}.{bad[0]}")
    return checked


def backend_options(cls: type, options: BaseModel | Mapping[str, Any] | None, kwargs: Mapping[str, Any]) -> Any:
    """The validated ``Options`` of ``cls`` built as ``cls(options)`` or ``cls(**kwargs)``.

    Parameters
    ----------
    cls : type
        A backend class with ``name`` and ``Options``.
    options : Options instance, mapping or None
        An instance of ``cls.Options`` is used as is (its floats must be
        finite); a mapping is validated like keywords.
    kwargs : mapping
        Options as keywords, validated by :func:`validate_options`; only
        when ``options`` is None.

    Raises
    ------
    SceneError
        For a misspelt or bad option (one line, field ``backends.options.NAME.KEY``).
    TypeError
        When both forms are given, or ``options`` is of another type.

    Examples
    --------
    >>> from graphseg.backends.matchers.reprojection import ReprojectionMatcher
    >>> backend_options(ReprojectionMatcher, {"stride": 2}, {}).stride
    2
    >>> backend_options(ReprojectionMatcher, ReprojectionMatcher.Options(), {"seed": 1})
    Traceback (most recent call last):
    ...
    TypeError: reprojection: give options either as an Options instance or as keywords, not both
    """
    from ..validation import non_finite

    model: type[BaseModel] = cls.Options  # type: ignore[attr-defined]
    label = str(getattr(cls, "name", "") or cls.__name__)
    if options is None or isinstance(options, Mapping):
        if options is not None and kwargs:
            raise TypeError(f"{label}: give options either as an Options instance or as keywords, not both")
        return validate_options(model, kwargs if options is None else options, label)
    if kwargs:
        raise TypeError(f"{label}: give options either as an Options instance or as keywords, not both")
    if not isinstance(options, model):
        raise TypeError(f"{label}: expected {model.__name__} options (got {type(options).__name__})")
    bad = non_finite(options)
    if bad is not None:
        raise SceneError(f"expected a finite number (got {bad[1]!r})", field=f"backends.options.{label}.{bad[0]}")
    return options


def option_fields(cls: Any) -> frozenset[str]:
    """The option names a backend class declares (the fields of its ``Options``; none without one).

    The pipeline passes a run-wide setting (``seed``, ``num_matches``) only to
    backends that declare it.

    Examples
    --------
    >>> from graphseg.backends.matchers.reprojection import ReprojectionMatcher
    >>> sorted(option_fields(ReprojectionMatcher) & {"seed", "num_matches"})
    ['num_matches', 'seed']
    >>> option_fields(object)
    frozenset()
    """
    model = getattr(cls, "Options", None)
    if isinstance(model, type) and issubclass(model, BaseModel):
        return frozenset(model.model_fields)
    return frozenset()


# packages whose declared dependencies pull torchvision or opencv-python: installed without them
_NO_DEPS = {
    "sam2": "SAM2_BUILD_CUDA=0 pip install --no-build-isolation --no-deps sam2",
    "romatch": "pip install --no-deps romatch",
}


def require_backend(module: str, backend: str, extra: str, option: str | None = "checkpoint") -> Any:
    """Import ``module`` for ``backend`` or raise a one-line :class:`MissingDependencyError`.

    The message names the extra to install and the option that sets the checkpoint.

    Examples
    --------
    >>> try:
    ...     require_backend("no_such_module_xyz", "sam2", "sam2")
    ... except MissingDependencyError as err:
    ...     print(err)
    sam2 needs 'no_such_module_xyz': pip install "graphseg[sam2]", then set --backend-option sam2.checkpoint=PATH
    >>> try:
    ...     require_backend("romatch.no_such_module", "roma", "roma", option=None)
    ... except MissingDependencyError as err:
    ...     print(err)  # doctest: +ELLIPSIS
    roma needs '...': pip install "graphseg[roma]"...
    """
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as err:
        missing = getattr(err, "name", None) or module
        top = missing.split(".")[0]
        also = f" && {_NO_DEPS[top]}" if top in _NO_DEPS else ""
        then = f", then set --backend-option {backend}.{option}=PATH" if option else ""
        raise MissingDependencyError(f"{backend} needs '{missing}': {install_hint(extra, missing)}{also}{then}") from err


def checkpoint_path(path: str | Path | None, backend: str, extra: str, option: str = "checkpoint") -> Path:
    """Check that a user's checkpoint file exists; never downloads.

    Raises
    ------
    SceneError
        ``where`` = the path (when given), ``field`` = ``backends.options.BACKEND.OPTION``.

    Examples
    --------
    >>> try:
    ...     checkpoint_path(None, "loftr", "loftr")
    ... except ValueError as err:
    ...     print(err)
    backends.options.loftr.checkpoint: no checkpoint given; set --backend-option loftr.checkpoint=PATH (weights are never downloaded; extra: graphseg[loftr])
    """
    field = f"backends.options.{backend}.{option}"
    hint = f"set --backend-option {backend}.{option}=PATH (weights are never downloaded; extra: graphseg[{extra}])"
    if path is None or str(path) == "":
        raise SceneError(f"no checkpoint given; {hint}", field=field)
    p = Path(path).expanduser()
    if not p.is_file():
        raise SceneError(f"checkpoint file not found; {hint}", where=str(path), field=field)
    return p


def _signature(model: type[BaseModel]) -> inspect.Signature:
    """``(options=None, /, *, field=default, ...)``: what ``help(Backend)`` shows."""
    params = [inspect.Parameter("options", inspect.Parameter.POSITIONAL_ONLY, default=None)]
    params += [
        inspect.Parameter(k, inspect.Parameter.KEYWORD_ONLY, default=f.get_default(call_default_factory=True), annotation=f.annotation)
        for k, f in model.model_fields.items()
    ]
    return inspect.Signature(params)


class Backend:
    """Base of every backend: ``name`` and one pydantic ``Options`` model that holds its defaults.

    Parameters
    ----------
    options : Options instance or mapping, optional
        The settings (default: all defaults).
    **kwargs
        The settings as keywords, validated into ``Options``.

    Notes
    -----
    Subclasses set ``name`` (the registry name) and a nested ``Options``
    (``extra="forbid"``; default: no options) and implement ``__call__``
    (a segmenter takes a view, a matcher two views, a lifter a scene, a
    feature extractor a view). A subclass that checks more in its
    constructor calls ``super().__init__(options, **kwargs)`` first.
    ``inspect.signature(cls)`` lists the option fields.
    """

    name: ClassVar[str] = ""
    Options: ClassVar[type[BaseModel]] = NoOptions
    #: Whether calls may run in forked worker processes (:mod:`graphseg.parallel`): each call
    #: independent of the others, nothing held that forking breaks (threads of a loaded model).
    parallel: ClassVar[bool] = False

    def __init__(self, options: BaseModel | Mapping[str, Any] | None = None, /, **kwargs: Any) -> None:
        self.options: Any = backend_options(type(self), options, kwargs)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.__signature__ = _signature(cls.Options)  # type: ignore[attr-defined]

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.options!r})"


class ModelBackend(Backend):
    """Base of the model backends: a :class:`Backend` with the pip ``extra`` that installs its packages."""

    extra: ClassVar[str]
