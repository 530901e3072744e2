"""The model library page, generated from the library itself (what `certiloop list` shows):
every model with its expected verdict and description, grouped by the case study that adds it."""

from __future__ import annotations


def page() -> str:
    from certiloop.models import library
    from certiloop.models.library.registry import studies

    out = [
        "# The model library",
        "",
        "Generated from the library when the docs are built: every model `certiloop list` shows, "
        "with the verdict its author expects (`certiloop gate` checks each against it). Unsafe "
        "designs are kept, expected `refuted`.",
        "",
    ]
    owned = {name: study for study in studies() for name in study.models}
    groups = [("The textbook models", "", [n for n in library.names() if n not in owned])]
    groups += [
        (study.title, f"../studies/{study.name}.md", [n for n in library.names() if owned.get(n) is study])
        for study in studies()
    ]
    for title, link, names in groups:
        if not names:
            continue
        out += [f"## {title}", ""]
        if link:
            out += [
                f"The case study: [{title}]({link}). `certiloop gate {names[0].split('.')[0]}` checks these.",
                "",
            ]
        out += ["| model | expected | what it is |", "|---|---|---|"]
        for name in names:
            theorem = library.get(name)
            what = " ".join(theorem.description.split()).replace("|", "\\|")
            out.append(f"| `{name}` | {theorem.expected} | {what} |")
        out.append("")
    return "\n".join(out)


if __name__ == "__main__":
    print(page())
