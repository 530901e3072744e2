"""The entry point `extract(theorem)`: split the model into its control step, choose the code
shape (vectorised over a family of boundaries, else scalar Python), generate the module, and
word any refusal as one line that starts with the model's name."""

from __future__ import annotations

from certiloop.kernel.extract.analysis import families_only_tested, split, uses_families
from certiloop.kernel.extract.errors import ExtractError
from certiloop.kernel.extract.scalar import python
from certiloop.kernel.extract.vectorised import vectorised_source
from certiloop.models.lang.terms import ModelError
from certiloop.models.lang.theorem import Theorem


def extract(theorem: Theorem) -> str:
    """Python source of the model's control step (or algorithm): one function `controller`.
    Raises ExtractError, with a one-line reason, for a shape it cannot extract."""
    from certiloop.kernel.extract.names import generate_renamed, python_unsafe

    source = generate_renamed(theorem, python_unsafe, _extract)
    try:  # the last guard that extract never returns Python that does not parse
        compile(source, f"<extracted {theorem.name}>", "exec")
    except SyntaxError as exc:
        raise ExtractError(f"{theorem.name}: the generated Python does not parse ({exc.msg}, line "
                           f"{exc.lineno}); please report it with the model") from None
    return source


def _extract(theorem: Theorem) -> str:
    try:
        step = split(theorem)
        if uses_families(step.parts) and not families_only_tested(step.parts):
            if step.where in ("modes", "switched", "algorithm"):
                raise ExtractError("a family of boundaries in a switched plant or an algorithm is not "
                                   "vectorised")
            return vectorised_source(theorem, step)
        return python(theorem, step)
    except ModelError as exc:
        message = " ".join(str(exc).split())
        if not message.startswith(f"{theorem.name}:"):
            message = f"{theorem.name}: {message}"
        raise ExtractError(message) from None
