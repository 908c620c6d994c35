"""ldv-survey: SINS + LDV + GNSS drive-log processing (navigation, height, gravity, DOV)."""

from ldvsurvey import compilecache as _compilecache

__version__ = "0.1.0"
FORMAT_VERSION = "ldv-drive-log/1"

_compilecache.configure()  # before anything imports numba: compiled code is cached once per installation
