"""The dual-arm kernel's pins on its extracted code: studies/dualarm/generated/builtdr.py and
studies/dualarm/generated/check_path.py were generated from the proved models `cfmpa.builtdr` and
`cfmpa.check_path`; refuse to run them once either model has changed since (the gate's
drift check says the same before a merge, this says it at run time)."""

from __future__ import annotations

from certiloop.studies.dualarm.generated import builtdr as cfmpa_builtdr
from certiloop.studies.dualarm.generated import check_path as cfmpa_check

_checked = False


def check_extracted() -> None:
    """Raise RuntimeError naming the fix when a model's hash differs from its extracted module's."""
    global _checked
    if _checked:
        return
    from certiloop.models import library

    for module, path in ((cfmpa_builtdr, "studies/dualarm/generated/builtdr.py"),
                         (cfmpa_check, "studies/dualarm/generated/check_path.py")):
        current = library.get(module.MODEL).content_hash
        if current != module.MODEL_HASH:
            raise RuntimeError(f"{path} was extracted from an older {module.MODEL} (hash "
                               f"{module.MODEL_HASH}, now {current}); run "
                               "`python -m certiloop.studies regenerate`")
    _checked = True
