"""Load a module as it was at an older commit, beside today's code, for side-by-side timing.

The module's source comes from `git show COMMIT:PATH`; its imports of certiloop modules that
have moved since (the case studies into studies/, the CLI out of proofs/) are rewritten to
where those modules live now, and `from certiloop.kernel import x` of a moved module likewise.
"""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# old dotted name -> today's (longest first, so a prefix never shadows a longer name)
MOVED = [
    ("certiloop.models.library.cfmpa_geometry", "certiloop.studies.dualarm.models.geometry"),
    ("certiloop.models.library.rcm_lyapunov", "certiloop.studies.rcm.models.lyapunov"),
    ("certiloop.models.library.cfmpa_motion", "certiloop.studies.dualarm.models.motion"),
    ("certiloop.kernel.extract.c_certified", "certiloop.kernel.extract.c.certified"),
    ("certiloop.models.library.cfmpa_paths", "certiloop.studies.dualarm.models.paths"),
    ("certiloop.models.library.rcm_energy", "certiloop.studies.rcm.models.energy"),
    ("certiloop.falsify.campaign_report", "certiloop.studies.raven.campaign.outputs"),
    ("certiloop.falsify.campaign_search", "certiloop.studies.raven.campaign.fault_search"),
    ("certiloop.kernel.extract.c_family", "certiloop.kernel.extract.c.family"),
    ("certiloop.kernel.extract.c_scalar", "certiloop.kernel.extract.c.scalar"),
    ("certiloop.kernel.extract.c_syntax", "certiloop.kernel.extract.c.syntax"),
    ("certiloop.proofs.cli.gate_report", "certiloop.cli.gate_report"),
    ("certiloop.falsify.campaign_plots", "certiloop.studies.raven.campaign.plots"),
    ("certiloop.kernel.extract.c_build", "certiloop.kernel.extract.c.build"),
    ("certiloop.kernel.dualarm_planner", "certiloop.studies.dualarm.planner"),
    ("certiloop.kernel.plan.kinematics", "certiloop.studies.raven.plan.kinematics"),
    ("certiloop.falsify.rcm_push_plot", "certiloop.studies.rcm.push_plot"),
    ("certiloop.kernel.plan.intervals", "certiloop.studies.raven.plan.intervals"),
    ("certiloop.proofs.cli.gate_view", "certiloop.cli.gate_view"),
    ("certiloop.falsify.batch_search", "certiloop.falsify.batch.phase"),
    ("certiloop.kernel.cfmpa_builtdr", "certiloop.studies.dualarm.generated.builtdr"),
    ("certiloop.models.library.cfmpa", "certiloop.studies.dualarm.models.builtdr"),
    ("certiloop.models.library.raven", "certiloop.studies.raven.models"),
    ("certiloop.proofs.cli.push_cmd", "certiloop.studies.rcm.push_cli"),
    ("certiloop.proofs.cli.plan_cmd", "certiloop.studies.raven.plan_cli"),
    ("certiloop.proofs.cli.__main__", "certiloop.cli.__main__"),
    ("certiloop.falsify.batch_state", "certiloop.falsify.batch.state"),
    ("certiloop.kernel.rcm_dynamics", "certiloop.studies.rcm.dynamics"),
    ("certiloop.kernel.dualarm_pins", "certiloop.studies.dualarm.pins"),
    ("certiloop.kernel.plan.certify", "certiloop.studies.raven.plan.certify"),
    ("certiloop.kernel.plan.planner", "certiloop.studies.raven.plan.planner"),
    ("certiloop.proofs.cli.loading", "certiloop.cli.loading"),
    ("certiloop.falsify.batch_ints", "certiloop.falsify.batch.ints"),
    ("certiloop.falsify.batch_open", "certiloop.falsify.batch.open_values"),
    ("certiloop.models.library.sbs", "certiloop.studies.sbs.models"),
    ("certiloop.models.library.rcm", "certiloop.studies.rcm.models.constraint"),
    ("certiloop.kernel.cfmpa_check", "certiloop.studies.dualarm.generated.check_path"),
    ("certiloop.kernel.plan.scenes", "certiloop.studies.raven.plan.scenes"),
    ("certiloop.proofs.cli.loading", "certiloop.api.loading"),
    ("certiloop.proofs.cli.guards", "certiloop.cli.guards"),
    ("certiloop.proofs.cli.report", "certiloop.cli.proof_table"),
    ("certiloop.kernel.plan.check", "certiloop.studies.raven.plan.check"),
    ("certiloop.kernel.plan.track", "certiloop.studies.raven.plan.track"),
    ("certiloop.falsify.campaign", "certiloop.studies.raven.campaign.run"),
    ("certiloop.falsify.rcm_push", "certiloop.studies.rcm.push"),
    ("certiloop.kernel.extract.c", "certiloop.kernel.extract.c.emit"),
    ("certiloop.kernel.rcm_guard", "certiloop.studies.rcm.generated.axial_guard"),
    ("certiloop.kernel.rcm_cloud", "certiloop.studies.rcm.cloud"),
    ("certiloop.kernel.deviation", "certiloop.studies.raven.deviation"),
    ("certiloop.kernel.extract.c", "certiloop.kernel.extract.c.emit"),
    ("certiloop.proofs.cli.gate", "certiloop.cli.gate"),
    ("certiloop.proofs.cli.main", "certiloop.cli.main"),
    ("certiloop.falsify.metrics", "certiloop.studies.raven.campaign.metrics"),
    ("certiloop.kernel.rcm_demo", "certiloop.studies.rcm.demo"),
    ("certiloop.proofs.cli.gate", "certiloop.api.gate_run"),
    ("certiloop.kernel.fixture", "certiloop.studies.sbs.fixture"),
    ("certiloop.kernel.monitor", "certiloop.studies.sbs.monitor"),
    ("certiloop.kernel.rcm_arm", "certiloop.studies.rcm.arm"),
    ("certiloop.kernel.dualarm", "certiloop.studies.dualarm.arms"),
    ("certiloop.proofs.cli.ui", "certiloop.cli.ui"),
    ("certiloop.falsify.batch", "certiloop.falsify.batch.program"),
    ("certiloop.kernel.native", "certiloop.studies.sbs.native"),
    ("certiloop.kernel.ctrl2", "certiloop.studies.sbs.generated.ctrl2"),
    ("certiloop.kernel.raven", "certiloop.studies.raven.arm"),
    ("certiloop.kernel.demo", "certiloop.studies.sbs.demo"),
    ("certiloop.kernel.plan", "certiloop.studies.raven.plan"),
    ("certiloop.proofs.cli", "certiloop.cli"),
    ("certiloop.kernel.rcm", "certiloop.studies.rcm.kernel"),
    ("certiloop.proofs.cli", "certiloop.cli"),
]
_PATTERN = re.compile("|".join(re.escape(old) + r"(?![A-Za-z0-9_])" for old, _ in MOVED))
_NEW = dict(MOVED)


