"""Plugin registries: built-ins by name, third-party plugins by entry point.

A :class:`Registry` maps names to plugin classes. Built-ins are recorded as
``"module:Attr"`` strings and imported only when first asked for; third-party
plugins are discovered through an entry-point group (for example
``graphseg.edge_adders``) and loaded lazily too. :meth:`Registry.resolve`
accepts a name, a class or an instance, so every public function can take any
of the three.

Examples
--------
>>> reg = Registry("thing", group="graphseg.no_such_group")
>>> reg.register("counter", "collections:Counter")
>>> reg.get("counter").__name__
'Counter'
>>> reg.resolve("counter")
Counter()
>>> try:
...     reg.get("nope")
... except PluginNotFoundError as err:
...     print(err)
unknown thing 'nope'; installed choices: counter
"""

from __future__ import annotations

import importlib
import warnings
from importlib.metadata import EntryPoint, entry_points
from typing import Any

__all__ = [
    "Registry",
    "PluginNotFoundError",
    "GraphsegWarning",
    "PluginLoadWarning",
    "MissingDependencyError",
    "TORCH_CPU",
    "install_hint",
    "require",
]

#: The one instruction that installs torch's CPU build on any Linux machine (PyTorch's CPU wheel
#: index, as in PyTorch's own install guide); every "install torch" hint uses it.
TORCH_CPU = "pip install torch==2.13.0 --extra-index-url https://download.pytorch.org/whl/cpu"


class PluginNotFoundError(LookupError):
    """Raised when a plugin name is unknown; the message lists the installed choices."""


class GraphsegWarning(UserWarning):
    """Base class of the warnings graphseg itself issues (the test suite turns them into errors)."""


class PluginLoadWarning(GraphsegWarning, RuntimeWarning):
    """Warned when a registered plugin fails to import."""


class MissingDependencyError(ImportError):
    """Raised when an optional dependency is missing; the message names the extra."""


def install_hint(extra: str, missing: str = "") -> str:
    """The pip command that installs graphseg's ``extra``, torch's CPU build first when torch is missing.

    Plain ``pip install torch`` (or an extra that asks for it) takes a CUDA build of several GB;
    the CPU build comes from PyTorch's CPU wheel index (:data:`TORCH_CPU`).

    Examples
    --------
    >>> install_hint("onnx")
    'pip install "graphseg[onnx]"'
    >>> install_hint("torch", missing="torch")
    'pip install torch==2.13.0 --extra-index-url https://download.pytorch.org/whl/cpu && pip install "graphseg[torch]"'
    """
    first = f"{TORCH_CPU} && " if missing.split(".")[0] == "torch" else ""
    return f'{first}pip install "graphseg[{extra}]"'


def require(module: str, extra: str) -> Any:
    """Import an optional dependency or fail with the pip command that installs it.

    Parameters
    ----------
    module : str
        Module to import, for example ``"torch"``.
    extra : str
        The graphseg extra that provides it, for example ``"torch"``.

    Returns
    -------
    module
        The imported module.

    Raises
    ------
    MissingDependencyError
        If the import fails.

    Examples
    --------
    >>> require("json", "none").__name__
    'json'
    >>> try:
    ...     require("no_such_module_xyz", "onnx")
    ... except MissingDependencyError as err:
    ...     print(err)
    this feature needs 'no_such_module_xyz': pip install "graphseg[onnx]"
    """
    try:
        return importlib.import_module(module)
    except ImportError as err:
        raise MissingDependencyError(
            f"this feature needs '{module}': {install_hint(extra, module)}"
        ) from err


def _load_target(target: str) -> Any:
    mod_name, _, attr = target.partition(":")
    obj: Any = importlib.import_module(mod_name)
    for part in attr.split(".") if attr else []:
        obj = getattr(obj, part)
    return obj


