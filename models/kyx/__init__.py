"""KeYmaera X archives (.kyx): read entries into Theorems, write Theorems as archives."""

from certiloop.models.kyx.reader import Entry, KyxError, read_entries
from certiloop.models.kyx.writer import NotExpressible, to_kyx, write_archive

__all__ = ["Entry", "KyxError", "NotExpressible", "read_entries", "to_kyx", "write_archive"]
