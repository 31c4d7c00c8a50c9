"""The one typed configuration layer: every file a curator or installer writes is read and
checked here, by the same field types, so `exhibit check-config` and the running kiosk agree.

- :mod:`exhibit.schema.files`: reading a file safely (regular file, size cap, UTF-8, TOML);
- :mod:`exhibit.schema.types`: the field types (finite numbers with ranges, distances, angles,
  the one resolution cap, texts, the quit combination) and the shared limits;
- :mod:`exhibit.schema.validate`: pydantic models in, ``file: key: reason`` lines out.
"""

from exhibit.schema.files import MAX_CONFIG_BYTES, check_file_ref, read_bytes, read_text, read_toml
from exhibit.schema.types import MAX_RESOLUTION, MIN_DISTANCE, Model
from exhibit.schema.validate import validate

__all__ = [
    "MAX_CONFIG_BYTES",
    "MAX_RESOLUTION",
    "MIN_DISTANCE",
    "Model",
    "check_file_ref",
    "read_bytes",
    "read_text",
    "read_toml",
    "validate",
]
