"""`certiloop init`: a new project in the current folder (a `[tool.certiloop]` section, an example
model, a pytest file), never overwriting anything that is already there."""

from __future__ import annotations

import argparse
from importlib.resources import files
from pathlib import Path

from certiloop.cli.errors import EXIT_OK, BadInput

MODEL_FILE = "drone_models.py"
TEST_FILE = "test_drone.py"
SECTION = f"""[tool.certiloop]
# what `certiloop gate` and `certiloop list` check when no MODEL is named
models = ["{MODEL_FILE}:altitude_limiter", "{MODEL_FILE}:no_reaction_time"]
"""


def add_parser(sub) -> None:
    sub.add_parser(
        "init", help="start a project here: a [tool.certiloop] section, an example model, a test",
        description=f"Write a [tool.certiloop] section into ./pyproject.toml (created if missing, "
        f"appended to otherwise), an example model ({MODEL_FILE}) and a pytest file ({TEST_FILE}) "
        "into the current folder, and print the next steps. Nothing is overwritten: an existing "
        "[tool.certiloop] section or file of the same name is bad input (exit 2), and then "
        "nothing is written.")


def run(args: argparse.Namespace) -> int:
    import tomllib

    folder = Path.cwd()
    pyproject = folder / "pyproject.toml"
    text = pyproject.read_text(encoding="utf-8") if pyproject.is_file() else ""
    try:
        existing = tomllib.loads(text).get("tool", {}).get("certiloop")
    except tomllib.TOMLDecodeError as exc:
        raise BadInput(f"{pyproject}: not valid TOML ({exc}): fix it, then run certiloop init "
                       "again") from None
    if existing is not None:
        raise BadInput(f"{pyproject} already has a [tool.certiloop] section: nothing written "
                       "(edit it by hand, or remove it and run certiloop init again)")
    taken = [name for name in (MODEL_FILE, TEST_FILE) if (folder / name).exists()]
    if taken:
        raise BadInput(f"{folder / taken[0]} already exists: nothing written (move it away, or run "
                       "certiloop init in an empty folder)")
    templates = files("certiloop.cli.templates")
    for name in (MODEL_FILE, TEST_FILE):
        (folder / name).write_text(templates.joinpath(name).read_text(encoding="utf-8"), encoding="utf-8")
    separator = "" if not text or text.endswith("\n\n") else ("\n" if text.endswith("\n") else "\n\n")
    pyproject.write_text(text + separator + SECTION, encoding="utf-8")
    verb = "appended [tool.certiloop] to" if text else "wrote"
    steps = [("certiloop list", "the models [tool.certiloop] names"),
             (f"certiloop prove {MODEL_FILE}:altitude_limiter", "prove the limiter safe"),
             (f"certiloop prove {MODEL_FILE}:no_reaction_time", "the unsafe variant's counterexample"),
             (f"certiloop extract {MODEL_FILE}:altitude_limiter -o limiter.py", "the proved controller"),
             ("certiloop gate", "what CI runs: every model meets its expected verdict"),
             ("python -m pytest -q", "the same claims as pytest tests")]
    width = max(len(command) for command, _ in steps) + 2
    print(f"{verb} pyproject.toml; wrote {MODEL_FILE} and {TEST_FILE}\nnext steps:")
    for command, what in steps:
        print(f"  {command:<{width}}{what}")
    return EXIT_OK
