"""Importers: field recordings (NovAtel, u-blox, KF-GINS, NMEA, RTKLIB, any CSV, native) to a bundle.

Every importer module declares ``IMPORTER``, an :class:`~ldvsurvey.io.importers.contract.Importer`
(format name, roles, typed options, ``read`` and ``sniff``). :data:`REGISTRY` lists the formats;
the command line and the API take their lists from it.
:func:`~ldvsurvey.io.importers.build.build_bundle` turns the parts into a validated bundle.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from ldvsurvey.errors import BundleError

if TYPE_CHECKING:
    from ldvsurvey.io.importers.build import ImportResult, Source, build_bundle, parse_partial_manifest
    from ldvsurvey.io.importers.contract import Importer, Option

#: names this package gives from its modules, imported on first use: the command line reads
#: :data:`REGISTRY` at every start (``run`` and ``validate`` too), which must not pay for the import
#: machinery (numpy, the checks) it does not use
_LAZY = {
    "ImportResult": "build",
    "Source": "build",
    "build_bundle": "build",
    "parse_partial_manifest": "build",
    "Importer": "contract",
    "Option": "contract",
}

#: format name -> module (imported on first use: some need optional libraries)
REGISTRY = {
    "novatel": "novatel",
    "ubx": "ubx",
    "kf-gins": "kfgins",
    "nmea": "nmea",
    "rtklib": "rtklib",
    "csv": "csvmap",
    "native": "native",
}
#: the order in which formats are tried when none is named
SNIFF_ORDER = ("native", "novatel", "ubx", "rtklib", "nmea", "kf-gins")


def get_importer(fmt: str, file: str | None = None) -> Importer:
    """The importer of a format name."""
    key = str(fmt).strip().lower()
    if key not in REGISTRY:
        raise BundleError(f"unknown import format '{fmt}' (known: {', '.join(REGISTRY)})", file=file, field="format")
    from ldvsurvey.io.importers.contract import from_module

    imp = from_module(importlib.import_module(f"ldvsurvey.io.importers.{REGISTRY[key]}"))
    if imp.name != key:
        raise TypeError(f"the module of format '{key}' declares the name '{imp.name}'")
    return imp


def importers() -> list[Importer]:
    """Every registered importer, in the registry's order."""
    return [get_importer(k) for k in REGISTRY]


def formats_help() -> str:
    """One line per format: name, roles, what it reads (for ``ldv-survey import --help``)."""
    return "\n".join(f"  {i.name:<8} {'/'.join(i.roles):<13} {i.summary}" for i in importers())


def detect(data: bytes, name: str) -> tuple[str, str] | None:
    """(format, role) of a file from its content, or None when no importer recognises it."""
    for fmt in SNIFF_ORDER:
        role = get_importer(fmt).sniff(data, name)
        if role:
            return fmt, role
    return None


def __getattr__(name: str):
    """The names of :data:`_LAZY`, from their module on first use (PEP 562)."""
    if name in _LAZY:
        value = getattr(importlib.import_module(f"ldvsurvey.io.importers.{_LAZY[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "REGISTRY",
    "SNIFF_ORDER",
    "ImportResult",
    "Importer",
    "Option",
    "Source",
    "build_bundle",
    "detect",
    "formats_help",
    "get_importer",
    "importers",
    "parse_partial_manifest",
]
