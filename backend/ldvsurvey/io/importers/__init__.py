"""Importers: field recordings (NovAtel, u-blox, KF-GINS, NMEA, any CSV, native) to a bundle.

Every importer module has ``NAME``, ``ROLES`` (which of ``imu``, ``gnss``, ``ldv`` it reads),
``read(data, file, role, options) -> part`` and ``sniff(data, file_name) -> role or None``.
:func:`~ldvsurvey.io.importers.build.build_bundle` turns the parts into a validated bundle.
"""

from __future__ import annotations

import importlib

from ldvsurvey.errors import BundleError

#: format name -> module (imported on first use: some need optional libraries)
REGISTRY = {
    "novatel": "novatel",
    "ubx": "ubx",
    "kf-gins": "kfgins",
    "nmea": "nmea",
    "csv": "csvmap",
    "native": "native",
}
#: the order in which formats are tried when none is named
SNIFF_ORDER = ("native", "novatel", "ubx", "nmea", "kf-gins")


def get_importer(fmt: str, file: str | None = None):
    """The importer module of a format name."""
    key = str(fmt).strip().lower()
    if key not in REGISTRY:
        raise BundleError(f"unknown import format '{fmt}' (known: {', '.join(REGISTRY)})", file=file, field="format")
    return importlib.import_module(f"ldvsurvey.io.importers.{REGISTRY[key]}")


def detect(data: bytes, name: str) -> tuple[str, str] | None:
    """(format, role) of a file from its content, or None when no importer recognises it."""
    for fmt in SNIFF_ORDER:
        role = get_importer(fmt).sniff(data, name)
        if role:
            return fmt, role
    return None


from ldvsurvey.io.importers.build import ImportResult, Source, build_bundle, parse_partial_manifest  # noqa: E402

__all__ = ["REGISTRY", "ImportResult", "Source", "build_bundle", "detect", "get_importer", "parse_partial_manifest"]
