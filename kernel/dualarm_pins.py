"""The dual-arm kernel's pins on its extracted code: kernel/cfmpa_builtdr.py and
kernel/cfmpa_check.py were generated from the proved models `cfmpa.builtdr` and
`cfmpa.check_path`; refuse to run them once either model has changed since (the gate's
drift check says the same before a merge, this says it at run time)."""

from __future__ import annotations

from certiloop.kernel import cfmpa_builtdr, cfmpa_check

_checked = False


def check_extracted() -> None:
    """Raise RuntimeError naming the fix when a model's hash differs from its extracted module's."""
    global _checked
    if _checked:
        return
    from certiloop.models import library

    for module, path in ((cfmpa_builtdr, "kernel/cfmpa_builtdr.py"), (cfmpa_check, "kernel/cfmpa_check.py")):
        current = library.get(module.MODEL).content_hash
        if current != module.MODEL_HASH:
            raise RuntimeError(f"{path} was extracted from an older {module.MODEL} (hash "
                               f"{module.MODEL_HASH}, now {current}); run "
                               f"`certiloop extract {module.MODEL} -o {path}`")
    _checked = True
