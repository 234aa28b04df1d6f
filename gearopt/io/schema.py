"""The schema of scene sections, re-exported from :mod:`gearopt.schema` (a base-layer module, so that
the option sets of :mod:`gearopt.settings`, which the library layers import, can build them)."""

from __future__ import annotations

from ..schema import (  # noqa: F401 - re-exported
    ALIASES, KIND_UNITS, Bounds, Field, Section, ToolSection, closest, describe, format_field, key_hint, problem,
    toml_text, type_name,
)

__all__ = ["Field", "Section", "ToolSection", "Bounds", "KIND_UNITS", "ALIASES", "format_field", "problem",
           "toml_text", "type_name", "closest", "key_hint", "describe"]