class Registry:
    """A lazily loading name -> plugin map backed by built-ins and entry points.

    Parameters
    ----------
    kind : str
        What the plugins are, used in messages (``"edge adder"``).
    group : str
        Entry-point group scanned for third-party plugins.

    Notes
    -----
    Entry points are listed (not imported) on the first lookup. A plugin is
    imported the first time it is asked for; one that fails to import warns with
    :class:`PluginLoadWarning` and is then reported as unavailable.
    """

    def __init__(self, kind: str, group: str) -> None:
        self.kind = kind
        self.group = group
        self._targets: dict[str, str | Any] = {}
        self._entry_points: dict[str, EntryPoint] | None = None
        self._loaded: dict[str, Any] = {}
        self._failed: dict[str, str] = {}

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, group={self.group!r}, names={self.names()})"

    def register(self, name: str, target: str | Any | None = None) -> Any:
        """Register ``target`` (a ``"module:Attr"`` string or an object) under ``name``.

        Used without ``target`` it returns a class decorator.
        """
        if target is None:

            def deco(obj: Any) -> Any:
                self.register(name, obj)
                return obj

            return deco
        self._targets[name] = target
        self._loaded.pop(name, None)
        self._failed.pop(name, None)
        return None

    def unregister(self, name: str) -> None:
        """Forget an in-process registration (entry points are not affected)."""
        self._targets.pop(name, None)
        self._loaded.pop(name, None)
        self._failed.pop(name, None)

    def _eps(self) -> dict[str, EntryPoint]:
        if self._entry_points is None:
            found: dict[str, EntryPoint] = {}
            try:
                for ep in entry_points(group=self.group):
                    found.setdefault(ep.name, ep)
            except Exception as err:  # pragma: no cover - broken metadata
                warnings.warn(f"could not list entry points of {self.group}: {err}", PluginLoadWarning, stacklevel=3)
            self._entry_points = found
        return self._entry_points

    def refresh(self) -> None:
        """Forget the entry points seen so far and scan them again on next use."""
        self._entry_points = None
        for name in list(self._loaded):
            if name not in self._targets:
                del self._loaded[name]
        self._failed.clear()

    def names(self) -> list[str]:
        """Names of all registered plugins (built-ins first), without importing them."""
        names = list(self._targets)
        names += [n for n in self._eps() if n not in self._targets]
        return names

    def available(self) -> list[str]:
        """Names minus the plugins that failed to import so far."""
        return [n for n in self.names() if n not in self._failed]

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in self.names()

    def _not_found(self, name: str) -> PluginNotFoundError:
        choices = ", ".join(self.available()) or "(none)"
        msg = f"unknown {self.kind} {name!r}; installed choices: {choices}"
        if name in self._failed:
            msg = f"{self.kind} {name!r} failed to load ({self._failed[name]}); installed choices: {choices}"
        return PluginNotFoundError(msg)

    def missing_message(self, name: str) -> str:
        """Why ``name``, named by a saved file or config, cannot be used here: not installed, or failing to load.

        Examples
        --------
        >>> print(Registry("edge criterion", group="graphseg.edge_adders").missing_message("probe_x"))
        edge criterion 'probe_x' is not installed (a plugin: install the package that provides the graphseg.edge_adders entry point 'probe_x')
        """
        if name in self._failed:
            return f"{self.kind} {name!r} is installed but failed to load ({self._failed[name]})"
        return f"{self.kind} {name!r} is not installed (a plugin: install the package that provides the {self.group} entry point {name!r})"

    def get(self, name: str) -> Any:
        """Return the plugin object (usually a class) registered as ``name``.

        Raises
        ------
        PluginNotFoundError
            If ``name`` is unknown or failed to load; the message lists the choices.
        """
        if name in self._loaded:
            return self._loaded[name]
        if name in self._failed:
            raise self._not_found(name)
        target: Any
        if name in self._targets:
            target = self._targets[name]
        elif name in self._eps():
            target = self._eps()[name]
        else:
            raise self._not_found(name)
        try:
            if isinstance(target, EntryPoint):
                obj = target.load()
            elif isinstance(target, str):
                obj = _load_target(target)
            else:
                obj = target
        except MissingDependencyError:
            raise
        except Exception as err:
            self._failed[name] = f"{type(err).__name__}: {err}"
            warnings.warn(
                f"{self.kind} plugin {name!r} failed to load: {self._failed[name]}",
                PluginLoadWarning,
                stacklevel=2,
            )
            raise self._not_found(name) from err
        self._loaded[name] = obj
        return obj

    def resolve(self, spec: str | type | Any, **kwargs: Any) -> Any:
        """Turn a name, a class or an instance into an instance.

        Parameters
        ----------
        spec : str, type or object
            A registered name, a plugin class (instantiated with ``kwargs``) or a
            ready instance (returned unchanged; ``kwargs`` must then be empty).
        **kwargs
            Constructor arguments for names and classes.
        """
        if isinstance(spec, str):
            spec = self.get(spec)
        if isinstance(spec, type):
            return spec(**kwargs)
        if kwargs:
            raise TypeError(f"cannot apply options {sorted(kwargs)} to an existing {self.kind} instance")
        return spec

