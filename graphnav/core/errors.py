"""Error types raised by graphnav.

Every error about input data names where the problem is (file or stream, line or index, field), so a
user can go straight to the bad record. Library code raises only these types for bad input.
"""
from __future__ import annotations


class GraphnavError(Exception):
    """Base class of every error graphnav raises on purpose."""


class DataError(GraphnavError, ValueError):
    """Invalid input data.

    Attributes:
        source: file path or stream name (e.g. ``"imu"``, ``".../IMU_trajectory1.csv"``).
        line: 1-based line in a file, or 0-based index in an in-memory stream; None if not applicable.
        field: column or field name; None if not applicable.
        message: the message without the place.
    """

    def __init__(self, message: str, source: str | None = None, line: int | None = None,
                 field: str | None = None):
        self.source = source
        self.line = line
        self.field = field
        self.message = message          # without the place, for an error that says more around it
        where = []
        if source is not None:
            where.append(str(source))
        if line is not None:
            where.append(f"line {line}" if _is_file(source) else f"index {line}")
        if field is not None:
            where.append(f"field '{field}'")
        prefix = ", ".join(where)
        super().__init__(f"{prefix}: {message}" if prefix else message)

    @classmethod
    def at_sample(cls, message: str, source: str | None, index: int, field: str | None = None) -> "DataError":
        """An error about sample ``index`` (0-based) of an array built from ``source``: its index for an in-memory
        stream; for a file, whose arrays no longer map to its lines (a header, rows dropped or sorted), the sample
        is named in the message and no line (a "line 0" would point at the header)."""
        if _is_file(source):
            return cls(f"{message} (sample {index} of the stream)", source, None, field)
        return cls(message, source, index, field)


class ConfigError(GraphnavError, ValueError):
    """Invalid configuration (file or arguments)."""


class GeometryError(GraphnavError, ValueError):
    """A DVL geometry problem, e.g. fewer than three valid beams for a least-squares velocity."""


def _is_file(source: str | None) -> bool:
    return source is not None and ("/" in source or "." in source)
