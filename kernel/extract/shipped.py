"""The kernels the case studies ship, generated from their models, and whether each is still
byte-for-byte a fresh extraction (`shipped_drift`; the gate fails when one is not).

Which files are generated from which model is each study's declaration (`Study.generated` in
the registry): a Python module, and for some models a folder with the C kernel.
`python -m certiloop.studies regenerate` rewrites them all."""

from __future__ import annotations

from pathlib import Path

from certiloop.kernel.extract.generate import extract

REGENERATE = "python -m certiloop.studies regenerate"


def shipped() -> dict[str, tuple[Path, Path | None]]:
    """model -> (its generated Python module, the folder of its generated C kernel or None)."""
    import importlib

    from certiloop.models.library.registry import studies

    found = {}
    for study in studies():
        if not study.generated:
            continue
        root = Path(importlib.import_module(study.package).__file__).parent
        for model, (module, c_folder) in study.generated.items():
            found[model] = (root / module, root / c_folder if c_folder else None)
    return found


def fresh_files(model: str) -> dict[Path, str]:
    """Every file generated from `model`, with the text a fresh extraction gives it."""
    from certiloop.kernel.extract.c import extract_c
    from certiloop.models import library

    module, c_folder = shipped()[model]
    theorem = library.get(model)
    files = {module: extract(theorem)}
    if c_folder is not None:
        files.update({c_folder / name: text for name, text in extract_c(theorem).items()})
    return files


def shipped_drift(model: str) -> str:
    """"" if every file generated from `model` is exactly a fresh extraction, else why not."""
    for path, text in fresh_files(model).items():
        if not path.exists():
            return f"{path} is missing; run `{REGENERATE}`"
        if path.read_text() != text:
            return (f"{path.name} differs from a fresh extraction of {model}: the model changed since it was "
                    f"extracted; run `{REGENERATE}`")
    return ""


def regenerate() -> list[Path]:
    """Rewrite every generated file that differs from a fresh extraction; the paths rewritten."""
    written = []
    for model in shipped():
        for path, text in fresh_files(model).items():
            if not path.exists() or path.read_text() != text:
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(text)
                written.append(path)
    return written
