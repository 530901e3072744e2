"""The kernels this package ships, generated from their models (SHIPPED: model -> module
in `certiloop.kernel`), and `shipped_drift`, which says whether a shipped module is still
byte-for-byte a fresh extraction of its model (the gate fails when it is not)."""

from __future__ import annotations

from certiloop.kernel.extract.generate import extract

SHIPPED = {"sbs.ctrl2": "ctrl2.py"}  # model -> module in certiloop.kernel generated from it


def shipped_drift(model: str) -> str:
    """"" if the shipped kernel module is exactly a fresh extraction of `model`, else why not."""
    from pathlib import Path

    from certiloop.models import library

    path = Path(__file__).parent.parent / SHIPPED[model]
    fresh = extract(library.get(model))
    if not path.exists():
        return f"{path} is missing"
    if path.read_text() != fresh:
        return (f"{path.name} differs from a fresh extraction of {model}: the model changed since it was "
                f"extracted; run `certiloop extract {model} -o kernel/{path.name}`")
    return ""
