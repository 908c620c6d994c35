"""The one interface of every importer: :class:`Importer`, with typed :class:`Option` s.

Each importer module declares ``IMPORTER = Importer(...)``: its format name, the roles it reads
(``imu``, ``gnss``, ``ldv``), ``read(data, file, role, options) -> part`` and
``sniff(data, file_name) -> role or None``, and the options it takes under ``import.<role>`` of
the partial manifest. :meth:`Importer.read` checks the role and the options' types before reading,
so every importer refuses a wrong option the same way (exit 2 naming ``import.<role>.<key>``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ldvsurvey.errors import BundleError

MANIFEST_FILE = "manifest (partial)"
_TYPE_NAMES = {str: "a string", int: "a whole number", float: "a number", dict: "an object", list: "a list"}


@dataclass(frozen=True)
class Option:
    """An option under ``import.<role>`` of the partial manifest.

    Attributes
    ----------
    name : the key.
    types : the JSON types it may have (``int`` excludes booleans; ``float`` accepts whole numbers).
    help : what it does, with its unit.
    roles : the roles it applies to.
    """

    name: str
    types: tuple[type, ...]
    help: str
    roles: tuple[str, ...] = ("imu", "gnss", "ldv")

    def check(self, value, role: str) -> None:
        """Raise a :class:`BundleError` naming ``import.<role>.<name>`` if ``value`` has none of the types."""
        ok = any(
            (isinstance(value, t) and not isinstance(value, bool))
            or (t is float and isinstance(value, int) and not isinstance(value, bool))
            for t in self.types
        )
        if not ok:
            want = " or ".join(_TYPE_NAMES.get(t, t.__name__) for t in self.types)
            raise BundleError(f"expected {want}, got {value!r}", file=MANIFEST_FILE, field=f"import.{role}.{self.name}")


#: options every format takes (read by the bundle builder, not by the importer)
COMMON_OPTIONS = (
    Option("axes", (str,), "the sensor's axis convention, three letters of F/B, R/L, U/D (e.g. FRD)", ("imu",)),
    Option("max_static_tilt_deg", (float,), "largest tilt of gravity's reaction in the static start, deg", ("imu",)),
    Option(
        "static_gravity_tolerance",
        (float,),
        "relative |f| error at rest against normal gravity accepted (default 0.01, at most 0.10)",
        ("imu",),
    ),
    Option(
        "geoid_separation_m", (float,), "geoid separation for recordings with ellipsoidal heights only, m", ("gnss",)
    ),
)


@dataclass(frozen=True)
class Importer:
    """One recording format: what it reads and how."""

    name: str
    roles: tuple[str, ...]
    reader: Callable  #: (data: bytes, file: str, role: str, options: dict) -> ImuPart | GnssPart | LdvPart
    sniffer: Callable  #: (data: bytes, file_name: str) -> role or None
    options: tuple[Option, ...] = ()
    summary: str = ""

    def option_specs(self, role: str) -> dict[str, Option]:
        """Option name -> :class:`Option` of everything the format takes in ``role`` (common options included)."""
        return {o.name: o for o in (*COMMON_OPTIONS, *self.options) if role in o.roles}

    def read(self, data: bytes, file: str, role: str, options: dict | None = None):
        """Read one recording in ``role``; the options' types are checked first. Options this
        format does not know are named in the part's notes (they may be meant for another format)."""
        if role not in self.roles:
            raise BundleError(f"the {self.name} format has no {role} data (it has: {', '.join(self.roles)})", file=file)
        options = dict(options or {})
        specs = self.option_specs(role)
        unknown = []
        for key, value in options.items():
            if key in specs:
                specs[key].check(value, role)
            else:
                unknown.append(key)
        part = self.reader(data, file, role, options)
        if unknown:
            part.notes.append(
                f"{file}: option(s) {', '.join(f'import.{role}.{k}' for k in unknown)} not used by the {self.name} "
                f"format (it knows: {', '.join(sorted(specs)) or 'none'})"
            )
        return part

    def sniff(self, data: bytes, name: str) -> str | None:
        """The role the file's first bytes show it holds in this format, or None when it is not this format."""
        return self.sniffer(data, name)


def from_module(module) -> Importer:
    """A module's ``IMPORTER``; a module without one is no importer (a :class:`TypeError`)."""
    imp = getattr(module, "IMPORTER", None)
    if not isinstance(imp, Importer):
        raise TypeError(f"{module.__name__} is no importer: it declares no IMPORTER = Importer(...)")
    return imp
