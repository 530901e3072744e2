"""The kernels this package ships, generated from their models (SHIPPED: model -> module
in `certiloop.kernel`; SHIPPED_C: model -> its C kernel in `kernel/c/`), and `shipped_drift`,
which says whether a shipped kernel (Python, and C where there is one) is still byte-for-byte
a fresh extraction of its model (the gate fails when it is not)."""

from __future__ import annotations

from certiloop.kernel.extract.generate import extract

# model -> module in certiloop.kernel generated from it
SHIPPED = {"sbs.ctrl2": "ctrl2.py", "cfmpa.builtdr": "cfmpa_builtdr.py", "cfmpa.check_path": "cfmpa_check.py",
           "rcm.axial_guard": "rcm_guard.py"}
SHIPPED_C = {"sbs.ctrl2": "c"}  # model -> folder of certiloop.kernel holding its C kernel


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
    return shipped_c_drift(model) if model in SHIPPED_C else ""


def shipped_c_drift(model: str) -> str:
    """"" if the shipped C kernel of `model` is exactly a fresh `extract_c`, else why not."""
    from pathlib import Path

    from certiloop.kernel.extract.c import extract_c
    from certiloop.models import library

    folder = Path(__file__).parent.parent / SHIPPED_C[model]
    for name, text in extract_c(library.get(model)).items():
        path = folder / name
        if not path.exists() or path.read_text() != text:
            return (f"kernel/{SHIPPED_C[model]}/{name} is not a fresh C extraction of {model}; run "
                    f"`certiloop extract {model} --lang c -o kernel/{SHIPPED_C[model]}`")
    return ""