def _from_import(m: re.Match) -> str:
    package, names = m.group(1), m.group(2)
    lines = []
    for item in names.split(", "):
        name, _, alias = item.partition(" as ")
        new = _NEW.get(f"{package}.{name}")
        if new:
            parent, _, leaf = new.rpartition(".")
            lines.append(f"from {parent} import {leaf} as {alias or name}")
        else:
            lines.append(f"from {package} import {item}")
    return "\n".join(lines)


def today(text: str) -> str:
    """`text` with every moved module's old dotted name replaced by today's."""
    text = re.sub(r"^from (certiloop[a-z_.]*) import ([A-Za-z_][A-Za-z0-9_, ]*)$", _from_import, text,
                  flags=re.M)
    return _PATTERN.sub(lambda m: _NEW[m.group(0)], text)


def source(commit: str, path: str) -> str:
    """The file at `path` as it was at `commit`, imports rewritten to today's layout."""
    text = subprocess.run(["git", "show", f"{commit}:{path}"], capture_output=True, text=True, check=True,
                          cwd=ROOT).stdout
    return today(text) if path.endswith(".py") else text


def load(name: str, text: str, folder: Path):
    """Import `text` as module `name` from a file in `folder`."""
    (folder / f"{name}.py").write_text(text)
    spec = importlib.util.spec_from_file_location(name, folder / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module
