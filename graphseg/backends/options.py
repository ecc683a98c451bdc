"""Options and checks shared by the model backends (``sam2``, ``loftr``, ``roma``, ...).

A model backend declares its settings once, as a pydantic ``Options`` model
(unknown keys forbidden), and takes them as constructor keywords. Users set
them with ``--backend-option NAME.KEY=VALUE`` on the command line or under
``backends: {options: {NAME: {KEY: VALUE}}}`` in the config file. Every check
that can fail (package, checkpoint file, option value) runs in the constructor,
before any image is processed, and fails with one line.

Examples
--------
>>> from pydantic import BaseModel, ConfigDict
>>> class Demo(ModelBackend):
...     name, extra = "demo", "torch"
...     class Options(BaseModel):
...         model_config = ConfigDict(extra="forbid")
...         size: int = 4
>>> Demo(size=8).options.size
8
>>> import inspect; str(inspect.signature(Demo))
'(*, size: int = 4)'
>>> try:
...     Demo(sise=8)
... except ValueError as err:
...     print(err)
backends.options.demo.sise: unknown option; valid keys: size; did you mean 'size'?
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
from pathlib import Path
from typing import Any, ClassVar

from pydantic import BaseModel, ValidationError

from ..registry import MissingDependencyError
from ..scene import SceneError

__all__ = ["ModelBackend", "validate_options", "require_backend", "checkpoint_path"]


def validate_options(model: type[BaseModel], options: dict[str, Any], backend: str) -> Any:
    """Validate ``options`` against ``model``; raise one-line :class:`SceneError` naming the key.

    Parameters
    ----------
    model : pydantic model class
        The backend's ``Options`` (``extra="forbid"``).
    options : dict
        Keyword arguments given to the constructor.
    backend : str
        Registry name, used in the field path ``backends.options.BACKEND.KEY``.

    Raises
    ------
    SceneError
        For an unknown key (the message lists the valid keys and the closest
        one), a bad value, or a float that is NaN or infinite.
    """
    from ..validation import did_you_mean, non_finite

    try:
        checked = model(**options)
    except ValidationError as err:
        e = err.errors()[0]
        key = ".".join(str(p) for p in e["loc"]) or "?"
        field = f"backends.options.{backend}.{key}"
        if e["type"] == "extra_forbidden":
            valid = ", ".join(model.model_fields)
            hint = did_you_mean(str(e["loc"][-1]) if e["loc"] else key, model.model_fields)
            raise SceneError(f"unknown option; valid keys: {valid}" + (f"; {hint}" if hint else ""), field=field) from None
        raise SceneError(f"{e['msg']} (got {e.get('input')!r})", field=field) from None
    bad = non_finite(checked)
    if bad is not None:
        raise SceneError(f"expected a finite number (got {bad[1]!r})", field=f"backends.options.{backend}.{bad[0]}")
    return checked


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
        raise MissingDependencyError(f"{backend} needs '{missing}': pip install \"graphseg[{extra}]\"{also}{then}") from err


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


class ModelBackend:
    """Base of the model backends: ``Options`` validation and a keyword signature.

    Subclasses set ``name`` (registry name), ``extra`` (pip extra) and a nested
    pydantic ``Options`` class; ``self.options`` holds the validated values.
    ``inspect.signature(cls)`` lists the option fields, so the pipeline can pass
    ``seed`` and ``num_matches`` to the backends that take them.
    """

    name: ClassVar[str]
    extra: ClassVar[str]
    Options: ClassVar[type[BaseModel]]

    def __init__(self, **options: Any) -> None:
        self.options = validate_options(self.Options, options, self.name)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        opts = getattr(cls, "Options", None)
        if opts is not None:
            params = [
                inspect.Parameter(k, inspect.Parameter.KEYWORD_ONLY, default=f.default, annotation=f.annotation)
                for k, f in opts.model_fields.items()
            ]
            cls.__signature__ = inspect.Signature(params)  # type: ignore[attr-defined]

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.options!r})"
