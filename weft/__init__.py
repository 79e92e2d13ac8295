"""weft: implicit cloth simulation for film and animation pipelines."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("weft")
except PackageNotFoundError:  # running from a source tree without an install
    __version__ = "0.0.0+source"
