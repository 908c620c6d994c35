"""ldv-survey: SINS + LDV + GNSS drive-log processing (navigation, height, gravity, DOV)."""

__version__ = "0.1.0"
FORMAT_VERSION = "ldv-drive-log/1"
