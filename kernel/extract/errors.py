"""The extractor's one error and how it words a refusal. ExtractError (a ModelError)
carries a one-line reason; `refuse` names the statement it cannot extract and why, shortened
by `brief` to one line. Every other module of the extractor raises through these."""

from __future__ import annotations

from certiloop.models.lang.terms import ModelError


class ExtractError(ModelError):
    """The model's controller is not of a shape the extractor supports."""


def brief(x: object, width: int = 90) -> str:
    """A statement or formula on one line, shortened."""
    text = " ".join(str(x).split())
    return text if len(text) <= width else text[: width - 3] + "..."


def refuse(what: object, why: str) -> ExtractError:
    return ExtractError(f"cannot extract `{brief(what)}`: {why}")
