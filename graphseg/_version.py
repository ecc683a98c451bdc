"""The package version, in a module of its own: any module can read it without importing the package's API.

Examples
--------
>>> __version__.count(".") >= 1
True
"""

__all__ = ["__version__"]

__version__ = "0.1.0"
