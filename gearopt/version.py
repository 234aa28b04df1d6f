"""gearopt's version, importable from any layer without importing the package root
(``gearopt.__version__`` re-exports it; results.json and the CLI's ``--version`` read it)."""

__version__ = "0.1.0"
