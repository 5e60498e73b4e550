"""Where the shipped weights live and how a weights file and its model card are fingerprinted."""
from __future__ import annotations

import hashlib
from pathlib import Path

#: Version of the weights file layout and model card; bump when either changes incompatibly. Version 2: an
#: ensemble (``"members"`` in the card's architecture), which a reader of version 1 cannot build; a single network
#: is still written as version 1, so earlier graphnav versions keep reading it.
FORMAT_VERSION = 2
#: The versions this graphnav reads.
READABLE_VERSIONS = tuple(range(1, FORMAT_VERSION + 1))


def card_format_version(architecture: dict) -> int:
    """The oldest format version that describes a model of this ``architecture``."""
    return FORMAT_VERSION if "members" in architecture else 1


def file_sha256(path: Path) -> str:
    """Hex SHA-256 of a file's bytes (data and weights fingerprints in the model card)."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def weights_dir() -> Path:
    """The folder of the shipped weights inside the package."""
    return Path(__file__).resolve().parent / "weights"
