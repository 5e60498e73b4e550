"""Where the shipped weights live and how a weights file and its model card are fingerprinted."""
from __future__ import annotations

import hashlib
from pathlib import Path

#: Version of the weights file layout and model card; bump when either changes incompatibly.
FORMAT_VERSION = 1


def file_sha256(path: Path) -> str:
    """Hex SHA-256 of a file's bytes (data and weights fingerprints in the model card)."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def weights_dir() -> Path:
    """The folder of the shipped weights inside the package."""
    return Path(__file__).resolve().parent / "weights"
